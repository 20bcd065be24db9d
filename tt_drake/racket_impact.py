"""The racket's impact on a spinning ball with friction: what a stroke that makes spin obeys.

A rigid racket face (unit normal ``n`` toward the ball, velocity ``v_R``, of unlimited mass: the
arm's inertia is ~10^3 times the ball's) meets a hollow ball (mass m, radius R, moment of
inertia I = 2/3 m R^2) at the contact point r = -R n from the ball's centre. The ball's contact
point moves relative to the face with

    u = v + omega x r - v_R,    u_n = n . u (< 0 approaching),    u_t = u - u_n n (the slip).

An impulse J at the contact changes v by J / m and omega by (r x J) / I. Along the normal the
face returns the relative speed with restitution e:

    J_n = m (1 + e) (-u_n).                                                               (1)

A tangential impulse J_t changes the slip by (1/m + R^2/I) J_t = (5/2) J_t / m. Coulomb friction
with coefficient mu opposes the slip and stops it if it can within its cone:

    J_t = -min(2/5 m |u_t|, mu J_n) u_t / |u_t|.                                          (2)

When the first term is the smaller the ball leaves *rolling* on the face (no slip, the tangential
restitution 0 of a rubber face that grips); otherwise it slides through the whole contact. Then

    v' = v + (J_n n + J_t) / m,    omega' = omega + (r x J_t) / I                          (3)

and the spin about the normal is unchanged (a point contact has no torsional friction). For a
racket with the tangential velocity of the ball's contact point (``racket_law``'s flat stroke)
u_t = 0, so J_t = 0: the spin passes unchanged. Brushing the ball (a tangential racket velocity)
makes spin: the rolling limit gives Delta v_t = -2/5 u_t and Delta omega = -(3 / (2 R)) n x
Delta v_t.

The inverse, :func:`racket_for_spin_return`, gives the racket that turns (v, omega) into a wanted
v_out with the ball rolling off the face: the tangential change Delta v_t = v_out,t - v_t must
lie in the friction cone, |Delta v_t| <= mu |Delta v_n| (the normal is tilted from v_out - v
by at most atan(mu) for that), and the racket's tangential velocity is then the contact point's
plus 5/2 Delta v_t.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tt_drake.constants import BALL

#: The inertia ratio m R^2 / I of a hollow ball (I = 2/3 m R^2).
HOLLOW_BALL_RATIO = 1.5


@dataclass(frozen=True)
class Impact:
    """The ball after the face: velocity (m/s), spin (rad/s), and whether it left rolling."""

    velocity: np.ndarray
    spin: np.ndarray
    rolling: bool


def _unit(normal) -> np.ndarray:
    n = np.asarray(normal, dtype=float).reshape(3)
    norm = float(np.linalg.norm(n))
    if not np.isfinite(norm) or norm < 1e-12:
        raise ValueError(f"the face normal must be a finite non-zero vector, got {normal!r}")
    return n / norm


def rolling_spin_change(normal, dv_t, radius: float = BALL.radius) -> np.ndarray:
    """The spin a rolling exit adds for the tangential velocity change ``dv_t`` across the face
    with unit ``normal``: Delta omega = (m R^2 / I) (r x Delta v_t) / R^2 with r = -R n
    (equation (3) with J_t = m Delta v_t)."""
    n = np.asarray(normal, dtype=float)
    return HOLLOW_BALL_RATIO * np.cross(-radius * n, np.asarray(dv_t, dtype=float)) / radius**2


def topspin(state) -> float:
    """The spin component (rad/s) of a ball state (p, v, omega) that turns the ball's top toward
    its horizontal direction of travel d: omega . (z x d); positive for topspin, negative for
    backspin."""
    s = np.asarray(state, dtype=float).reshape(-1)
    horizontal = np.array([s[3], s[4], 0.0])
    norm = float(np.linalg.norm(horizontal))
    if norm < 1e-9:
        raise ValueError("a return must travel horizontally")
    return float(s[6:9] @ np.cross((0.0, 0.0, 1.0), horizontal / norm))


def racket_impact(v, omega, normal, v_racket, restitution: float, mu: float,
                  radius: float = BALL.radius) -> Impact:
    """The ball's velocity and spin after the face, by equations (1)-(3) of the module
    docstring. ``normal`` points from the face toward the ball; raises ``ValueError`` if the
    ball's contact point is not approaching the face (u_n >= 0), or for e outside [0, 1] or a
    negative mu."""
    if not 0.0 <= restitution <= 1.0:
        raise ValueError(f"restitution must be in [0, 1], got {restitution}")
    if mu < 0.0:
        raise ValueError(f"friction coefficient must be >= 0, got {mu}")
    n = _unit(normal)
    v = np.asarray(v, dtype=float).reshape(3)
    w = np.asarray(omega, dtype=float).reshape(3)
    r = -radius * n
    u = v + np.cross(w, r) - np.asarray(v_racket, dtype=float).reshape(3)
    u_n = float(n @ u)
    if u_n >= 0.0:
        raise ValueError(f"the ball is not approaching the face (normal speed {u_n:.3g} m/s)")
    dv_n = (1.0 + restitution) * -u_n  # J_n / m, equation (1)
    u_t = u - u_n * n
    slip = float(np.linalg.norm(u_t))
    stop = slip / (1.0 + HOLLOW_BALL_RATIO)  # |J_t| / m that ends the slip
    rolling = stop <= mu * dv_n
    dv_t = np.zeros(3) if slip == 0.0 else -min(stop, mu * dv_n) * u_t / slip  # equation (2)
    # omega' - omega = r x J_t / I = (m R^2 / I) (r / R^2) x dv_t, equation (3)
    dw = HOLLOW_BALL_RATIO * np.cross(r, dv_t) / radius**2
    return Impact(v + dv_n * n + dv_t, w + dw, bool(rolling))


def brushed_normal(v, v_out, brush, tilt: float) -> np.ndarray:
    """The face normal for a stroke that changes the ball's velocity from ``v`` to ``v_out``
    while brushing it along ``brush`` (e.g. world up for topspin on a forward return): the
    direction d of v_out - v turned by ``tilt`` (rad) away from the brush,

        n = cos(tilt) d - sin(tilt) t,    t = unit(brush - (brush . d) d),

    so that the change's tangential part, |v_out - v| sin(tilt) (sin(tilt) d + cos(tilt) t),
    points along the brush for tilt > 0 (a closed face brushing upward) and against it for
    tilt < 0. tilt = 0 is the flat stroke's normal d."""
    d = _unit(np.asarray(v_out, dtype=float) - np.asarray(v, dtype=float))
    b = np.asarray(brush, dtype=float).reshape(3)
    t = b - float(b @ d) * d
    if float(np.linalg.norm(t)) < 1e-9:
        raise ValueError("the brush direction must not be parallel to v_out - v")
    t /= np.linalg.norm(t)
    return np.cos(tilt) * d - np.sin(tilt) * t


