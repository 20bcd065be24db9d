"""A stroke that chooses the return's spin: aim, face tilt and racket velocity together.

The flat stroke of :mod:`tt_drake.racket_law` sends the ball back with the spin it came with (an
incoming topspin leaves as backspin relative to the return). A brushed stroke tilts the face by
an angle alpha from v_out - v_in toward world up (:func:`tt_drake.racket_impact.brushed_normal`)
and moves it across the ball so that the ball leaves rolling on the rubber; friction then changes
the spin by (:mod:`tt_drake.racket_impact`)

    Delta omega = -(3 / (2 R)) n x Delta v_t,    |Delta v_t| = |v_out - v_in| sin(alpha),

perpendicular to the face normal n. Closing the face (alpha > 0) brushes upward and adds
topspin; opening it (alpha < 0) adds backspin.

:func:`spin_stroke` finds, for a landing target and flight time, the outgoing velocity and the
tilt whose outgoing spin has a wanted topspin component s* = omega_out . (z x d) (d: the
return's horizontal direction, :func:`tt_drake.racket_impact.topspin`). The outgoing spin bends
the flight (Magnus), so the aim and the spin are solved together by fixed point: aim with the
spin guessed, then the tilt by bisection on s(alpha) = s* within the friction cone (|tan alpha|
<= ``cone`` mu, a margin so that errors in the strike still leave the ball rolling), then aim
again with the spin that tilt makes, until the spin moves less than 1e-6 rad/s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tt_drake.ball_model import BallModel
from tt_drake.constants import BALL, TABLE
from tt_drake.racket_impact import (
    brushed_normal,
    racket_for_spin_return,
    rolling_spin_change,
    topspin,
)
from tt_drake.racket_law import (
    FLIGHT_TIMES,
    RacketState,
    aim_rank,
    net_clearance,
    racket_restitution,
    solve_outgoing_velocity,
)

#: The rubber's friction with the ball in the Drake world (docs/constants.md).
RACKET_MU = 0.9
#: The share of the friction cone a stroke may use.
CONE_SHARE = 0.8
#: World up: the brush direction of a topspin stroke (alpha > 0), against it for backspin.
UP = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class SpinStroke:
    """The ball's outgoing velocity and spin, the flight time and face tilt (rad) that make
    them, and the racket (normal, velocity, restitution) at impact."""

    v_out: np.ndarray
    spin_out: np.ndarray
    flight_time: float
    tilt: float
    racket: RacketState
    net_clearance: float


def _spin_after(v_in, spin_in, v_out, tilt: float) -> np.ndarray:
    """omega_out of a rolling exit for the face tilted by ``tilt``: omega_in - 3/(2R) n x
    Delta v_t."""
    n = brushed_normal(v_in, v_out, UP, tilt)
    dv = np.asarray(v_out) - np.asarray(v_in)
    return np.asarray(spin_in, dtype=float) + rolling_spin_change(n, dv - float(n @ dv) * n)


def _tilt_for(v_in, spin_in, v_out, wanted: float, max_tilt: float) -> float:
    """The tilt in [-max_tilt, max_tilt] whose rolling exit has topspin ``wanted`` (bisection;
    the topspin grows with the tilt); ValueError if the cone cannot make it."""

    def excess(tilt):
        return topspin(np.r_[0.0, 0.0, 0.0, v_out, _spin_after(v_in, spin_in, v_out, tilt)]) \
            - wanted

    lo, hi = -max_tilt, max_tilt
    f_lo, f_hi = excess(lo), excess(hi)
    if f_lo > 0.0 or f_hi < 0.0:
        raise ValueError(f"topspin {wanted:.0f} rad/s is outside what friction can make here "
                         f"({f_lo + wanted:.0f} to {f_hi + wanted:.0f} rad/s)")
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if excess(mid) > 0.0:
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


def spin_stroke(p_hit, v_in, spin_in, target, flight_time: float, wanted_topspin: float,
                model: BallModel | None = None, mu: float = RACKET_MU,
                cone: float = CONE_SHARE) -> SpinStroke:
    """The stroke that lands the ball at ``target`` (x, y on the table) after ``flight_time``
    with topspin ``wanted_topspin`` (rad/s; negative: backspin), from the ball's velocity
    ``v_in`` and spin ``spin_in`` at ``p_hit`` (module docstring). Raises ValueError if the
    friction cone cannot make that spin or the aim does not converge."""
    model = model or BallModel()
    p_hit = np.asarray(p_hit, dtype=float)
    v_in = np.asarray(v_in, dtype=float)
    goal = np.array([target[0], target[1], TABLE.surface_z + BALL.radius])
    max_tilt = float(np.arctan(cone * mu))
    spin = np.asarray(spin_in, dtype=float)
    for _ in range(30):
        v_out = solve_outgoing_velocity(p_hit, goal, flight_time, model, spin=spin)
        tilt = _tilt_for(v_in, spin_in, v_out, wanted_topspin, max_tilt)
        new_spin = _spin_after(v_in, spin_in, v_out, tilt)
        moved = float(np.linalg.norm(new_spin - spin))
        spin = new_spin
        if moved < 1e-6:
            break
    else:
        raise ValueError("the aim and the spin it makes do not settle")
    v_out = solve_outgoing_velocity(p_hit, goal, flight_time, model, spin=spin)
    normal = brushed_normal(v_in, v_out, UP, tilt)
    v_racket, e, spin_out = racket_for_spin_return(v_in, spin_in, v_out, normal, mu,
                                                   racket_restitution)
    return SpinStroke(v_out, spin_out, float(flight_time), tilt,
                      RacketState(normal, v_racket, e),
                      net_clearance(model, p_hit, v_out, spin_out))


def spin_stroke_candidates(p_hit, v_in, spin_in, target, wanted_topspin: float,
                           model: BallModel | None = None, flight_times=FLIGHT_TIMES,
                           min_clearance: float = 0.05) -> list[SpinStroke]:
    """:func:`spin_stroke` for every candidate flight time that has one, best first as the flat
    stroke's aims are ranked (:func:`tt_drake.racket_law.aim_candidates`): those clearing the
    net by ``min_clearance`` by increasing racket speed, then the others by decreasing
    clearance."""
    ranked = []
    for t in flight_times:
        try:
            stroke = spin_stroke(p_hit, v_in, spin_in, target, t, wanted_topspin, model)
        except ValueError:
            continue
        ranked.append((aim_rank(stroke.net_clearance, stroke.racket.velocity, min_clearance),
                       stroke))
    ranked.sort(key=lambda item: item[0])
    return [stroke for _, stroke in ranked]
