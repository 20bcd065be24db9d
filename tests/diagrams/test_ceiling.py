"""The returnable bound (``serve --ceiling``): a serve is returnable when one of the oracle
strategies returns it legally; the strategies are tried in order on what is left, and every
summary counts the player's returns inside and outside the bound."""

import numpy as np
import pytest

from tt_drake.diagrams import serve as serve_module
from tt_drake.diagrams.ceiling import (
    STRATEGIES,
    OracleStrategy,
    beyond_reach,
    ceiling_summary,
    returnable_by,
    strategy_player,
)
from tt_drake.diagrams.episodes import EpisodeResult, ServeDiagram, episode_seed
from tt_drake.diagrams.scenario import Scenario
from tt_drake.hitting_time import HittingBand
from tt_drake.referee_rules import Outcome
from tt_drake.serves import ServeSampler
from tt_drake.systems.momp_player import MOVING_GOAL_TORQUE_FRACTION
from tt_drake.wam_params import (
    RACKET,
    racket_center_in_world,
    reach_bound,
    shoulder_pose_in_world,
)


def _result(seed, returned):
    outcome = Outcome("returned" if returned else "missed", returned, returned, False)
    return EpisodeResult(seed, [0.0] * 9, [0.0] * 7, 1.0, outcome, 0.1)


def test_strategies_are_tried_in_order_on_the_serves_left():
    a, b, c = (OracleStrategy(n) for n in "abc")
    returns = {"a": {0, 3}, "b": {1, 3, 4}, "c": {4, 5}}
    asked = []

    def play(strategy, indices):
        asked.append((strategy.name, list(indices)))
        return [i in returns[strategy.name] for i in indices]

    found = returnable_by(play, 6, (a, b, c))
    assert found == ["a", "b", None, "a", "b", "c"]
    # each strategy plays only the serves no earlier one returned
    assert asked == [("a", [0, 1, 2, 3, 4, 5]), ("b", [1, 2, 4, 5]), ("c", [2, 5])]
    # nothing left: no further strategy is played
    asked.clear()
    assert returnable_by(play, 2, (OracleStrategy("b"), a, c)) == ["a", "b"]
    assert [name for name, _ in asked] == ["b", "a"]
    with pytest.raises(ValueError, match="1 results for 2 serves"):
        returnable_by(lambda s, i: [True], 2, (a,))


def test_ceiling_summary_counts_returns_inside_and_outside_the_bound():
    returned = [True, False, True, True, False]
    returnable = ["teacher", "long", None, "teacher", None]
    s = ceiling_summary(returned, returnable)
    assert s["returnable_serves"] == 3 and s["returnable_rate"] == pytest.approx(3 / 5)
    assert s["returns_of_returnable"] == 2
    assert s["return_rate_of_returnable"] == pytest.approx(2 / 3)
    assert s["returns_outside_ceiling"] == 1  # serve 2: the bound is wrong for this player
    assert ceiling_summary([False], [None])["return_rate_of_returnable"] is None
    with pytest.raises(ValueError, match="2 episodes but 1 ceiling"):
        ceiling_summary([True, False], [None])


