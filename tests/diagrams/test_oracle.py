"""The oracle perception: the plant's true ball state (p, v, omega) at the camera's frames,
delivered at the first planning tick after each frame, as the camera and estimator would."""

import numpy as np
import pytest
from pydrake.systems.framework import DiagramBuilder

from tt_drake.diagrams.episodes import add_perception
from tt_drake.diagrams.scenario import Scenario, ScenarioError, validate
from tt_drake.serves import ServeSampler
from tt_drake.systems.aerodynamics import add_aerodynamics
from tt_drake.systems.ball_oracle import BallOracle
from tt_drake.systems.world import WorldConfig, add_world, make_simulator, set_ball_state

FRAME = 1.0 / 60
TICK = 1.0 / 250


def _ball_world(perception: str):
    scenario = Scenario(world=WorldConfig(with_robot=False, flight_accuracy=0.0),
                        perception=perception)
    builder = DiagramBuilder()
    world = add_world(builder, scenario.world)
    add_aerodynamics(builder, world, scenario.aerodynamics)
    seeded, perceived = add_perception(builder, world, scenario)
    diagram = builder.Build()
    simulator = make_simulator(diagram, scenario.world)
    return world, diagram, simulator, seeded, perceived


def _outputs(system, context):
    c = system.GetMyContextFromRoot(context)
    return {name: system.GetOutputPort(name).Eval(c).copy()
            for name in ("state", "spin", "covariance", "status")}


def test_oracle_gives_the_true_state_at_a_frame_after_the_next_planning_tick():
    world, diagram, simulator, seeded, oracle = _ball_world("oracle")
    assert isinstance(oracle, BallOracle) and seeded == []
    serve = ServeSampler("spin").sample(5)  # a spinning ball: the spin must come through too
    assert np.linalg.norm(serve.launch_state[6:9]) > 10.0
    context = simulator.get_mutable_context()
    set_ball_state(world, world.plant.GetMyMutableContextFromRoot(context), serve.launch_state)
    simulator.Initialize()
    assert _outputs(oracle, context)["status"][0] == 0.0  # nothing delivered before a frame
    # Frame 15 is captured at 0.25 s, between planning ticks 62 (0.248 s) and 63 (0.252 s).
    t_frame = 15 * FRAME
    simulator.AdvanceTo(t_frame)
    truth = world.plant.get_state_output_port(world.ball).Eval(
        world.plant.GetMyContextFromRoot(context)).copy()
    simulator.AdvanceTo(63 * TICK - 0.5e-3)
    before = _outputs(oracle, context)
    assert before["status"][1] == pytest.approx(14 * FRAME, abs=1e-12)  # still the last frame
    simulator.AdvanceTo(63 * TICK + 0.5e-3)
    out = _outputs(oracle, context)
    assert out["status"] == pytest.approx([1.0, t_frame], abs=1e-12)
    # Exactly the plant's state when the frame was taken: no noise, no delay in the value.
    np.testing.assert_array_equal(out["state"][0:3], truth[4:7])
    np.testing.assert_array_equal(out["state"][3:6], truth[10:13])
    np.testing.assert_array_equal(out["spin"], truth[7:10])
    np.testing.assert_array_equal(out["covariance"], np.zeros(36))
    # The ball has moved on since (2.5 ms at > 3 m/s): the state is at t_state, not now.
    now = world.plant.get_state_output_port(world.ball).Eval(
        world.plant.GetMyContextFromRoot(context))
    assert np.linalg.norm(now[4:7] - truth[4:7]) > 0.0075


def test_camera_perception_keeps_the_camera_and_estimator_and_bad_perception_is_refused():
    _, diagram, _, seeded, estimator = _ball_world("camera")
    assert [s.get_name() for s in seeded] == ["ball_camera"]
    assert estimator.get_name() == "ball_flight_estimator"
    for name in ("state", "covariance", "status"):
        assert estimator.GetOutputPort(name).size() == BallOracle().GetOutputPort(name).size()
    with pytest.raises(ScenarioError, match="perception 'sonar' is not one of camera, oracle"):
        validate(Scenario(perception="sonar"))


def test_the_oracle_analytical_player_gets_the_true_spin():
    from tt_drake.diagrams.episodes import ServeDiagram

    d = ServeDiagram(Scenario(perception="oracle"), "analytical")
    oracle = d.diagram.GetSubsystemByName("ball_oracle")
    player = d.diagram.GetSubsystemByName("analytical_player")
    for port, target in (("state", "estimated_state"), ("spin", "estimated_spin"),
                         ("status", "estimator_status")):
        assert d.diagram.AreConnected(oracle.GetOutputPort(port), player.GetInputPort(target))
    assert d.seeded == [d.launcher]  # the oracle draws no random numbers
