"""Numpy model of a table-tennis ball: flight with gravity, drag and Magnus, and the table bounce.

It is the model the Drake world is calibrated to, shared by the launcher (serve rejection), the
ball-flight estimator, the physical-model hitting-point predictor and the analytical player.

Flight (docs/constants.md, "Aerodynamics"):

    p' = v,    v' = g - k |v| v + C_L (omega x v),    omega' = 0

Table bounce: the Drake world uses point contact with Hunt-Crossley dissipation,
f_n = k x (1 + d x'), whose normal restitution depends on d * v_n only
(:func:`hunt_crossley_restitution`); tangentially Coulomb friction acts on a thin hollow sphere
(I = 2/3 m R^2) until the contact point stops slipping (the rolling limit v' = 0.6 v + 0.4 omega R).

The state is a 9-vector ``(p, v, omega)`` in the world frame of :mod:`tt_drake.constants`.
Scalar arithmetic on Python floats is used on purpose: for 3-vectors it is several times faster
than numpy (docs/constants.md, "Drake contact and integration").
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from tt_drake.constants import BALL, CONTACT, GRAVITY, NET, TABLE
from tt_drake.flight_kernel import (
    STOP_NEVER,
    STOP_PLANE,
    STOP_TIME,
    UNTIL_CONTACT,
    UNTIL_STOP,
    flight_until,
    rk4_flight,
)
from tt_drake.interp_kernel import interp_one


@lru_cache(maxsize=1)
def restitution_table() -> tuple[np.ndarray, np.ndarray]:
    """Tabulate e(d v) by integrating the dimensionless Hunt-Crossley impact.

    With x = v0 sqrt(m/k) xi and t = sqrt(m/k) s the impact is xi'' = -xi (1 + (d v0) xi')^+,
    xi(0) = 0, xi'(0) = 1, independent of k and m; the contact ends when xi returns to 0 or the
    force vanishes (Drake clamps f_n >= 0), and e = -xi'(end).
    """
    dv = np.linspace(0.0, 3.0, 601)
    xi = np.zeros_like(dv)
    rate = np.ones_like(dv)
    done = np.zeros(dv.shape, dtype=bool)
    e = np.zeros_like(dv)
    h = 5e-4

    def accel(x: np.ndarray, r: np.ndarray) -> np.ndarray:
        return -np.maximum(x, 0.0) * np.maximum(1.0 + dv * r, 0.0)

    for _ in range(int(4.0 / h)):
        k1x, k1r = rate, accel(xi, rate)
        k2x, k2r = rate + 0.5 * h * k1r, accel(xi + 0.5 * h * k1x, rate + 0.5 * h * k1r)
        k3x, k3r = rate + 0.5 * h * k2r, accel(xi + 0.5 * h * k2x, rate + 0.5 * h * k2r)
        k4x, k4r = rate + h * k3r, accel(xi + h * k3x, rate + h * k3r)
        xi_new = xi + h / 6.0 * (k1x + 2 * k2x + 2 * k3x + k4x)
        rate_new = rate + h / 6.0 * (k1r + 2 * k2r + 2 * k3r + k4r)
        # Separation: penetration back to zero, or the force vanished while moving outward.
        ended = ~done & ((xi_new <= 0.0) | ((1.0 + dv * rate_new <= 0.0) & (rate_new < 0)))
        e[ended] = -rate_new[ended]
        done |= ended
        xi, rate = xi_new, rate_new
        if done.all():
            break
    return dv, e


def hunt_crossley_restitution(dissipation: float, impact_speed: float) -> float:
    """Normal coefficient of restitution of a Hunt-Crossley contact, a function of d * v_n only.

    Close to the textbook first-order result e ~ 1 - (2/3) d v for small d v (docs/constants.md, the
    restitution table).
    """
    dv_grid, e_grid = restitution_table()
    return interp_one(dissipation * abs(impact_speed), dv_grid, e_grid)


def event_stop(event: tuple[int, float, float]):
    """The event function ``stop(t, pos, vel)`` of a compiled flight's stop (kind, a, b)
    (:func:`tt_drake.flight_kernel.flight_until`): the same arithmetic, so that a Python step
    and a compiled one agree on its sign. STOP_PLANE: b (y - a), the plane y = a approached
    from the side b (+1 from above, -1 from below); STOP_TIME: a - t; STOP_NEVER: 1."""
    kind, a, b = event
    if kind == STOP_PLANE:
        return lambda _t, q, _v: b * (q[1] - a)
    if kind == STOP_TIME:
        return lambda t, _q, _v: a - t
    if kind == STOP_NEVER:
        return lambda _t, _q, _v: 1.0
    raise ValueError(f"unknown stop kind {kind}")


@dataclass(frozen=True)
class BallModelParams:
    """Everything the numpy ball model needs; defaults come from :mod:`tt_drake.constants`."""

    gravity: float = GRAVITY
    drag_k: float = BALL.drag_k
    magnus_cl: float = BALL.magnus_cl
    radius: float = BALL.radius
    mass: float = BALL.mass
    table_dissipation: float = field(default_factory=lambda: CONTACT.effective_dissipation("table"))
    table_friction: float = CONTACT.table_friction_combined
    table_z: float = TABLE.surface_z
    table_half_length: float = 0.5 * TABLE.length
    table_half_width: float = 0.5 * TABLE.width


@dataclass(frozen=True)
class Bounce:
    """A table bounce: when and where the ball's centre was at impact."""

    t: float
    position: tuple[float, float, float]


@dataclass(frozen=True)
class PlaneCrossing:
    """The ball's state when its centre crosses a plane y = const (or reaches a time)."""

    t: float
    position: np.ndarray
    velocity: np.ndarray
    spin: np.ndarray
    bounces: tuple[Bounce, ...]

    @property
    def state(self) -> np.ndarray:
        return np.concatenate([self.position, self.velocity, self.spin])


def _mat3_mul(a: tuple, b: tuple) -> tuple[float, ...]:
    """The 3 x 3 matrix product a b (row-major 9-tuples)."""
    a0, a1, a2, a3, a4, a5, a6, a7, a8 = a
    b0, b1, b2, b3, b4, b5, b6, b7, b8 = b
    return (a0 * b0 + a1 * b3 + a2 * b6, a0 * b1 + a1 * b4 + a2 * b7, a0 * b2 + a1 * b5 + a2 * b8,
            a3 * b0 + a4 * b3 + a5 * b6, a3 * b1 + a4 * b4 + a5 * b7, a3 * b2 + a4 * b5 + a5 * b8,
            a6 * b0 + a7 * b3 + a8 * b6, a6 * b1 + a7 * b4 + a8 * b7, a6 * b2 + a7 * b5 + a8 * b8)


def _mat3_axpy(x: tuple, h: float, y: tuple) -> tuple[float, ...]:
    """x + h y for 3 x 3 matrices (row-major 9-tuples)."""
    x0, x1, x2, x3, x4, x5, x6, x7, x8 = x
    y0, y1, y2, y3, y4, y5, y6, y7, y8 = y
    return (x0 + h * y0, x1 + h * y1, x2 + h * y2, x3 + h * y3, x4 + h * y4,
            x5 + h * y5, x6 + h * y6, x7 + h * y7, x8 + h * y8)


def _mat3_rk4(x: tuple, h6: float, k1: tuple, k2: tuple, k3: tuple, k4: tuple) -> tuple:
    """The RK4 update x + h/6 (k1 + 2 k2 + 2 k3 + k4) of a 3 x 3 matrix (row-major 9-tuples)."""
    x0, x1, x2, x3, x4, x5, x6, x7, x8 = x
    return (x0 + h6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0]),
            x1 + h6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1]),
            x2 + h6 * (k1[2] + 2 * k2[2] + 2 * k3[2] + k4[2]),
            x3 + h6 * (k1[3] + 2 * k2[3] + 2 * k3[3] + k4[3]),
            x4 + h6 * (k1[4] + 2 * k2[4] + 2 * k3[4] + k4[4]),
            x5 + h6 * (k1[5] + 2 * k2[5] + 2 * k3[5] + k4[5]),
            x6 + h6 * (k1[6] + 2 * k2[6] + 2 * k3[6] + k4[6]),
            x7 + h6 * (k1[7] + 2 * k2[7] + 2 * k3[7] + k4[7]),
            x8 + h6 * (k1[8] + 2 * k2[8] + 2 * k3[8] + k4[8]))


