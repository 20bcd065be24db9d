"""The station: its named ports, the arm following the desired state given at its inputs, the
ball seen from robot B through the mirror, and the referee's reward port."""

import ast
from pathlib import Path

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

import tt_drake
from tt_drake.constants import BALL, TABLE
from tt_drake.diagrams.rally import rally_scenario
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.diagrams.station import awaiting_posture, build_station, make_station
from tt_drake.drives import DriveEnvelope
from tt_drake.rally_rules import mirror_matrix13
from tt_drake.systems.world import set_ball_state
from tt_drake.wam_params import AWAITING

ARM = ("desired_state", "desired_acceleration", "state", "torque", "acceleration")


def _ports(diagram):
    inputs = {diagram.get_input_port(i).get_name() for i in range(diagram.num_input_ports())}
    outputs = {diagram.get_output_port(i).get_name() for i in range(diagram.num_output_ports())}
    return inputs, outputs


def test_one_and_two_robot_stations_export_the_documented_ports():
    inputs, outputs = _ports(make_station(load_scenario(), robots=1))
    assert inputs == {"wam_A_desired_state", "wam_A_desired_acceleration"}
    assert outputs == {"ball_state", "contact_results", "outcome", "reward", "wam_A_state",
                       "wam_A_torque", "wam_A_acceleration"}
    inputs, outputs = _ports(make_station(rally_scenario(load_scenario()), robots=2))
    assert inputs == {f"wam_{s}_{p}" for s in "AB" for p in ARM[:2]}
    assert outputs == ({"ball_state", "ball_state_B", "contact_results", "rally"}
                       | {f"wam_{s}_{p}" for s in "AB" for p in ARM[2:]})
    with pytest.raises(ValueError, match="0, 1 or 2 robots"):
        make_station(load_scenario(), robots=3)


def test_the_arm_settles_at_the_desired_state_given_to_the_station():
    station = build_station(load_scenario(), robots=1, end_when_decided=False)
    diagram = station.diagram
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    awaiting_posture(station.world, context)
    target = np.asarray(AWAITING) + np.array([0.2, -0.1, 0.1, 0.2, -0.1, 0.1, 0.1])
    diagram.GetInputPort("wam_A_desired_state").FixValue(context, np.r_[target, np.zeros(7)])
    diagram.GetInputPort("wam_A_desired_acceleration").FixValue(context, np.zeros(7))
    # The ball at rest on the far half of the table: nothing but the arm moves.
    set_ball_state(station.world, station.world.plant.GetMyMutableContextFromRoot(context),
                   [0.0, 1.0, TABLE.surface_z + BALL.radius, 0, 0, 0, 0, 0, 0])
    simulator.AdvanceTo(1.5)
    assert context.get_time() == 1.5
    x = diagram.GetOutputPort("wam_A_state").Eval(context)
    np.testing.assert_allclose(x[:7], target, atol=1e-3)
    np.testing.assert_allclose(x[7:], 0.0, atol=1e-2)
    # At rest, the commanded torques hold the arm against gravity only: not all zero.
    assert np.linalg.norm(diagram.GetOutputPort("wam_A_torque").Eval(context)) > 1.0
    outcome = diagram.GetOutputPort("outcome").Eval(context)
    assert outcome.outcome == "missed" and not outcome.hit
    assert diagram.GetOutputPort("reward").Eval(context)[0] == outcome.reward == 0.0


def test_robot_b_sees_the_ball_through_the_mirror():
    station = build_station(rally_scenario(load_scenario()), robots=2)
    context = station.diagram.CreateDefaultContext()
    launch = [0.3, -0.8, 1.1, 0.5, 4.0, 1.0, 10.0, -20.0, 30.0]
    set_ball_state(station.world, station.world.plant.GetMyMutableContextFromRoot(context),
                   launch)
    ball = station.diagram.GetOutputPort("ball_state").Eval(context)
    np.testing.assert_allclose(ball[4:7], launch[:3])  # p, in the world frame
    np.testing.assert_allclose(station.diagram.GetOutputPort("ball_state_B").Eval(context),
                               mirror_matrix13() @ ball, atol=1e-15)


