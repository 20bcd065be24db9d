"""Strokes that choose the return's spin (tt_drake.spin_stroke): forward through the impact law
and the flight model, they land on the target with the topspin asked for."""

import numpy as np
import pytest

from tt_drake.ball_model import BallModel
from tt_drake.constants import BALL, TABLE
from tt_drake.racket_impact import racket_impact, topspin
from tt_drake.racket_law import racket_for_return, solve_outgoing_velocity
from tt_drake.spin_stroke import RACKET_MU, spin_stroke, spin_stroke_candidates

P_HIT = np.array([0.2, -1.75, 0.95])
V_IN = np.array([-0.3, -4.6, -1.1])
SPIN_IN = np.array([110.0, 8.0, -15.0])  # topspin toward the robot: backspin on a flat return
TARGET = (-0.2, 0.9)


@pytest.mark.parametrize("wanted", [-40.0, 0.0, 40.0, 80.0])
def test_the_stroke_lands_on_the_target_with_the_topspin_asked_for(wanted):
    stroke = spin_stroke(P_HIT, V_IN, SPIN_IN, TARGET, 0.6, wanted)
    racket = stroke.racket
    out = racket_impact(V_IN, SPIN_IN, racket.normal, racket.velocity, racket.restitution,
                        RACKET_MU)
    assert out.rolling
    np.testing.assert_allclose(out.velocity, stroke.v_out, atol=1e-8)
    np.testing.assert_allclose(out.spin, stroke.spin_out, atol=1e-6)
    assert topspin(np.r_[P_HIT, out.velocity, out.spin]) == pytest.approx(wanted, abs=1e-6)
    landing = BallModel().first_bounce(np.r_[P_HIT, out.velocity, out.spin])
    assert landing.t == pytest.approx(0.6, abs=2e-3)
    np.testing.assert_allclose(landing.position[:2], TARGET, atol=2e-3)


def test_asking_for_the_spin_the_ball_has_is_the_flat_stroke():
    goal = (*TARGET, TABLE.surface_z + BALL.radius)
    v_flat = solve_outgoing_velocity(P_HIT, goal, 0.6, spin=SPIN_IN)
    flat_topspin = topspin(np.r_[P_HIT, v_flat, SPIN_IN])
    stroke = spin_stroke(P_HIT, V_IN, SPIN_IN, TARGET, 0.6, flat_topspin)
    assert abs(stroke.tilt) < 1e-9
    np.testing.assert_allclose(stroke.v_out, v_flat, atol=1e-9)
    flat = racket_for_return(V_IN, stroke.v_out, SPIN_IN)
    np.testing.assert_allclose(stroke.racket.normal, flat.normal, atol=1e-6)
    np.testing.assert_allclose(stroke.racket.velocity, flat.velocity, atol=1e-4)


def test_more_topspin_needs_a_more_closed_face_and_too_much_is_refused():
    tilts = [spin_stroke(P_HIT, V_IN, SPIN_IN, TARGET, 0.6, w).tilt for w in (0.0, 40.0, 80.0)]
    assert tilts[0] < tilts[1] < tilts[2]
    with pytest.raises(ValueError, match="friction"):
        spin_stroke(P_HIT, V_IN, SPIN_IN, TARGET, 0.6, 2000.0)
    ranked = spin_stroke_candidates(P_HIT, V_IN, SPIN_IN, TARGET, 60.0)
    assert ranked and all(s.net_clearance >= 0.05 for s in ranked[:1])
