"""The analytical player (the teacher): a physics-model planner and polynomial stroke stages.

For each new estimate (at the first planning tick after the estimator's update), while the ball
comes toward the robot and the hitting stage has not begun, the
:class:`StrokePlanner`

1. predicts the ball's state where it crosses the virtual hitting plane (or, for a ball that
   crosses it too low or not at all, at a point chosen along its path:
   :func:`tt_drake.hitting_time.choose_hitting_point`), with the physical model
   (:class:`tt_drake.ball_model.CompliantBounceBallModel`) from the estimator's state: the
   stimulus (p_hit, v_hit, t_hit), and the ball's spin there: the model starts from the
   estimator's spin and carries it through any bounce still ahead (docs/spin.md);
2. chooses the outgoing velocity that lands the ball on the target, and the racket normal and
   velocity that produce it (:mod:`tt_drake.racket_law`);
3. solves the arm: the hitting configuration theta_hit that puts the racket centre at
   p_hit - (R + t/2) n with that normal n (so that the ball's centre, at p_hit, touches the blade
   face of thickness t just then), closest to a comfort posture, and theta_dot_hit that gives the
   blade's velocity with the racket free to rotate (the contact is at the blade centre; holding
   it still would make the wrist counter-rotate at 10+ rad/s)
   (:class:`tt_drake.systems.hitting_ik.HittingIK`);
4. re-plans the stages from the current desired state (:func:`tt_drake.stages.plan_stroke`).

It stops re-planning once the hitting stage has begun (paper section III-A), except for
corrections: a prediction that moves more than the racket forgives (the spin seen at the
robot-side bounce, usually after the hitting stage's start) re-plans the rest of the hitting
stage from the current desired state, until 80 ms before the hit (with
``PlannerConfig.posture_fallback``, a correction refused in every stroke is tried again with the
arm nearest the committed posture: :meth:`StrokePlanner.committed_posture`). A re-plan is
dropped, keeping the previous one, when the arm solution jumps to another configuration
(> ``max_branch_change`` on a joint) while the hitting point moved less than
``research_distance``, or when the new plan leaves the joint position, velocity or acceleration
limits or asks for more than 90 % of an actuator's effort limit (inverse dynamics along the plan,
gravity included: ``HittingIK.torques``; an acceleration limit alone let a plan ask the shoulder
for twice its 75 N m). The player only sees what the camera sees: its inputs are the
estimator's outputs, never the true ball state.

Ports of :class:`AnalyticalPlayer`: inputs ``estimated_state`` (6: p, v), ``estimated_spin``
(3: omega, rad/s; taken as zero when not connected) and ``estimator_status`` (2: valid, time of
the estimate); outputs ``desired_state`` (14: q, q_dot) and
``desired_acceleration`` (7) for the InverseDynamicsController, ``stage`` (1: index into
:data:`tt_drake.stages.STAGES`), ``stroke`` (the :class:`Stroke` planned, for datasets) and
``predicted_hit`` (4: p_hit and a valid flag, for drawing).
The output ports evaluate the stored plan (a quintic per joint): O(1) work per integrator step.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from pydrake.common.value import AbstractValue

from tt_drake import wam_params as wp
from tt_drake.ball_model import BallModel, BallModelParams, CompliantBounceBallModel
from tt_drake.constants import BALL, PLANES, TABLE, TARGET
from tt_drake.drives import SUPPLY_FRACTION, EffortBudget, drive_envelope, joint_limits
from tt_drake.hitting_time import (
    BounceCount,
    HittingBand,
    choose_hitting_point,
    count_bounces,
    last_robot_bounce,
    robot_bounces_by,
)
from tt_drake.racket_law import (
    FLIGHT_TIMES,
    aim_candidates,
    racket_for_return,
    solve_outgoing_velocity,
)
from tt_drake.rally_aim import (
    Aim,
    CompetitiveAim,
    draw_aims,
    opponent_hitting_point,
    passes_own_end,
)
from tt_drake.spin_stroke import spin_stroke_candidates
from tt_drake.stages import (
    AWAITING,
    HITTING,
    PREPARATION,
    Quintic,
    StagePlan,
    StageTimes,
    correction_stages,
    plan_extremes,
    plan_stroke,
    within_effort,
)
from tt_drake.systems.hitting_ik import SHOULDER, HittingIK
from tt_drake.systems.immutable import Immutable
from tt_drake.systems.seed_parameter import SeedParameter
from tt_drake.systems.stage_player import StagePlanPlayer, remaining


@dataclass(frozen=True)
class Stroke:
    """What a stroke was planned from and to: the stimulus, racket state and arm solution."""

    p_hit: np.ndarray
    v_hit: np.ndarray
    t_hit: float
    spin: np.ndarray
    v_out: np.ndarray
    racket_normal: np.ndarray
    racket_velocity: np.ndarray
    q_hit: np.ndarray
    qd_hit: np.ndarray
    ik_position_error: float
    ik_angle_error: float
    flight_time: float
    replans: int = 1
    spin_share: float = 1.0  # of the spin the racket compensates (PlannerConfig.stroke_spins)
    blade_offset: float = 0.0  # m, the contact's distance from the blade centre
    reach_in: float = 0.0  # m, how far toward the shoulder the stroke was planned (reach_point)
    spin_out: np.ndarray | None = None  # rad/s, the spin the stroke sends the ball back with
    aimed: bool = False  # planned for the stroke's drawn aim (AnalyticalPlayer.aims)


@dataclass(frozen=True)
class PlannerConfig:
    target_x: float = TARGET.x
    target_y: float = TARGET.y
    replan_position: float = 0.003  # m: a prediction this close to the last one changes nothing
    replan_time: float = 0.002  # s
    replan_spin: float = 10.0  # rad/s at impact: R * 10 rad/s = 0.2 m/s at the contact point
    # After the hitting stage has begun: a prediction that moved more than the racket forgives
    # (its blade is 76 mm in radius; a 20 rad/s spin error turns the return by ~0.4 m/s at the
    # contact) re-plans the rest of the hitting stage, until ``correct_lead`` before the hit.
    correct_position: float = 0.010  # m
    correct_time: float = 0.005  # s
    correct_spin: float = 20.0  # rad/s
    correct_lead: float = 0.08  # s
    # A correction the effort check refuses tries the fallbacks below (stroke_spins x
    # blade_offsets) in turn, as a first plan does; False: the first stroke the arm reaches only.
    correction_fallbacks: bool = False
    # A first plan the joint or effort limits refuse tries the fallbacks below in turn, as a
    # correction does with ``correction_fallbacks``; False: only the first stroke the arm reaches.
    plan_fallbacks: bool = False
    max_branch_change: float = 0.5  # rad: a re-plan moving theta_hit further is another IK branch
    research_distance: float = 0.05  # m: a hitting point this far from the last re-aims fully
    torque_fraction: float = 0.9  # of the effort limits a plan may ask for
    # Of the effort limits a correction of the committed stroke may ask for; None:
    # ``torque_fraction``. A correction comes late, so the arm's lag when a plan asks for the
    # whole limit costs less than the ball the committed stroke would miss.
    correction_torque_fraction: float | None = None
    # A correction the limits refuse in every stroke (with ``correction_fallbacks``, every
    # fallback) is tried again with each arm solution nearest the committed stroke's posture in
    # units of the joints' speed limits (:meth:`StrokePlanner.committed_posture`) instead of the
    # comfort posture: the slow base joint then turns least when the bounce moves the hit.
    posture_fallback: bool = False
    # The solver of the arm's position problem (hitting_ik.SOLVERS): Drake's SNOPT or the compiled
    # SQP (docs/hitting_ik.md, "Solvers"); used when the planner builds its own arm.
    ik_solver: str = "snopt"
    # The drives' supply voltage (V, tt_drake.drives): a plan must also stay within
    # ``supply_fraction`` of the supply at every joint speed, and each joint within that
    # share of its no-load speed; 0: ideal drives.
    drive_voltage: float = 0.0
    supply_fraction: float = SUPPLY_FRACTION
    times: StageTimes = StageTimes()
    # Where a ball off the plane may be hit (tt_drake.hitting_time); None: the plane only.
    band: HittingBand | None = HittingBand()
    # The return's candidate flight times to the target (s; racket_law.aim_candidates).
    flight_times: tuple[float, ...] = FLIGHT_TIMES
    # The virtual hitting plane y (m; paper section III-A).
    plane_y: float = PLANES.hitting_y
    # Fallbacks for a stroke the arm cannot make (tried in order, each share with each offset):
    # the shares of the predicted spin at impact the stroke compensates, in the aim's flight and
    # the racket law (docs/spin.md; less asks for a smaller racket tilt and speed change), and
    # the offsets (m) of the contact from the blade centre toward the shoulder, within the face
    # (the blade is 76 mm in radius, the ball 20 mm): docs/analytical_player.md, "Fallbacks".
    stroke_spins: tuple[float, ...] = (1.0, 0.5, 0.0)
    blade_offsets: tuple[float, ...] = (0.0, 0.03, 0.06)
    # The last fallback, for a ball just beyond the arm's reach: the stroke planned for the
    # hitting point moved these distances (m) toward the shoulder (:func:`reach_point`), the
    # blade's rim meeting the ball. Empty: none (the teacher's; the returnable bound tries it).
    reach_in: tuple[float, ...] = ()
    # The return's topspin (rad/s; negative: backspin) a brushed stroke makes
    # (tt_drake.spin_stroke); None: the flat stroke, the ball keeping the spin it came with.
    topspin: float | None = None
    # Waiting at rest for the latest start of a direct hit (:meth:`StrokePlanner.schedule`): the
    # player waits only while a hit started this long after now would still be feasible (s).
    # The window of start times it leaves is this long: one camera frame is the least, and then
    # a t_hit that moves a few ms between frames can close it before the player acts; three
    # frames (docs/analytical_player.md, "Stages").
    start_margin: float = 3.0 / 60.0
    # The awaiting posture (rad): where the arm waits for the ball and every stroke returns to.
    awaiting: tuple[float, ...] = wp.AWAITING


#: How much larger than the table the planner's model takes it (m): the launcher serves only onto
#: the table, and a ball bouncing within a few centimetres of the edge is, with camera noise,
#: otherwise predicted to miss it (and to cross the hitting plane half a metre low).
TABLE_EDGE_PRIOR = 0.05

#: The planner's ball-model step (s). Its RK4 steps locate the bounces and the hitting plane
#: exactly within a step, so the step sets only the integration error: from the states the
#: player predicts from, 10 ms gives the same stimulus as 2 ms to ~2e-9 m and ~4e-10 s
#: (docs/performance.md, "The teacher") in a fifth of the steps, and a prediction is most of
#: what the teacher computes per camera frame.
PREDICTION_STEP = 0.01
#: The step (s) of the test for a bounce behind the ball (``hitting_time.last_robot_bounce``,
#: which looks at the path once a step): 2 ms, ~1 cm of the ball's travel, at the table's edges.
BOUNCE_TEST_STEP = 2e-3


def planner_ball_model(dt: float = PREDICTION_STEP) -> BallModel:
    params = BallModelParams()
    params = dataclasses.replace(
        params, table_half_length=params.table_half_length + TABLE_EDGE_PRIOR,
        table_half_width=params.table_half_width + TABLE_EDGE_PRIOR)
    return CompliantBounceBallModel(params, dt=dt)


def blade_centre(p_hit, normal, contact_offset: float, offset: float = 0.0) -> np.ndarray:
    """Where the blade centre must be for the ball's centre ``p_hit`` to touch the face with
    unit ``normal``: p_hit - (R + t/2) n, moved ``offset`` (m) within the face toward the
    shoulder, d / |d| with d = (I - n n^T)(p_shoulder - p_hit), so the ball meets the blade
    ``offset`` from its centre on the side away from the arm."""
    p_hit, n = np.asarray(p_hit, dtype=float), np.asarray(normal, dtype=float)
    centre = p_hit - contact_offset * n
    if offset == 0.0:
        return centre
    d = SHOULDER - p_hit
    d -= (d @ n) * n
    norm = float(np.linalg.norm(d))
    return centre if norm < 1e-9 else centre + offset * d / norm


def reach_point(p_hit, distance: float) -> np.ndarray:
    """The hitting point moved ``distance`` (m) toward the shoulder within the hitting plane:
    p_hit + distance d / |d|, d = p_shoulder - p_hit with its y component removed."""
    p_hit = np.asarray(p_hit, dtype=float)
    if distance == 0.0:
        return p_hit
    d = SHOULDER - p_hit
    d[1] = 0.0
    norm = float(np.linalg.norm(d))
    return p_hit.copy() if norm < 1e-9 else p_hit + distance * d / norm


class StrokePlanner:
    """Prediction -> aim -> racket state -> arm solution -> stage plan (module docstring)."""

    def __init__(self, arm=None, config: PlannerConfig | None = None,
                 model: BallModel | None = None):
        self.config = config or PlannerConfig()
        self.drive = drive_envelope(self.config.drive_voltage)
        if arm is None:
            arm = HittingIK(solver=self.config.ik_solver)
        self.arm = arm
        self.model = model or planner_ball_model()
        self.q_await = np.asarray(self.config.awaiting, dtype=float)
        self.effort_budget = EffortBudget(self.config.torque_fraction, self.drive,
                                          self.config.supply_fraction)
        correction = self.config.correction_torque_fraction
        self.correction_budget = (self.effort_budget if correction is None else
                                  dataclasses.replace(self.effort_budget, fraction=correction))
        self.limits = joint_limits(self.drive, self.config.supply_fraction)

    def aimed(self, aim: Aim) -> StrokePlanner:
        """This planner with ``aim``'s target, flight time (if any) and topspin: a shallow copy
        sharing the arm, the ball model and the limits (:mod:`tt_drake.rally_aim`)."""
        planner = copy.copy(self)
        times = self.config.flight_times if aim.flight_time is None else (aim.flight_time,)
        planner.config = dataclasses.replace(self.config, target_x=aim.target_x,
                                             target_y=aim.target_y, flight_times=times,
                                             topspin=aim.topspin)
        return planner

    def awaiting_plan(self, t: float = 0.0) -> StagePlan:
        zero = np.zeros(7)
        return StagePlan([(AWAITING, Quintic.fit(t, 1.0, self.q_await, zero, zero,
                                                  self.q_await, zero, zero))])

    def predict(self, state6, t_state: float, spin=None, bounces_behind: int | None = None):
        """Stimulus (p_hit, v_hit, t_hit absolute), the ball's spin there and whether the
        prediction went through a bounce; or None.

        The ball model starts from the estimate (p, v) and the estimated ``spin`` (omega, rad/s;
        zero if None) and carries both through the bounces ahead (the bounce changes spin and
        velocity together), so the spin at impact is the model's from the estimator's. The
        hitting point comes before the ball's second bounce on the robot's half (the rules):
        ``bounces_behind`` is how many it has made so far (:meth:`count_bounces`; None: found
        from the estimate alone, 0 or 1)."""
        state6 = np.asarray(state6, dtype=float)
        plane_y = self.config.plane_y
        if state6[4] >= 0.0 or state6[1] <= plane_y:
            return None  # not coming toward the robot, or already past the plane
        w = np.zeros(3) if spin is None else np.asarray(spin, dtype=float)
        if self.config.band is None:
            hit = self.model.predict_plane(np.r_[state6, w], plane_y)
            if bounces_behind is None:
                bounces_behind = int(last_robot_bounce(self.model, np.r_[state6, w],
                                                       step=BOUNCE_TEST_STEP) is not None)
            if hit is not None and robot_bounces_by(hit, bounces_behind) >= 2:
                return None  # the plane comes after the second bounce on the robot's half
        else:  # the plane when it serves, else a point along the path (tt_drake.hitting_time)
            hit = choose_hitting_point(self.model, np.r_[state6, w], plane_y,
                                       self.config.band, bounce_step=BOUNCE_TEST_STEP,
                                       bounces_behind=bounces_behind)
        if hit is None:
            return None
        return hit.position, hit.velocity, t_state + hit.t, hit.spin, bool(hit.bounces)

    def count_bounces(self, count: BounceCount, state6, t_state: float,
                      spin=None) -> BounceCount:
        """``count`` after the estimate (p, v) at ``t_state`` and its ``spin``
        (:func:`tt_drake.hitting_time.count_bounces` on the planner's model)."""
        w = np.zeros(3) if spin is None else np.asarray(spin, dtype=float)
        return count_bounces(self.model, count, np.r_[np.asarray(state6, dtype=float), w],
                             t_state, step=BOUNCE_TEST_STEP)

    def aims(self, p_hit, v_hit, spin, previous: Stroke | None) -> list:
        """The outgoing velocities to try, best first, as (v_out, flight time): every candidate
        flight time ranked by :func:`tt_drake.racket_law.aim_candidates`; for a correction
        (``previous``: a stroke whose hitting point barely moved) its flight time's one outgoing
        velocity, with nothing to rank."""
        cfg = self.config
        if previous is not None:
            goal = (cfg.target_x, cfg.target_y, TABLE.surface_z + BALL.radius)
            return [(solve_outgoing_velocity(p_hit, goal, previous.flight_time, spin=spin),
                     previous.flight_time)]
        return [(aim.v_out, aim.flight_time)
                for aim in aim_candidates(p_hit, v_hit, (cfg.target_x, cfg.target_y),
                                          flight_times=cfg.flight_times, spin=spin)]

    def stroke(self, p_hit, v_hit, t_hit, spin, previous: Stroke | None,
               near_previous: bool = False) -> Stroke | None:
        """Aim, racket and arm for a stimulus; None if the arm cannot reach it, or if the
        hitting point barely moved but the solution jumped to another arm configuration (the
        IK's local optimum moved, not the task).

        Small corrections keep the previous flight time (one Broyden solve); a hitting point that
        moved more than ``research_distance`` searches all candidate flight times again.
        ``near_previous``: the arm solution nearest ``previous``'s posture
        (:meth:`committed_posture`) instead of the comfort posture."""
        return next(self._solutions(p_hit, v_hit, t_hit, spin, previous, near_previous), None)

    def strokes(self, p_hit, v_hit, t_hit, spin, previous: Stroke | None,
                near_previous: bool = False) -> Iterator[Stroke]:
        """Every stroke the arm reaches for a stimulus, in the fallbacks' order (:meth:`stroke`
        is the first): each spin share of ``stroke_spins`` with each of ``blade_offsets``, then
        the ``reach_in`` points; strokes that jump to another arm configuration for a hitting
        point that barely moved are left out. Solved lazily: a caller that takes the first
        stroke its own check accepts (:meth:`correct`'s effort check) solves no more."""
        for stroke in self._solutions(p_hit, v_hit, t_hit, spin, previous, near_previous):
            if stroke is not None:
                yield stroke

    def committed_posture(self, committed: Stroke) -> tuple[np.ndarray, np.ndarray]:
        """The (q_c, w) of an arm solution nearest ``committed``'s posture
        (:meth:`HittingIK.solve`): q_c = its theta_hit and w_j = 1 / v_j² for the joints' speed
        limits v_j, so the solution minimises sum_j ((q_j - q_c,j) / v_j)², the squared times the
        joints need at their limits to reach it from the committed posture."""
        return (np.asarray(committed.q_hit, dtype=float),
                1.0 / np.asarray(self.limits.velocity, dtype=float) ** 2)

    def _solutions(self, p_hit, v_hit, t_hit, spin, previous: Stroke | None,
                   near_previous: bool = False) -> Iterator[Stroke | None]:
        """Each arm solution of :meth:`strokes` as its stroke, in order, or None in its place
        when it jumped to another arm configuration; lazy, so :meth:`stroke` (the first item)
        solves no further."""
        close = previous is not None and float(
            np.linalg.norm(np.asarray(p_hit) - previous.p_hit)) < self.config.research_distance
        seed = previous.q_hit if previous is not None else None
        posture = (self.committed_posture(previous) if near_previous and previous is not None
                   else None)
        # The ball touches the blade face when its centre is R + t/2 in front of the blade centre.
        contact_offset = BALL.radius + 0.5 * wp.RACKET.blade_thickness
        spins, offsets = self.config.stroke_spins, self.config.blade_offsets
        if close:  # a correction keeps the stroke's kind first
            spins = (previous.spin_share, *(x for x in spins if x != previous.spin_share))
            offsets = (previous.blade_offset,
                       *(x for x in offsets if x != previous.blade_offset))
        replans = previous.replans + 1 if previous is not None else 1
        spin = np.asarray(spin, dtype=float)
        for reach in (0.0, *self.config.reach_in):
            for found in self._feasible(reach_point(p_hit, reach), v_hit, spin, spins, offsets,
                                        contact_offset, seed, previous if close else None,
                                        posture):
                share, offset, v_out, spin_out, flight_time, racket, ik, qd_hit = found
                if close and (np.abs(ik.q - previous.q_hit).max()
                              > self.config.max_branch_change):
                    # The solver jumped to another arm configuration: not this stroke.
                    stroke = None
                else:
                    stroke = Stroke(np.asarray(p_hit), np.asarray(v_hit), float(t_hit), spin,
                                    v_out, racket.normal, racket.velocity, np.asarray(ik.q),
                                    np.asarray(qd_hit), ik.position_error, ik.angle_error,
                                    float(flight_time), replans, float(share), float(offset),
                                    float(reach), np.asarray(spin_out))
                yield stroke

    def _feasible(self, p_hit, v_hit, spin, spins, offsets, contact_offset, seed,
                  previous, posture=None) -> Iterator[tuple]:
        """Each (share, offset, v_out, spin_out, flight time, racket, IK, theta_dot_hit) the arm
        reaches within its joint speed limits, in order: for each spin share s and each blade
        offset in turn (shares outermost), every aim of :meth:`aims` for the spin s omega, best
        first, with its racket by the racket law and the blade centre of :func:`blade_centre`.
        The first is the plain stroke (s = 1, the ball on the centre). ``posture``: the arm
        solution's (q_c, w) (:meth:`committed_posture`; None: the comfort posture)."""
        for share in spins:
            compensated = share * spin
            aims = self._strokes(p_hit, v_hit, compensated, previous)
            for offset in offsets:
                for v_out, spin_out, flight_time, racket in aims:
                    ik = self.arm.solve(blade_centre(p_hit, racket.normal, contact_offset,
                                                     offset), racket.normal,
                                        q_seed=seed, posture=posture)
                    if not ik.success:
                        continue
                    qd_hit = self.hit_velocities(ik.q, racket.velocity)
                    if np.all(np.abs(qd_hit) <= self.limits.velocity):
                        yield share, offset, v_out, spin_out, flight_time, racket, ik, qd_hit

    def hit_velocities(self, q_hit, v_racket) -> np.ndarray:
        """theta_dot_hit for the blade velocity ``v_racket`` at ``q_hit``, the racket free to
        rotate (:meth:`HittingIK.joint_velocities_free_spin`); with drives, in units of each
        joint's no-load speed, so that the slow base joint gives way to the wrist."""
        scale = None if self.drive is None else self.drive.no_load_speed
        return self.arm.joint_velocities_free_spin(q_hit, v_racket, speed_scale=scale)

    def _strokes(self, p_hit, v_hit, spin, previous: Stroke | None) -> list:
        """(v_out, spin_out, flight time, racket) to try, best first, for a ball spinning at
        ``spin``: the flat stroke's aims (:meth:`aims`) and :func:`racket_for_return`, the ball
        keeping ``spin``, or with ``config.topspin`` the brushed strokes of
        :func:`spin_stroke_candidates` (a correction keeps the previous stroke's flight time)."""
        cfg = self.config
        if cfg.topspin is None:
            return [(v_out, spin, flight_time, racket_for_return(v_hit, v_out, spin))
                    for v_out, flight_time in self.aims(p_hit, v_hit, spin, previous)]
        times = (previous.flight_time,) if previous is not None else cfg.flight_times
        return [(s.v_out, s.spin_out, s.flight_time, s.racket)
                for s in spin_stroke_candidates(p_hit, v_hit, spin, (cfg.target_x, cfg.target_y),
                                                cfg.topspin, flight_times=times)]

    def needs_replan(self, previous: Stroke | None, p_hit, t_hit, spin=None) -> bool:
        """Whether a prediction moved from the one ``previous`` was planned on by more than
        ``replan_position``, ``replan_time`` or (when given) ``replan_spin`` at impact."""
        if previous is None:
            return True
        cfg = self.config
        return (float(np.linalg.norm(np.asarray(p_hit) - previous.p_hit)) > cfg.replan_position
                or abs(t_hit - previous.t_hit) > cfg.replan_time
                or (spin is not None and float(np.linalg.norm(np.asarray(spin) - previous.spin))
                    > cfg.replan_spin))

    def needs_correction(self, previous: Stroke, p_hit, t_hit, spin) -> bool:
        """Whether a prediction during the hitting stage moved from the committed one by more
        than the racket forgives (``correct_*`` of :class:`PlannerConfig`)."""
        cfg = self.config
        return (float(np.linalg.norm(np.asarray(p_hit) - previous.p_hit)) > cfg.correct_position
                or abs(t_hit - previous.t_hit) > cfg.correct_time
                or float(np.linalg.norm(np.asarray(spin) - previous.spin)) > cfg.correct_spin)

    def correct(self, now: float, current: StagePlan, stroke: Stroke) -> StagePlan | None:
        """The current plan up to ``now`` and a new hitting segment from the current desired
        state to the corrected stroke's (theta_hit, theta_dot_hit) at its t_hit, then the
        follow-through and the return; None if that is not feasible for the arm (keep the
        committed plan), its effort checked against :attr:`correction_budget`
        (``correction_torque_fraction`` of the effort limits)."""
        plan = correction_stages(now, current, stroke.t_hit, stroke.q_hit, stroke.qd_hit,
                                 self.q_await, self.limits, self.config.times)
        if plan is None or not self.feasible(plan, now, self.correction_budget):
            return None
        return current.continued(now, plan)

    def feasible(self, plan: StagePlan, now: float = -np.inf,
                 budget: EffortBudget | None = None) -> bool:
        """Within the joint position, velocity and acceleration limits everywhere (sampled at
        200 Hz), and within ``budget`` (default :attr:`effort_budget`: ``torque_fraction`` of
        the effort limits, and with ``drive_voltage`` ``supply_fraction`` of the drives' supply
        at each sample's joint speed) from ``now`` on (inverse dynamics on the control plant at
        50 Hz, M q_ddot + C q_dot - tau_g): the controller can then follow it, with the rest of
        the torque left for tracking errors."""
        ext = plan_extremes(plan, rate=200.0)
        if not (np.all(ext["qdd_max"] <= self.limits.acceleration)
                and np.all(ext["qd_max"] <= self.limits.velocity)
                and np.all(ext["q_min"] >= self.limits.lower)
                and np.all(ext["q_max"] <= self.limits.upper)):
            return False
        if not hasattr(self.arm, "torques"):
            return True
        budget = self.effort_budget if budget is None else budget
        return within_effort(plan, self.arm.torques, budget, now)

    def schedule(self, now: float, current: StagePlan,
                 stroke: Stroke) -> tuple[StagePlan | None, bool]:
        """(the current plan up to ``now`` followed by the stroke, False), or (None, True) to
        keep waiting, or (None, False) if the stroke is not feasible for the arm.

        Waiting at rest is safe only while a direct hit started ``config.start_margin`` later
        would still be feasible; otherwise the hit starts now."""
        preparing = current.stage_at(now) == PREPARATION
        state = current.evaluate(now)

        def stroke_from(t: float, allow_wait: bool):
            return plan_stroke(t, state, stroke.t_hit, stroke.q_hit, stroke.qd_hit, self.q_await,
                               self.limits, self.config.times, preparing, allow_wait)

        plan = stroke_from(now, allow_wait=True)
        if plan is None:
            later = stroke_from(now + self.config.start_margin, allow_wait=False)
            if self.feasible(later, now):
                return None, True
            plan = stroke_from(now, allow_wait=False)
        if not self.feasible(plan, now):
            return None, False  # not feasible for the arm: keep the current plan
        return current.continued(now, plan), False


class StrokeAims:
    """A competitive player's per-stroke aims (:mod:`tt_drake.rally_aim`): stroke k of the
    rally with seed s plays the first of its drawn aims (:func:`draw_aims`) whose stroke the
    ``planner``'s arm can make and whose return the opponent can play
    (:func:`opponent_hitting_point`, :meth:`CompetitiveAim.playable`) and passes over the
    striker's own end line (:func:`passes_own_end`); chosen at the stroke's first prediction
    and kept for it."""

    def __init__(self, planner: StrokePlanner, aims: CompetitiveAim):
        self.base, self.aims = planner, aims
        self._chosen: dict[tuple[int, int], StrokePlanner | None] = {}

    def stroke(self, seed: int, index: int, p_hit, v_hit, t_hit, spin,
               previous: Stroke | None = None, near_previous: bool = False) -> Stroke | None:
        """Stroke ``index``'s stroke (``aimed``) for the prediction (p_hit, v_hit, t_hit,
        spin), by its aim's planner (a re-plan of ``previous``, a stroke of the same aim, its
        arm nearest ``previous``'s with ``near_previous``: :meth:`StrokePlanner.stroke`); None if
        no drawn aim served the prediction the aim was chosen on (class docstring) or the arm
        cannot make it for this one."""
        key = (int(seed), int(index))
        if key in self._chosen:
            planner = self._chosen[key]
            found = None if planner is None else planner.stroke(p_hit, v_hit, t_hit, spin,
                                                                previous, near_previous)
        else:
            planner, found = self._choose(seed, index, p_hit, v_hit, t_hit, spin)
            if len(self._chosen) > 256:  # derived planners, cheap to make again
                self._chosen.clear()
            self._chosen[key] = planner
        return None if found is None else dataclasses.replace(found, aimed=True)

    def chosen(self, seed: int, index: int) -> StrokePlanner | None:
        """The planner of the aim chosen for stroke ``index`` (None: none served, or not yet
        asked)."""
        return self._chosen.get((int(seed), int(index)))

    def _choose(self, seed: int, index: int, p_hit, v_hit, t_hit, spin) -> tuple:
        """(the planner of the first drawn aim that serves, its stroke), or (None, None)."""
        for aim in draw_aims(self.aims, seed, index):
            planner = self.base.aimed(aim)
            found = planner.stroke(p_hit, v_hit, t_hit, spin, None)
            if found is None:
                continue
            cfg = planner.config
            point = opponent_hitting_point(planner.model, found.p_hit, found.v_out,
                                           found.spin_out, cfg.plane_y, cfg.band)
            if self.aims.playable(point) and passes_own_end(
                    found.p_hit, found.v_out, found.spin_out, self.aims.end_clearance):
                return planner, found
        return None, None


class PlayerState(Immutable):
    """``seen``: the time of the estimate last acted on (the player waits for a newer one);
    ``bounces``: the incoming ball's bounces on the robot's half seen so far; ``strokes``: the
    balls played so far in the episode (a rally's per-stroke aim is drawn by this index)."""

    __slots__ = ("plan", "stroke", "committed", "seen", "bounces", "strokes")

    def __init__(self, plan: StagePlan, stroke: Stroke | None = None, committed: bool = False,
                 seen: float = -math.inf, bounces: BounceCount | None = None,
                 strokes: int = 0):
        self.plan, self.stroke, self.committed = plan, stroke, committed
        self.seen, self.bounces, self.strokes = seen, bounces or BounceCount(), strokes


class AnalyticalPlayer(SeedParameter, StagePlanPlayer):
    """``corrections``: after the hitting stage has begun, re-plan its rest when the prediction
    moves more than the racket forgives (:meth:`StrokePlanner.needs_correction`): the spin a
    launcher serve carries is seen only at the robot-side bounce, which for most serves comes
    after the hitting stage's start (0.4 s before the hit).

    ``play_again`` (the rally, docs/rally.md): after the planned hit, once the estimator reports
    the ball flying away (v_y > 0), the player is free again: it keeps the rest of its plan (the
    follow-through and the return to the awaiting posture) and waits for the next ball coming to
    it. Without it (``serve``) the player stays committed to its one stroke.

    ``aims`` (the rally's competitive aim, :mod:`tt_drake.rally_aim`): each stroke plays the
    first of its drawn aims whose stroke the arm can make and whose return the opponent can play
    (:meth:`CompetitiveAim.playable`), chosen at the stroke's first prediction and kept for it;
    the draws are keyed by the episode's seed, a numeric parameter (:meth:`set_seed`), and the
    stroke's index. When no drawn aim serves, or the chosen aim's stroke is not feasible for the
    arm at a later prediction, the stroke plays the planner's own aim. None: every stroke plays
    the planner's aim.

    A stroke the arm cannot follow from the current state (outside the joint or effort limits)
    leaves the plan as it is; the player then tries the next stroke (the planner's own aim's
    after a drawn aim's), and if it can follow none it records the first as the prediction
    acted on and plans again when the prediction moves."""

    # Predictions past the committed stroke's correction cut-off can change nothing, so none is
    # made; docs/examples/lever_toggle.py turns them back on to measure what they cost.
    predict_past_cutoff = False

    def __init__(self, planner: StrokePlanner | None = None, rate: float = wp.PLANNING_RATE,
                 setpoint_lead: float = 0.0, corrections: bool = True, play_again: bool = False,
                 setpoint_period: float | None = None,
                 aims: CompetitiveAim | None = None):
        super().__init__(setpoint_lead, setpoint_period)
        self.planner = planner or StrokePlanner()
        self.corrections = corrections
        self.play_again = play_again
        self.aims = aims
        self.declare_seed()  # the episode's seed, from which the per-stroke aims are drawn
        self._estimate = self.DeclareVectorInputPort("estimated_state", 6)
        self._spin = self.DeclareVectorInputPort("estimated_spin", 3)
        self._status = self.DeclareVectorInputPort("estimator_status", 2)
        self._state_index = self.DeclareAbstractState(
            AbstractValue.Make(PlayerState(self.planner.awaiting_plan())))
        # On the planning ticks: a new estimate is acted on at the first tick after it.
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / rate, 0.0, self._update)
        self.DeclareForcedUnrestrictedUpdateEvent(self._update)

    @property
    def aims(self) -> CompetitiveAim | None:
        """The competitive aim's settings (class docstring); None: the planner's aim."""
        return None if self._aims is None else self._aims.aims

    @aims.setter
    def aims(self, aims: CompetitiveAim | None) -> None:
        self._aims = None if aims is None else StrokeAims(self.planner, aims)

    def player_state(self, context) -> PlayerState:
        return context.get_abstract_state(self._state_index).get_value()

    def _strokes(self, context, old: PlayerState, p_hit, v_hit, t_hit, spin,
                 fallbacks: bool = False,
                 near_previous: bool = False) -> Iterator[Stroke | None]:
        """The strokes to try for the prediction, best first (None: the arm cannot reach it):
        the stroke's chosen aim's (when the player has ``aims``), then the planner's own aim's,
        with ``fallbacks`` each of its fallbacks the arm reaches (:meth:`StrokePlanner.strokes`).
        Each planner corrects only a stroke it planned itself (``Stroke.aimed``);
        ``near_previous``: each arm solution nearest that stroke's posture
        (:meth:`StrokePlanner.committed_posture`)."""
        if self._aims is not None:
            previous = old.stroke if old.stroke is not None and old.stroke.aimed else None
            yield self._aims.stroke(self.seed(context), old.strokes, p_hit, v_hit, t_hit, spin,
                                    previous, near_previous)
        previous = old.stroke if old.stroke is not None and not old.stroke.aimed else None
        if fallbacks:
            yield from self.planner.strokes(p_hit, v_hit, t_hit, spin, previous, near_previous)
        else:
            yield self.planner.stroke(p_hit, v_hit, t_hit, spin, previous, near_previous)

    def _update(self, context, state):
        old = self.player_state(context)
        now = context.get_time()
        if old.committed:
            if self.play_again and self._ball_gone(context, old, now):
                state.get_mutable_abstract_state(self._state_index).set_value(
                    PlayerState(remaining(old.plan, now), None, False, old.seen, old.bounces,
                                 old.strokes + 1))
                return
            if self.corrections:
                self._correct(context, state, old, now)
            return
        plan = old.plan
        hit_segment = next((seg for stage, seg in plan.segments if stage == HITTING), None)
        if hit_segment is not None and now >= hit_segment.t0:
            new = PlayerState(plan, old.stroke, committed=True, bounces=old.bounces,
                               strokes=old.strokes)
            state.get_mutable_abstract_state(self._state_index).set_value(new)
            return
        fresh = self._fresh_prediction(context, state, old, old.committed)
        if fresh is None:
            return
        seen, bounces, (p_hit, v_hit, t_hit, spin, _) = fresh
        if t_hit - now < 0.05:
            return
        moved = self.planner.needs_replan(old.stroke, p_hit, t_hit, spin)
        if hit_segment is not None and not moved:
            return  # a stroke is planned and the prediction has not moved
        if hit_segment is None and not moved:
            strokes = (old.stroke,)  # waiting: same stroke, but decide again whether to start
        else:
            strokes = self._strokes(context, old, p_hit, v_hit, t_hit, spin,
                                    fallbacks=self.planner.config.plan_fallbacks)
        # The first stroke the arm can follow (or wait for) is planned; when it can follow none,
        # the plan is kept and the first stroke is recorded as the prediction acted on, so the
        # player plans again when the prediction moves.
        chosen = None
        for stroke in strokes:
            if stroke is None:
                continue
            new_plan, wait = self.planner.schedule(now, plan, stroke)
            if new_plan is not None or wait:
                chosen = (plan if new_plan is None else new_plan, stroke)
                break
            if chosen is None:
                chosen = (plan, stroke)
        if chosen is not None:
            state.get_mutable_abstract_state(self._state_index).set_value(
                PlayerState(*chosen, False, seen, bounces, old.strokes))

    def _ball_gone(self, context, old: PlayerState, now: float) -> bool:
        """After the planned hit, the estimator tracks a ball flying away from the robot."""
        if old.stroke is None or now <= old.stroke.t_hit:
            return False
        status = self._status.Eval(context)
        return status[0] > 0.5 and self._estimate.Eval(context)[4] > 0.0

    def _fresh_prediction(self, context, state, old: PlayerState, committed: bool,
                          predict: bool = True):
        """(seen, the bounces counted, the planner's prediction) from an estimate newer than
        the last one acted on, which the state then records as seen (with the bounces counted
        from it); None if there is none or it predicts no hit (or ``predict`` is off: the
        estimate is only recorded as seen)."""
        status = self._status.Eval(context)
        seen = float(status[1])
        if status[0] < 0.5 or not seen > old.seen:
            return None
        if not predict:
            state.get_mutable_abstract_state(self._state_index).set_value(
                PlayerState(old.plan, old.stroke, committed, seen, old.bounces, old.strokes))
            return None
        estimate = self._estimate.Eval(context)
        spin = self._spin.Eval(context) if self._spin.HasValue(context) else None
        bounces = self.planner.count_bounces(old.bounces, estimate, seen, spin)
        state.get_mutable_abstract_state(self._state_index).set_value(
            PlayerState(old.plan, old.stroke, committed, seen, bounces, old.strokes))
        prediction = self.planner.predict(estimate, seen, spin, bounces.count)
        return None if prediction is None else (seen, bounces, prediction)

    def _correct(self, context, state, old: PlayerState, now: float) -> None:
        """During the hitting stage: re-plan its rest on a prediction that moved more than the
        racket forgives, until ``correct_lead`` before the hit (class docstring)."""
        if old.stroke is None:
            return
        cfg = self.planner.config
        # Past the committed stroke's cut-off no prediction can correct it (the estimate is
        # still recorded as seen): the teacher's frames from there to the episode's end.
        before_cutoff = old.stroke.t_hit - now >= cfg.correct_lead
        fresh = self._fresh_prediction(context, state, old, True,
                                       predict=before_cutoff or self.predict_past_cutoff)
        if fresh is None:
            return
        seen, bounces, (p_hit, v_hit, t_hit, spin, _) = fresh
        if (not before_cutoff or t_hit - now < cfg.correct_lead
                or not self.planner.needs_correction(old.stroke, p_hit, t_hit, spin)):
            return
        # A correction the effort check refuses tries the planner's fallbacks in turn (a smaller
        # share of the spin compensated, the contact off the blade centre): after the robot-side
        # bounce the prediction can move by several centimetres (spin about the ball's direction
        # of travel makes no Magnus force, so the filter sees it only in the bounce), and the
        # full correction may ask the shoulder for more than the committed stroke left it.
        # With ``posture_fallback``, when every stroke is refused they are tried again with the
        # arm nearest the committed posture: the base, the slowest joint, then turns least.
        for near_committed in (False, True) if cfg.posture_fallback else (False,):
            for stroke in self._strokes(context, old, p_hit, v_hit, t_hit, spin,
                                        fallbacks=cfg.correction_fallbacks,
                                        near_previous=near_committed):
                plan = None if stroke is None else self.planner.correct(now, old.plan, stroke)
                if plan is not None:
                    state.get_mutable_abstract_state(self._state_index).set_value(
                        PlayerState(plan, stroke, True, seen, bounces, old.strokes))
                    return
