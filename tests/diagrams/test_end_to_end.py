"""End-to-end runs of the analytical player (slow: opt in with `make test-slow`).

The full figures come from `tt-drake serve --player analytical --serves 1000`
(see docs/analytical_player.md); these check the same on a small sample, so a regression shows
without a long run.
"""

import pytest

from tt_drake.diagrams.scenario import load_scenario
from tt_drake.diagrams.serve import run_serves


@pytest.mark.slow
@pytest.mark.parametrize("robot", ["default", "ideal_robot"])
def test_analytical_player_returns_default_serves(robot):
    """On both robots the teacher returns the serves without touching the table. The ideal
    robot tracks its plans, which keep every joint inside its position limits; on the stock
    robot the wrist (joint 6) can pass its limit while it tracks a stroke
    (docs/analytical_player.md, "Drives"), so the limits are checked on the ideal robot only."""
    data = run_serves(load_scenario(robot), "analytical", 40, seed=123, progress=False, workers=2)
    s = data["summary"]
    assert s["return_rate"] >= 0.85
    assert s["target_rate"] >= 0.6
    assert s["robot_table_contacts"] == 0
    if robot == "ideal_robot":
        assert s["joint_limit_violations"] == 0
