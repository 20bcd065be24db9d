"""MoMPTrajectorySource LeafSystem: the learned player's stage machine (paper sections III-A, C).

At the first planning tick (250 Hz) after the predictor publishes a new prediction, until the
hitting stage has begun, it reads the predicted stimulus x = (p_hit, v_hit), the hitting time
t_hit and the hitting configuration (theta_hit, theta_dot_hit) and, when they are new (the hitting
point moved more than ``replan_position`` or t_hit more than ``replan_time``, or theta changed),
re-plans the stroke from the current desired state with
:func:`tt_drake.learned_player.plan_momp_stroke`:

- preparation: the preparation DMP to ``q_prep = theta_hit - (T_hit / 2) theta_dot_hit``;
- hitting: the mixture of motor primitives ``pi(x) = sum_i gamma_i k(x - x_i) pi_i / sum_i gamma_i
  k(x - x_i)`` (Eq. 6, Algorithm 1) with ``g_f = theta_hit``, ``g_dot = theta_dot_hit`` and
  ``tau`` = the time to t_hit (Eqs. 1-5), so the arm arrives at (theta_hit, theta_dot_hit) at t_hit;
- follow-through and the return to the awaiting posture: their stage DMPs.

The hitting stage lasts 0.4 s after a preparation if there is time for both; with a late
prediction, shorter hitting stages (down to 0.15 s) still after a preparation, and last a
hitting stage from the current state until t_hit, are tried in turn; the first plan inside the
joint position, velocity (10 rad/s) and acceleration (200 rad/s^2) limits, and (with an ``arm``)
within ``torque_fraction`` of the effort limits by inverse dynamics, is executed. A hitting DMP
started far from where the demonstrations started (they start at rest at q_prep) is the usual
offender. (DMP amplitude scaling, ``eta = (g_f - y0) / A``, mirrors or amplifies the demonstrated
shape.) If none is inside the limits the player keeps its previous plan if it has one, and
otherwise falls back to the teacher's quintic stages (:func:`tt_drake.stages.plan_stroke`) to the
same hitting configuration; ``MoMPStroke.fallback`` records it. With ``correction_fallback`` a
re-plan refused while a previous plan exists takes the teacher's fallbacks of a refused move
(below) instead of keeping that plan.

With the moving goal (``goal_cutoff``) the hitting stage's goal follows new predictions until the
cut-off (:func:`tt_drake.learned_player.move_hitting_goal`); a refused move is tried again at
the next planning tick (with ``retry_period``: only once the prediction or configuration moved
past the re-planning thresholds, or that long after the refusal). When the hitting
configuration also gives ``theta_dot_hit_spinless`` (the teacher's IK with the predicted spin:
the racket without the spinning contact point's tangential term), a plan or move that does not
fit the limits with ``theta_dot_hit`` is tried with those velocities (``MoMPStroke.spinless``);
after such a move the stroke keeps to them until the hit. With ``stroke_fallbacks`` a move
refused even as the teacher's quintic correction (``correction_fallback``) is made as the
teacher's correction to another of its strokes for the prediction (the configuration's
``fallback_strokes``: less of the spin compensated, the ball off the blade's centre), and
those strokes replace the spinless racket in moves. Safety: with the measured arm
state connected (``arm_state``), a joint faster than ``hold_speed`` times its velocity limit or
more than ``hold_error`` from the plan (the arm no longer follows it: a saturated joint under
the inverse-dynamics controller) ends the stroke: the player plays
:meth:`MoMPTrajectorySource.hold_plan` from the measured state (``MoMPStroke.held``).

Without a library (``library=None``: the ``crkr`` player of paper section III-B.2) every plan is
the teacher's quintic stages to the hitting configuration: the learned configuration on its own.

Each stage is sampled once per plan at 500 Hz into one quintic per interval
(:class:`tt_drake.learned_player.SampledSegment`); the output ports evaluate it in O(1).

The stimulus is the library's layout (:mod:`tt_drake.stimulus`, recorded in its artefact): the
paper's x = (p_hit, v_hit), or with the predicted spin at impact appended (``spin_hit``).

Ports: inputs ``p_hit`` (3), ``v_hit`` (3), ``t_hit`` (1, absolute) and ``spin_hit`` (3, needed
only by a stimulus with spin) from the HittingPointPredictor, ``theta_hit`` (7),
``theta_dot_hit`` (7), ``configuration_valid`` (1) and ``theta_dot_hit_spinless`` (7, optional:
tried when a move of the goal is refused) and ``fallback_strokes`` (abstract, optional: the
teacher's other strokes) from HittingConfiguration, ``arm_state``
(14: measured q, q_dot; optional, for the hold); outputs
``desired_state`` (14: q, q_dot) and ``desired_acceleration`` (7) for the
InverseDynamicsController, ``stage`` (1: index into :data:`tt_drake.stages.STAGES`),
``predicted_hit`` (4: p_hit and a valid flag, for drawing) and ``stroke`` (the
:class:`tt_drake.learned_player.MoMPStroke`: which primitives carried the hitting stage, with their
mixture weights).
"""

