"""The arm's mechanical joint stops (systems/joint_stops.py): the law as written, a stop that
pushes only outward, and in the station a controller commanding a joint past its limit leaves
it at the stop (without stops it follows the command past the limit)."""

import dataclasses

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, LogVectorOutput

from tt_drake import wam_params as wp
from tt_drake.diagrams.scenario import ScenarioError, load_scenario, validate
from tt_drake.diagrams.station import add_station, arm_port
from tt_drake.systems.joint_stops import JointStopsConfig, awaiting_inertia, stop_stiffness

N = wp.NUM_JOINTS
WRIST = 5  # joint 6, the stock wrist that a fast stroke drives past its limit


def _station(stops: bool):
    scenario = load_scenario("default")
    scenario.world.joint_stops = JointStopsConfig(enabled=stops)
    builder = DiagramBuilder()
    station = add_station(builder, scenario, robots=1, launcher=False, referee=False)
    return scenario, builder, station


def _reference_torque(q, v, lower, upper, k, alpha):
    above, below = q - upper, lower - q
    down = np.where(above > 0, -np.maximum(0.0, k * above * (1 + alpha * v)), 0.0)
    up = np.where(below > 0, np.maximum(0.0, k * below * (1 - alpha * v)), 0.0)
    return down + up


def test_the_stops_torque_is_the_hunt_crossley_law_and_only_pushes_outward():
    scenario, builder, station = _station(stops=True)
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    plant, robot = station.world.plant, station.world.robot
    stops = diagram.GetSubsystemByName("joint_stops")
    config = scenario.world.joint_stops
    k = stop_stiffness(awaiting_inertia(plant, robot), config.natural_frequency)
    lower, upper = np.asarray(wp.JOINT_LOWER), np.asarray(wp.JOINT_UPPER)
    rng = np.random.default_rng(11)
    plant_context = plant.GetMyMutableContextFromRoot(context)
    start = plant.GetJointByName(wp.JOINT_NAMES[0], robot).velocity_start()
    pushing = 0
    for _ in range(200):
        q = rng.uniform(lower - 0.3, upper + 0.3)
        v = rng.normal(0.0, 2.0, N)
        plant.SetPositions(plant_context, robot, q)
        plant.SetVelocities(plant_context, robot, v)
        out = stops.get_output_port().Eval(stops.GetMyContextFromRoot(context))
        tau = out[start:start + N]
        np.testing.assert_allclose(tau, _reference_torque(q, v, lower, upper, k,
                                                          config.dissipation), rtol=1e-12)
        assert np.count_nonzero(out) == np.count_nonzero(tau)  # nothing on the ball
        inside = (q >= lower) & (q <= upper)
        assert np.all(tau[inside] == 0.0)
        assert np.all(tau[q > upper] <= 0.0) and np.all(tau[q < lower] >= 0.0)
        pushing += np.count_nonzero(tau)
    assert pushing > 100


def _drive_the_wrist_past_its_limit(stops: bool, past: float = 0.5, duration: float = 1.0):
    """The station's controller holding a set-point with joint 6 ``past`` rad beyond its upper
    limit, from the awaiting posture; returns (joint 6's positions, its velocities, stiffness)."""
    _, builder, station = _station(stops)
    target = np.asarray(wp.AWAITING, dtype=float).copy()
    target[WRIST] = wp.JOINT_UPPER[WRIST] + past
    desired = builder.AddSystem(ConstantVectorSource(np.concatenate([target, np.zeros(N)])))
    accel = builder.AddSystem(ConstantVectorSource(np.zeros(N)))
    builder.Connect(desired.get_output_port(), station.inputs[arm_port(0, "desired_state")])
    builder.Connect(accel.get_output_port(),
                    station.inputs[arm_port(0, "desired_acceleration")])
    log = LogVectorOutput(station.outputs[arm_port(0, "state")], builder, 2e-4)
    diagram = builder.Build()
    simulator = Simulator(diagram)
    plant, robot = station.world.plant, station.world.robot
    context = simulator.get_mutable_context()
    plant.SetPositions(plant.GetMyMutableContextFromRoot(context), robot,
                       np.asarray(wp.AWAITING, dtype=float))
    simulator.get_mutable_integrator().set_maximum_step_size(2e-3)
    simulator.get_mutable_integrator().set_target_accuracy(1e-4)
    simulator.AdvanceTo(duration)
    data = log.FindLog(context).data()
    k = stop_stiffness(awaiting_inertia(plant, robot), JointStopsConfig().natural_frequency)
    return data[WRIST], data[N + WRIST], k[WRIST]


def test_a_joint_commanded_past_its_limit_stays_at_its_stop():
    q, v, k = _drive_the_wrist_past_its_limit(stops=True)
    upper = wp.JOINT_UPPER[WRIST]
    assert q.max() > upper  # it reached the stop
    omega = JointStopsConfig().natural_frequency
    # Entering at speed v the joint passes the stop by at most ~ v / omega (the undamped
    # spring's amplitude for the joint's own inertia), and pressed by its drive at rest by
    # tau / k: the drive's torque is bounded by its effort limit.
    entry_speed = np.abs(v[q <= upper]).max()
    assert q.max() - upper < 1.5 * entry_speed / omega + wp.EFFORT_LIMIT[WRIST] / k
    assert 0.0 < q[-1] - upper < 1.2 * wp.EFFORT_LIMIT[WRIST] / k
    assert abs(v[-1]) < 1e-2


def test_without_stops_the_plant_lets_the_joint_follow_its_command_past_the_limit():
    q, _, _ = _drive_the_wrist_past_its_limit(stops=False)
    assert q[-1] - wp.JOINT_UPPER[WRIST] > 0.4


@pytest.mark.parametrize("field, value", [("natural_frequency", 0.0),
                                          ("natural_frequency", float("nan")),
                                          ("dissipation", -1.0)])
def test_a_stop_that_is_not_a_stop_is_refused(field, value):
    scenario = load_scenario("default")
    scenario.world.joint_stops = dataclasses.replace(scenario.world.joint_stops,
                                                     **{field: value})
    with pytest.raises(ScenarioError, match=f"world.joint_stops.{field}"):
        validate(scenario)