class BallModel:
    """Ball flight and table bounce (see the module docstring for the equations)."""

    def __init__(self, params: BallModelParams | None = None, dt: float = 1e-3):
        self.params = params or BallModelParams()
        self.dt = dt

    # -- flight ---------------------------------------------------------------------------------
    def acceleration(self, v: tuple, w: tuple) -> tuple[float, float, float]:
        """v' = g - k |v| v + C_L (omega x v)."""
        p = self.params
        vx, vy, vz = v
        wx, wy, wz = w
        speed = math.sqrt(vx * vx + vy * vy + vz * vz)
        kd = p.drag_k * speed
        c = p.magnus_cl
        return (
            -kd * vx + c * (wy * vz - wz * vy),
            -kd * vy + c * (wz * vx - wx * vz),
            -p.gravity - kd * vz + c * (wx * vy - wy * vx),
        )

    def acceleration_jacobian(self, v: tuple, w: tuple) -> tuple[float, ...]:
        """d(v')/dv = -k (|v| I + v v^T / |v|) + C_L [omega]x, row-major (9 floats).

        ([omega]x is the cross-product matrix, [omega]x u = omega x u; at v = 0 the drag term's
        derivative is 0.)"""
        p = self.params
        vx, vy, vz = v
        wx, wy, wz = w
        speed = math.sqrt(vx * vx + vy * vy + vz * vz)
        k, c = p.drag_k, p.magnus_cl
        kd = k * speed
        ks = k / speed if speed > 0.0 else 0.0
        return (
            -kd - ks * vx * vx, -ks * vx * vy - c * wz, -ks * vx * vz + c * wy,
            -ks * vy * vx + c * wz, -kd - ks * vy * vy, -ks * vy * vz - c * wx,
            -ks * vz * vx - c * wy, -ks * vz * vy + c * wx, -kd - ks * vz * vz,
        )

    def flight_step(self, pos: tuple, vel: tuple, w: tuple, h: float) -> tuple[tuple, tuple]:
        """One classical Runge-Kutta (RK4) step of the flight ODE, no contact: with
        a(v) = g - k |v| v + C_L (omega x v) (:meth:`acceleration`) and the stage velocities

            v1 = v,  v2 = v + h/2 a(v1),  v3 = v + h/2 a(v2),  v4 = v + h a(v3),

        p+ = p + h/6 (v1 + 2 v2 + 2 v3 + v4), v+ = v + h/6 (a1 + 2 a2 + 2 a3 + a4). Compiled
        (:func:`tt_drake.flight_kernel.rk4_flight`): this is every prediction's innermost loop.
        """
        return self.fly(pos, vel, w, h, 1)

    def fly(self, pos: tuple, vel: tuple, w: tuple, h: float, steps: int
            ) -> tuple[tuple, tuple]:
        """(p, v) after ``steps`` :meth:`flight_step` steps of ``h`` (the same numbers), in one
        compiled call."""
        p = self.params
        r = rk4_flight(pos[0], pos[1], pos[2], vel[0], vel[1], vel[2], w[0], w[1], w[2],
                       p.drag_k, p.magnus_cl, p.gravity, h, steps)
        return r[:3], r[3:]

    def rk4_stages(self, pos: tuple, vel: tuple, w: tuple, h: float
                   ) -> tuple[tuple, tuple, tuple]:
        """:meth:`flight_step` (the same numbers) with its stage velocities (v1, v2, v3, v4), which
        the variational steps evaluate their Jacobians at. Returns (stages, new_p, new_v)."""
        hh = 0.5 * h
        a1 = self.acceleration(vel, w)
        v2 = (vel[0] + hh * a1[0], vel[1] + hh * a1[1], vel[2] + hh * a1[2])
        a2 = self.acceleration(v2, w)
        v3 = (vel[0] + hh * a2[0], vel[1] + hh * a2[1], vel[2] + hh * a2[2])
        a3 = self.acceleration(v3, w)
        v4 = (vel[0] + h * a3[0], vel[1] + h * a3[1], vel[2] + h * a3[2])
        a4 = self.acceleration(v4, w)
        h6 = h / 6.0
        new_p = (pos[0] + h6 * (vel[0] + 2 * v2[0] + 2 * v3[0] + v4[0]),
                 pos[1] + h6 * (vel[1] + 2 * v2[1] + 2 * v3[1] + v4[1]),
                 pos[2] + h6 * (vel[2] + 2 * v2[2] + 2 * v3[2] + v4[2]))
        new_v = (vel[0] + h6 * (a1[0] + 2 * a2[0] + 2 * a3[0] + a4[0]),
                 vel[1] + h6 * (a1[1] + 2 * a2[1] + 2 * a3[1] + a4[1]),
                 vel[2] + h6 * (a1[2] + 2 * a2[2] + 2 * a3[2] + a4[2]))
        return (vel, v2, v3, v4), new_p, new_v

    def flight_step_variational(self, pos: tuple, vel: tuple, w: tuple, h: float,
                                dp: tuple, dv: tuple) -> tuple[tuple, tuple, tuple, tuple]:
        """:meth:`flight_step` together with the sensitivities of its result.

        ``dp``, ``dv`` are the 3 x 3 sensitivities (row-major, 9 floats) of ``pos`` and ``vel`` to
        some three parameters, e.g. the initial velocity. They obey the variational equation

            dp' = dv,    dv' = J(v) dv,    J = d(v')/dv (:meth:`acceleration_jacobian`),

        and RK4 applied to the joint system, with D_i = J(v_i) X_i at the flight step's stage
        velocities v_i and X1 = dv, X2 = dv + h/2 D1, X3 = dv + h/2 D2, X4 = dv + h D3, gives

            dp+ = dp + h/6 (X1 + 2 X2 + 2 X3 + X4),    dv+ = dv + h/6 (D1 + 2 D2 + 2 D3 + D4),

        which is exactly the derivative of the RK4 step (Runge-Kutta steps commute with
        differentiation). Returns (new_p, new_v, new_dp, new_dv); new_p, new_v equal
        :meth:`flight_step`'s to the last bit. Omega is held fixed (no sensitivity to it).
        """
        hh, h6 = 0.5 * h, h / 6.0
        (_, v2, v3, v4), new_p, new_v = self.rk4_stages(pos, vel, w, h)
        d1 = _mat3_mul(self.acceleration_jacobian(vel, w), dv)
        x2 = _mat3_axpy(dv, hh, d1)
        d2 = _mat3_mul(self.acceleration_jacobian(v2, w), x2)
        x3 = _mat3_axpy(dv, hh, d2)
        d3 = _mat3_mul(self.acceleration_jacobian(v3, w), x3)
        x4 = _mat3_axpy(dv, h, d3)
        d4 = _mat3_mul(self.acceleration_jacobian(v4, w), x4)
        return new_p, new_v, _mat3_rk4(dp, h6, dv, x2, x3, x4), _mat3_rk4(dv, h6, d1, d2, d3, d4)

    # -- table bounce ---------------------------------------------------------------------------
    def table_restitution(self, impact_speed: float) -> float:
        return hunt_crossley_restitution(self.params.table_dissipation, impact_speed)

    def bounce(self, vel: tuple, w: tuple) -> tuple[tuple, tuple]:
        """Velocity and spin after a table impact (surface normal +z).

        Normal: v_z' = -e(v_z) v_z. Tangential: the friction impulse J_t opposes the contact
        point's slip u = v_t - R (omega x n); for a hollow sphere it changes u by 2.5 J_t / m, so
        |J_t| = min(mu J_n, m |u| / 2.5) (sliding, or the rolling limit).
        """
        p = self.params
        vx, vy, vz = vel
        wx, wy, wz = w
        r = p.radius
        e = self.table_restitution(-vz)
        jn = (1.0 + e) * (-vz)  # normal impulse per unit mass
        ux, uy = vx - r * wy, vy + r * wx  # slip of the contact point: v + omega x (-R z)
        slip = math.hypot(ux, uy)
        if slip > 1e-12:
            jt = min(p.table_friction * jn, slip / 2.5)
            jx, jy = -jt * ux / slip, -jt * uy / slip
        else:
            jx = jy = 0.0
        # Angular impulse per unit mass: r_c x J with r_c = -R z; I/m = 2/3 R^2.
        inv_i = 1.0 / (2.0 / 3.0 * r * r)
        new_w = (wx + inv_i * r * jy, wy - inv_i * r * jx, wz)
        return (vx + jx, vy + jy, -e * vz), new_w

    def over_table(self, x: float, y: float) -> bool:
        p = self.params
        return abs(x) <= p.table_half_width and abs(y) <= p.table_half_length

    # -- prediction -----------------------------------------------------------------------------
    def advance(self, state, stop, max_time: float, until_bounce: bool = False,
                event: tuple[int, float, float] | None = None):
        """Integrate from ``state`` until ``stop(t, pos, vel)`` changes sign from positive to
        non-positive (an event function), bouncing on the table on the way. Returns the state at
        the event (located by :meth:`_locate`) or None if the ball reaches the floor (centre below
        ``radius``) or ``max_time`` passes first. With ``until_bounce`` the first table impact
        before the event ends it instead: its :class:`Bounce` is returned.

        ``event``: instead of ``stop`` (then None), one of the compiled flight's stop kinds,
        (kind, a, b) of :func:`tt_drake.flight_kernel.flight_until` (a plane, a time, none),
        which then flies between bounces in one call per flight; the event function that
        locates it and tests it at a bounce is :func:`event_stop`. None: every step in Python,
        for any ``stop``."""
        if event is not None:
            if stop is not None:
                raise ValueError("give the stop as a function or as a compiled event, not both")
            stop = event_stop(event)
        p = self.params
        s = np.asarray(state, dtype=float).reshape(-1)
        if s.shape != (9,) and s.shape != (6,):
            raise ValueError(f"ball state must have 6 or 9 entries, got shape {s.shape}")
        if not np.all(np.isfinite(s)):
            raise ValueError("ball state contains NaN or infinity")
        # Python floats (tolist), not numpy scalars: the same numbers, at a third of the cost
        # per arithmetic operation.
        x = s.tolist()
        pos, vel = tuple(x[0:3]), tuple(x[3:6])
        w = tuple(x[6:9]) if s.size == 9 else (0.0, 0.0, 0.0)
        t = 0.0
        bounces: list[Bounce] = []
        g0 = stop(t, pos, vel)
        if g0 <= 0.0:
            return None
        # The innermost loop of every prediction: locals, and table_impact's cheap precondition
        # (the step goes down through the contact height) tested here, not in a call per step.
        dt, step, floor = self.dt, self.flight_step, p.radius
        contact_z = p.table_z + p.radius
        pending = np.empty(6) if event is not None else None
        while t < max_time:
            if event is not None:
                # The steps of the loop below in one compiled call, up to the first that needs
                # Python (a step through the contact height) or ends the flight.
                ended, t, h, *state6 = flight_until(
                    *pos, *vel, *w, p.drag_k, p.magnus_cl, p.gravity, dt, t, max_time,
                    contact_z, floor, event[0], event[1], event[2], pending)
                pos, vel = tuple(state6[0:3]), tuple(state6[3:6])
                if ended == UNTIL_STOP:
                    return self._finish(t, pos, vel, w, h, stop, bounces)
                if ended != UNTIL_CONTACT:
                    return None
                new_p, new_v = tuple(pending[0:3].tolist()), tuple(pending[3:6].tolist())
            else:
                h = dt if max_time - t > dt else max_time - t
                new_p, new_v = step(pos, vel, w, h)
            impact = (self.table_impact(pos, vel, w, h, new_p, new_v)
                      if new_p[2] < contact_z <= pos[2] and new_v[2] < 0.0 else None)
            if impact is not None:
                th, hp, hv = impact
                # Check the stop event before the impact first.
                if stop(t + th, hp, hv) <= 0.0:
                    return self._finish(t, pos, vel, w, h, stop, bounces)
                if until_bounce:
                    return Bounce(t + th, hp)
                bounces.append(Bounce(t + th, hp))
                hv, w = self.bounce(hv, w)
                pos, vel, t = hp, hv, t + th
                continue
            if stop(t + h, new_p, new_v) <= 0.0:
                return self._finish(t, pos, vel, w, h, stop, bounces)
            if new_p[2] < floor:
                return None
            pos, vel, t = new_p, new_v, t + h
        return None

    #: Bracket width (s) at which :meth:`_locate` stops, and its cap on function evaluations.
    #: 1e-14 s costs about one evaluation more than 1e-12 s and keeps the estimator's
    #: finite-difference Jacobian across a bounce (which divides the impact-time error by its
    #: 1e-6 step) accurate to ~1e-8.
    LOCATE_TOL = 1e-14
    LOCATE_MAX_EVALS = 60

    def table_impact(self, pos: tuple, vel: tuple, w: tuple, h: float, new_p: tuple,
                     new_v: tuple) -> tuple[float, tuple, tuple] | None:
        """If the flight step of length ``h`` from (pos, vel) to (new_p, new_v) takes the ball's
        centre down through ``table_z + radius`` over the table, the impact: (sub-step th, p, v)
        just before the bounce (th located by :meth:`_locate`); otherwise None."""
        contact_z = self.params.table_z + self.params.radius
        if not (new_p[2] < contact_z <= pos[2] and new_v[2] < 0.0):
            return None
        th = self._locate(pos, vel, w, h, lambda _s, q, _v: q[2] - contact_z)
        hp, hv = self.flight_step(pos, vel, w, th)
        if not self.over_table(hp[0], hp[1]):
            return None
        return th, hp, hv

    def _locate(self, pos, vel, w, h, g) -> float:
        """The sub-step s in [0, h] at which g(s, p(s), v(s)) crosses zero, (p(s), v(s)) being the
        flight step of length s from (pos, vel).

        Regula falsi with the Anderson-Bjoerck correction on a bracket [lo, hi] with
        g(lo) > 0 >= g(hi): the next point is the secant root

            s = (lo g_hi - hi g_lo) / (g_hi - g_lo),

        and when s replaces the same end as the previous point did, the other end's g is scaled
        by m = 1 - g(s) / g_replaced (by 1/2 if m <= 0), so that end moves too (superlinear
        convergence). Points closer than ``LOCATE_TOL / 4`` to an end are moved that far inside,
        which closes the bracket once the secant root is that accurate, and after four
        iterations in a row that did not halve the bracket the next point is its midpoint.
        Stops when the bracket is narrower than ``LOCATE_TOL`` (returning its midpoint, the side
        convention of bisection) or g(s) is exactly 0 (returning s), or after
        ``LOCATE_MAX_EVALS`` points (returning the midpoint). If g(0) > 0 >= g(h) does not hold
        it falls back to :meth:`_bisect`."""
        lo, hi = 0.0, h
        g_lo = g(0.0, pos, vel)
        hp, hv = self.flight_step(pos, vel, w, h)
        g_hi = g(h, hp, hv)
        if not g_lo > 0.0 >= g_hi:
            return self._bisect(pos, vel, w, h, g)
        tol = self.LOCATE_TOL
        side = 0  # +1: the last point replaced lo, -1: it replaced hi
        slow = 0  # iterations in a row that did not halve the bracket
        for _ in range(self.LOCATE_MAX_EVALS):
            width = hi - lo
            if width <= tol:
                break
            if slow >= 4:
                s, slow = 0.5 * (lo + hi), 0
            else:
                s = (lo * g_hi - hi * g_lo) / (g_hi - g_lo)
                s = min(max(s, lo + 0.25 * tol), hi - 0.25 * tol)
            sp, sv = self.flight_step(pos, vel, w, s)
            g_s = g(s, sp, sv)
            if g_s > 0.0:
                if side == 1:
                    m = 1.0 - g_s / g_lo
                    g_hi *= m if m > 0.0 else 0.5
                lo, g_lo, side = s, g_s, 1
            elif g_s < 0.0:
                if side == -1:
                    m = 1.0 - g_s / g_hi
                    g_lo *= m if m > 0.0 else 0.5
                hi, g_hi, side = s, g_s, -1
            else:
                return s
            slow = slow + 1 if hi - lo > 0.5 * width else 0
        return 0.5 * (lo + hi)

    def _bisect(self, pos, vel, w, h, g) -> float:
        """Bisection for the sub-step s at which g(s, pos, vel) crosses zero within [0, h]: 30
        halvings keeping g(lo) > 0 (the only use of g(hi) <= 0), then the midpoint."""
        lo, hi = 0.0, h
        for _ in range(30):
            mid = 0.5 * (lo + hi)
            mp, mv = self.flight_step(pos, vel, w, mid)
            if g(mid, mp, mv) > 0.0:
                lo = mid
            else:
                hi = mid
        return 0.5 * (lo + hi)

    def _finish(self, t, pos, vel, w, h, stop, bounces) -> PlaneCrossing:
        th = self._locate(pos, vel, w, h, lambda s, q, v: stop(t + s, q, v))
        fp, fv = self.flight_step(pos, vel, w, th)
        return PlaneCrossing(t + th, np.array(fp), np.array(fv), np.array(w), tuple(bounces))

    def predict_plane(self, state, plane_y: float, max_time: float = 3.0) -> PlaneCrossing | None:
        """State when the ball centre next crosses y = ``plane_y`` (either direction), or None if it
        does not within ``max_time`` seconds or reaches the floor first."""
        s = np.asarray(state, dtype=float).reshape(-1)
        side = 1.0 if s[1] > plane_y else -1.0
        return self.advance(s, None, max_time, event=(STOP_PLANE, plane_y, side))

    def first_bounce(self, state, max_time: float = 3.0) -> Bounce | None:
        """The ball's first table impact from ``state`` (when, and where its centre is), or None
        if it reaches the floor (misses the table) or ``max_time`` passes first."""
        return self.advance(state, None, max_time, until_bounce=True,
                            event=(STOP_NEVER, 0.0, 0.0))

    def predict_time(self, state, duration: float) -> PlaneCrossing:
        """State after ``duration`` seconds (bounces on the table included). Raises ValueError if
        the ball reaches the floor before then."""
        if duration <= 0.0:
            s = np.asarray(state, dtype=float).reshape(-1)
            w = s[6:9] if s.size == 9 else np.zeros(3)
            return PlaneCrossing(0.0, s[0:3].copy(), s[3:6].copy(), np.array(w), ())
        hit = self.advance(state, None, duration + 1.0, event=(STOP_TIME, duration, 0.0))
        if hit is None:
            raise ValueError(f"the ball reaches the floor before {duration} s")
        return hit

    def trajectory(self, state, duration: float, rate: float = 200.0) -> tuple[np.ndarray, ...]:
        """Sampled ball positions over ``duration`` (for plots and drawing): (t, positions)."""
        times = np.arange(0.0, duration + 1e-12, 1.0 / rate)
        positions = np.array([self.predict_time(state, t).position for t in times])
        return times, positions

    def net_clearance(self, state, max_time: float = 3.0) -> float | None:
        """Height of the ball's lowest point above the net top when crossing y = 0 (negative: it
        hits the net), or None if it never reaches the net plane."""
        hit = self.predict_plane(state, 0.0, max_time)
        if hit is None:
            return None
        return float(hit.position[2] - self.params.radius - (TABLE.surface_z + NET.height))