import math
from dataclasses import dataclass, replace

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import EventStatus

from tt_drake import wam_params as wp
from tt_drake.drives import EffortBudget, drive_envelope, joint_limits
from tt_drake.learned_player import (
    MoMPStroke,
    move_hitting_goal,
    plan_momp_stroke,
    within_limits,
)
from tt_drake.momp import MotorPrimitiveLibrary
from tt_drake.stages import (
    AWAITING,
    HITTING,
    PREPARATION,
    Quintic,
    StagePlan,
    StageTimes,
    correction_stages,
    plan_stroke,
    within_effort,
)
from tt_drake.stimulus import PAPER_STIMULUS, compose_stimulus, stimulus_layout, stimulus_size
from tt_drake.systems.hitting_configuration import FallbackStrokes
from tt_drake.systems.immutable import Immutable
from tt_drake.systems.stage_player import PlanTable, StagePlanPlayer, remaining

# A planning tick that finds nothing new (committed, no valid configuration, a prediction already
# acted on) changes no state: "did nothing" tells the simulator not to write the state back, so
# the caches of everything downstream (the set-points) stay valid.
_NOTHING = EventStatus.DidNothing()

# The moving goal's cut-off (s before the hit) when the scenario turns it on: the teacher's.
MOVING_GOAL_CUTOFF = 0.08
# The effort budget of the player with the moving goal (a multiple of the effort limits; the
# paper profile's player keeps MoMPConfig.torque_fraction = 1.5). docs/learned_player.md,
# "Serve 135": with the hard set of 0.1.0, a moved goal asking the shoulder 1.0-1.42x its limit
# for 0.12 s at 9 rad/s made the inverse-dynamics controller diverge (202 rad/s); with 1.2x the
# same serve was returned without saturating.
MOVING_GOAL_TORQUE_FRACTION = 1.2


def arm_follows(x: np.ndarray, q: np.ndarray, velocity: np.ndarray, hold_speed: float,
                hold_error: float) -> bool:
    """Whether the measured arm ``x = (q_m, q_dot_m)`` (2n values) follows the plan's positions
    ``q`` (n): for every joint j, |q_dot_m,j| <= ``hold_speed`` v_max,j (``velocity``) and
    |q_m,j - q_j| <= ``hold_error``; a NaN fails. The planning tick's safety check
    (:meth:`MoMPTrajectorySource._hold_if_lost`), on Python floats: each product and comparison
    is the one numpy's array expressions make, so the verdict is theirs, without the temporary
    arrays they build at every tick (docs/performance.md, "The players' Python")."""
    x, q, velocity = x.tolist(), q.tolist(), velocity.tolist()
    n = len(q)
    for j in range(n):
        if not abs(x[n + j]) <= hold_speed * velocity[j]:
            return False
    for j in range(n):
        if not abs(x[j] - q[j]) <= hold_error:
            return False
    return True