def test_serve_ceiling_plays_the_same_serves_with_the_oracle_strategies(monkeypatch):
    player = [True, False, True, False, True]
    second = STRATEGIES[1].name
    by_strategy = {"teacher": {0, 1}, second: {4}}
    calls = []

    def fake_episodes(scenario, player_fn, seeds, progress, workers, label=None):
        calls.append((label, scenario.perception, scenario.launcher.run_seed, list(seeds)))
        name = label.split()[-1]
        index = {episode_seed(9, i): i for i in range(5)}
        return [_result(s, index[s] in by_strategy.get(name, set())) for s in seeds]

    monkeypatch.setattr(serve_module, "_episodes", fake_episodes)
    scenario = Scenario()
    scenario.launcher.run_seed = 9
    results = [_result(i, r) for i, r in enumerate(player)]
    data = serve_module._report(scenario, "momp", 9, results)
    serve_module.add_ceiling(data, scenario, "momp", 5, 9, results, False, 1)
    # the same serves (seed, run seed), the oracle's perception; the caller's scenario unchanged
    assert calls[0] == ("oracle teacher", "oracle", 9, [episode_seed(9, i) for i in range(5)])
    assert calls[1][3] == [episode_seed(9, i) for i in (2, 3, 4)]
    # serves 2 and 3 stay unreturned: every later strategy tries them, and only them
    assert len(calls) == len(STRATEGIES)
    assert all(c[3] == [episode_seed(9, i) for i in (2, 3)] for c in calls[2:])
    assert scenario.perception == "camera"
    s = data["summary"]
    assert s["returnable_serves"] == 3 and s["returnable_rate"] == pytest.approx(3 / 5)
    assert s["returns_of_returnable"] == 2  # serves 0 and 4
    assert s["returns_outside_ceiling"] == 1  # serve 2
    assert [e["returnable_by"] for e in data["episodes"]] == [
        "teacher", "teacher", None, None, second]
    line = serve_module.format_summary(data)
    assert "legal return 60.0% [23.1%, 88.2%]" in line  # Wilson's 95 % interval of 3 in 5
    assert "legal returns outside the bound 1" in line


def test_a_strategy_plays_the_analytical_player_with_its_settings():
    strategy = OracleStrategy("x", target=(0.4, 1.0), band=HittingBand(z_min=0.7),
                              plane_y=-1.7)
    scenario = Scenario(perception="oracle")
    diagram = ServeDiagram(scenario, strategy_player(strategy))
    config = diagram.player.planner.config
    assert (config.target_x, config.target_y, config.band, config.plane_y) == (
        0.4, 1.0, HittingBand(z_min=0.7), -1.7)
    teacher = ServeDiagram(scenario, strategy_player(STRATEGIES[0])).player.planner.config
    assert (teacher.target_x, teacher.target_y) == (scenario.referee.target_x,
                                                    scenario.referee.target_y)
    assert len({s.name for s in STRATEGIES}) == len(STRATEGIES)


@pytest.mark.parametrize("fallbacks", [True, False])
def test_every_teacher_strategy_plays_the_scenarios_teacher(fallbacks):
    """The bound's teacher strategies plan as the scenario's teacher does (its ``teacher``
    settings and drives), with their own target, band, plane and spin shares on top: a teacher
    setting that returns more serves raises the bound with it."""
    scenario = Scenario(perception="oracle")
    scenario.teacher.correction_fallbacks = fallbacks
    scenario.teacher.plan_fallbacks = not fallbacks
    scenario.teacher.min_hitting = 0.15 if fallbacks else 0.0
    scenario.controller.drive_voltage = 40.0
    for strategy in STRATEGIES:
        if strategy.artefacts is not None:
            continue
        config = strategy.planner_config(scenario)
        assert (config.correction_fallbacks, config.plan_fallbacks) == (fallbacks, not fallbacks)
        assert config.times.min_hitting == scenario.teacher.min_hitting
        assert config.drive_voltage == 40.0 and config.plane_y == strategy.plane_y


def test_ceiling_from_reads_an_earlier_runs_bound_of_the_same_serves(tmp_path):
    """``serve --ceiling-from``: the bound of an earlier --ceiling run is reused only for the
    same serves; anything else is refused with one line."""
    import json

    results = [_result(i, r) for i, r in enumerate([True, False, True])]
    data = serve_module._report(Scenario(), "momp", 9, results)
    serve_module.add_returnable(data, results, ["teacher", None, "long"])
    path = tmp_path / "earlier.json"
    path.write_text(json.dumps(data))
    again = serve_module._report(Scenario(), "crkr", 9, results)
    assert serve_module.read_returnable(str(path), again) == ["teacher", None, "long"]
    other = serve_module._report(Scenario(), "crkr", 9, [_result(i + 1, True) for i in range(3)])
    with pytest.raises(serve_module.CeilingFileError, match="another run's serves"):
        serve_module.read_returnable(str(path), other)
    path.write_text(json.dumps({"episodes": [{"seed": 1}]}))
    with pytest.raises(serve_module.CeilingFileError, match="not a serve --ceiling --json"):
        serve_module.read_returnable(str(path), None)