def racket_for_spin_return(v, omega, v_out, normal, mu: float, restitution_of,
                           radius: float = BALL.radius) -> tuple[np.ndarray, float, np.ndarray]:
    """The face velocity that turns the ball's (``v``, ``omega``) into ``v_out`` with the face
    ``normal`` (from :func:`brushed_normal`), the ball leaving rolling (module docstring).
    Returns (v_racket, e, omega_out). ``restitution_of(speed)``: e at a normal impact speed
    (m/s), solved by fixed point as e depends on the racket's own normal speed.

    With Delta v = v_out - v split along n (Delta v_n > 0) and across it (Delta v_t):
    v_R,n = n . v + Delta v_n / (1 + e) (equation (1)), v_R,t = (v + omega x r)_t + 5/2 Delta
    v_t (the rolling limit of (2)), omega_out = omega + 3/2 (r x Delta v_t) / R^2 (3). Raises
    ``ValueError`` if Delta v_n <= 0 or if |Delta v_t| > mu Delta v_n: friction cannot make
    that change, the ball would slide."""
    n = _unit(normal)
    v = np.asarray(v, dtype=float).reshape(3)
    w = np.asarray(omega, dtype=float).reshape(3)
    dv = np.asarray(v_out, dtype=float).reshape(3) - v
    dv_n = float(n @ dv)
    if dv_n <= 0.0:
        raise ValueError("the face must push the ball along its normal (n . (v_out - v) > 0)")
    dv_t = dv - dv_n * n
    if float(np.linalg.norm(dv_t)) > mu * dv_n * (1.0 + 1e-12):
        raise ValueError(f"the tangential change {np.linalg.norm(dv_t):.3g} m/s exceeds the "
                         f"friction cone mu * {dv_n:.3g} m/s: tilt the face less")
    e = float(restitution_of(dv_n / 2.0))
    for _ in range(50):  # the impact speed |u_n| = dv_n / (1 + e) depends on e itself
        e_new = float(restitution_of(dv_n / (1.0 + e)))
        if abs(e_new - e) < 1e-13:
            break
        e = e_new
    e = e_new
    r = -radius * n
    contact = v + np.cross(w, r)
    v_racket = (float(n @ v) + dv_n / (1.0 + e)) * n + (contact - float(n @ contact) * n) \
        + (1.0 + HOLLOW_BALL_RATIO) * dv_t
    return v_racket, e, w + rolling_spin_change(n, dv_t, radius)