@dataclass(frozen=True)
class MoMPConfig:
    replan_position: float = 0.003  # m
    replan_time: float = 0.002  # s
    replan_configuration: float = 1e-3  # rad (or rad/s)
    min_time_to_hit: float = 0.05  # s: closer than this to t_hit no (re-)plan starts
    # Hitting-stage durations tried in turn (with a preparation before), then none (hit from
    # the current state until t_hit): the first plan inside the joint limits is executed.
    hitting_durations: tuple = (0.4, 0.35, 0.3, 0.25, 0.2, 0.15)
    # A preparation may be as short as 0.1 s (or the move time): every plan is checked against
    # the limits anyway. With the teacher's 0.25 s, fast serves (0.3-0.45 s between the first
    # prediction and the hit) left only the hitting DMP from the awaiting posture, which the
    # amplitude factor stretches to 220-380 rad/s^2: 23 % of the strokes of 1,000 serves fell
    # back to the teacher's quintics; with this, 7 of 10 such serves were carried by the MoMP.
    times: StageTimes = StageTimes(min_preparation=0.1)
    # With an ``arm`` (inverse dynamics), a plan must also ask for at most this multiple of every
    # actuator's effort limit. Plans inside the kinematic limits can still ask far more of the
    # shoulder; the saturated arm then lags and, in 1 of 1,000 serves, spun a joint 7.6 rad past
    # its limit. On 200 serves: no check 200/200 returned by the primitives, 45 of 1,000 episodes
    # above 10 rad/s; 1.5x: 199/200, peak 7.8 rad/s; 0.9x (the teacher's budget): 186/200 -
    # re-plans near the hit are refused and the stroke keeps aiming at an earlier prediction.
    torque_fraction: float = 1.5
    # The drives' supply voltage (V, tt_drake.drives): the check then also asks for at most
    # ``supply_fraction`` of the supply at each joint speed, and each joint stays within that
    # share of its no-load speed; 0: ideal drives.
    drive_voltage: float = 0.0
    # None: ``torque_fraction``. The effort budget bounds the current a plan asks for, this the
    # voltage: a plan asking somewhat more than the supply gives at a joint's speed is followed
    # with a short lag (:data:`tt_drake.drives.SUPPLY_FRACTION`, the teacher's share).
    supply_fraction: float | None = None
    # The hitting DMP's moving goal (Eq. 4, section III-C): with a value, the hitting stage is
    # not committed at its start; each new prediction (the predictor's refreshed, spin-aware one
    # after the robot-side bounce) moves its goal (theta_hit, theta_dot_hit, t_hit) until this
    # long before the hit (s), as the teacher's corrections stop 80 ms before it
    # (:func:`tt_drake.learned_player.move_hitting_goal`). None: the paper profile's player,
    # committed at the swing start.
    goal_cutoff: float | None = None
    # With a value (s), a move of the goal refused by the limits is tried again only when the
    # prediction or the configuration has moved past the re-planning thresholds since the
    # refusal, or this long after it. None (the default): at every planning tick. 0.02 s cut a
    # third of the tries on 60 real-test serves but, with the 1.2x budget, lost one return
    # (docs/learned_player.md, "Refused moves").
    retry_period: float | None = None
    # Safety (needs the ``arm_state`` input): when a measured joint is faster than
    # ``hold_speed`` times its velocity limit (no plan asks for more than the limit) or farther
    # than ``hold_error`` (rad) from the plan, the stroke is abandoned and the arm holds: a
    # quintic from the measured state to rest, then back to the awaiting posture
    # (``MoMPStroke.held``). Returned strokes lag by up to 0.26 rad (the wrist, real-test serve
    # 15 of seed 13); the diverging arm of serve 135 passed 15 rad/s 50 ms before 1 rad of
    # error. None: off.
    hold_error: float | None = 0.6
    hold_speed: float = 1.5
    # A move of the goal that the limits refuse (every goal velocity tried), or a re-plan before
    # the hitting stage whose primitive plans they refuse, is made as the teacher's correction
    # instead: the quintic stages from the current desired state to the new hitting
    # configuration (:func:`tt_drake.stages.correction_stages`), if those fit the limits
    # (``MoMPStroke.fallback``). The robot-side bounce shows a spinning ball's spin, and the
    # prediction can then move by 10-30 cm with 0.2-0.4 s to go, further than the rolled-out
    # hitting DMP (moved, or planned anew with a short hitting stage) can follow within the
    # stock drives. False: the stroke keeps its goal, or its plan.
    correction_fallback: bool = False
    # With ``correction_fallback``: when that correction too is refused, the teacher's other
    # strokes for the prediction (the ``fallback_strokes`` input: less of the spin compensated,
    # the ball met off the blade's centre, as the teacher's own refused corrections try them)
    # are made the same way, the first that fits the limits being played (``MoMPStroke.
    # configuration``). The stock base joint often cannot turn the committed stroke to a
    # bounce-moved hitting point, while a stroke nearer the shoulder or tilted less can still
    # meet the ball. These strokes take the place of the spinless racket in a refused move
    # (``theta_dot_hit_spinless`` is then tried for a first plan only): a stroke compensating
    # less of the spin is aimed for that spin, while the spinless racket keeps the full
    # compensation's aim and sent its returns long or wide (docs/learned_player.md, "On the
    # stock robot").
    stroke_fallbacks: bool = False

    def __post_init__(self):
        for name in ("torque_fraction", "supply_fraction"):
            value = getattr(self, name)
            if value is not None and not 0.0 < value < math.inf:
                raise ValueError(f"MoMPConfig.{name} must be a number > 0 (got {value})")

    @property
    def supply_share(self) -> float:
        """The share of the drives' supply a plan may ask for: ``supply_fraction``, or
        ``torque_fraction`` when that is None."""
        return self.torque_fraction if self.supply_fraction is None else self.supply_fraction


