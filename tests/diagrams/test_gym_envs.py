"""The Gymnasium environments: registration, Gymnasium's own checks, reproducible seeds, and what
the actions do to the arm and the ball."""

import functools
import warnings

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import tt_drake.gym  # noqa: F401
from tt_drake import wam_params as wp
from tt_drake.constants import PLANES
from tt_drake.diagrams.episodes import ServeDiagram, add_analytical_player
from tt_drake.diagrams.gym_envs import ReturnBallEnv, ReturnBallStepEnv
from tt_drake.diagrams.scenario import ScenarioError, load_scenario
from tt_drake.systems.analytical_player import AnalyticalPlayer

SERVE = 1234567  # a default serve the analytical player returns on target


@pytest.fixture(scope="module")
def episodic():
    env = gymnasium.make("tt_drake/ReturnBall-v0")
    yield env
    env.close()


@pytest.fixture(scope="module")
def stepped():
    env = gymnasium.make("tt_drake/ReturnBallStep-v0", control_rate=100.0)
    yield env
    env.close()


def test_both_environments_are_registered_with_their_classes():
    assert isinstance(gymnasium.make("tt_drake/ReturnBall-v0").unwrapped, ReturnBallEnv)
    assert isinstance(gymnasium.make("tt_drake/ReturnBallStep-v0").unwrapped, ReturnBallStepEnv)


@pytest.mark.parametrize("env_id", ["tt_drake/ReturnBall-v0", "tt_drake/ReturnBallStep-v0"])
def test_gymnasium_check_env_passes_without_warnings(env_id):
    env = gymnasium.make(env_id).unwrapped
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env)
    assert [str(w.message) for w in caught] == []


def test_episodic_zero_action_is_the_analytical_players_return(episodic):
    obs, start = episodic.reset(options={"serve_seed": SERVE})
    assert start["committed"] and start["serve_seed"] == SERVE
    assert obs[1] == pytest.approx(PLANES.hitting_y)  # p_hit lies on the virtual hitting plane
    assert obs[4] < 0.0 and 0.05 < obs[6] < 0.6  # coming toward the robot, hit still ahead
    _, reward, terminated, truncated, info = episodic.step(np.zeros(14))
    # The teacher without corrections after commit (the agent's stroke is final).
    no_corrections = functools.partial(AnalyticalPlayer, corrections=False)
    teacher = ServeDiagram(load_scenario(), functools.partial(
        add_analytical_player, player_type=no_corrections)).run(SERVE).outcome
    assert terminated and not truncated
    assert reward == teacher.reward and info["outcome"] == teacher.as_dict()
    assert info["is_success"] == teacher.on_target
    assert teacher.on_target
    # The committed prediction says when the racket meets the ball (referee samples at 250 Hz).
    assert info["outcome"]["hit_time"] == pytest.approx(start["time"] + obs[6], abs=0.012)


def test_episodic_offset_moves_the_arms_hitting_configuration(episodic):
    env = episodic.unwrapped
    episodic.reset(options={"serve_seed": SERVE})
    context = env.player.GetMyContextFromRoot(env.serve_diagram.context)
    stroke = env.player.player_state(context).stroke
    action = np.zeros(14)
    action[0], action[8] = 0.5, -1.0  # theta_1 += 0.05 rad, theta_dot_2 -= 1 rad/s
    _, reward, *_ = episodic.step(action)
    new = env.player.player_state(env.player.GetMyContextFromRoot(env.serve_diagram.context))
    np.testing.assert_allclose(new.stroke.q_hit - stroke.q_hit, [0.05, 0, 0, 0, 0, 0, 0],
                               atol=1e-15)
    np.testing.assert_allclose(new.stroke.qd_hit - stroke.qd_hit, [0, -1, 0, 0, 0, 0, 0],
                               atol=1e-15)
    # The servo tracked the new stroke: the arm passes the hitting time at the offset
    # configuration (logged at 250 Hz; the nearest sample is within 2 ms of t_hit).
    log = env.serve_diagram.arm_logger.FindLog(env.serve_diagram.context)
    k = int(np.argmin(np.abs(log.sample_times() - stroke.t_hit)))
    q = log.data()[:7, k] + log.data()[7:, k] * (stroke.t_hit - log.sample_times()[k])
    assert np.abs(q - new.stroke.q_hit).max() < 0.02
    assert abs(q[0] - stroke.q_hit[0] - 0.05) < 0.02


def test_episodic_seeded_resets_replay_the_episode(episodic):
    action = np.linspace(-0.3, 0.3, 14)
    first = [episodic.reset(seed=42), episodic.step(action)]
    other = episodic.reset(seed=43)
    again = [episodic.reset(seed=42), episodic.step(action)]
    assert first[0][1]["serve_seed"] == again[0][1]["serve_seed"] != other[1]["serve_seed"]
    np.testing.assert_array_equal(first[0][0], again[0][0])
    assert first[1][1] == again[1][1] and first[1][4] == again[1][4]
    assert not np.array_equal(first[0][0], other[0])


