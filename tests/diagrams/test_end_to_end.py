"""End-to-end runs of the analytical player (slow: opt in with `make test-slow`).

The full figures come from `tt-drake serve --player analytical --serves 1000`
(see docs/analytical_player.md); these check the same on a small sample, so a regression shows
without a long run.
"""

import pytest

from tt_drake.diagrams.scenario import load_scenario
from tt_drake.diagrams.serve import run_serves


@pytest.mark.slow
def test_analytical_player_returns_default_serves():
    data = run_serves(load_scenario(), "analytical", 40, seed=123, progress=False, workers=2)
    s = data["summary"]
    assert s["return_rate"] >= 0.85
    assert s["target_rate"] >= 0.6
    assert s["joint_limit_violations"] == 0 and s["robot_table_contacts"] == 0
