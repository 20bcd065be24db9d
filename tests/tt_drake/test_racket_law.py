"""The analytical player's stroke math: aim with drag, racket law, and both checked end to end."""

import numpy as np
import pytest

from tt_drake.ball_model import BallModel
from tt_drake.constants import NET, TABLE, TARGET
from tt_drake.racket_law import (
    aim_return,
    ball_after_racket,
    landing_after_racket,
    net_clearance,
    racket_for_return,
    racket_restitution,
    solve_outgoing_velocity,
)

MODEL = BallModel(dt=5e-4)
CONTACT_Z = TABLE.surface_z + 0.02


def landing(p, v):
    """Where the ball centre first comes down to table-contact height (fine-step model)."""
    c = MODEL.predict_plane(np.r_[p, v, 0, 0, 0], TABLE.opponent_edge_y)
    assert c is not None and c.bounces, "the ball never came down on the table"
    return np.array(c.bounces[0].position)


@pytest.mark.parametrize("p_hit, v_in", [
    ((0.3, -1.82, 1.0), (0.2, -4.5, 1.5)),
    ((-0.15, -1.82, 0.85), (0.5, -6.0, 0.5)),
    ((0.75, -1.82, 1.45), (-0.6, -3.5, 2.5)),
])
def test_planned_racket_state_sends_the_ball_to_the_target_within_1cm(p_hit, v_in):
    aim = aim_return(np.array(p_hit), np.array(v_in))
    racket = racket_for_return(v_in, aim.v_out)
    v_out = ball_after_racket(v_in, racket)  # the impact law, forward
    land = landing(p_hit, v_out)
    assert np.hypot(land[0] - TARGET.x, land[1] - TARGET.y) < 0.01
    assert aim.net_clearance >= 0.05


def test_drag_matters_a_drag_free_aim_lands_short():
    p = np.array([0.3, -1.82, 1.0])
    goal = np.array([TARGET.x, TARGET.y, CONTACT_Z])
    v_drag = solve_outgoing_velocity(p, goal, 0.6, MODEL)
    t = 0.6
    v_parabola = (goal - p - 0.5 * np.array([0, 0, -9.81]) * t * t) / t
    short = landing(p, v_parabola)
    assert TARGET.y - short[1] > 0.1
    assert np.linalg.norm(landing(p, v_drag)[:2] - goal[:2]) < 1e-3


def test_racket_law_matches_equations_md_along_the_normal():
    v_in, v_out = np.array([0.3, -5.0, 1.0]), np.array([-0.5, 5.5, 2.0])
    r = racket_for_return(v_in, v_out)
    n = r.normal
    assert np.allclose(n, (v_out - v_in) / np.linalg.norm(v_out - v_in))
    e = r.restitution
    # Normal speed of the racket: (n.v_out + e n.v_in) / (1 + e), with e at the impact speed.
    assert n @ r.velocity == pytest.approx((n @ v_out + e * (n @ v_in)) / (1 + e))
    assert e == pytest.approx(racket_restitution(n @ (r.velocity - v_in)))
    # Tangentially the racket moves with the ball: no slip, so friction does not act.
    tangential = (np.eye(3) - np.outer(n, n))
    assert np.allclose(tangential @ r.velocity, tangential @ v_in)


def test_held_racket_restitution_matches_the_drake_measurements():
    # tests/systems/test_racket.py measured 0.862, 0.781, 0.712 at 4, 8, 12 m/s.
    for speed, e in ((4.0, 0.862), (8.0, 0.781), (12.0, 0.712)):
        assert racket_restitution(speed) == pytest.approx(e, abs=0.015)


def test_net_clearance_sign():
    p = np.array([0.0, -1.0, TABLE.surface_z + NET.height + 0.02 + 0.3])
    assert net_clearance(MODEL, p, np.array([0.0, 8.0, 0.0])) > 0
    assert net_clearance(MODEL, p, np.array([0.0, 2.0, -1.5])) == -np.inf


def test_no_impact_needed_is_an_error():
    with pytest.raises(ValueError):
        racket_for_return([1.0, 2.0, 3.0], [1.0, 2.0, 3.0])


@pytest.mark.parametrize("spin", [(0.0, 0.0, 0.0), (140.0, 28.0, -57.0), (-60.0, 0.0, 30.0)])
def test_landing_after_racket_inverts_the_aim(spin):
    """The racket the teacher plans for an aim lands the (spinning) ball at the aim's target; a
    racket turned 3 degrees about the vertical lands it measurably to the side; one that sends
    the ball upward at 6 m/s misses the table (None)."""
    p_hit, v_in = np.array([0.3, -1.82, 1.0]), np.array([0.2, -4.5, 1.5])
    aim = aim_return(p_hit, v_in, spin=spin, model=MODEL)
    racket = racket_for_return(v_in, aim.v_out, spin)
    landed = landing_after_racket(p_hit, v_in, racket, spin, MODEL)
    assert np.linalg.norm(landed - (TARGET.x, TARGET.y)) < 0.005
    c, s = np.cos(np.radians(3.0)), np.sin(np.radians(3.0))
    turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    turned = type(racket)(turn @ racket.normal, turn @ racket.velocity, racket.restitution)
    assert abs(landing_after_racket(p_hit, v_in, turned, spin, MODEL)[0] - landed[0]) > 0.05
    up = type(racket)(np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, 6.0]), 0.8)
    assert landing_after_racket(p_hit, v_in, up, spin, MODEL) is None