def test_step_env_increments_move_the_setpoint_and_the_arm_follows(stepped):
    obs, _ = stepped.reset(options={"serve_seed": SERVE})
    q_await = np.asarray(wp.AWAITING)
    np.testing.assert_array_equal(obs[:7], q_await)
    assert obs[20] == 0.0  # the estimator does not track the ball yet
    action = np.zeros(7)
    action[1] = 0.5  # 0.5 x (10 rad/s / 100 Hz) = 0.05 rad per step on joint 2
    for _ in range(6):
        obs, reward, terminated, truncated, _ = stepped.step(action)
        assert reward == 0.0 and not terminated and not truncated
    for _ in range(25):
        obs, *_ = stepped.step(np.zeros(7))
    expected = q_await.copy()
    expected[1] += 0.3
    np.testing.assert_allclose(obs[:7], expected, atol=0.01)
    assert np.abs(obs[7:14]).max() < 0.1  # about at rest again (it moved at 5 rad/s)
    assert obs[20] == 1.0  # by now (0.31 s) the camera's ball is tracked


def test_step_env_missed_ball_ends_with_the_referees_reward(stepped):
    stepped.reset(seed=7)
    rewards, done, steps = [], False, 0
    while not done:
        _, reward, terminated, truncated, info = stepped.step(np.zeros(7))
        rewards.append(reward)
        done, steps = terminated or truncated, steps + 1
    assert terminated and not truncated  # the referee ended it: the ball reached the floor
    assert info["outcome"]["outcome"] == "missed" and not info["is_success"]
    assert rewards == [0.0] * steps
    assert steps < stepped.unwrapped._t_end * 100


def test_scenario_options_name_a_file_or_pass_an_object():
    from tt_drake.diagrams.gym_envs import make_scenario
    from tt_drake.diagrams.scenario import scenario_path

    by_name = make_scenario("default", distribution="fixed")
    by_path = make_scenario(str(scenario_path("default")))
    given = load_scenario()
    given.referee.target_x = 0.3
    by_object = make_scenario(given, distribution="real")
    assert by_name.launcher.distribution == "fixed"
    assert by_path.launcher.distribution == given.launcher.distribution == "default"
    assert by_object.launcher.distribution == "real" and by_object.referee.target_x == 0.3


def test_bad_options_fail_clearly():
    with pytest.raises(ScenarioError, match="distribution"):
        gymnasium.make("tt_drake/ReturnBall-v0", distribution="nope")
    with pytest.raises(ValueError, match="control_rate"):
        gymnasium.make("tt_drake/ReturnBallStep-v0", control_rate=30.0)
    with pytest.raises(ValueError, match="render_mode"):
        ReturnBallEnv(render_mode="human")


def _example(name):
    import importlib.util
    import sys
    from pathlib import Path

    folder = Path(__file__).resolve().parents[2] / "docs" / "examples"
    sys.path.insert(0, str(folder))
    try:
        spec = importlib.util.spec_from_file_location(f"example_{name}", folder / f"{name}.py")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    finally:
        sys.path.remove(str(folder))
    return module


def test_gym_examples_write_their_curves_and_reject_bad_options(tmp_path, capsys):
    import json

    random_policy, cmaes = _example("gym_random"), _example("gym_cmaes")
    out = str(tmp_path / "random")
    assert random_policy.main(["--episodes", "1", "--seed", "3", "--out", out]) == 0
    result = json.loads((tmp_path / "random.json").read_text())
    assert result["analytical"]["serve_seeds"] == result["random"]["serve_seeds"]
    assert result["analytical"]["successes"] == [True]  # action 0: the teacher's return
    assert (tmp_path / "random.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    out2 = str(tmp_path / "cmaes")
    assert cmaes.main(["--episodes", "2", "--popsize", "2", "--serves", "1", "--eval-episodes",
                       "1", "--seed", "3", "--random-json", out + ".json", "--out", out2]) == 0
    run = json.loads((tmp_path / "cmaes.json").read_text())
    assert [h["episodes"] for h in run["history"]] == [2]
    assert run["final"]["serve_seeds"] == result["random"]["serve_seeds"]  # same serves
    assert (tmp_path / "cmaes.png").stat().st_size > 0
    (tmp_path / "cmaes.png").unlink()
    assert cmaes.main(["--replot", "--random-json", out + ".json", "--out", out2]) == 0
    assert (tmp_path / "cmaes.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    capsys.readouterr()
    bad = str(tmp_path / "bad")
    assert cmaes.main(["--episodes", "1", "--popsize", "2", "--out", bad]) == 2
    assert random_policy.main(["--episodes", "0", "--out", bad]) == 2
    assert capsys.readouterr().err.count("\n") == 2
    assert not list(tmp_path.glob("bad*"))
