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
from tt_drake.constants import BALL, PLANES, TABLE
from tt_drake.diagrams.episodes import ServeDiagram, add_analytical_player
from tt_drake.diagrams.gym_envs import (
    SHAPING_LENGTH,
    SHAPING_MAX,
    ReturnBallEnv,
    ReturnBallStepEnv,
)
from tt_drake.diagrams.gym_render import FrameRenderer
from tt_drake.diagrams.scenario import ScenarioError, load_scenario
from tt_drake.systems.analytical_player import AnalyticalPlayer

SERVE = 1234568  # a default serve the analytical player returns on target


@pytest.fixture(scope="module")
def episodic():
    env = gymnasium.make("tt_drake/ReturnBall-v0")
    yield env
    env.close()


@pytest.fixture(scope="module")
def absolute():
    env = gymnasium.make("tt_drake/ReturnBall-v0", action="absolute", reward="shaped")
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


ENVIRONMENTS = [("tt_drake/ReturnBall-v0", {}),
                ("tt_drake/ReturnBall-v0", {"action": "absolute"}),
                ("tt_drake/ReturnBallStep-v0", {})]


@pytest.mark.parametrize(("env_id", "kwargs"), ENVIRONMENTS)
def test_gymnasium_check_env_passes_without_warnings_with_float32_spaces(env_id, kwargs):
    env = gymnasium.make(env_id, **kwargs).unwrapped
    assert env.observation_space.dtype == env.action_space.dtype == np.float32
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env)
    assert [str(w.message) for w in caught] == []
    obs, _ = env.reset(seed=1)
    assert obs.dtype == np.float32 and obs in env.observation_space