# -- addition (hitting-point predictor): the bounce of a compliant table contact -------------------

class CompliantBounceBallModel(BallModel):
    """:class:`BallModel` with the tangential bounce corrected for the contact's compliance.

    In the Drake world the ball sinks into the table by up to
    ``delta = v_n sqrt(m / k)`` (k: the ball-table series stiffness) during the ~0.5 ms contact, so
    friction acts at a lever arm shorter than R. Rigid-contact friction with lever ``r``:
    slip ``u = v_t - r (omega x n)`` changes by ``(1 + m r^2 / I) J_t / m`` per impulse, so

        r = R (1 - lambda v_n sqrt(m / k) / R),
        |J_t| = min(mu J_n, m |u| / (1 + 1.5 (r / R)^2))      (I = 2/3 m R^2)

    and the spin changes by ``r x J_t / I``. The normal part is unchanged. ``lambda`` is the
    effective fraction of the peak penetration over the rolling phase, fitted against the Drake
    world: ``lambda = 0.2`` brings the crossing of the virtual hitting plane from up to 14 mm /
    4.7 ms off to within 2.4 mm / 0.4 ms over 100 ``default`` serves (the rigid model's rolling
    limit 0.6 v + 0.4 omega R loses too little tangential speed on fast impacts)."""

    def __init__(self, params: BallModelParams | None = None, dt: float = 1e-3,
                 lever_fraction: float = 0.2):
        super().__init__(params, dt)

        k_series = 1.0 / (1.0 / CONTACT.ball_stiffness + 1.0 / CONTACT.table_stiffness)
        self._sink_per_speed = math.sqrt(self.params.mass / k_series)  # delta / v_n (s)
        self.lever_fraction = lever_fraction

    def bounce(self, vel: tuple, w: tuple) -> tuple[tuple, tuple]:
        p = self.params
        vx, vy, vz = vel
        wx, wy, wz = w
        vn = -vz
        lever = 1.0 - self.lever_fraction * vn * self._sink_per_speed / p.radius
        r = p.radius * lever
        e = self.table_restitution(vn)
        jn = (1.0 + e) * vn
        ux, uy = vx - r * wy, vy + r * wx
        slip = math.hypot(ux, uy)
        if slip > 1e-12:
            jt = min(p.table_friction * jn, slip / (1.0 + 1.5 * lever * lever))
            jx, jy = -jt * ux / slip, -jt * uy / slip
        else:
            jx = jy = 0.0
        inv_i = 1.0 / (2.0 / 3.0 * p.radius * p.radius)
        return (vx + jx, vy + jy, e * vn), (wx + inv_i * r * jy, wy - inv_i * r * jx, wz)
