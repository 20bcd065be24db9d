"""The learned player's stroke as motor primitives (paper sections II-B, III-A, III-C).

Numpy only. A stroke is a :class:`tt_drake.stages.StagePlan` whose segments are
:class:`SampledSegment` objects: a DMP rollout sampled once per (re-)plan and stored as one quintic
per sample interval, so that evaluating the plan at any time is O(1) (one Horner evaluation of a
stored row; docs/design.md, "Clocks") and q, q_dot, q_ddot are continuous inside a segment.

Stages (section III-A) and what generates them:

- preparation: a single DMP (Eqs. 1-5 with ``g_dot = 0``) from the current desired state to the
  preparation posture ``q_prep = q_hit - (T_hit / 2) q_dot_hit`` (the teacher's rule, so that the
  hitting primitives start where the demonstrations started), arriving at the hitting stage's start;
- hitting: the mixture of motor primitives (Eq. 6, Algorithm 1) with goal ``g_f = theta_hit``,
  ``g_dot = theta_dot_hit`` and ``tau`` the time left to ``t_hit``, started from the end of the
  preparation (or from the current desired state if there is no time to prepare);
- follow-through: a single DMP from ``(theta_hit, theta_dot_hit)`` to rest at
  ``q_hit + (T_ft / 2) q_dot_hit`` (the teacher's follow-through posture), then
- awaiting: a single DMP back to rest at the awaiting posture.

Continuity at stage boundaries. Every segment starts at the previous one's end position and
velocity (the DMP rollout takes ``y0`` and ``y_dot0``). Its start acceleration, however, is the
DMP's, ``eta f(1) / tau^2`` (Eq. 4 with ``z = 1``: the spring is off), not the previous segment's.
:func:`blend_start_acceleration` adds the quintic ``p(t)`` on ``[0, T_b]`` with ``p(0) = p'(0) =
0``, ``p''(0) = a_prev - a_dmp(0)`` and ``p = p' = p'' = 0`` at ``T_b`` (default ``min(0.1 s,
tau)``): the acceleration becomes continuous and the arrival state at ``tau`` is untouched. The
position change it causes is at most ``0.0092 |da| T_b^2`` (the quintic's peak), e.g. 0.5 mrad for
``da = 5 rad/s^2``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tt_drake.artefacts import ArtefactError, load_artefact, save_artefact
from tt_drake.crkr import CrKR
from tt_drake.dmp import HittingDMP, Trajectory
from tt_drake.errors import BadInputError
from tt_drake.imitation import Demonstration, imitate
from tt_drake.momp import MotorPrimitiveLibrary
from tt_drake.responsibility import ResponsibilityParams
from tt_drake.stages import (
    AWAITING,
    FOLLOW_THROUGH,
    HITTING,
    PREPARATION,
    JointLimits,
    Quintic,
    StagePlan,
    StageTimes,
    continue_past_end,
    follow_through_time,
    quintic_coefficients,
    return_duration,
)
from tt_drake.stimulus import PAPER_STIMULUS, stimulus_layout, stimulus_size

__all__ = ["SampledSegment", "StagePrimitive", "blend_start_acceleration", "MoMPStroke",
           "plan_momp_stroke", "BLEND_TIME", "LearnedArtefactError", "save_player_library",
           "load_player_library", "save_configuration_model", "load_configuration_model",
           "ConfigurationModel", "within_limits", "move_hitting_goal"]

BLEND_TIME = 0.1  # s
_TIMES = StageTimes()


class SampledSegment:
    """One quintic per interval of a uniformly sampled trajectory (exact q, q_dot, q_ddot at the
    samples, C2 in between); the same interface as :class:`tt_drake.stages.Quintic` (``t0``,
    ``duration``, ``t_end``, ``evaluate``, ``cut``, ``sample``).

    Evaluation is O(1): the interval index is ``floor((t - t0) / dt)``. Past the end it continues
    with the end velocity at zero acceleration, like ``Quintic``.
    """

    __slots__ = ("t0", "dt", "coeffs", "duration", "_n")

    def __init__(self, t0: float, dt: float, coeffs: np.ndarray, duration: float | None = None):
        self.t0, self.dt, self.coeffs = float(t0), float(dt), coeffs
        self._n = coeffs.shape[0]
        self.duration = self._n * self.dt if duration is None else float(duration)

    @classmethod
    def from_trajectory(cls, t0: float, traj: Trajectory) -> SampledSegment:
        """From a rollout on the uniform grid ``traj.t`` (starting at 0) shifted to start at t0."""
        t = np.asarray(traj.t, dtype=float)
        dt = float(t[1] - t[0])
        coeffs = np.ascontiguousarray(quintic_coefficients(
            traj.q[:-1], traj.qd[:-1], traj.qdd[:-1], traj.q[1:], traj.qd[1:], traj.qdd[1:], dt))
        return cls(t0, dt, coeffs, float(t[-1] - t[0]))

    @property
    def t_end(self) -> float:
        return self.t0 + self.duration

    def cut(self, t: float) -> SampledSegment:
        return SampledSegment(self.t0, self.dt, self.coeffs, min(self.duration, t - self.t0))

    def evaluate(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        s = min(max(t - self.t0, 0.0), self.duration)
        k = min(int(s / self.dt), self._n - 1)
        u = s - k * self.dt
        u2 = u * u
        u3 = u2 * u
        u4 = u3 * u
        # Powers of u and their first and second derivatives: one (D, 6) x (6, 3) product.
        powers = np.array(((1.0, 0.0, 0.0), (u, 1.0, 0.0), (u2, 2.0 * u, 2.0),
                           (u3, 3.0 * u2, 6.0 * u), (u4, 4.0 * u3, 12.0 * u2),
                           (u4 * u, 5.0 * u4, 20.0 * u3)))
        r = self.coeffs[k] @ powers
        q, v, a = r[:, 0], r[:, 1], r[:, 2]
        extra = t - self.t_end
        if extra > 0.0:
            q = q + v * extra
            a = np.zeros_like(a)
        return q, v, a

    def evaluate_many(self, times) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`evaluate` at every time of ``times`` (K,) at once: (q, q_dot, q_ddot), each
        (K, D)."""
        t = np.asarray(times, dtype=float)
        s = np.clip(t - self.t0, 0.0, self.duration)
        k = np.minimum((s / self.dt).astype(int), self._n - 1)
        u = s - k * self.dt
        u2 = u * u
        u3 = u2 * u
        u4 = u3 * u
        powers = np.empty((u.size, 6, 3))  # (K, 6, 3), the rows of ``evaluate``'s matrix
        powers[:, 0] = (1.0, 0.0, 0.0)
        powers[:, 1, 0], powers[:, 1, 1], powers[:, 1, 2] = u, 1.0, 0.0
        powers[:, 2, 0], powers[:, 2, 1], powers[:, 2, 2] = u2, 2.0 * u, 2.0
        powers[:, 3, 0], powers[:, 3, 1], powers[:, 3, 2] = u3, 3.0 * u2, 6.0 * u
        powers[:, 4, 0], powers[:, 4, 1], powers[:, 4, 2] = u4, 4.0 * u3, 12.0 * u2
        powers[:, 5, 0], powers[:, 5, 1], powers[:, 5, 2] = u4 * u, 5.0 * u4, 20.0 * u3
        r = self.coeffs[k] @ powers  # (K, D, 3)
        q, v, a = r[:, :, 0], r[:, :, 1], r[:, :, 2]
        return continue_past_end((t - self.t_end)[:, None], q, v, a)

    def knots(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q, q_dot, q_ddot) at the samples (interval starts), shape (K, D) each."""
        c = self.coeffs
        return c[:, :, 0], c[:, :, 1], 2.0 * c[:, :, 2]

    def end_state(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return self.evaluate(self.t_end)

    def sample(self, rate: float = 500.0) -> tuple[np.ndarray, ...]:
        n = max(2, int(round(self.duration * rate)) + 1)
        times = np.linspace(self.t0, self.t_end, n)
        q, v, a = zip(*(self.evaluate(t) for t in times), strict=True)
        return times, np.array(q), np.array(v), np.array(a)


def within_limits(plan: StagePlan, limits: JointLimits, rate: float = 200.0) -> bool:
    """Every segment of ``plan`` inside the joint position, velocity and acceleration limits (at
    the stored samples of a :class:`SampledSegment`, at ``rate`` Hz for other segments)."""
    for _, seg in plan.segments:
        q, qd, qdd = seg.knots() if isinstance(seg, SampledSegment) else seg.sample(rate)[1:]
        if (np.any(q < limits.lower) or np.any(q > limits.upper)
                or np.any(np.abs(qd) > limits.velocity)
                or (limits.acceleration is not None
                    and np.any(np.abs(qdd) > limits.acceleration))):
            return False
    return True


def blend_start_acceleration(traj: Trajectory, a0, blend_time: float = BLEND_TIME) -> Trajectory:
    """``traj`` plus the quintic correction that makes its start acceleration ``a0`` and leaves
    everything after ``min(blend_time, duration)`` unchanged (module docstring)."""
    a0 = np.asarray(a0, dtype=float)
    delta = a0 - traj.qdd[0]
    if not np.any(delta):
        return traj
    tb = min(blend_time, traj.duration)
    zero = np.zeros_like(delta)
    c = Quintic.fit(0.0, tb, zero, zero, delta, zero, zero, zero).coeffs  # (D, 6)
    k = np.flatnonzero(traj.t <= tb + 1e-12)
    powers = np.minimum(traj.t[k], tb)[:, None] ** np.arange(6)  # (m, 6): s^0 .. s^5
    q, qd, qdd = traj.q.copy(), traj.qd.copy(), traj.qdd.copy()
    q[k] += powers @ c.T
    qd[k] += (powers[:, :5] * np.arange(1, 6)) @ c[:, 1:].T
    qdd[k] += (powers[:, :4] * np.array([2.0, 6.0, 12.0, 20.0])) @ c[:, 2:].T
    return Trajectory(traj.t, q, qd, qdd)


@dataclass(frozen=True)
class StagePrimitive:
    """A single DMP for one stage (awaiting/return, preparation or follow-through), imitated from
    one demonstration (Eqs. 7-8): weights ``(D, B)`` and the demonstrated amplitude ``(D,)``."""

    weights: np.ndarray
    amplitude: np.ndarray
    tau: float  # the demonstration's duration (information only)

    @classmethod
    def imitate(cls, dmp: HittingDMP, demo: Demonstration) -> StagePrimitive:
        res = imitate(dmp, demo)
        return cls(res.weights, res.amplitude, res.tau)

    def rollout(self, dmp: HittingDMP, state, g_f, g_dot, tau: float,
                rate: float = 500.0) -> Trajectory:
        """Eqs. 1-5 from ``state = (q, q_dot, q_ddot)`` to ``(g_f, g_dot)`` in ``tau`` seconds,
        start acceleration blended to ``q_ddot``."""
        q, qd, qdd = state
        traj = dmp.rollout(self.weights, q, g_f, g_dot, tau, yd0=qd, amplitude=self.amplitude,
                           rate=rate)
        return blend_start_acceleration(traj, qdd)


@dataclass(frozen=True)
class MoMPStroke:
    """What one (re-)plan of the learned player used: the stimulus, the hitting configuration,
    and the primitives that carried the hitting stage with their mixture weights (Eq. 6)."""

    stimulus: np.ndarray  # x = (p_hit, v_hit)
    t_hit: float
    q_hit: np.ndarray
    qd_hit: np.ndarray
    primitives: np.ndarray  # indices into the library
    mixture: np.ndarray  # their normalised gating weights nu_i
    replans: int = 1
    # The MoMP plan left the joint or effort limits and the teacher's quintic stages were used
    # instead; ``primitives`` and ``mixture`` are then those of the mixture that failed.
    fallback: bool = False
    # The measured arm left the plan (``MoMPConfig.hold_error``): the stroke was abandoned and
    # the arm held (``MoMPTrajectorySource.hold_plan``).
    held: bool = False
    # The last move of the goal took the racket velocity without the spin's contact-point term
    # (``HittingConfiguration.theta_dot_hit_spinless``): the spin-aware one was refused.
    spinless: bool = False
    # The stroke is another of the teacher's strokes for the prediction (``MoMPConfig.
    # stroke_fallbacks``: less of the spin compensated, or the ball off the blade's centre):
    # (theta_hit, theta_dot_hit) the hitting configuration gave, which was refused; ``q_hit``,
    # ``qd_hit`` are the played stroke's. None: the played goal is the configuration's.
    configuration: tuple | None = None


def plan_momp_stroke(now: float, state, stimulus, t_hit: float, q_hit, qd_hit,
                     library: MotorPrimitiveLibrary, stages: dict, q_await,
                     limits: JointLimits, times: StageTimes = _TIMES,
                     preparing: bool = False, rate: float = 500.0,
                     hitting: float | None = None, prepare: bool = True
                     ) -> tuple[StagePlan, np.ndarray, np.ndarray]:
    """The stroke from the current desired ``state = (q, q_dot, q_ddot)`` at ``now``: returns the
    plan and the hitting stage's primitives (indices, weights).

    ``stages`` maps PREPARATION, FOLLOW_THROUGH and AWAITING to :class:`StagePrimitive`. Timing as
    the teacher's (:func:`tt_drake.stages.plan_stroke`): the hitting stage lasts ``hitting``
    (default ``times.hitting``) and ends at ``t_hit``. With ``prepare`` the preparation DMP runs
    first and needs ``times.min_preparation`` or the move time to ``q_prep`` (``times.min_replan``
    for an ongoing preparation), else ValueError; without, the hitting stage starts now and lasts
    until ``t_hit``. The caller (:class:`tt_drake.systems.momp_player.MoMPTrajectorySource`) tries
    shorter hitting stages, then no preparation, until the plan stays within the joint limits.
    """
    dmp = library.dmp
    q, qd, qdd = (np.asarray(x, dtype=float) for x in state)
    q_hit, qd_hit = np.asarray(q_hit, dtype=float), np.asarray(qd_hit, dtype=float)
    zero = np.zeros_like(q)
    if t_hit - now <= 1e-2:
        raise ValueError(f"no time left to hit: t_hit {t_hit:.3f} s, now {now:.3f} s")
    segments: list = []
    t_hitting = times.hitting if hitting is None else float(hitting)
    t_start_hit = t_hit - t_hitting
    q_prep = limits.clip(q_hit - 0.5 * t_hitting * qd_hit)
    lead = times.min_replan if preparing else max(times.min_preparation,
                                                   limits.move_time(q, q_prep))
    if prepare and t_start_hit - now < lead:
        raise ValueError(f"no time to prepare a {t_hitting:.2f} s hitting stage")
    if prepare:
        prep = stages[PREPARATION].rollout(dmp, (q, qd, qdd), q_prep, zero, t_start_hit - now,
                                           rate)
        segments.append((PREPARATION, SampledSegment.from_trajectory(now, prep)))
        start, t0 = segments[-1][1].end_state(), t_start_hit
    else:
        start, t0 = (q, qd, qdd), now
    idx, nu = library.active(stimulus)
    hit = library.plan(stimulus, start[0], q_hit, qd_hit, t_hit - t0, yd0=start[1], rate=rate)
    hit = blend_start_acceleration(hit, start[2])
    segments.append((HITTING, SampledSegment.from_trajectory(t0, hit)))
    _finish_stroke(segments, t_hit, dmp, stages, q_await, limits, times, rate)
    return StagePlan(segments), idx, nu


def _finish_stroke(segments: list, t_hit: float, dmp: HittingDMP, stages: dict, q_await,
                   limits: JointLimits, times: StageTimes, rate: float) -> None:
    """Append the follow-through and awaiting DMPs after the hitting segment ``segments[-1]``."""
    end = segments[-1][1].end_state()
    zero = np.zeros_like(end[0])
    t_follow = follow_through_time(end[0], end[1], limits, times)
    q_end = limits.clip(end[0] + 0.5 * t_follow * end[1])
    follow = stages[FOLLOW_THROUGH].rollout(dmp, end, q_end, zero, t_follow, rate)
    segments.append((FOLLOW_THROUGH, SampledSegment.from_trajectory(t_hit, follow)))
    end = segments[-1][1].end_state()
    back = stages[AWAITING].rollout(dmp, end, np.asarray(q_await, dtype=float), zero,
                                    return_duration(end[0], q_await, limits, times), rate)
    segments.append((AWAITING, SampledSegment.from_trajectory(segments[-1][1].t_end, back)))


def move_hitting_goal(now: float, plan: StagePlan, stimulus, t_hit: float, q_hit, qd_hit,
                      library: MotorPrimitiveLibrary, stages: dict, q_await,
                      limits: JointLimits, times: StageTimes = _TIMES, rate: float = 500.0
                      ) -> tuple[StagePlan, np.ndarray, np.ndarray]:
    """The hitting stage of ``plan`` (under way at ``now``) with its goal moved to the new
    hitting configuration ``(q_hit, qd_hit)`` at ``t_hit``: the hitting DMP's moving goal
    (Eq. 4: ``g_f``, ``g_dot`` and the duration are the supervisor's latest, section III-C).

    The mixture (Eq. 6) for the new ``stimulus`` is rolled out from the hitting stage's start
    state at its start ``t0`` (the phase keeps running from there) to the new goal. At ``now`` it
    differs from the plan being executed by ``(dq, dq_dot, dq_ddot)``; the quintic with those
    values at ``now`` and zero position, velocity and acceleration at ``t_hit`` is added to it
    from ``now`` on, so the desired motion stays C2 and arrives exactly at the new goal. The
    part executed before ``now`` is kept; the follow-through and awaiting DMPs follow as in
    :func:`plan_momp_stroke`. Returns (plan, primitive indices, mixture weights); ValueError if
    the plan has no hitting stage under way or ``t_hit`` is not after ``now``.
    """
    hit = next((seg for stage, seg in plan.segments if stage == HITTING), None)
    if hit is None or not hit.t0 <= now:
        raise ValueError("no hitting stage under way")
    if t_hit - now <= 1e-2:
        raise ValueError(f"no time left to move the goal: t_hit {t_hit:.3f} s, now {now:.3f} s")
    q0, qd0, qdd0 = hit.evaluate(hit.t0)
    idx, nu = library.active(stimulus)
    rollout = library.plan(stimulus, q0, np.asarray(q_hit, dtype=float),
                           np.asarray(qd_hit, dtype=float), t_hit - hit.t0, yd0=qd0, rate=rate)
    moved = SampledSegment.from_trajectory(hit.t0, blend_start_acceleration(rollout, qdd0))
    old, new = plan.evaluate(now), moved.evaluate(now)
    span = t_hit - now
    n = max(2, int(math.ceil(span * rate)))
    s = np.linspace(0.0, span, n + 1)
    q, qd, qdd = moved.evaluate_many(now + s)
    zero = np.zeros_like(q0)
    c = quintic_coefficients(old[0] - new[0], old[1] - new[1], old[2] - new[2], zero, zero,
                             zero, span)  # (D, 6)
    powers = s[:, None] ** np.arange(6)
    q = q + powers @ c.T
    qd = qd + (powers[:, :5] * np.arange(1, 6)) @ c[:, 1:].T
    qdd = qdd + (powers[:, :4] * np.array([2.0, 6.0, 12.0, 20.0])) @ c[:, 2:].T
    segments = plan.truncated(now).segments
    segments.append((HITTING, SampledSegment.from_trajectory(now, Trajectory(s, q, qd, qdd))))
    _finish_stroke(segments, t_hit, library.dmp, stages, q_await, limits, times, rate)
    return StagePlan(segments), idx, nu


# ---------------------------------------------------------------------- artefacts
LIBRARY_FILE_KIND = "momp-player-library"
CRKR_FILE_KIND = "crkr-hitting-configuration"
LEARNED_FORMAT_VERSION = 1
_STAGE_KEYS = {PREPARATION: "preparation", FOLLOW_THROUGH: "follow_through",
               AWAITING: "awaiting"}


class LearnedArtefactError(ArtefactError, BadInputError):
    """A learned-player artefact that is missing, corrupt, or trained for another scenario."""


# The physical range of each array of a primitive library, (low, high), checked at load (finite
# values alone let an all-1e300 library through, which overflows in the first roll-out):
# amplitudes are joint-angle differences of a demonstration (less than a turn); stage durations
# at most 10 s (an episode lasts a few); the forcing weights act in normalised time, a
# weight w asks ~w / tau^2 rad/s^2 of the arm, and 1e5 is far past any joint's reach at any
# stage's tau (the WAM's joints reach hundreds of rad/s^2); stimuli are positions (m),
# velocities (m/s) and spins (rad/s) of the ball; responsibilities gamma lie in [0, 1]; the
# bandwidths are kernel widths in the stimulus' units, and s, n sums of rewards and counts.
LIBRARY_RANGES = {
    "weights": (-1e5, 1e5), "amplitude": (-2 * math.pi, 2 * math.pi),
    "stimuli": (-1e4, 1e4), "bandwidths": (0.0, 1e4), "gamma": (0.0, 1.0),
    "s": (0.0, 1e9), "n": (0.0, 1e9),
    **{f"{key}_{name}": bounds for key in ("preparation", "follow_through", "awaiting")
       for name, bounds in (("weights", (-1e5, 1e5)), ("amplitude", (-2 * math.pi, 2 * math.pi)),
                            ("tau", (1e-3, 10.0)))}}


def _check_ranges(path, arrays: dict, ranges: dict) -> None:
    """Raise LearnedArtefactError naming the first array with a value outside its range."""
    for name, (low, high) in ranges.items():
        a = arrays.get(name)
        if a is not None and a.size and not (a.min() >= low and a.max() <= high):
            raise LearnedArtefactError(f"{path}: array {name!r} holds values outside its "
                                       f"physical range [{low:g}, {high:g}] (min {a.min():g}, "
                                       f"max {a.max():g})")


def _check_meta(path, meta: dict, scenario: str | None, hitting_y: float | None) -> None:
    version = meta.get("learned_format_version")
    if version != LEARNED_FORMAT_VERSION:
        raise LearnedArtefactError(f"{path}: learned-player format version {version!r} is not "
                                   f"supported (reads {LEARNED_FORMAT_VERSION})")
    if scenario is not None and meta.get("scenario") != scenario:
        raise LearnedArtefactError(f"{path}: trained for scenario {meta.get('scenario')!r}, "
                                   f"not {scenario!r}; train it again on this scenario's data")
    if hitting_y is not None and not abs(float(meta.get("hitting_y", np.nan)) - hitting_y) < 1e-9:
        raise LearnedArtefactError(f"{path}: trained for the hitting plane y = "
                                   f"{meta.get('hitting_y')}, not {hitting_y}")


def _stimulus_from_meta(meta: dict, size: int) -> tuple[str, ...]:
    """The stimulus layout an artefact records (:mod:`tt_drake.stimulus`; none recorded: the
    paper's 6-D ``p_hit, v_hit``), checked against the ``size`` of its stored stimuli."""
    layout = stimulus_layout(meta.get("stimulus", list(PAPER_STIMULUS)))
    if stimulus_size(layout) != size:
        raise ValueError(f"its stimulus layout {', '.join(layout)} has {stimulus_size(layout)} "
                         f"values, its stimuli {size}")
    return layout


def save_player_library(path, library: MotorPrimitiveLibrary, stages: dict, meta: dict) -> None:
    """The hitting library (Eq. 6) and the three stage DMPs in one artefact, with ``meta``
    (scenario name, hitting-plane y, training data), the stimulus layout (the library's, else the
    paper's 6-D one) and a format version."""
    arrays = {"weights": library.weights, "amplitude": library.amplitude,
              "stimuli": library.stimuli, "bandwidths": library.bandwidths,
              "gamma": library.gamma, "s": library.s, "n": library.n}
    for stage, key in _STAGE_KEYS.items():
        arrays[f"{key}_weights"] = stages[stage].weights
        arrays[f"{key}_amplitude"] = stages[stage].amplitude
        arrays[f"{key}_tau"] = np.array(stages[stage].tau)
    doc = {**meta, "learned_format_version": LEARNED_FORMAT_VERSION, "dmp": library.dmp.to_dict(),
           "responsibility": library.responsibility.to_dict(), "min_weight": library.min_weight,
           "stimulus": list(library.stimulus_layout or PAPER_STIMULUS)}
    save_artefact(path, LIBRARY_FILE_KIND, arrays, doc)


def load_player_library(path, scenario: str | None = None, hitting_y: float | None = None
                        ) -> tuple[MotorPrimitiveLibrary, dict, dict]:
    """(library, stage primitives, meta); :class:`LearnedArtefactError` if the file is missing,
    corrupt, of another version, or trained for another scenario or hitting plane."""
    try:
        arrays, meta = load_artefact(path, LIBRARY_FILE_KIND)
    except LearnedArtefactError:
        raise
    except ArtefactError as err:
        raise LearnedArtefactError(f"primitive library: {err}") from None
    _check_meta(path, meta, scenario, hitting_y)
    _check_ranges(path, arrays, LIBRARY_RANGES)
    try:
        dmp = HittingDMP.from_dict(meta["dmp"])
        library = MotorPrimitiveLibrary(
            dmp, arrays["weights"], arrays["amplitude"], arrays["stimuli"], arrays["bandwidths"],
            gamma=arrays["gamma"], s=arrays["s"], n=arrays["n"],
            responsibility=ResponsibilityParams(**meta["responsibility"]),
            min_weight=float(meta["min_weight"]),
            stimulus_layout=_stimulus_from_meta(meta, arrays["stimuli"].shape[-1]))
        stages = {stage: StagePrimitive(arrays[f"{key}_weights"], arrays[f"{key}_amplitude"],
                                        float(arrays[f"{key}_tau"]))
                  for stage, key in _STAGE_KEYS.items()}
        for prim in stages.values():
            if prim.weights.shape != library.weights.shape[1:]:
                raise ValueError("stage DMP weights do not match the library's")
            if prim.amplitude.shape != library.amplitude.shape[1:]:
                raise ValueError("stage DMP amplitudes do not match the library's")
    except (KeyError, TypeError, ValueError) as exc:
        raise LearnedArtefactError(f"{path}: inconsistent primitive library ({exc})") from None
    return library, stages, meta


@dataclass
class ConfigurationModel:
    """The CrKR hitting-configuration map (section II-C.2) around a constant prior mean:
    ``[theta_hit, theta_dot_hit](s) = y_mean + k(s)^T (K + lambda C)^-1 (Y - y_mean)``.

    The prior mean (the training targets' mean) is this project's addition: without it the
    Gaussian-kernel mean falls to zero (joint angles of 0 rad) between sparse samples."""

    crkr: CrKR
    y_mean: np.ndarray
    # The parts of s (tt_drake.stimulus); the paper's (p_hit, v_hit) unless trained otherwise.
    stimulus: tuple[str, ...] = PAPER_STIMULUS

    @classmethod
    def fit(cls, x, y, costs, bandwidths, lam: float, stimulus=PAPER_STIMULUS
            ) -> ConfigurationModel:
        y = np.asarray(y, dtype=float)
        mean = y.mean(axis=0)
        layout = stimulus_layout(stimulus)
        if np.shape(x)[-1] != stimulus_size(layout):
            raise ValueError(f"stimuli of {np.shape(x)[-1]} values for the layout "
                             f"{', '.join(layout)} ({stimulus_size(layout)})")
        return cls(CrKR(bandwidths, lam).fit(x, y - mean, costs), mean, layout)

    def predict(self, s, variance: bool = True) -> tuple[np.ndarray, np.ndarray, float]:
        """(theta_hit (7), theta_dot_hit (7), variance sigma^2(s)) for one stimulus (of the
        model's layout; ValueError for another size). Without ``variance`` (NaN then) only the
        mean is computed: O(n) instead of O(n^2)."""
        x = np.asarray(s, dtype=float).reshape(1, -1)
        if x.shape[1] != self.crkr.x.shape[1]:
            raise ValueError(f"stimulus of {x.shape[1]} values for a CrKR model of "
                             f"{self.crkr.x.shape[1]} ({', '.join(self.stimulus)})")
        if variance:
            mean, var = self.crkr.predict(x)
            var = float(var[0])
        else:
            mean, var = self.crkr.predict(x, return_var=False), math.nan
        y = mean[0] + self.y_mean
        return y[:7], y[7:], var


def save_configuration_model(path, model: ConfigurationModel, meta: dict) -> None:
    """The CrKR map stimulus -> (theta_hit, theta_dot_hit) with ``meta`` (scenario, hitting-plane
    y, comfort posture, inputs) and a format version."""
    y_mean, layout, model = model.y_mean, model.stimulus, model.crkr
    # The training pairs only (O(n) numbers): the O(n^2) Cholesky factor is recomputed on load
    # (about a second for 2,500 pairs), which keeps the shipped model small.
    arrays = {"x": model.x, "y": model.y, "costs": model.costs, "bandwidths": model.bandwidths,
              "y_mean": y_mean}
    doc = {**meta, "learned_format_version": LEARNED_FORMAT_VERSION, "lam": model.lam,
           "n_samples": model.n_samples, "stimulus": list(layout)}
    save_artefact(path, CRKR_FILE_KIND, arrays, doc)


def load_configuration_model(path, scenario: str | None = None, hitting_y: float | None = None
                             ) -> tuple[ConfigurationModel, dict]:
    """(model, meta); :class:`LearnedArtefactError` on any problem (see
    :func:`load_player_library`)."""
    try:
        arrays, meta = load_artefact(path, CRKR_FILE_KIND)
    except ArtefactError as err:
        raise LearnedArtefactError(f"CrKR model: {err}") from None
    _check_meta(path, meta, scenario, hitting_y)
    try:
        model = CrKR(arrays["bandwidths"], float(meta["lam"]))
        x, y, c = model.check_samples(arrays["x"], arrays["y"], arrays["costs"])
        if y.shape[1] != 14 or arrays["y_mean"].shape != (14,):
            raise ValueError("expected 14 outputs (theta_hit, theta_dot_hit)")
        layout = _stimulus_from_meta(meta, x.shape[1])
        model.fit(x, y, c)
    except (KeyError, TypeError, ValueError, np.linalg.LinAlgError) as exc:
        raise LearnedArtefactError(f"{path}: inconsistent CrKR model ({exc})") from None
    return ConfigurationModel(model, arrays["y_mean"], layout), meta