def momp_config(moving_goal: bool = False, drive_voltage: float = 0.0,
                correction_fallback: bool = False, stroke_fallbacks: bool = False,
                supply_fraction: float | None = None) -> MoMPConfig:
    """The player of the paper profile, or with the hitting DMP's moving goal (the hard
    protocol's: cut-off :data:`MOVING_GOAL_CUTOFF`, effort budget
    :data:`MOVING_GOAL_TORQUE_FRACTION`, and ``correction_fallback``, ``stroke_fallbacks`` for
    a refused move); its effort check knows drives of ``drive_voltage`` (0: ideal), of whose
    supply its plans may ask ``supply_fraction`` (None: the effort budget's multiple)."""
    if not moving_goal:
        return MoMPConfig(drive_voltage=drive_voltage, supply_fraction=supply_fraction)
    return MoMPConfig(goal_cutoff=MOVING_GOAL_CUTOFF,
                      torque_fraction=MOVING_GOAL_TORQUE_FRACTION, drive_voltage=drive_voltage,
                      supply_fraction=supply_fraction, correction_fallback=correction_fallback,
                      stroke_fallbacks=stroke_fallbacks)


class _State(Immutable):
    """``seen``: the prediction (t_hit, p_hit) last acted on; the player does nothing more until
    the predictor publishes another. ``refused``: the last refused move of the goal (time,
    p_hit, t_hit, theta_hit, theta_dot_hit), None after an accepted one. ``spinless_move``: a
    move of the goal during the hitting stage took the spinless velocities; the stroke keeps to
    them until the hit."""

    __slots__ = ("plan", "stroke", "committed", "seen", "refused", "spinless_move")

    def __init__(self, plan: StagePlan, stroke: MoMPStroke | None = None,
                 committed: bool = False, seen: tuple | None = None,
                 refused: tuple | None = None, spinless_move: bool = False):
        self.plan, self.stroke, self.committed, self.seen = plan, stroke, committed, seen
        self.refused, self.spinless_move = refused, spinless_move


