"""The four movement stages of a stroke as joint-space quintic segments (paper section III-A).

- awaiting: hold the awaiting posture, or move back to it after a stroke;
- preparation: swing back to the preparation posture, arriving at rest when the predicted time to
  impact equals the hitting duration; re-planned from the current desired state whenever the
  prediction improves;
- hitting: from rest to the hitting configuration (theta_hit, theta_dot_hit) at t_hit;
- follow-through: keep moving the way the racket went and come to rest; then awaiting again.

Every segment is a quintic per joint fitted to position, velocity and acceleration at both ends
and starts from the state where the previous one stands at that instant, so q, q_dot and q_ddot
are continuous everywhere, also across re-plans.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tt_drake.quintic_kernel import quintic_many

AWAITING, PREPARATION, HITTING, FOLLOW_THROUGH = "awaiting", "preparation", "hitting", \
    "follow_through"
STAGES = (AWAITING, PREPARATION, HITTING, FOLLOW_THROUGH)


def quintic_coefficients(q0, v0, a0, q1, v1, a1, T) -> np.ndarray:
    """Coefficients c_0..c_5 (last axis) of the quintic with q, q_dot, q_ddot = (q0, v0, a0) at
    s = 0 and (q1, v1, a1) at s = T; element-wise over any leading shape (T broadcasts)."""
    q0, v0, a0, q1, v1, a1 = (np.asarray(x, dtype=float) for x in (q0, v0, a0, q1, v1, a1))
    h = q1 - q0 - v0 * T - 0.5 * a0 * T * T
    dv = v1 - v0 - a0 * T
    da = a1 - a0
    c3 = (10 * h - 4 * dv * T + 0.5 * da * T * T) / T**3
    c4 = (-15 * h + 7 * dv * T - da * T * T) / T**4
    c5 = (6 * h - 3 * dv * T + 0.5 * da * T * T) / T**5
    return np.stack([q0, v0, 0.5 * a0, c3, c4, c5], axis=-1)


@dataclass(frozen=True)
class Quintic:
    """q(t) = sum_k c_k (t - t0)^k, k = 0..5, per joint, on [t0, t0 + duration].

    Outside the interval it is clamped: before t0 it stands at its start state, after the end at
    its end position with its end velocity continued at zero acceleration (only the last segment
    of a plan is ever evaluated past its end, and it ends at rest).
    """

    t0: float
    duration: float
    coeffs: np.ndarray  # (n_dof, 6)

    @classmethod
    def fit(cls, t0, duration, q0, v0, a0, q1, v1, a1) -> Quintic:
        """The quintic with the given boundary positions, velocities and accelerations."""
        T = float(duration)
        if T <= 0.0:
            raise ValueError(f"segment duration must be > 0, got {T}")
        return cls(float(t0), T, quintic_coefficients(q0, v0, a0, q1, v1, a1, T))

    @property
    def t_end(self) -> float:
        return self.t0 + self.duration

    def cut(self, t: float) -> Quintic:
        """The same polynomial ending at ``t`` (t0 < t)."""
        return Quintic(self.t0, min(self.duration, t - self.t0), self.coeffs)

    def evaluate(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q, q_dot, q_ddot) at ``t``, each (n_dof,): the Horner forms of
        :mod:`tt_drake.quintic_kernel` at s = clip(t - t0, 0, duration), continued past the end
        at the end velocity and zero acceleration."""
        q, v, a = quintic_many(self.coeffs, self.t0, self.duration, np.array([float(t)]))
        return q[0], v[0], a[0]

    def sample(self, rate: float = 500.0) -> tuple[np.ndarray, ...]:
        """(t, q, q_dot, q_ddot) sampled over the segment at ``rate`` Hz, both ends included."""
        n = max(2, int(round(self.duration * rate)) + 1)
        times = np.linspace(self.t0, self.t_end, n)
        return (times, *self.evaluate_many(times))

    def evaluate_many(self, times) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`evaluate` at every time of ``times`` (K,) at once: (q, q_dot, q_ddot), each
        (K, n_dof), with the same operations (hence the same values) as K calls
        (:func:`tt_drake.quintic_kernel.quintic_many`, compiled)."""
        return quintic_many(self.coeffs, self.t0, self.duration,
                            np.asarray(times, dtype=float).reshape(-1))


def continue_past_end(extra: np.ndarray, q, v, a):
    """Rows with ``extra`` > 0 (after the segment's end): position continued with the end
    velocity, zero acceleration (as ``evaluate``)."""
    past = extra[:, 0] > 0.0
    if np.any(past):
        q, a = q.copy(), a.copy()
        q[past] = q[past] + v[past] * extra[past]
        a[past] = 0.0
    return q, v, a


def evaluate_segment_many(segment, times) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``segment.evaluate`` at every time of ``times``: vectorised when the segment has
    ``evaluate_many``, else one call per time."""
    if hasattr(segment, "evaluate_many"):
        return segment.evaluate_many(times)
    q, v, a = zip(*(segment.evaluate(t) for t in times), strict=True)
    return np.array(q), np.array(v), np.array(a)


@dataclass
class StagePlan:
    """A sequence of (stage, segment), each starting where the previous one ends; evaluated by
    time. Before the first segment and after the last it holds the boundary states."""

    segments: list[tuple[str, Quintic]] = field(default_factory=list)

    def stage_at(self, t: float) -> str:
        for stage, seg in self.segments:
            if t < seg.t_end:
                return stage
        return AWAITING

    def segment_at(self, t: float) -> Quintic:
        for _, seg in self.segments:
            if t < seg.t_end:
                return seg
        return self.segments[-1][1]

    def evaluate(self, t: float):
        return self.segment_at(t).evaluate(t)

    def evaluate_many(self, times) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`evaluate` at every time of ``times`` (K,): (q, q_dot, q_ddot), each (K, n_dof).
        Each time goes to the segment :meth:`segment_at` picks, and each segment's times are
        evaluated at once (:func:`evaluate_segment_many`)."""
        t = np.asarray(times, dtype=float)
        left = np.ones(t.shape, dtype=bool)
        parts = []
        first, last = t.min(), len(self.segments) - 1
        for i, (_, seg) in enumerate(self.segments):
            if i < last and seg.t_end <= first:
                continue  # over before every time
            mine = left if i == last else left & (t < seg.t_end)
            if mine.any():
                parts.append((mine, evaluate_segment_many(seg, t[mine])))
                left = left & ~mine
                if not left.any():
                    break
        n_dof = parts[0][1][0].shape[1]
        out = tuple(np.empty((t.size, n_dof)) for _ in range(3))
        for mine, values in parts:
            for o, v in zip(out, values, strict=True):
                o[mine] = v
        return out

    def truncated(self, t: float) -> StagePlan:
        """The part of the plan executed before ``t``: segments that started earlier, the one under
        way cut to end at ``t`` (to be followed by a re-plan from the state at ``t``)."""
        return StagePlan([(s, q.cut(t)) for s, q in self.segments if q.t0 < t])

    def continued(self, t: float, plan: StagePlan) -> StagePlan:
        """This plan up to ``t`` (:meth:`truncated`), then ``plan`` (a re-plan from the
        state at ``t``)."""
        return StagePlan(self.truncated(t).segments + plan.segments)


@dataclass(frozen=True)
class StageTimes:
    """Durations (s) of the stroke stages the analytical player uses."""

    hitting: float = 0.40  # the hitting stage: from rest at the preparation posture to the hit
    follow_through: float = 0.30
    return_to_awaiting: float = 0.80
    min_preparation: float = 0.25  # a swing-back from rest needs at least this long (s)
    min_replan: float = 0.05  # an ongoing swing-back may be re-planned until this close to its end
    min_follow_through: float = 0.10
    # 0: the hitting stage always lasts ``hitting``; a duration: it is shortened, to no less
    # than this, where a joint's swing-back is clipped at its limit (:func:`hitting_duration`).
    min_hitting: float = 0.0
    # With no time for a swing-back, the arm waits at rest for a better prediction until the
    # hitting stage's start, and no later than this long before the hit (s): a direct hit
    # started then leaves a slow joint time for the corrections after the bounce. 0: until the
    # hitting stage's start (:func:`plan_stroke`).
    direct_lead: float = 0.0


@dataclass(frozen=True)
class JointLimits:
    lower: np.ndarray
    upper: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray | None = None
    margin: float = 0.05  # rad kept from the position limits when choosing postures

    def clip(self, q: np.ndarray) -> np.ndarray:
        return np.clip(q, self.lower + self.margin, self.upper - self.margin)

    def move_time(self, q0, q1, safety: float = 1.25) -> float:
        """Time a rest-to-rest quintic from q0 to q1 needs to stay within the velocity and
        acceleration limits: its peaks are 1.875 |dq| / T and 5.77 |dq| / T^2 (times
        ``safety``)."""
        dq = np.abs(np.asarray(q1, dtype=float) - np.asarray(q0, dtype=float))
        t = 1.875 * dq / self.velocity
        if self.acceleration is not None:
            t = np.maximum(t, np.sqrt(5.7735 * dq / self.acceleration))
        return safety * float(t.max())


def plan_stroke(now: float, state: tuple, t_hit: float, q_hit, qd_hit, q_await,
                limits: JointLimits, times: StageTimes = StageTimes(),
                preparing: bool = False, allow_wait: bool = True) -> StagePlan | None:
    """The whole stroke from the current desired ``state`` = (q, q_dot, q_ddot) at ``now``:
    preparation -> hitting (arriving at (q_hit, qd_hit) at ``t_hit``) -> follow-through ->
    back to ``q_await``.

    Preparation posture: q_prep = q_hit - (T_hit / 2) qd_hit (clipped to the limits), the
    swing-back from which a rest-to-rest-like quintic reaches qd_hit in T_hit. Follow-through:
    q_hit + (T_ft / 2) qd_hit reached at rest, a quintic without overshoot; T_ft is shortened
    (to no less than ``min_follow_through``) so that every joint stops inside its limits.

    Timing: the hitting stage starts at t_hit - T_hit. A swing-back from rest starts only with
    enough time before then: ``min_preparation``, or longer if the distance to q_prep needs it
    (:meth:`JointLimits.move_time`); an ongoing one (``preparing``) is re-planned until
    ``min_replan`` before its end. Otherwise, at rest and if ``allow_wait``, it returns None: wait
    (keep the current plan, re-plan at the next prediction) until the hitting stage's start and
    while more than ``times.direct_lead`` is left before the hit; the caller decides whether
    waiting is safe (a direct hit started later must still be feasible).
    Without a swing-back the hitting segment starts from ``state`` and lasts until t_hit,
    possibly longer than T_hit.
    """
    q, qd, qdd = (np.asarray(x, dtype=float) for x in state)
    q_hit, qd_hit = np.asarray(q_hit, dtype=float), np.asarray(qd_hit, dtype=float)
    zero = np.zeros_like(q)
    segments: list[tuple[str, Quintic]] = []
    t_hitting = hitting_duration(q_hit, qd_hit, limits, times)
    t_start_hit = t_hit - t_hitting
    q_prep = limits.clip(q_hit - 0.5 * t_hitting * qd_hit)
    if preparing:
        lead = times.min_replan
    else:
        lead = max(times.min_preparation, limits.move_time(q, q_prep))
    if t_start_hit - now >= lead:
        prep = Quintic.fit(now, t_start_hit - now, q, qd, qdd, q_prep, zero, zero)
        segments.append((PREPARATION, prep))
        start = (q_prep, zero, zero, t_start_hit)
    elif allow_wait and not preparing and t_start_hit > now and t_hit - now > times.direct_lead:
        return None  # at rest: wait, re-planning meanwhile, until the hit must start
    else:
        if t_hit - now <= 1e-3:
            raise ValueError(f"no time left to hit: t_hit {t_hit:.3f} s, now {now:.3f} s")
        start = (q, qd, qdd, now)
    hit = Quintic.fit(start[3], t_hit - start[3], start[0], start[1], start[2], q_hit, qd_hit, zero)
    segments.append((HITTING, hit))
    t_follow = follow_through_time(q_hit, qd_hit, limits, times)
    q_end = limits.clip(q_hit + 0.5 * t_follow * qd_hit)
    follow = Quintic.fit(t_hit, t_follow, q_hit, qd_hit, zero, q_end, zero, zero)
    segments.append((FOLLOW_THROUGH, follow))
    back = Quintic.fit(follow.t_end, return_duration(q_end, q_await, limits, times), q_end,
                       zero, zero, np.asarray(q_await, dtype=float), zero, zero)
    segments.append((AWAITING, back))
    return StagePlan(segments)


def correction_stages(now: float, current: StagePlan, t_hit: float, q_hit, qd_hit, q_await,
                      limits: JointLimits, times: StageTimes) -> StagePlan | None:
    """The stages of a correction made at ``now``: :func:`plan_stroke` from ``current``'s
    desired state there to (``q_hit``, ``qd_hit``) at ``t_hit``, as a swing under way
    (``preparing``) that does not wait; None if there is no time left to hit. The caller checks
    them against its limits and continues ``current`` with them (:meth:`StagePlan.continued`)."""
    try:
        return plan_stroke(now, current.evaluate(now), t_hit, q_hit, qd_hit, q_await, limits,
                           times, preparing=True, allow_wait=False)
    except ValueError:
        return None


def hitting_duration(q_hit, qd_hit, limits: JointLimits, times: StageTimes) -> float:
    """The hitting stage's duration T: ``times.hitting``, or, with ``times.min_hitting`` > 0, the
    longest T (down to ``min_hitting``) in which no joint moves back past its swing-back posture.

    The hitting segment is the quintic from rest at q_prep to (q_hit, v) with zero end
    acceleration; in normalised time s its velocity starts as (30 d - 12 v T) s^2 / T, with
    d = q_hit - q_prep, so it first moves backward when |d| < 0.4 |v| T. Unclipped, q_prep =
    q_hit - (T / 2) v gives |d| = 0.5 |v| T; a joint whose swing-back is clipped at its limit
    (less the margin) has only ``room`` = |q_hit - limit| and needs T <= 2.5 room / |v| (at
    equality its velocity is v s^3 (4 - 3 s), never negative)."""
    if times.min_hitting <= 0.0:
        return times.hitting
    return _longest_within_room(q_hit, -np.asarray(qd_hit, dtype=float), limits, 2.5,
                                times.min_hitting, times.hitting)


def return_duration(q_end, q_await, limits: JointLimits, times: StageTimes) -> float:
    """The awaiting stage's duration: ``times.return_to_awaiting``, or longer if the rest-to-rest
    move from ``q_end`` to ``q_await`` needs it (:meth:`JointLimits.move_time`); nothing waits
    for the return, so it takes the time the joint limits ask for."""
    return max(times.return_to_awaiting, limits.move_time(q_end, q_await))


def follow_through_time(q_hit, qd_hit, limits: JointLimits, times: StageTimes) -> float:
    """The longest follow-through (up to ``times.follow_through``) in which every joint, moving
    (T / 2) qd on a rest-ending quintic, stays inside its limits (less the margin)."""
    return _longest_within_room(q_hit, qd_hit, limits, 2.0, times.min_follow_through,
                                times.follow_through)


def _longest_within_room(q, direction, limits: JointLimits, per_speed: float, shortest: float,
                         longest: float) -> float:
    """min over joints of ``per_speed`` room_j / |direction_j|, clipped to [shortest, longest]:
    room_j is how far joint j may go from ``q`` in the sign of ``direction_j`` before its limit
    (less the margin), none for a joint that does not move. A rest-ending quintic from (q, v)
    in T covers (T / 2) v (``per_speed`` 2); a hitting quintic needs T <= 2.5 room / |v| behind
    the hit (:func:`hitting_duration`, ``direction`` = -v)."""
    room = np.where(direction > 0, limits.upper - limits.margin - q,
                    q - (limits.lower + limits.margin))
    speed = np.abs(direction)
    with np.errstate(divide="ignore"):
        allowed = np.where(speed > 1e-9, per_speed * np.maximum(room, 0.0) / speed, np.inf)
    return float(np.clip(allowed.min(), shortest, longest))


def plan_extremes(plan: StagePlan, rate: float = 500.0) -> dict:
    """Sampled extremes of a plan: lowest and highest positions, largest |q_dot| and |q_ddot|
    per joint."""
    qs, vs, accs = [], [], []
    for _, seg in plan.segments:
        _, q, v, a = seg.sample(rate)
        qs.append(q)
        vs.append(v)
        accs.append(a)
    q, v, a = np.vstack(qs), np.vstack(vs), np.vstack(accs)
    return {"q_min": q.min(0), "q_max": q.max(0), "qd_max": np.abs(v).max(0),
            "qdd_max": np.abs(a).max(0)}


def within_effort(plan: StagePlan, torques, budget, now: float = -np.inf,
                  rate: float = 50.0) -> bool:
    """Inverse dynamics ``torques(q, q_dot, q_ddot)`` along ``plan`` from ``now`` on, sampled at
    ``rate`` Hz, within ``budget`` everywhere: the controller can then follow it. ``torques``
    must be the plan's whole feed-forward torque, M q_ddot + C q_dot - tau_g
    (:meth:`tt_drake.systems.hitting_ik.HittingIK.torques`, gravity included), for many
    samples at once: (K, n_dof) arrays in, (K, n_dof) out. ``budget``: per joint,
    ``|tau| <= budget``; or an object whose ``bounds(q_dot)`` gives the (lower, upper) torques
    at joint speeds ``q_dot`` elementwise, for one sample (n_dof,) or many (K, n_dof)
    (:class:`tt_drake.drives.EffortBudget`, the drives' envelope).

    Segment by segment, each segment's samples, their torques and their bounds in one call each
    (:func:`evaluate_segment_many`); the check stops at the first segment with a sample over
    budget."""
    bounds = getattr(budget, "bounds", None)
    if bounds is None:
        limit = np.asarray(budget, dtype=float)

        def bounds(_v):
            return -limit, limit
    for _, seg in plan.segments:
        if seg.t_end <= now:
            continue
        times = np.arange(max(seg.t0, now), seg.t_end + 1e-9, 1.0 / rate)
        if times.size == 0:
            continue
        q, v, a = evaluate_segment_many(seg, times)
        lower, upper = bounds(v)
        tau = torques(q, v, a)
        if (tau > upper).any() or (tau < lower).any():
            return False
    return True
