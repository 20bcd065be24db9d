"""Numpy model of a table-tennis ball: flight with gravity, drag and Magnus, and the table bounce.

It is the model the Drake world is calibrated to, shared by the launcher (serve rejection), the
ball-flight estimator, the physical-model hitting-point predictor and the analytical player.

Flight (facts.md section 1):

    p' = v,    v' = g - k |v| v + C_L (omega x v),    omega' = 0

Table bounce: the Drake world uses point contact with Hunt-Crossley dissipation,
f_n = k x (1 + d x'), whose normal restitution depends on d * v_n only
(:func:`hunt_crossley_restitution`); tangentially Coulomb friction acts on a thin hollow sphere
(I = 2/3 m R^2) until the contact point stops slipping (the rolling limit v' = 0.6 v + 0.4 omega R).

The state is a 9-vector ``(p, v, omega)`` in the world frame of :mod:`tt_drake.constants`.
Scalar arithmetic on Python floats is used on purpose: for 3-vectors it is several times faster
than numpy (facts.md section 4).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from tt_drake.constants import BALL, CONTACT, GRAVITY, NET, TABLE


@lru_cache(maxsize=1)
def _restitution_table() -> tuple[np.ndarray, np.ndarray]:
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

    Close to the textbook first-order result e ~ 1 - (2/3) d v for small d v (facts.md section 4).
    """
    dv_grid, e_grid = _restitution_table()
    return float(np.interp(dissipation * abs(impact_speed), dv_grid, e_grid))


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

    def flight_step(self, pos: tuple, vel: tuple, w: tuple, h: float) -> tuple[tuple, tuple]:
        """One classical Runge-Kutta (RK4) step of the flight ODE, no contact."""
        a1 = self.acceleration(vel, w)
        v2 = tuple(vel[i] + 0.5 * h * a1[i] for i in range(3))
        a2 = self.acceleration(v2, w)
        v3 = tuple(vel[i] + 0.5 * h * a2[i] for i in range(3))
        a3 = self.acceleration(v3, w)
        v4 = tuple(vel[i] + h * a3[i] for i in range(3))
        a4 = self.acceleration(v4, w)
        new_p = tuple(pos[i] + h / 6.0 * (vel[i] + 2 * v2[i] + 2 * v3[i] + v4[i]) for i in range(3))
        new_v = tuple(vel[i] + h / 6.0 * (a1[i] + 2 * a2[i] + 2 * a3[i] + a4[i]) for i in range(3))
        return new_p, new_v

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
    def _advance(self, state, stop, max_time: float):
        """Integrate from ``state`` until ``stop(t, pos, vel)`` changes sign from positive to
        non-positive (an event function), bouncing on the table on the way. Returns the state at
        the event (located by bisection) or None if the ball reaches the floor (centre below
        ``radius``) or ``max_time`` passes first."""
        p = self.params
        s = np.asarray(state, dtype=float).reshape(-1)
        if s.shape != (9,) and s.shape != (6,):
            raise ValueError(f"ball state must have 6 or 9 entries, got shape {s.shape}")
        if not np.all(np.isfinite(s)):
            raise ValueError("ball state contains NaN or infinity")
        pos, vel = tuple(s[0:3]), tuple(s[3:6])
        w = tuple(s[6:9]) if s.size == 9 else (0.0, 0.0, 0.0)
        t = 0.0
        bounces: list[Bounce] = []
        g0 = stop(t, pos, vel)
        if g0 <= 0.0:
            return None
        contact_z = p.table_z + p.radius
        while t < max_time:
            h = min(self.dt, max_time - t)
            new_p, new_v = self.flight_step(pos, vel, w, h)
            # Table impact inside this step: locate it and bounce.
            if new_p[2] < contact_z <= pos[2] and new_v[2] < 0.0:
                th = self._locate(pos, vel, w, h, lambda _s, q, _v: q[2] - contact_z)
                hp, hv = self.flight_step(pos, vel, w, th)
                if self.over_table(hp[0], hp[1]):
                    # Check the stop event before the impact first.
                    if stop(t + th, hp, hv) <= 0.0:
                        return self._finish(t, pos, vel, w, h, stop, bounces)
                    bounces.append(Bounce(t + th, hp))
                    hv, w = self.bounce(hv, w)
                    pos, vel, t = hp, hv, t + th
                    continue
            if stop(t + h, new_p, new_v) <= 0.0:
                return self._finish(t, pos, vel, w, h, stop, bounces)
            if new_p[2] < p.radius:
                return None
            pos, vel, t = new_p, new_v, t + h
        return None

    def _locate(self, pos, vel, w, h, g) -> float:
        """Bisection for the sub-step s at which g(s, pos, vel) crosses zero within [0, h]."""
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

        def stop(_t, q, _v):
            return side * (q[1] - plane_y)

        return self._advance(s, stop, max_time)

    def predict_time(self, state, duration: float) -> PlaneCrossing:
        """State after ``duration`` seconds (bounces on the table included). Raises ValueError if
        the ball reaches the floor before then."""

        def stop(t, _q, _v):
            return duration - t

        if duration <= 0.0:
            s = np.asarray(state, dtype=float).reshape(-1)
            w = s[6:9] if s.size == 9 else np.zeros(3)
            return PlaneCrossing(0.0, s[0:3].copy(), s[3:6].copy(), np.array(w), ())
        hit = self._advance(state, stop, duration + 1.0)
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
        from tt_drake.constants import CONTACT

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