def test_the_station_camera_frames_a_resting_ball_where_it_lies():
    scenario = load_scenario()
    scenario.camera.sigma = 0.0  # a noiseless camera sees the true position
    station = build_station(scenario, robots=0, end_when_decided=False, camera=True)
    assert "camera_frames" not in _ports(make_station(scenario))[1]  # off by default
    simulator = Simulator(station.diagram)
    context = simulator.get_mutable_context()
    rest = [0.3, 1.0, TABLE.surface_z + BALL.radius]
    set_ball_state(station.world, station.world.plant.GetMyMutableContextFromRoot(context),
                   [*rest, 0, 0, 0, 0, 0, 0])
    simulator.AdvanceTo(0.1)  # frames at 0, 1/60, ..., 5/60 s; each delivered a frame late
    frame = station.diagram.GetOutputPort("camera_frames").Eval(context)
    np.testing.assert_allclose(frame[:3], rest, atol=1e-6)  # the ball settles on the table
    assert frame[3] == pytest.approx(4 / 60, abs=1e-12) and frame[4] == 1.0


def test_the_station_is_the_only_builder_of_the_world():
    """Every diagram gets its world (plant, scene graph, table, robots, ball) from the station:
    no module of the package but ``diagrams/station.py`` calls ``add_world``."""
    root = Path(tt_drake.__file__).resolve().parent.parent
    callers = []
    for path in sorted(p for d in ("tt_drake", "systems", "diagrams")
                       for p in (root / d).rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
                    and node.func.id == "add_world"):
                callers.append(path.relative_to(root).as_posix())
    assert callers == ["diagrams/station.py"]


def test_the_drives_limit_both_arms_and_sit_before_the_joint_faults():
    """With ``controller.drive_voltage`` each robot's commanded torque reaches its plant
    through the drives: a base joint already turning faster than its no-load speed gets no
    driving torque whatever the controller asks (it can only brake), and the serve's robot's
    joint friction is added after the drives."""
    drive = DriveEnvelope(48.0)
    for robots in (1, 2):
        scenario = load_scenario()
        if robots == 2:
            scenario = rally_scenario(scenario)
        scenario.controller.drive_voltage = 48.0
        scenario.controller.joint_viscous = [2.0] * 7
        station = build_station(scenario, robots=robots, end_when_decided=False)
        diagram, world = station.diagram, station.world
        context = diagram.CreateDefaultContext()
        awaiting_posture(world, context)
        plant_context = world.plant.GetMyContextFromRoot(context)
        instances = [world.robot] + ([world.robot_b] if robots == 2 else [])
        for side, instance in zip("AB"[:robots], instances, strict=True):
            v = np.zeros(7)
            v[0] = 1.2 * drive.no_load_speed[0]
            world.plant.SetVelocities(world.plant.GetMyMutableContextFromRoot(context),
                                      instance, v)
            desired = np.r_[AWAITING, 3.0 * v]  # asks for more speed: a driving torque
            diagram.GetInputPort(f"wam_{side}_desired_state").FixValue(context, desired)
            diagram.GetInputPort(f"wam_{side}_desired_acceleration").FixValue(context,
                                                                              np.zeros(7))
        for side, instance in zip("AB"[:robots], instances, strict=True):
            commanded = diagram.GetOutputPort(f"wam_{side}_torque").Eval(context)
            applied = world.plant.get_actuation_input_port(instance).Eval(plant_context)
            friction = -2.0 * 1.2 * drive.no_load_speed[0] if robots == 1 else 0.0
            assert commanded[0] > 0.0
            lower, upper = drive.bounds(world.plant.GetVelocities(plant_context, instance))
            assert upper[0] < 0.0
            assert applied[0] == pytest.approx(np.clip(commanded[0], lower[0], upper[0])
                                               + friction, abs=1e-9)