class MoMPTrajectorySource(StagePlanPlayer):
    def __init__(self, library: MotorPrimitiveLibrary | None, stages: dict | None,
                 config: MoMPConfig | None = None, rate: float = wp.PLANNING_RATE, q_await=None,
                 arm=None, setpoint_lead: float = 0.0, stimulus=None, play_again: bool = False,
                 setpoint_period: float | None = None):
        """``play_again`` (the rally): after the planned hit, once the predictor has dropped its
        prediction (it saw the ball fly away: ``HittingPointPredictor.play_again``), the
        player is free again for the next ball, as ``AnalyticalPlayer.play_again``.
        ``setpoint_lead``, ``setpoint_period``: :class:`StagePlanPlayer`."""
        super().__init__(setpoint_lead, setpoint_period)
        self.play_again = play_again
        # The stimulus layout: the library's if it names one; else ``stimulus`` (for the crkr
        # player the configuration model's, so that its strokes can train it), else the paper's.
        named = None if library is None else library.stimulus_layout
        self.stimulus = stimulus_layout(named or stimulus or PAPER_STIMULUS)
        if library is not None and stimulus_size(self.stimulus) != library.stimuli.shape[1]:
            raise ValueError(f"stimulus layout {', '.join(self.stimulus)} for a library whose "
                             f"stimuli have {library.stimuli.shape[1]} values")
        self.library, self.stages, self.arm = library, stages, arm
        self.config = config or MoMPConfig()
        drive = drive_envelope(self.config.drive_voltage)
        self.limits = joint_limits(drive, self.config.supply_share)
        self.effort_budget = EffortBudget(self.config.torque_fraction, drive,
                                          self.config.supply_share)
        self.q_await = np.asarray(wp.AWAITING if q_await is None else q_await, dtype=float)
        self._p = self.DeclareVectorInputPort("p_hit", 3)
        self._v = self.DeclareVectorInputPort("v_hit", 3)
        self._t = self.DeclareVectorInputPort("t_hit", 1)
        self._q_hit = self.DeclareVectorInputPort("theta_hit", 7)
        self._qd_hit = self.DeclareVectorInputPort("theta_dot_hit", 7)
        self._valid = self.DeclareVectorInputPort("configuration_valid", 1)
        self._spin = self.DeclareVectorInputPort("spin_hit", 3)
        # Optional: the goal's velocities without the spin's contact-point term
        # (HittingConfiguration.theta_dot_hit_spinless), tried when a move of the goal is refused.
        self._qd_spinless = self.DeclareVectorInputPort("theta_dot_hit_spinless", 7)
        # Optional: the teacher's other strokes for the prediction (HittingConfiguration's
        # ``fallback_strokes``), read only when a move and its correction are refused.
        self._fallback_strokes = self.DeclareAbstractInputPort(
            "fallback_strokes", AbstractValue.Make(FallbackStrokes()))
        # The measured arm state (q, q_dot), for the hold (MoMPConfig.hold_error); optional.
        self._arm_state = self.DeclareVectorInputPort("arm_state", 14)
        self._index = self.DeclareAbstractState(AbstractValue.Make(_State(self.awaiting_plan())))
        # The plan's positions at the planning ticks, for the hold's check (one table per plan).
        self._planned = PlanTable(1.0 / rate)
        # On the planning ticks: a new prediction is acted on at the first tick after it.
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / rate, 0.0, self._update)
        self.DeclareForcedUnrestrictedUpdateEvent(self._update)

    def awaiting_plan(self, t: float = 0.0) -> StagePlan:
        zero = np.zeros(7)
        return StagePlan([(AWAITING, Quintic.fit(t, 1.0, self.q_await, zero, zero,
                                                  self.q_await, zero, zero))])

    def player_state(self, context) -> _State:
        return context.get_abstract_state(self._index).get_value()

    def _needs_replan(self, old: MoMPStroke | None, p_hit, t_hit, q_hit, qd_hit) -> bool:
        """Whether the prediction or the configuration moved from those ``old`` was planned on
        (for another of the teacher's strokes, the configuration it was played instead of)."""
        if old is None:
            return True
        q, qd = (old.q_hit, old.qd_hit) if old.configuration is None else old.configuration
        return self._moved((old.stimulus[:3], old.t_hit, q, qd), p_hit, t_hit, q_hit, qd_hit)

    def _moved(self, ref: tuple, p_hit, t_hit, q_hit, qd_hit) -> bool:
        """The prediction or configuration differs from ``ref = (p_hit, t_hit, theta_hit,
        theta_dot_hit)`` by more than the re-planning thresholds."""
        cfg = self.config
        p, t, q, qd = ref
        return (float(np.linalg.norm(p_hit - p)) > cfg.replan_position
                or abs(t_hit - t) > cfg.replan_time
                or float(np.abs(q_hit - q).max()) > cfg.replan_configuration
                or float(np.abs(qd_hit - qd).max()) > cfg.replan_configuration)

    def _update(self, context, state):
        old = self.player_state(context)
        now = context.get_time()
        if self._hold_if_lost(context, state, old, now):
            return None
        if old.committed:
            if (self.play_again and old.stroke is not None and now > old.stroke.t_hit
                    and self._valid.Eval(context)[0] < 0.5):
                state.get_mutable_abstract_state(self._index).set_value(
                    _State(remaining(old.plan, now), None, False, old.seen))
                return None
            return _NOTHING
        plan = old.plan
        hit = next((seg for stage, seg in plan.segments if stage == HITTING), None)
        if hit is not None and now >= hit.t0:  # the hitting stage has begun
            cutoff = self.config.goal_cutoff
            if (cutoff is None or self.library is None or old.stroke is None
                    or now > old.stroke.t_hit - cutoff):  # no more re-plans
                state.get_mutable_abstract_state(self._index).set_value(
                    _State(plan, old.stroke, committed=True))
                return None
            return self._move_goal(context, state, old, now)
        if self._valid.Eval(context)[0] < 0.5:
            if hit is not None and old.stroke is not None:
                # The prediction was withdrawn before the hitting stage (the rules leave the
                # ball no hitting point): let it go, stopping from the desired state.
                q, qd, _ = plan.evaluate(now)
                state.get_mutable_abstract_state(self._index).set_value(
                    _State(self.hold_plan(now, q, qd), None, False, old.seen))
                return None
            return _NOTHING
        p_hit, t_hit = self._p.Eval(context), float(self._t.Eval(context)[0])
        seen = (t_hit, float(p_hit[0]), float(p_hit[1]), float(p_hit[2]))
        if seen == old.seen:
            return _NOTHING
        # From here on this prediction has been acted on, whether or not a plan comes of it.
        abstract = state.get_mutable_abstract_state(self._index)
        abstract.set_value(_State(plan, old.stroke, False, seen))
        v_hit = self._v.Eval(context)
        q_hit, qd_hit = self._q_hit.Eval(context), self._qd_hit.Eval(context)
        if t_hit - now < self.config.min_time_to_hit:
            return None
        if not self._needs_replan(old.stroke, p_hit, t_hit, q_hit, qd_hit):
            return None
        spin = self._spin.Eval(context) if self._spin.HasValue(context) else None
        x = compose_stimulus(self.stimulus, p_hit, v_hit, spin)
        preparing = plan.stage_at(now) == PREPARATION
        new, idx, nu = self._plan_primitives(now, plan, x, t_hit, q_hit, qd_hit, preparing)
        spinless = False
        qd_spinless = (self._spinless_goal(context, qd_hit)
                       if new is None and self.library is not None else None)
        if qd_spinless is not None:
            # No primitive plan fits the limits with the spin-aware racket: try the racket that
            # does not follow the spinning ball's contact point (HittingConfiguration).
            alt = self._plan_primitives(now, plan, x, t_hit, q_hit, qd_spinless, preparing)
            if alt[0] is not None:
                (new, idx, nu), qd_hit, spinless = alt, qd_spinless, True
        fallback = new is None and self.library is not None
        if new is None:
            if fallback and old.stroke is not None:
                # The limits refused the primitives for the new prediction: the teacher's
                # correction to it (or to another of its strokes), else keep the feasible plan
                # made before.
                corrected = self._teacher_fallback(context, now, plan, x, t_hit, q_hit,
                                                   [(np.array(qd_hit), False)],
                                                   old.stroke.replans + 1)
                if corrected is not None:
                    abstract.set_value(_State(*corrected, False, seen))
                return None
            new = plan_stroke(now, plan.evaluate(now), t_hit, q_hit, qd_hit, self.q_await,
                              self.limits, self.config.times, preparing, allow_wait=False)
            if not fallback:
                idx, nu = np.zeros(0, dtype=int), np.zeros(0)
        replans = 1 if old.stroke is None else old.stroke.replans + 1
        stroke = MoMPStroke(x, t_hit, np.array(q_hit), np.array(qd_hit), idx, nu, replans,
                            fallback, spinless=spinless)
        abstract.set_value(_State(plan.continued(now, new), stroke, False, seen))

    def _move_goal(self, context, state, old: _State, now: float):
        """During the hitting stage, before the cut-off: a prediction that differs from the
        stroke's goal (re-planning thresholds) moves the hitting DMP's goal if the plan that
        comes of it stays inside the joint and effort limits; otherwise the stroke keeps its
        goal and the move is tried again at the next tick (a re-plan refused before the hitting
        stage is tried here too). A refused move is tried once more with
        ``theta_dot_hit_spinless`` when that input is connected and differs (the stroke then
        records ``spinless`` and moves on those velocities until the hit). With
        ``retry_period``, a refused move is tried again only once the prediction or
        configuration has moved past the re-planning thresholds since the refusal, or that long
        after it. Returns :data:`_NOTHING` when it changes no state."""
        if self._valid.Eval(context)[0] < 0.5:
            return _NOTHING  # a swing under way is played out, as a real arm's would be
        p_hit, t_hit = self._p.Eval(context), float(self._t.Eval(context)[0])
        seen = (t_hit, float(p_hit[0]), float(p_hit[1]), float(p_hit[2]))
        q_hit, qd_hit = self._q_hit.Eval(context), self._qd_hit.Eval(context)
        # Once a move of the goal took the spinless velocities, the stroke keeps to them until
        # the hit: no switching between two goal velocities from tick to tick (one refused, the
        # other accepted, and back).
        sticky = old.spinless_move and self._qd_spinless.HasValue(context)
        if sticky:
            qd_hit = self._qd_spinless.Eval(context)
        if (t_hit - now < self.config.goal_cutoff
                or not self._needs_replan(old.stroke, p_hit, t_hit, q_hit, qd_hit)):
            return _NOTHING
        period = self.config.retry_period
        if (old.refused is not None and period is not None and now - old.refused[0] < period
                and not self._moved(old.refused[1:], p_hit, t_hit, q_hit, qd_hit)):
            return _NOTHING
        refused = _State(old.plan, old.stroke, False, old.seen,
                         (now, np.array(p_hit), t_hit, np.array(q_hit), np.array(qd_hit)),
                         old.spinless_move)
        spin = self._spin.Eval(context) if self._spin.HasValue(context) else None
        x = compose_stimulus(self.stimulus, p_hit, self._v.Eval(context), spin)
        # The goal's velocities tried in turn: the configuration's, then (if connected and
        # different) the racket that does not follow the spinning ball's contact point.
        tries = [(np.array(qd_hit), sticky)]
        # With the teacher's other strokes, those take the spinless racket's place: a stroke with
        # less of the spin compensated is aimed for that spin, the spinless racket is not.
        others = self.config.correction_fallback and self.config.stroke_fallbacks
        qd_spinless = None if sticky or others else self._spinless_goal(context, qd_hit)
        if qd_spinless is not None and self._needs_replan(old.stroke, p_hit, t_hit, q_hit,
                                                          qd_spinless):
            tries.append((qd_spinless, True))
        for qd_goal, spinless in tries:
            try:
                new, idx, nu = move_hitting_goal(now, old.plan, x, t_hit, q_hit, qd_goal,
                                                 self.library, self.stages, self.q_await,
                                                 self.limits, self.config.times)
            except ValueError:
                continue
            if self._fits_ahead(new, now):
                stroke = MoMPStroke(x, t_hit, np.array(q_hit), qd_goal, idx, nu,
                                    old.stroke.replans + 1, False, spinless=spinless)
                state.get_mutable_abstract_state(self._index).set_value(
                    _State(new, stroke, False, seen, spinless_move=spinless))
                return None
        corrected = self._teacher_fallback(context, now, old.plan, x, t_hit, q_hit, tries,
                                           old.stroke.replans + 1)
        if corrected is not None:
            plan, stroke = corrected
            state.get_mutable_abstract_state(self._index).set_value(
                _State(plan, stroke, False, seen, spinless_move=stroke.spinless))
            return None
        state.get_mutable_abstract_state(self._index).set_value(refused)
        return None

    def _teacher_fallback(self, context, now: float, plan: StagePlan, x, t_hit: float, q_hit,
                          tries: list, replans: int) -> tuple | None:
        """With ``correction_fallback``, for a re-plan or a move of the goal whose primitive
        plans the limits refused: (plan, stroke) of the teacher's quintic correction from the
        current desired state to (``q_hit``, each goal velocity of ``tries`` in turn) at
        ``t_hit`` (:meth:`_quintic_correction`), or with ``stroke_fallbacks`` then to the first
        of the teacher's other strokes that fits (:meth:`_other_stroke`); None if none fits or
        the fallback is off. ``tries``: (theta_dot_hit, spinless) pairs, the configuration's
        first."""
        if not self.config.correction_fallback:
            return None
        for qd_goal, spinless in tries:
            corrected = self._quintic_correction(now, plan, t_hit, q_hit, qd_goal)
            if corrected is not None:
                idx, nu = self.library.active(x)  # the mixture that failed (MoMPStroke)
                return corrected, MoMPStroke(x, t_hit, np.array(q_hit), qd_goal, idx, nu,
                                             replans, True, spinless=spinless)
        if not self.config.stroke_fallbacks:
            return None
        qd_hit = tries[0][0]
        played = self._other_stroke(context, now, plan, t_hit, q_hit, qd_hit)
        if played is None:
            return None
        corrected, q_goal, qd_goal = played
        idx, nu = self.library.active(x)
        return corrected, MoMPStroke(x, t_hit, q_goal, qd_goal, idx, nu, replans, True,
                                     configuration=(np.array(q_hit), np.array(qd_hit)))

    def _other_stroke(self, context, now: float, plan: StagePlan, t_hit: float, q_hit,
                      qd_hit) -> tuple | None:
        """(plan, theta_hit, theta_dot_hit) of the first of the teacher's strokes for the
        prediction (``fallback_strokes``, in its fallbacks' order) whose correction
        (:meth:`_quintic_correction`) fits the limits, passing over the configuration's own
        (``q_hit``, ``qd_hit``), already tried; None if none does or the input is not
        connected."""
        if not self._fallback_strokes.HasValue(context):
            return None
        for q_goal, qd_goal in self._fallback_strokes.Eval(context):
            if np.array_equal(q_goal, q_hit) and np.array_equal(qd_goal, qd_hit):
                continue
            corrected = self._quintic_correction(now, plan, t_hit, q_goal, qd_goal)
            if corrected is not None:
                return corrected, np.array(q_goal), np.array(qd_goal)
        return None

    def _fits_ahead(self, plan: StagePlan, now: float) -> bool:
        """Whether the part of ``plan`` from ``now`` on is inside the joint limits and (with
        an ``arm``) the effort budget."""
        ahead = StagePlan([(s, seg) for s, seg in plan.segments if seg.t0 >= now])
        return within_limits(ahead, self.limits) and self._within_effort(plan, now)

    def _quintic_correction(self, now: float, plan: StagePlan, t_hit: float, q_hit,
                            qd_hit) -> StagePlan | None:
        """``plan`` up to ``now``, then the teacher's quintic stages from its desired state
        there to (``q_hit``, ``qd_hit``) at ``t_hit`` (the analytical player's correction); None
        if they leave the limits (``correction_fallback``)."""
        new = correction_stages(now, plan, t_hit, q_hit, qd_hit, self.q_await, self.limits,
                                self.config.times)
        if new is None:
            return None
        corrected = plan.continued(now, new)
        return corrected if self._fits_ahead(corrected, now) else None

    def _spinless_goal(self, context, qd_hit) -> np.ndarray | None:
        """The configuration's ``theta_dot_hit_spinless`` when that input is connected and
        differs from ``qd_hit`` by more than ``replan_configuration`` on some joint (a goal worth
        trying when the one with ``qd_hit`` is refused); else None."""
        if not self._qd_spinless.HasValue(context):
            return None
        qd = np.array(self._qd_spinless.Eval(context))
        return qd if float(np.abs(qd - qd_hit).max()) > self.config.replan_configuration else None

    def _hold_if_lost(self, context, state, old: _State, now: float) -> bool:
        """The safety behaviour: if a measured joint is faster than ``hold_speed`` times its
        velocity limit or more than ``hold_error`` from the plan (the arm no longer follows:
        e.g. a saturated shoulder under the inverse-dynamics controller, which then feeds the
        other joints torques for an acceleration the shoulder does not make), replace the plan
        by :meth:`hold_plan` from the measured state and commit; True if it did."""
        cfg = self.config
        if cfg.hold_error is None or not self._arm_state.HasValue(context):
            return False
        x = self._arm_state.Eval(context)
        planned = self._planned.row(old.plan, now)
        q = old.plan.evaluate(now)[0] if planned is None else planned[:7]
        if arm_follows(x, q, self.limits.velocity, cfg.hold_speed, cfg.hold_error):
            return False
        stroke = None if old.stroke is None else replace(old.stroke, held=True)
        state.get_mutable_abstract_state(self._index).set_value(
            _State(self.hold_plan(now, x[:7], x[7:]), stroke, True, old.seen))
        return True

    def hold_plan(self, now: float, q, qd) -> StagePlan:
        """From the measured ``(q, q_dot)`` at ``now``: a quintic to rest at ``q + (T/2) q_dot``
        (inside the position limits) with T = max(0.1 s, 2 max_j |q_dot_j| / a_max_j), so that
        it decelerates at most 1.5 |q_dot| / T = 0.75 a_max, then a rest-to-rest quintic to the
        awaiting posture within the velocity and acceleration limits (at least 1 s); both
        labelled AWAITING (the stroke is over)."""
        q, qd = np.asarray(q, dtype=float), np.asarray(qd, dtype=float)
        zero = np.zeros_like(q)
        acc = self.limits.acceleration
        t_stop = max(0.1, 2.0 * float(np.max(np.abs(qd) / acc)))
        q_stop = self.limits.clip(q + 0.5 * t_stop * qd)
        stop = Quintic.fit(now, t_stop, q, qd, zero, q_stop, zero, zero)
        t_back = max(1.0, self.limits.move_time(q_stop, self.q_await))
        back = Quintic.fit(stop.t_end, t_back, q_stop, zero, zero, self.q_await, zero, zero)
        return StagePlan([(AWAITING, stop), (AWAITING, back)])

    def _plan_primitives(self, now, plan, x, t_hit, q_hit, qd_hit, preparing):
        """The first motor-primitive plan inside the joint limits (hitting-stage durations tried
        in turn) as (plan, primitive indices, mixture weights); if none is, (None, indices,
        weights) of the mixture that failed (the responsibility learning blames it), and (None,
        None, None) for a player without a library (the ``crkr`` player: teacher's quintics)."""
        if self.library is None:
            return None, None, None
        tried = None
        for hitting in (*self.config.hitting_durations, None):
            try:
                new, idx, nu = plan_momp_stroke(
                    now, plan.evaluate(now), x, t_hit, q_hit, qd_hit, self.library, self.stages,
                    self.q_await, self.limits, self.config.times, preparing,
                    hitting=hitting, prepare=hitting is not None)
            except ValueError:
                continue
            if within_limits(new, self.limits) and self._within_effort(new, now):
                return new, idx, nu
            tried = tried or (idx, nu)
        idx, nu = tried or self.library.active(x)
        return None, idx, nu

    def _within_effort(self, plan: StagePlan, now: float) -> bool:
        if self.arm is None:
            return True
        return within_effort(plan, self.arm.torques, self.effort_budget, now)

    @staticmethod
    def hit_point(stroke):
        return stroke.stimulus[:3]
