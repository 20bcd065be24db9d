"""Choosing the hitting point along the predicted path, for balls the fixed plane cannot serve.

The paper's players hit where the ball crosses the virtual hitting plane (section III-A). Real
serves often cross it low (a quarter of the ``real-test`` pool below 0.45 m, in the model) or
bounce a second time on the robot's half before it; the lab's later work chooses the hitting time
along the predicted path instead. :func:`choose_hitting_point` keeps the plane when it can and
otherwise takes the last point of the path inside a reachable band (docs/analytical_player.md,
"Choosing the hitting point"):

1. The *hittable window* of the predicted path (ball model, spin included) starts at the ball's
   bounce on the robot's half (at once if it has bounced there already:
   :func:`robot_half_bounces`) and ends at its next bounce, where it falls to :data:`FALL_Z`,
   or at the hitting plane. The rules end it at the second bounce on the robot's half: a ball
   that has bounced there twice already has no hitting point (the player lets it go).
2. If the path crosses the plane inside the window at least ``plane_z_min`` high, the crossing
   is the hitting point (every ``default`` serve: the paper's rule, unchanged).
3. Otherwise the hitting point is the *last* point of the window at least ``z_min`` high (the
   most time to prepare, the ball nearest the robot): where the ball falls through ``z_min``;
   it is taken if it lies at least 0.18 m behind the robot's table edge (y <= ``y_max``), where
   the arm reaches it, else there is none (None: the player does not strike).

The band's numbers come from the teacher's own stroke solver (aim, racket law and IK) on a grid
of hitting points (x in {-0.2, 0, 0.3} m, incoming velocity (0, -5, -1) m/s): it reaches balls
down to z = 0.5 m at y <= -1.6 m and z >= 0.7 m from y = -1.5 m, and none over the table.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tt_drake.ball_model import BallModel, PlaneCrossing
from tt_drake.constants import PLANES, TABLE

#: The path is followed until the ball's centre falls to this height (m): far below any hit.
FALL_Z = 0.1


@dataclass(frozen=True)
class HittingBand:
    """Where the analytical player may hit a ball off the plane (module docstring, rule 2-3)."""

    plane_z_min: float = 0.5  # m: a plane crossing at least this high is kept
    z_min: float = 0.65  # m: elsewhere the ball must be at least this high
    y_max: float = TABLE.robot_edge_y - 0.18  # m: and this far behind the robot's table edge


def unbounce(model: BallModel, vel, w, iterations: int = 20) -> tuple[tuple, tuple]:
    """The velocity and spin just before a table bounce that leaves the ball with (``vel``,
    ``w``): the inverse of ``model.bounce``.

    The normal part is exact: the incoming speed v_n solves v_z' = e(v_n) v_n (fixed point
    v_n <- v_z' / e(v_n); e varies slowly with v_n). The bounce keeps the spin about the normal,
    so the unknowns are x = (v_x, v_y, omega_x, omega_y), solving bounce(x) = x'. A ball that
    leaves rolling (no slip at the contact) has many pre-images (every incoming slip below the
    rolling limit): x' itself, the least change, is taken when bounce(x') = x'. Otherwise the
    bounce was sliding: it changed x by an impulse of fixed size (mu J_n) against the slip,
    whose direction it kept, so x' minus the change of a ball sliding the same way (x' with
    10 m/s more slip) is close, and Newton's method on bounce(x) = x' (forward-difference
    Jacobian) finishes it."""
    r = model.params.radius
    vz_out = float(vel[2])
    vn = vz_out
    for _ in range(iterations):
        vn = vz_out / model.table_restitution(vn)
    target = np.array([vel[0], vel[1], w[0], w[1]], dtype=float)
    wz = float(w[2])

    def residual(x):
        out_v, out_w = model.bounce((x[0], x[1], -vn), (x[2], x[3], wz))
        return np.array([out_v[0], out_v[1], out_w[0], out_w[1]]) - target

    def result(x):
        return (float(x[0]), float(x[1]), -vn), (float(x[2]), float(x[3]), wz)

    if np.abs(residual(target)).max() < 1e-12:
        return result(target)
    ux, uy = vel[0] - r * w[1], vel[1] + r * w[0]
    slip = math.hypot(ux, uy) or 1.0
    far = target + np.array([10.0 * ux / slip, 10.0 * uy / slip, 0.0, 0.0])
    x = target - residual(far) + (far - target)  # x' - (bounce(far) - far)
    for _ in range(iterations):
        f = residual(x)
        if np.abs(f).max() < 1e-12:
            break
        h = 1e-7
        jac = np.column_stack([(residual(x + h * e) - f) / h for e in np.eye(4)])
        try:
            x = x - np.linalg.solve(jac, f)
        except np.linalg.LinAlgError:
            break
    return result(x)


def robot_half_bounces(model: BallModel, state, max_time: float = 1.0,
                       step: float | None = None) -> int:
    """How many times a ball on the robot's half (y < 0) has bounced there since it crossed the
    net's plane y = 0: 0, 1 or 2 (two or more; the rules' lost point). The flight is followed
    back in time (the model's flight step with a negative step, ``step`` long: default the
    model's ``dt``); where it meets the table (centre at the contact height, over the table),
    the bounce is undone (:func:`unbounce`) and the flight followed on back, until the net's
    plane. The test looks at the path every ``step``, so near the table's edges and the net it
    is as fine as the ball's travel in one step."""
    s = np.asarray(state, dtype=float).reshape(-1)
    if s[1] >= 0.0:
        return 0
    p = model.params
    contact_z = p.table_z + p.radius
    pos, vel = tuple(s[0:3].tolist()), tuple(s[3:6].tolist())
    w = tuple(s[6:9].tolist()) if s.size >= 9 else (0.0, 0.0, 0.0)
    dt = model.dt if step is None else step
    t, bounces = 0.0, 0
    while t < max_time:
        pos, vel = model.flight_step(pos, vel, w, -dt)
        t += dt
        if pos[1] >= 0.0:
            return bounces
        if pos[2] <= contact_z and vel[2] > 0.0 and model.over_table(pos[0], pos[1]):
            bounces += 1
            if bounces == 2:
                return 2
            vel, w = unbounce(model, vel, w)
            pos = (pos[0], pos[1], contact_z)
    return bounces


def _fall_through(t0, z0, vz0, t1, z1, vz1, level: float) -> float:
    """The time in [t0, t1] at which the cubic Hermite interpolant of z (values and slopes at
    both ends) falls through ``level`` (z0 >= level > z1): bisection, 50 halvings."""
    h = t1 - t0

    def z(u):
        return ((2 * u**3 - 3 * u**2 + 1) * z0 + (u**3 - 2 * u**2 + u) * h * vz0
                + (-2 * u**3 + 3 * u**2) * z1 + (u**3 - u**2) * h * vz1)

    lo, hi = 0.0, 1.0
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        if z(mid) >= level:
            lo = mid
        else:
            hi = mid
    return t0 + 0.5 * (lo + hi) * h


def choose_hitting_point(model: BallModel, state, plane_y: float = PLANES.hitting_y,
                         band: HittingBand | None = None, max_time: float = 3.0,
                         bounce_step: float | None = None) -> PlaneCrossing | None:
    """The ball's state at the chosen hitting point (time relative to ``state``, the spin there
    and the bounces on the way), by the rule of the module docstring; or None.

    ``state``: (p, v, omega), 9 floats (or 6: no spin). Rule 3's point is where the ball falls
    through ``z_min`` for the last time in the window (located on the cubic Hermite interpolant
    of the model's steps, then integrated to exactly), so successive estimates of one flight
    give the same point to the model's accuracy, not to a step. ``bounce_step``: the step of
    :func:`robot_half_bounces`' test (default the model's ``dt``)."""
    band = band or HittingBand()
    s = np.asarray(state, dtype=float).reshape(-1)
    if s.size == 6:
        s = np.r_[s, np.zeros(3)]
    side = 1.0 if s[1] > plane_y else -1.0
    samples: dict[float, tuple[float, float]] = {}  # t -> (z, v_z) along the path

    def stop(t, q, v):
        samples[t] = (q[2], v[2])
        return min(side * (q[1] - plane_y), q[2] - FALL_Z)

    end = model._advance(s, stop, max_time)  # predict_plane's integration, with a second event
    if end is None:
        return None
    robot = [b.t for b in end.bounces if b.position[1] < 0.0]
    behind = robot_half_bounces(model, s, step=bounce_step)
    if behind >= 2:
        return None  # the point is lost: the ball is out of play (the rules, Law 2.10.1.3)
    if behind == 1:
        start, stop_t = 0.0, (robot[0] if robot else end.t)
    elif robot:
        start, stop_t = robot[0], (robot[1] if len(robot) > 1 else end.t)
    else:
        return None  # it does not reach the robot's half
    at_plane = abs(end.position[1] - plane_y) < 1e-9
    if at_plane and stop_t == end.t and end.position[2] >= band.plane_z_min:
        return end
    times = [t for t in sorted(samples) if start < t <= stop_t]
    for a, b in zip(reversed(times[:-1]), reversed(times[1:]), strict=True):
        (za, va), (zb, vb) = samples[a], samples[b]
        if za >= band.z_min > zb:
            hit = model.predict_time(s, _fall_through(a, za, va, b, zb, vb, band.z_min))
            return hit if hit.position[1] <= band.y_max else None
    return None
