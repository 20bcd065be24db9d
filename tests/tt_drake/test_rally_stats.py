"""Figures of a player's returns (tt_drake.rally_stats): spin sense, mirror invariance, spread."""

import numpy as np
import pytest

from tt_drake.ball_model import BallModel
from tt_drake.racket_impact import topspin
from tt_drake.rally_stats import from_returners_end, outgoing_figures

# A drive from the robot's end: 1.5 m behind the net's plane, 0.25 m above the table, 6 m/s.
DRIVE = np.array([0.1, -1.5, 1.01, -0.2, 5.8, 1.4, -80.0, 5.0, 10.0])


def mirrored(state):
    """The same return played from the other end: turned by Rz(pi)."""
    s = np.asarray(state, dtype=float)
    return np.array([-s[0], -s[1], s[2], -s[3], -s[4], s[5], -s[6], -s[7], s[8]])


def test_topspin_turns_the_balls_top_toward_its_travel():
    # omega . (z x d), z x d = (-d_y, d_x, 0)
    assert topspin(DRIVE) == pytest.approx((80.0 * 5.8 - 5.0 * 0.2) / np.hypot(0.2, 5.8))
    assert topspin(mirrored(DRIVE)) == pytest.approx(topspin(DRIVE))
    backspin = DRIVE.copy()
    backspin[6] = 80.0
    assert topspin(backspin) < 0.0
    # the top point's velocity relative to the centre, omega x (R z), points along the travel
    top = np.cross(DRIVE[6:9], [0.0, 0.0, 0.02])
    assert top @ DRIVE[3:6] > 0.0
    with pytest.raises(ValueError, match="horizontally"):
        topspin([0, 0, 1, 0, 0, -3, 10, 0, 0])


def test_the_figures_are_the_same_from_either_end():
    rng = np.random.default_rng(3)
    states = [DRIVE + np.r_[rng.normal(0, 0.05, 3), rng.normal(0, 0.3, 3), rng.normal(0, 20, 3)]
              for _ in range(8)]
    mixed = [s if k % 2 else mirrored(s) for k, s in enumerate(states)]
    assert outgoing_figures(mixed) == outgoing_figures(states)
    np.testing.assert_allclose(from_returners_end(mirrored(DRIVE)), DRIVE)


def test_a_repeated_return_has_no_spread_and_two_mirror_images_across_have_their_offset():
    one = outgoing_figures([DRIVE] * 3)
    assert one["landing_std"] == [0.0, 0.0] and one["n"] == one["landed"] == 3
    at_net = one["speed_at_net"]
    assert at_net["p10"] == at_net["p50"] == at_net["p90"] < np.linalg.norm(DRIVE[3:6])
    assert one["topspin_share"] == 1.0
    # Mirror images through the plane x = 0 (spin about x only, which the reflection keeps) land
    # at +-x: spread across |x|, none along.
    right = np.r_[DRIVE[:6], -80.0, 0.0, 0.0]
    left = right * np.array([-1, 1, 1, -1, 1, 1, 1, 1, 1])
    x_land = BallModel().first_bounce(right).position[0]
    pair = outgoing_figures([left, right])
    assert pair["landing_std"][0] == pytest.approx(abs(x_land), abs=1e-4)
    assert pair["landing_std"][1] == pytest.approx(0.0, abs=1e-4)
    assert outgoing_figures([]) is None
