"""The rally's per-stroke aims (tt_drake.rally_aim): a pure function of (seed, stroke), drawn
from the configured ranges and kinds."""

import numpy as np
import pytest

from tt_drake.rally_aim import STROKE_KINDS, CompetitiveAim, draw_aim


def test_an_aim_is_a_pure_function_of_the_rallys_seed_and_the_strokes_index():
    c = CompetitiveAim()
    assert draw_aim(c, 7, 3) == draw_aim(c, 7, 3)
    assert draw_aim(c, 7, 3) != draw_aim(c, 7, 4) != draw_aim(c, 8, 4)


def test_the_draws_cover_their_ranges_with_the_kinds_probabilities():
    c = CompetitiveAim()
    aims = [draw_aim(c, 11, k) for k in range(4000)]
    for name, values in (("x", [a.target_x for a in aims]), ("y", [a.target_y for a in aims]),
                         ("flight_time", [a.flight_time for a in aims])):
        low, high = getattr(c, name)
        assert low <= min(values) and max(values) <= high
        # uniform: mean at the middle, standard deviation (high - low) / sqrt(12)
        assert np.mean(values) == pytest.approx((low + high) / 2, abs=0.02 * (high - low))
        assert np.std(values) == pytest.approx((high - low) / np.sqrt(12), rel=0.05)
    shares = [np.mean([a.kind == k for a in aims]) for k in STROKE_KINDS]
    np.testing.assert_allclose(shares, c.kinds, atol=0.025)
    drives = [a.topspin for a in aims if a.kind == "drive"]
    assert c.drive_topspin[0] <= min(drives) and max(drives) <= c.drive_topspin[1]
    assert {a.topspin for a in aims if a.kind == "push"} == {c.push_topspin}
    assert {a.topspin for a in aims if a.kind == "block"} == {c.block_topspin}


def test_bad_ranges_and_probabilities_are_named():
    bad = CompetitiveAim(y=[-0.2, 0.5], kinds=[0.5, 0.5, 0.5], flight_time=[0.8, 0.4])
    problems = " ".join(bad.problems())
    assert "rally.competitive.y" in problems and "kinds" in problems
    assert "flight_time" in problems
    assert CompetitiveAim().problems() == []