def test_episodic_zero_action_is_theadd_analytical_players_return(episodic):
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
    action[3], action[8] = 0.5, -1.0  # theta_4 += 0.05 rad, theta_dot_2 -= 1 rad/s
    _, reward, *_ = episodic.step(action)
    new = env.player.player_state(env.player.GetMyContextFromRoot(env.serve_diagram.context))
    np.testing.assert_allclose(new.stroke.q_hit - stroke.q_hit, [0, 0, 0, 0.05, 0, 0, 0],
                               atol=1e-15)
    np.testing.assert_allclose(new.stroke.qd_hit - stroke.qd_hit, [0, -1, 0, 0, 0, 0, 0],
                               atol=1e-15)
    # The servo tracked the new stroke: the arm passes the hitting time at the offset
    # configuration (logged at 250 Hz; the nearest sample is within 2 ms of t_hit).
    log = env.serve_diagram.arm_logger.FindLog(env.serve_diagram.context)
    k = int(np.argmin(np.abs(log.sample_times() - stroke.t_hit)))
    q = log.data()[:7, k] + log.data()[7:, k] * (stroke.t_hit - log.sample_times()[k])
    assert np.abs(q - new.stroke.q_hit).max() < 0.02
    assert abs(q[3] - stroke.q_hit[3] - 0.05) < 0.02


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
    np.testing.assert_array_equal(obs[:7], q_await.astype(np.float32))
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
        ReturnBallEnv(render_mode="ansi")


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
    assert random_policy.main(["--episodes", "1", "--seed", "6", "--out", out]) == 0
    result = json.loads((tmp_path / "random.json").read_text())
    assert result["analytical"]["serve_seeds"] == result["random"]["serve_seeds"]
    assert result["analytical"]["successes"] == [True]  # action 0: the teacher's return, on target
    assert (tmp_path / "random.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    out2 = str(tmp_path / "cmaes")
    assert cmaes.main(["--episodes", "2", "--popsize", "2", "--serves", "1", "--eval-episodes",
                       "1", "--seed", "6", "--random-json", out + ".json", "--out", out2]) == 0
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


def _absolute_action(env, q_hit, qd_hit, t_hit):
    """The absolute mode's action for a stroke (the inverse of ``ReturnBallEnv.stroke_of``)."""
    window = env.player.player_state(env.player.GetMyContextFromRoot(
        env.serve_diagram.context)).window
    return np.r_[(q_hit - env.q_centre) / env.q_half, qd_hit / env.qd_max,
                 2.0 * (t_hit - window.start) / (window.end - window.start) - 1.0]


def test_absolute_mode_plays_the_teachers_stroke_when_given_it(episodic, absolute):
    """No teacher inside, but the action space holds its strokes: the analytical stroke of the
    serve, given as an absolute action, returns it as the teacher does (the same landing to
    1 mm; the stroke starts from the awaiting posture at the decision, not where the teacher
    was). The arm passes t_hit at the chosen configuration."""
    episodic.reset(options={"serve_seed": SERVE})
    env = episodic.unwrapped
    stroke = env.player.player_state(env.player.GetMyContextFromRoot(
        env.serve_diagram.context)).stroke
    *_, teacher = episodic.step(np.zeros(14))
    obs, start = absolute.reset(options={"serve_seed": SERVE})
    assert start["committed"] and obs.shape == (18,)
    assert 0.0 < obs[9] < obs[17] < obs[10]  # the plane crossing lies inside the window
    assert obs[12] == pytest.approx(PLANES.hitting_y)
    env = absolute.unwrapped
    action = _absolute_action(env, stroke.q_hit, stroke.qd_hit, stroke.t_hit)
    assert np.abs(action).max() < 1.0
    np.testing.assert_allclose(env.stroke_of(action)[0], stroke.q_hit, atol=1e-12)
    _, reward, terminated, _, info = absolute.step(action.astype(np.float32))
    assert terminated and info["outcome"]["returned"] and info["is_success"]
    np.testing.assert_allclose(info["outcome"]["landing"], teacher["outcome"]["landing"],
                               atol=1e-3)
    assert reward == pytest.approx(teacher["outcome"]["reward"], abs=1e-3)
    # A hit: the racket centre came within the ball's radius plus half the blade of its centre.
    assert info["closest_approach"] < BALL.radius + wp.RACKET.blade_thickness + 0.02
    log = env.serve_diagram.arm_logger.FindLog(env.serve_diagram.context)
    k = int(np.argmin(np.abs(log.sample_times() - stroke.t_hit)))
    q = log.data()[:7, k] + log.data()[7:, k] * (stroke.t_hit - log.sample_times()[k])
    assert np.abs(q - stroke.q_hit).max() < 0.02


def test_absolute_window_is_between_the_two_robot_side_contacts(absolute):
    """The window starts at the ball's bounce on the robot's half and ends where it comes down
    to the table's contact height again (the true ball, logged at 250 Hz: within 2 samples)."""
    obs, start = absolute.reset(options={"serve_seed": SERVE})
    env = absolute.unwrapped
    absolute.step(np.r_[np.zeros(14), 1.0].astype(np.float32))  # the latest hit: a miss here
    times, ball, _ = env.serve_diagram.poses()
    z, y = ball[:, 6], ball[:, 5]
    contact = TABLE.surface_z + BALL.radius
    robot_half = (y < 0.0) & (times > start["time"])
    bounce = times[robot_half][np.argmin(z[robot_half][: int(0.4 * 250)])]
    assert start["time"] + obs[9] == pytest.approx(bounce, abs=0.008)
    later = robot_half & (times > bounce + 0.05) & (z <= contact + 1e-3)
    assert start["time"] + obs[10] == pytest.approx(times[later][0], abs=0.008)


def test_shaped_reward_grades_a_miss_by_the_closest_approach(absolute):
    """Off by default; with ``reward="shaped"`` a miss scores SHAPING_MAX exp(-d / length)
    (< 0.2, a hit's least) where the referee gives 0, and a hit the referee's reward."""
    referee = gymnasium.make("tt_drake/ReturnBall-v0", action="absolute")
    assert referee.unwrapped.reward_mode == "referee"
    action = np.full(15, 0.2, dtype=np.float32)
    results = []
    for env in (referee, absolute):
        env.reset(options={"serve_seed": SERVE})
        results.append(env.step(action))
    (_, plain, *_, plain_info), (_, shaped, *_, info) = results
    assert not info["outcome"]["hit"] and plain == 0.0 and "closest_approach" not in plain_info
    d = info["closest_approach"]
    assert 0.05 < d < 2.0
    assert shaped == pytest.approx(SHAPING_MAX * np.exp(-d / SHAPING_LENGTH))
    assert info["outcome"] == plain_info["outcome"]  # the shaping changes no verdict


def test_step_env_shaped_reward_on_the_last_step_only():
    env = gymnasium.make("tt_drake/ReturnBallStep-v0", reward="shaped")
    env.reset(seed=7)
    rewards, done = [], False
    while not done:
        _, reward, terminated, truncated, info = env.step(np.zeros(7, dtype=np.float32))
        rewards.append(reward)
        done = terminated or truncated
    assert info["outcome"]["outcome"] == "missed" and rewards[:-1] == [0.0] * (len(rewards) - 1)
    d = info["closest_approach"]  # the arm held still at the awaiting posture
    assert rewards[-1] == pytest.approx(SHAPING_MAX * np.exp(-d / SHAPING_LENGTH))
    assert 0.0 < rewards[-1] < SHAPING_MAX


def test_unbounded_options_are_refused_by_name():
    with pytest.raises(ValueError, match="max_position_offset"):
        gymnasium.make("tt_drake/ReturnBall-v0", max_position_offset=np.inf)
    with pytest.raises(ValueError, match="max_velocity_offset"):
        gymnasium.make("tt_drake/ReturnBall-v0", max_velocity_offset=np.nan)
    with pytest.raises(ValueError, match="control_rate"):
        gymnasium.make("tt_drake/ReturnBallStep-v0", control_rate=np.inf)
    with pytest.raises(ValueError, match="action"):
        gymnasium.make("tt_drake/ReturnBall-v0", action="joints")
    with pytest.raises(ValueError, match="reward"):
        gymnasium.make("tt_drake/ReturnBallStep-v0", reward="dense")


def test_nan_actions_are_refused_naming_the_action_in_both_environments(episodic, stepped):
    """The same rule in both: a NaN (or infinite) action raises ValueError naming the action,
    before anything is simulated; the episode goes on with a valid action."""
    obs, _ = episodic.reset(options={"serve_seed": SERVE})
    bad = np.zeros(14)
    bad[3] = np.nan
    with pytest.raises(ValueError, match="action"):
        episodic.step(bad)
    _, reward, terminated, _, info = episodic.step(np.zeros(14))
    assert terminated and info["outcome"]["returned"]
    stepped.reset(options={"serve_seed": SERVE})
    t = stepped.unwrapped.serve_diagram.context.get_time()
    with pytest.raises(ValueError, match="action"):
        stepped.step(np.full(7, np.nan))
    assert stepped.unwrapped.serve_diagram.context.get_time() == t
    stepped.step(np.zeros(7))
    assert stepped.unwrapped.serve_diagram.context.get_time() == pytest.approx(t + 0.01)


def test_one_step_episodes_need_same_step_autoreset_in_vector_envs():
    """Gymnasium 1.x vector envs reset a finished sub-environment on the *next* step by default:
    with one-step episodes every other step is then a reset, reward 0, nothing played. With
    ``autoreset_mode=SAME_STEP`` every step plays a serve (docs/gym.md)."""
    from gymnasium.vector import AsyncVectorEnv, AutoresetMode, SyncVectorEnv

    def make():
        return gymnasium.make("tt_drake/ReturnBall-v0", action="absolute")

    envs = AsyncVectorEnv([make, make], autoreset_mode=AutoresetMode.SAME_STEP)
    try:
        obs, infos = envs.reset(seed=3)
        assert obs.shape == (2, 18) and obs.dtype == np.float32
        for _ in range(2):
            zero = np.zeros((2, 15), dtype=np.float32)
            obs, rewards, terminated, truncated, infos = envs.step(zero)
            assert terminated.all() and not truncated.any()
            # The episode's info and last observation; obs is already the next serve's.
            final = infos["final_info"]
            assert set(final["outcome"]["outcome"]) <= {"missed", "fault", "returned"}
            assert not np.array_equal(infos["final_obs"][0], obs[0])
            assert obs.shape == (2, 18) and np.abs(obs).sum(axis=1).min() > 0  # new serves
    finally:
        envs.close()
    sync = SyncVectorEnv([make])  # the default, AutoresetMode.NEXT_STEP
    sync.reset(seed=3)
    first = sync.step(np.zeros((1, 15), dtype=np.float32))
    second = sync.step(np.zeros((1, 15), dtype=np.float32))
    assert first[2][0] and not second[2][0] and second[1][0] == 0.0  # a reset, not a serve
    assert "outcome" not in second[4]
    sync.close()


def test_step_env_runs_in_an_async_vector_env():
    from gymnasium.vector import AsyncVectorEnv

    envs = AsyncVectorEnv([lambda: gymnasium.make("tt_drake/ReturnBallStep-v0")] * 2)
    try:
        obs, _ = envs.reset(seed=[5, 6])
        np.testing.assert_array_equal(obs[:, :7], np.float32([wp.AWAITING] * 2))
        action = np.zeros((2, 7), dtype=np.float32)
        action[:, 1] = 0.5
        for _ in range(10):  # 0.1 s: a stock joint 2 reaches 0.1 rad in about 0.07 s
            obs, rewards, *_ = envs.step(action)
        assert obs.dtype == np.float32 and (rewards == 0.0).all()
        assert (obs[:, 1] > wp.AWAITING[1] + 0.1).all()  # both arms follow joint 2's set-point
    finally:
        envs.close()


def test_rgb_array_frames_show_the_arm_and_the_ball():
    """(H, W, 3) uint8 frames from Drake's VTK render engine, offscreen; moving the ball or the
    arm changes the pixels where they are drawn, and only there."""
    env = gymnasium.make("tt_drake/ReturnBall-v0", render_mode="rgb_array")
    env.reset(options={"serve_seed": SERVE})
    frame = env.render()
    env.close()
    assert frame.shape == (360, 480, 3) and frame.dtype == np.uint8
    renderer = FrameRenderer(load_scenario().world)
    q = np.asarray(wp.AWAITING)
    away = np.r_[1.0, 0.0, 0.0, 0.0, 0.0, 3.0, -5.0]  # the ball far outside the view
    ball = np.r_[1.0, 0.0, 0.0, 0.0, 0.3, -1.0, 1.2]  # above the robot's half of the table
    empty = renderer.frame(q, away).astype(int)
    with_ball = np.abs(renderer.frame(q, ball).astype(int) - empty).sum(axis=2) > 0
    assert 3 <= with_ball.sum() < 400  # a 40 mm ball, a few pixels across
    bent = q.copy()
    bent[0] += 0.5
    moved = np.abs(renderer.frame(bent, away).astype(int) - empty).sum(axis=2) > 0
    assert moved.sum() > 500  # the arm swung: many pixels changed
    assert frame.std() > 10  # not a blank image


def test_human_mode_writes_the_episodes_as_a_meshcat_page(tmp_path):
    path = tmp_path / "episodes.html"
    env = gymnasium.make("tt_drake/ReturnBall-v0", render_mode="human", html=str(path))
    env.reset(options={"serve_seed": SERVE})
    assert env.render() is None and not path.exists()  # no episode has ended yet
    for serve in (SERVE, SERVE + 1):
        env.reset(options={"serve_seed": serve})
        env.step(np.zeros(14))
    assert env.render() is None  # Gymnasium's rule for human rendering; the page is written
    page = path.read_text()
    assert page.startswith("<!DOCTYPE html>") or "<html" in page[:500]
    assert "ReturnBallEnv player, 2 default serves" in page
