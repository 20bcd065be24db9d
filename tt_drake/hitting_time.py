"""Choosing the hitting point along the predicted path, for balls the fixed plane cannot serve.

The paper's players hit where the ball crosses the virtual hitting plane (section III-A). Real
serves often cross it low (a quarter of the ``real-test`` pool below 0.45 m, in the model) or
bounce a second time on the robot's half before it; the lab's later work chooses the hitting time
along the predicted path instead. :func:`choose_hitting_point` keeps the plane when it can and
otherwise takes the last point of the path inside a reachable band (docs/analytical_player.md,
"Choosing the hitting point"):

1. The *hittable window* of the predicted path (ball model, spin included) starts at the ball's
   bounce on the robot's half (at once if it has bounced there already:
   :func:`last_robot_bounce`) and ends at its next bounce, where it falls to :data:`FALL_Z`,
   or at the hitting plane. The rules end it at the second bounce on the robot's half: a ball
   that has bounced there twice already (as the player counted, :class:`BounceCount`) has no
   hitting point, and the player lets it go.
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

from dataclasses import dataclass

import numpy as np

from tt_drake.ball_model import BallModel, PlaneCrossing
from tt_drake.constants import PLANES, TABLE
from tt_drake.flight_kernel import last_table_contact

#: The path is followed until the ball's centre falls to this height (m): far below any hit.
FALL_Z = 0.1


@dataclass(frozen=True)
class HittingBand:
    """Where the analytical player may hit a ball off the plane (module docstring, rule 2-3)."""

    plane_z_min: float = 0.5  # m: a plane crossing at least this high is kept
    z_min: float = 0.65  # m: elsewhere the ball must be at least this high
    y_max: float = TABLE.robot_edge_y - 0.18  # m: and this far behind the robot's table edge


def last_robot_bounce(model: BallModel, state, max_time: float = 1.0,
                      step: float | None = None) -> float | None:
    """How long ago (s) a ball on the robot's half (y < 0) moving toward the robot last
    bounced there, or None if it has not since it crossed the net's plane y = 0: the flight
    followed back in time (the model's flight step with a negative step, ``step`` long: default
    the model's ``dt``) meets the table before it gets back to the net's plane. The test looks
    at the path every ``step``, so near the table's edges and the net it is as fine as the
    ball's travel in one step. Only the last bounce is found: the flight before it would need
    the bounce undone, which the estimated spin is not accurate enough for (a wrong spin moves
    the undone velocity by up to mu J_n); a player counts the bounces it has seen with
    :class:`BounceCount` instead."""
    s = np.asarray(state, dtype=float).reshape(-1)
    if s[1] >= 0.0:
        return None
    p = model.params
    w = s[6:9].tolist() if s.size >= 9 else [0.0, 0.0, 0.0]
    t = last_table_contact(*s[0:6].tolist(), *w, p.drag_k, p.magnus_cl, p.gravity,
                           model.dt if step is None else step, max_time, p.table_z + p.radius,
                           p.table_half_width, p.table_half_length)
    return None if t < 0.0 else t


@dataclass(frozen=True)
class BounceCount:
    """The bounces a player has seen the incoming ball make on its half: ``first``, the time of
    the first (simulation clock, s; None before it) and ``count`` (0, 1 or 2: two or more, the
    rules' lost point). Fed the time of the last bounce behind each new estimate
    (:func:`last_robot_bounce`), it counts a bounce more than ``SAME_BOUNCE`` after the first
    as the second: two bounces on one half are at least a flight apart (~0.1 s), while one
    bounce seen from successive estimates moves by the estimates' error (a few ms)."""

    first: float | None = None
    count: int = 0

    SAME_BOUNCE = 0.03  # s

    def seen(self, bounce_time: float | None) -> BounceCount:
        """This count after an estimate whose last bounce behind was at ``bounce_time``
        (None: none since the net's plane)."""
        if bounce_time is None or self.count >= 2:
            return self
        if self.first is None:
            return BounceCount(bounce_time, 1)
        if bounce_time > self.first + self.SAME_BOUNCE:
            return BounceCount(self.first, 2)
        return self


def count_bounces(model: BallModel, count: BounceCount, state, t_state: float,
                  step: float | None = None) -> BounceCount:
    """``count`` after an estimate ``state`` (p, v and optionally omega) taken at ``t_state``:
    the last bounce behind the ball on the robot's half (:func:`last_robot_bounce`, ``step``)
    counted; a ball on the opponent's half (y >= 0) starts a new count (a rally's next ball)."""
    s = np.asarray(state, dtype=float).reshape(-1)
    if s[1] >= 0.0:
        return BounceCount()
    ago = last_robot_bounce(model, s, step=step)
    return count.seen(None if ago is None else t_state - ago)


def robot_bounces_by(hit: PlaneCrossing, bounces_behind: int) -> int:
    """The ball's bounces on the robot's half (y < 0) when it reaches ``hit``: the
    ``bounces_behind`` it has made already and those on the way (two or more: the rules' lost
    point, Law 2.10.1.3)."""
    return bounces_behind + sum(b.position[1] < 0.0 for b in hit.bounces)


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
                         bounce_step: float | None = None,
                         bounces_behind: int | None = None) -> PlaneCrossing | None:
    """The ball's state at the chosen hitting point (time relative to ``state``, the spin there
    and the bounces on the way), by the rule of the module docstring; or None.

    ``state``: (p, v, omega), 9 floats (or 6: no spin). Rule 3's point is where the ball falls
    through ``z_min`` for the last time in the window (located on the cubic Hermite interpolant
    of the model's steps, then integrated to exactly), so successive estimates of one flight
    give the same point to the model's accuracy, not to a step. ``bounce_step``: the step of
    :func:`last_robot_bounce`'s test (default the model's ``dt``). ``bounces_behind``: the
    bounces the ball has made on the robot's half so far, as the caller counted them
    (:class:`BounceCount`); None: 1 if :func:`last_robot_bounce` finds one, else 0."""
    band = band or HittingBand()
    s = np.asarray(state, dtype=float).reshape(-1)
    if s.size == 6:
        s = np.r_[s, np.zeros(3)]
    side = 1.0 if s[1] > plane_y else -1.0
    samples: dict[float, tuple[float, float]] = {}  # t -> (z, v_z) along the path

    def stop(t, q, v):
        samples[t] = (q[2], v[2])
        return min(side * (q[1] - plane_y), q[2] - FALL_Z)

    end = model.advance(s, stop, max_time)  # predict_plane's integration, with a second event
    if end is None:
        return None
    robot = [b.t for b in end.bounces if b.position[1] < 0.0]
    if bounces_behind is None:
        bounces_behind = int(last_robot_bounce(model, s, step=bounce_step) is not None)
    if bounces_behind >= 2:
        return None  # the point is lost: the ball is out of play (the rules, Law 2.10.1.3)
    if bounces_behind == 1:
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


def closest_approach(model: BallModel, state, point, max_time: float = 3.0) -> float:
    """The least distance (m) of the ball's centre from ``point`` while the ball is on the
    robot's half (y < 0) and in play there: from ``state`` (p, v and optionally omega) until its
    second bounce on the robot's half (the rules' lost point), its fall to :data:`FALL_Z` or
    ``max_time``, sampled at the model's steps (a step's travel, ~1 cm at 2 ms, is the
    sampling's error). Infinite if the ball never reaches the robot's half in play."""
    s = np.asarray(state, dtype=float).reshape(-1)
    if s.size == 6:
        s = np.r_[s, np.zeros(3)]
    target = np.asarray(point, dtype=float)
    samples: list[tuple[float, float]] = []  # (t, distance) on the robot's half

    def stop(t, q, _v):
        if q[1] < 0.0:
            samples.append((t, float(np.linalg.norm(np.asarray(q) - target))))
        return q[2] - FALL_Z

    end = model.advance(s, stop, max_time)  # to the fall (None: floor or max_time first)
    bounces = () if end is None else end.bounces
    robot = [b.t for b in bounces if b.position[1] < 0.0]
    until = robot[1] if len(robot) > 1 else np.inf
    return min((d for t, d in samples if t <= until), default=np.inf)
