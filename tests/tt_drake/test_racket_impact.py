"""The impulse law of a racket with friction (tt_drake.racket_impact): its limits, its inverse,
and the flat stroke of the teacher's racket law as its special case without slip."""

import numpy as np
import pytest

from tt_drake.constants import BALL
from tt_drake.racket_impact import (
    HOLLOW_BALL_RATIO,
    brushed_normal,
    racket_for_spin_return,
    racket_impact,
)
from tt_drake.racket_law import racket_for_return, racket_restitution

MU = 0.9
V_IN = np.array([0.3, -5.0, -1.2])  # a ball coming at the robot after its bounce
SPIN_IN = np.array([110.0, -10.0, 20.0])  # rad/s, topspin toward the robot
V_OUT = np.array([-0.2, 5.5, 1.6])  # a return toward the opponent


def energy(v, w, v_racket):
    """Kinetic energy per unit mass in the racket's frame: translation plus rotation
    (I / m = R^2 / HOLLOW_BALL_RATIO)."""
    u = np.asarray(v) - v_racket
    return 0.5 * u @ u + 0.5 * BALL.radius**2 / HOLLOW_BALL_RATIO * (np.asarray(w) @ w)


def test_the_flat_stroke_of_the_racket_law_leaves_the_spin_as_it_was():
    racket = racket_for_return(V_IN, V_OUT, SPIN_IN)
    out = racket_impact(V_IN, SPIN_IN, racket.normal, racket.velocity, racket.restitution, MU)
    np.testing.assert_allclose(out.velocity, V_OUT, atol=1e-9)
    np.testing.assert_allclose(out.spin, SPIN_IN, atol=1e-9)
    assert out.rolling


@pytest.mark.parametrize("tilt", [-0.6, -0.3, 0.0, 0.3, 0.6])
def test_a_brushed_stroke_returns_the_wanted_velocity_and_the_spin_it_predicts(tilt):
    n = brushed_normal(V_IN, V_OUT, (0.0, 0.0, 1.0), tilt)
    v_racket, e, spin_out = racket_for_spin_return(V_IN, SPIN_IN, V_OUT, n, MU,
                                                   racket_restitution)
    out = racket_impact(V_IN, SPIN_IN, n, v_racket, e, MU)
    np.testing.assert_allclose(out.velocity, V_OUT, atol=1e-9)
    np.testing.assert_allclose(out.spin, spin_out, atol=1e-7)
    assert out.rolling
    assert e == pytest.approx(racket_restitution(-(n @ (V_IN - v_racket))), abs=1e-12)
    # The tangential change |dv| sin(tilt) spins the ball about the face by 3/2 of it over R.
    dv = np.linalg.norm(V_OUT - V_IN)
    made = spin_out - SPIN_IN
    assert np.linalg.norm(made) == pytest.approx(
        HOLLOW_BALL_RATIO * dv * abs(np.sin(tilt)) / BALL.radius, rel=1e-9)
    assert abs(made @ n) < 1e-9
    # Brushing upward (tilt > 0) on a ball sent toward +y is topspin: omega_x < 0 grows.
    assert np.sign(made[0]) == -np.sign(tilt) or tilt == 0.0
    assert energy(out.velocity, out.spin, v_racket) <= energy(V_IN, SPIN_IN, v_racket) + 1e-12


def test_a_change_outside_the_friction_cone_is_refused():
    too_far = np.arctan(MU) + 0.05
    n = brushed_normal(V_IN, V_OUT, (0.0, 0.0, 1.0), too_far)
    with pytest.raises(ValueError, match="friction cone"):
        racket_for_spin_return(V_IN, SPIN_IN, V_OUT, n, MU, racket_restitution)
    inside = brushed_normal(V_IN, V_OUT, (0.0, 0.0, 1.0), np.arctan(MU) - 1e-6)
    racket_for_spin_return(V_IN, SPIN_IN, V_OUT, inside, MU, racket_restitution)


def test_a_sliding_ball_gets_mu_times_the_normal_impulse_against_its_slip():
    n = np.array([0.0, 1.0, 0.0])
    v = np.array([6.0, -1.0, 0.0])  # grazing: slip 6 m/s, normal 1 m/s
    out = racket_impact(v, np.zeros(3), n, np.zeros(3), 0.8, MU)
    assert not out.rolling
    dv = out.velocity - v
    assert dv[1] == pytest.approx(1.8)  # (1 + e) |u_n|
    assert dv[0] == pytest.approx(-MU * 1.8)  # friction against the slip, at its cone
    assert dv[2] == pytest.approx(0.0)
    # omega = r x J_t / I with r = -R y and J_t along -x: a spin about -z
    assert out.spin == pytest.approx([0.0, 0.0, -HOLLOW_BALL_RATIO * MU * 1.8 / BALL.radius])
    assert energy(out.velocity, out.spin, 0.0) < energy(v, np.zeros(3), 0.0)


def test_bad_input_is_refused_with_the_reason():
    n = np.array([0.0, 1.0, 0.0])
    with pytest.raises(ValueError, match="not approaching"):
        racket_impact([0.0, 1.0, 0.0], np.zeros(3), n, np.zeros(3), 0.8, MU)
    with pytest.raises(ValueError, match="restitution"):
        racket_impact([0.0, -1.0, 0.0], np.zeros(3), n, np.zeros(3), 1.2, MU)
    with pytest.raises(ValueError, match="friction"):
        racket_impact([0.0, -1.0, 0.0], np.zeros(3), n, np.zeros(3), 0.8, -0.1)
    with pytest.raises(ValueError, match="normal"):
        racket_impact([0.0, -1.0, 0.0], np.zeros(3), np.zeros(3), np.zeros(3), 0.8, MU)
    with pytest.raises(ValueError, match="parallel"):
        brushed_normal(V_IN, V_OUT, V_OUT - V_IN, 0.2)
