"""A player added as one LeafSystem class plus one registration plays a serve, a rally and a
Gymnasium step episode through the same registry as the built-in players."""

import numpy as np
import pytest
from pydrake.systems.framework import BasicVector, LeafSystem

from tt_drake.diagrams.cli import build_parser
from tt_drake.diagrams.episodes import ServeDiagram
from tt_drake.diagrams.gym_envs import ReturnBallStepEnv
from tt_drake.diagrams.players import (
    PlayerError,
    drive_controller,
    player_function,
    player_names,
    register_player,
    unregister_player,
)
from tt_drake.diagrams.rally import RallyDiagram, rally_scenario
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.wam_params import AWAITING, VELOCITY_LIMIT

#: The posture the test player holds: the awaiting posture with the shoulder turned away.
POSTURE = np.asarray(AWAITING, dtype=float) + np.array([0.4, -0.3, 0.0, 0.2, 0.0, 0.0, 0.0])


class PostureHolder(LeafSystem):
    """Holds ``POSTURE`` at rest whatever the ball does: desired state (q, 0), zero
    acceleration; it reads the ball's state as every player does."""

    def __init__(self):
        super().__init__()
        self.DeclareVectorInputPort("ball_state", 13)
        self.DeclareVectorOutputPort("desired_state", BasicVector(14),
                                     lambda context, out: out.SetFromVector(
                                         np.r_[POSTURE, np.zeros(7)]))
        self.DeclareVectorOutputPort("desired_acceleration", BasicVector(7),
                                     lambda context, out: out.SetZero())


def add_posture_holder(builder, world, controller, scenario) -> list:
    holder = builder.AddNamedSystem("posture_holder", PostureHolder())
    drive_controller(builder, world, controller, holder)
    return []


@pytest.fixture(scope="module", autouse=True)
def registered():
    """The one registration, for this module's tests only (the registry is the process's)."""
    register_player("posture_holder", add_posture_holder)
    yield
    unregister_player("posture_holder")


def test_the_registered_player_is_listed_and_an_unknown_name_is_refused():
    assert player_names()[-1] == "posture_holder"
    args = build_parser().parse_args(["serve", "--player", "posture_holder"])
    assert args.player == "posture_holder"  # the command offers it too
    assert player_function("posture_holder") is add_posture_holder
    with pytest.raises(PlayerError, match="unknown player 'nobody'; choose one of idle, "):
        player_function("nobody")


def test_the_registered_player_plays_a_serve_and_its_arm_settles_at_its_posture():
    diagram = ServeDiagram(load_scenario(), "posture_holder")
    result = diagram.run(5)
    # The racket is turned away from the ball's path: the ball passes, a missed ball.
    assert (result.outcome.outcome, result.outcome.hit) == ("missed", False)
    q = diagram.arm_logger.FindLog(diagram.context).data()[:7, -1]
    np.testing.assert_allclose(q, POSTURE, atol=2e-3)  # the controller tracked the posture


def test_the_registered_player_plays_side_b_of_a_rally():
    scenario = load_scenario()
    scenario.rally.max_exchanges = 2
    rally = RallyDiagram(rally_scenario(scenario), ("analytical", "posture_holder"), log=True)
    result = rally.run(11)
    # A returns the serve; B's racket stays turned away: B misses A's ball.
    assert [e.player for e in result.exchanges] == [0]
    assert (result.fault.player, result.fault.kind) == (1, "missed")
    _, _, _, arm_b = result.poses
    np.testing.assert_allclose(arm_b[-1, :7], POSTURE, atol=2e-3)


def test_the_registered_player_plays_a_gymnasium_step_episode_under_the_agents_offset():
    env = ReturnBallStepEnv(player="posture_holder")
    observation, info = env.reset(seed=0, options={"serve_seed": 5})
    assert info["serve_seed"] == 5
    # The episode starts the arm at rest where its player waits.
    np.testing.assert_allclose(observation[:7], POSTURE, atol=1e-6)
    push = np.r_[1.0, np.zeros(6)]  # the shoulder turned further, for 4 steps
    steps, done = 0, False
    while not done:
        observation, reward, terminated, truncated, info = env.step(push if steps < 4
                                                                    else np.zeros(7))
        steps, done = steps + 1, terminated or truncated
    assert (info["outcome"]["outcome"], reward) == ("missed", 0.0)
    offset = 4 * VELOCITY_LIMIT[0] / 100.0  # 4 increments of a full step at 100 Hz: 0.4 rad
    expected = POSTURE + np.r_[offset, np.zeros(6)]
    np.testing.assert_allclose(observation[:7], expected, atol=2e-3)