def test_a_learned_strategy_plays_the_shipped_set_with_the_oracles_perception():
    from tt_drake.diagrams.ceiling import strategy_scenario
    from tt_drake.models import shipped_artefact

    learned = next(s for s in STRATEGIES if s.artefacts is not None)
    scenario = Scenario()
    played = strategy_scenario(learned, scenario)
    assert strategy_player(learned).keywords == {"band": learned.band}
    assert played.perception == "oracle" and scenario.perception == "camera"
    assert played.learned.library == str(shipped_artefact("library", learned.artefacts))
    assert scenario.learned.library == ""
    # the set as shipped, whatever the scenario's learned player does with a refused move
    for setting in ("correction_fallback", "stroke_fallbacks", "refresh_before_bounce"):
        assert getattr(scenario.learned, setting) and not getattr(played.learned, setting)
    assert played.learned.moving_goal
    # ... and asking the drives' supply the moving goal's multiple of the effort limits, not the
    # scenario's share
    assert played.learned.supply_fraction == MOVING_GOAL_TORQUE_FRACTION
    assert scenario.learned.supply_fraction != MOVING_GOAL_TORQUE_FRACTION
    teacher = strategy_scenario(STRATEGIES[0], scenario)
    assert teacher.learned == scenario.learned and teacher.perception == "oracle"


def test_a_camera_strategy_sees_the_serve_through_its_own_noise_stream():
    """The bound's camera strategies play the teacher through the camera with a noise stream
    the evaluated players never draw (stream 0 is theirs); an oracle strategy has none."""
    from tt_drake.diagrams.ceiling import strategy_scenario

    scenario = Scenario()
    cameras = [s for s in STRATEGIES if s.perception == "camera"]
    assert sorted(s.noise_stream for s in cameras) == [1, 1, 2, 2]
    played = strategy_scenario(cameras[0], scenario)
    assert (played.perception, played.camera.noise_stream) == ("camera", 1)
    assert scenario.camera.noise_stream == 0
    oracle = strategy_scenario(STRATEGIES[0], played)
    assert (oracle.perception, oracle.camera.noise_stream) == ("oracle", 0)
    with pytest.raises(ValueError, match="noise stream"):
        OracleStrategy("own-noise", perception="camera")
    with pytest.raises(ValueError, match="noise stream"):
        OracleStrategy("oracle-noise", noise_stream=3)


def test_the_reach_bound_bounds_the_racket_and_is_tight():
    """No joint angles put the blade farther from the shoulder than ``reach_bound`` (forward
    kinematics over random angles, limits ignored), and the stretched arm comes within 5 cm."""
    rng = np.random.default_rng(0)
    bound = reach_bound()
    shoulder = shoulder_pose_in_world()[:3, 3]
    far = max(float(np.linalg.norm(racket_center_in_world(q)[:3, 3] - shoulder))
              for q in rng.uniform(-np.pi, np.pi, (3000, 7))) + RACKET.blade_radius
    assert far <= bound < far + 0.05


def test_serves_beyond_reach_are_not_played_and_unreturnable():
    """A serve whose path in play never comes within reach is skipped by every strategy; a
    default serve (the paper's, returned by the teacher) is within reach."""
    sampler = ServeSampler("default")
    assert not beyond_reach(sampler.sample(3).launch_state)
    # bounces just past the net and leaves the table wide
    wide = np.array([0.0, 1.5, 1.0, 0.9, -5.0, 1.0, 0.0, 0.0, 0.0])
    assert beyond_reach(wide)
    asked = []

    def play(strategy, indices):
        asked.append(list(indices))
        return [True] * len(indices)

    found = returnable_by(play, 3, (OracleStrategy("a"),), within_reach=[True, False, True])
    assert found == ["a", None, "a"] and asked == [[0, 2]]
    with pytest.raises(ValueError, match="reach flags"):
        returnable_by(play, 3, (OracleStrategy("a"),), within_reach=[True])
