"""``serve --ceiling``: the returnable serves are those the oracle teacher returns, and the
player's rate among them is counted over exactly those serves."""

import pytest

from tt_drake.diagrams import serve as serve_module
from tt_drake.diagrams.episodes import EpisodeResult
from tt_drake.diagrams.scenario import Scenario
from tt_drake.referee_rules import Outcome


def _result(seed, returned):
    outcome = Outcome("returned" if returned else "missed", returned, returned, False)
    return EpisodeResult(seed, [0.0] * 9, [0.0] * 7, 1.0, outcome, 0.1)


def test_ceiling_counts_the_players_returns_among_the_oracles(monkeypatch):
    player = [True, False, True, False, True]
    oracle = [True, True, False, False, True]
    asked = {}

    def fake_episodes(scenario, player_name, serves, seed, progress, workers):
        asked.update(perception=scenario.perception, player=player_name, serves=serves,
                     seed=seed, run_seed=scenario.launcher.run_seed)
        return [_result(i, r) for i, r in enumerate(oracle)]

    monkeypatch.setattr(serve_module, "_episodes", fake_episodes)
    scenario = Scenario()
    scenario.launcher.run_seed = 9
    results = [_result(i, r) for i, r in enumerate(player)]
    data = serve_module._report(scenario, "momp", 9, results)
    serve_module.add_ceiling(data, scenario, "momp", 5, 9, results, False, 1)
    # The same serves (seed, run seed) by the oracle analytical player; the caller's scenario
    # is left as it was.
    assert asked == dict(perception="oracle", player="analytical", serves=5, seed=9, run_seed=9)
    assert scenario.perception == "camera"
    s = data["summary"]
    assert s["returnable_rate"] == pytest.approx(3 / 5) and s["returnable_serves"] == 3
    assert s["returns_of_returnable"] == 2  # serves 0 and 4; serve 2 was not returnable
    assert s["return_rate_of_returnable"] == pytest.approx(2 / 3)
    assert [e["returnable"] for e in data["episodes"]] == oracle
    assert "returnable (oracle analytical) 60.0% (3 serves)" in serve_module.format_summary(data)


def test_ceiling_of_nothing_returnable_is_none_and_the_oracle_run_is_its_own_ceiling(
        monkeypatch):
    monkeypatch.setattr(serve_module, "_episodes", lambda *a: [_result(0, False)])
    results = [_result(0, True)]
    data = serve_module._report(Scenario(), "analytical", 1, results)
    serve_module.add_ceiling(data, Scenario(), "analytical", 1, 1, results, False, 1)
    assert data["summary"]["return_rate_of_returnable"] is None
    assert "n/a" in serve_module.format_summary(data)

    def no_second_run(*_args):
        raise AssertionError("the oracle teacher's own run needs no second run")

    monkeypatch.setattr(serve_module, "_episodes", no_second_run)
    oracle = Scenario(perception="oracle")
    data = serve_module._report(oracle, "analytical", 1, results)
    serve_module.add_ceiling(data, oracle, "analytical", 1, 1, results, False, 1)
    assert data["summary"]["returnable_rate"] == 1.0
    assert data["summary"]["return_rate_of_returnable"] == 1.0
