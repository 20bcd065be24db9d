"""The analytical player's stroke: where to send the ball, and the racket state that sends it there.

Two steps, as in the teacher of the paper (its ref. [24]; docs/equations.md, "The teacher's racket
law"):

1. :func:`aim_return`: the outgoing ball velocity v_out that carries the ball from the hitting point
   to the landing target. It is solved with the drag model of :class:`BallModel` (a drag-free
   parabola lands the ball ~0.3 m short at these speeds), by Newton's method on
   p(T; v_out) = target for a flight time T chosen among candidates to keep the ball above the net
   with a margin while asking the least racket speed.
2. :func:`racket_for_return`: the racket normal n and velocity v_R. Along the normal, the impact
   law v_out,n = v_R,n + e (v_R,n - v_in,n) gives v_R,n = (n.v_out + e n.v_in) / (1 + e), and
   n = (v_out - v_in) / |v_out - v_in|. Tangentially the racket moves with the ball's contact
   point, v_R,t = tangential part of (v_in + omega x (-R n)): the contact point does not slip, so
   the rubber's friction (mu = 0.9 in our world) does not act and the ball's tangential velocity
   and spin pass unchanged, as the law assumes. The published form sets v_R,t = 0 instead, which
   with a grippy racket would pull the ball's tangential velocity toward the rolling limit; and a
   ball off the table carries 70-90 rad/s of topspin (omega R ~ 1.5 m/s at the contact point),
   which measured 0.3-0.5 m/s of error in v_out when ignored. The spin stays with the ball, so
   the aim includes its Magnus force.

The restitution e is the one the arm-held racket shows in the Drake world (tests/systems/
test_racket.py): a Hunt-Crossley contact with an effective dissipation
:data:`HELD_RACKET_DISSIPATION`, so e depends on the normal impact speed (0.86 at 4 m/s, 0.78 at
8 m/s, 0.71 at 12 m/s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tt_drake.ball_model import BallModel, hunt_crossley_restitution
from tt_drake.constants import BALL, NET, TABLE, TARGET
from tt_drake.flight_kernel import net_crossing_height

#: Effective Hunt-Crossley dissipation (s/m) of the racket as held by the controlled arm: fits
#: the restitution measured in Drake (0.862, 0.781, 0.712 at 4, 8, 12 m/s) within 0.013.
HELD_RACKET_DISSIPATION = 0.0526

#: Candidate outgoing flight times (s) searched by :func:`aim_return`.
FLIGHT_TIMES = (0.5, 0.6, 0.7, 0.8, 0.9)


def racket_restitution(impact_speed: float) -> float:
    """Normal restitution of the arm-held racket at a normal relative impact speed (m/s)."""
    return hunt_crossley_restitution(HELD_RACKET_DISSIPATION, impact_speed)


@dataclass(frozen=True)
class RacketState:
    """The racket state at impact: unit normal (facing the incoming ball) and velocity."""

    normal: np.ndarray
    velocity: np.ndarray
    restitution: float


def racket_for_return(v_in, v_out, spin=(0.0, 0.0, 0.0)) -> RacketState:
    """Racket normal and velocity that turn the ball's v_in (spinning at ``spin``) into v_out
    without slip (module docstring).

    e depends on the relative normal speed, which depends on v_R,n: a fixed-point iteration
    (it converges in a few steps, e changing slowly with speed).
    """
    v_in = np.asarray(v_in, dtype=float)
    v_out = np.asarray(v_out, dtype=float)
    dv = v_out - v_in
    norm = float(np.linalg.norm(dv))
    if norm < 1e-9:
        raise ValueError("v_out equals v_in: no impact needed")
    n = dv / norm
    vin_n, vout_n = float(n @ v_in), float(n @ v_out)
    e = racket_restitution(vout_n - vin_n)
    for _ in range(20):
        vr_n = (vout_n + e * vin_n) / (1.0 + e)
        e_new = racket_restitution(vr_n - vin_n)
        if abs(e_new - e) < 1e-12:
            break
        e = e_new
    vr_n = (vout_n + e * vin_n) / (1.0 + e)
    contact = v_in + np.cross(np.asarray(spin, dtype=float), -BALL.radius * n)
    v_racket = (contact - float(n @ contact) * n) + vr_n * n
    return RacketState(n, v_racket, e)


def ball_after_racket(v_in, racket: RacketState) -> np.ndarray:
    """The impact law forward: the ball's velocity after the racket (no slip tangentially when the
    racket's tangential velocity matches the ball's; otherwise the tangential part is kept)."""
    v_in = np.asarray(v_in, dtype=float)
    n = racket.normal
    rel_n = float(n @ (racket.velocity - v_in))
    return v_in + (1.0 + racket.restitution) * rel_n * n


def landing_after_racket(p_hit, v_in, racket: RacketState, spin=(0.0, 0.0, 0.0),
                         model: BallModel | None = None, max_time: float = 2.0
                         ) -> np.ndarray | None:
    """Where the ball first lands on the table after ``racket`` meets it at ``p_hit``: the impact
    law forward (:func:`ball_after_racket`), then free flight under ``model`` with the ball's
    ``spin`` (kept through the hit, as :func:`aim_candidates` assumes) to its first table impact.
    Returns (x, y) of the ball's centre there, or None if it reaches the floor (misses the
    table) or ``max_time`` passes first. The inverse of the teacher's aim: for the racket of
    :func:`racket_for_return` on an aim's ``v_out`` it returns the aim's target."""
    model = model or BallModel()
    state = np.r_[np.asarray(p_hit, dtype=float), ball_after_racket(v_in, racket),
                  np.asarray(spin, dtype=float)]
    bounce = model.first_bounce(state, max_time)
    return None if bounce is None else np.array(bounce.position[:2])


@dataclass(frozen=True)
class ReturnAim:
    """An outgoing ball velocity and what it achieves."""

    v_out: np.ndarray
    flight_time: float
    net_clearance: float  # lowest point of the ball above the net top when crossing (m)
    landing: np.ndarray  # where the ball centre reaches table-contact height (x, y)


def _fly(model: BallModel, p, v, duration: float, spin=(0.0, 0.0, 0.0),
         h: float = 0.02) -> tuple:
    """Ball position after ``duration`` seconds of free flight (no table), RK4 with step ~h."""
    steps = max(1, int(math.ceil(duration / h)))
    return model.fly(tuple(p), tuple(v), tuple(spin), duration / steps, steps)


def solve_outgoing_velocity(p_hit, target, flight_time: float, model: BallModel | None = None,
                            tol: float = 1e-6, spin=(0.0, 0.0, 0.0)) -> np.ndarray:
    """v_out with p(T; v_out) = target under gravity, drag and the Magnus force of ``spin``.

    Broyden's method from the drag-free solution v = (target - p - g T^2 / 2) / T and its
    Jacobian dp/dv = T I: drag is a smooth perturbation, so one flight per iteration and
    5-8 iterations reach ``tol`` (m). Raises ValueError if it does not converge.
    """
    model = model or BallModel()
    p = np.asarray(p_hit, dtype=float)
    goal = np.asarray(target, dtype=float)
    t = float(flight_time)
    g = np.array([0.0, 0.0, -model.params.gravity])
    v = (goal - p - 0.5 * g * t * t) / t
    inv_jac = np.eye(3) / t
    residual = np.array(_fly(model, p, v, t, spin)[0]) - goal
    for _ in range(30):
        if np.linalg.norm(residual) < tol:
            return v
        step = -inv_jac @ residual
        v = v + step
        new_residual = np.array(_fly(model, p, v, t, spin)[0]) - goal
        dr = new_residual - residual
        denom = float(step @ inv_jac @ dr)
        if abs(denom) > 1e-15:  # Broyden's "good" update of the inverse Jacobian
            inv_jac = inv_jac + np.outer(step - inv_jac @ dr, step @ inv_jac) / denom
        residual = new_residual
    if np.linalg.norm(residual) < 1e3 * tol:
        return v
    raise ValueError(f"no outgoing velocity reaches {goal} in {t} s from {p}")


def net_clearance(model: BallModel, p, v, spin=(0.0, 0.0, 0.0)) -> float:
    """Height of the ball's bottom above the net top when its centre crosses y = 0 (free flight
    in RK4 steps of 10 ms, linear inside the crossing step; -inf if it falls to the table height
    first)."""
    params = model.params
    w = tuple(float(c) for c in spin)
    z = net_crossing_height(float(p[0]), float(p[1]), float(p[2]), float(v[0]), float(v[1]),
                            float(v[2]), w[0], w[1], w[2], params.drag_k, params.magnus_cl,
                            params.gravity, 0.01, 200, TABLE.surface_z + BALL.radius)
    return z - BALL.radius - (TABLE.surface_z + NET.height)


def aim_rank(clearance: float, racket_velocity, min_clearance: float) -> tuple:
    """The sort key of an aim: those clearing the net by ``min_clearance`` first, by increasing
    racket speed, then the others by decreasing clearance."""
    if clearance >= min_clearance:
        return (0, float(np.linalg.norm(racket_velocity)))
    return (1, -clearance)


def aim_candidates(p_hit, v_in, target=(TARGET.x, TARGET.y), model: BallModel | None = None,
                   flight_times=FLIGHT_TIMES, min_clearance: float = 0.05,
                   spin=(0.0, 0.0, 0.0)) -> list[ReturnAim]:
    """One outgoing velocity per candidate flight time that lands the ball at ``target`` (x, y on
    the table surface), for a ball spinning at ``spin`` (kept through a no-slip hit), best first:
    those clearing the net by ``min_clearance`` by increasing racket speed, then the others by
    decreasing clearance. Each asks for a different racket normal."""
    model = model or BallModel()
    goal = np.array([target[0], target[1], TABLE.surface_z + BALL.radius])
    ranked = []
    for t in flight_times:
        v_out = solve_outgoing_velocity(p_hit, goal, t, model, spin=spin)
        clearance = net_clearance(model, p_hit, v_out, spin)
        key = aim_rank(clearance, racket_for_return(v_in, v_out, spin).velocity, min_clearance)
        ranked.append((key, ReturnAim(v_out, float(t), clearance, goal[:2].copy())))
    ranked.sort(key=lambda item: item[0])
    return [aim for _, aim in ranked]


def aim_return(p_hit, v_in, target=(TARGET.x, TARGET.y), model: BallModel | None = None,
               flight_times=FLIGHT_TIMES, min_clearance: float = 0.05,
               spin=(0.0, 0.0, 0.0)) -> ReturnAim:
    """The best of :func:`aim_candidates`: clears the net with the least racket speed."""
    return aim_candidates(p_hit, v_in, target, model, flight_times, min_clearance, spin)[0]
