"""Players that a Gymnasium environment drives (:mod:`tt_drake.diagrams.gym_envs`).

:class:`StrokeOffsetPlayer` is the analytical player (the teacher) with one difference: at the
planning tick at which its hitting stage has begun (the player commits to its last stroke and
stops re-planning, paper section III-A) it ends the simulation step
(``EventStatus.ReachedTermination``), so that an episodic environment can show the stroke's
stimulus to an agent and let it change the stroke's end before the simulation goes on
(:meth:`StrokeOffsetPlayer.apply_offset`). An offset of zero leaves the plan exactly as the
analytical player made it.

:class:`SetpointIncrementPlayer` takes an action every control period: joint set-point
increments. Ports: input ``increment`` (7, each in [-1, 1]); outputs ``desired_state`` (14) and
``desired_acceleration`` (7) for the servo holds, as the other players. :class:`SetpointOffset`
turns the same increments into an offset added to another player's desired joint positions.

:class:`AbsoluteStrokePlayer` has no teacher: it holds the awaiting posture, watches the
estimator, and ends the simulation step at its decision point (the first planning tick at which
the tracked ball has crossed the net toward the robot), with the *hittable window* of the ball's
predicted path (:func:`hittable_window`). The agent then chooses the whole stroke's end
(theta_hit, theta_dot_hit, t_hit; :meth:`AbsoluteStrokePlayer.apply_stroke`), which the stage
planner turns into preparation, hitting, follow-through and return as it does for the teacher
(:func:`tt_drake.stages.plan_stroke`).
"""

import dataclasses

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, EventStatus, LeafSystem

from tt_drake import wam_params as wp
from tt_drake.ball_model import BallModel
from tt_drake.constants import BALL, PLANES, TABLE
from tt_drake.hitting_time import last_robot_bounce
from tt_drake.stages import (
    AWAITING,
    FOLLOW_THROUGH,
    HITTING,
    Quintic,
    follow_through_time,
    plan_stroke,
    return_duration,
)
from tt_drake.systems.analytical_player import (
    AnalyticalPlayer,
    PlayerState,
    Stroke,
    StrokePlanner,
)
from tt_drake.systems.immutable import Immutable
from tt_drake.systems.stage_player import StagePlanPlayer


class StrokeOffsetPlayer(AnalyticalPlayer):
    """The analytical player, pausing the simulation when it commits (module docstring).

    The agent's stroke is final: this player makes no corrections after the hitting stage has
    begun (``corrections=False``; the analytical player's corrections would overwrite the
    agent's offset), so action 0 is the teacher without post-commit corrections."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("corrections", False)
        super().__init__(*args, **kwargs)

    def _update(self, context, state):
        was_committed = self.player_state(context).committed
        super()._update(context, state)
        new = state.get_mutable_abstract_state(self._state_index).get_value()
        if new.committed and not was_committed:
            return EventStatus.ReachedTermination(self, "committed to the stroke")
        return EventStatus.Succeeded()

    def apply_offset(self, context, dq_hit, dqd_hit) -> Stroke:
        """Re-fit the committed stroke to end at (theta_hit + dq_hit, theta_dot_hit + dqd_hit),
        clipped to the joint position limits (less their margin) and velocity limits.

        The hitting segment keeps its start (time and state) and duration; the follow-through and
        the return to the awaiting posture are re-planned from the new end as
        :func:`tt_drake.stages.plan_stroke` plans them. Segments before the hitting stage are
        kept. With zero offsets the plan is rebuilt bit for bit. Returns the new stroke."""
        old = self.player_state(context)
        if not old.committed or old.stroke is None:
            raise RuntimeError("the player has not committed to a stroke")
        planner = self.planner
        limits, times = planner.limits, planner.config.times
        index = next(i for i, (stage, _) in enumerate(old.plan.segments) if stage == HITTING)
        hit_old = old.plan.segments[index][1]
        stroke = old.stroke
        q_hit = np.clip(stroke.q_hit + np.asarray(dq_hit, dtype=float),
                        limits.lower + limits.margin, limits.upper - limits.margin)
        qd_hit = np.clip(stroke.qd_hit + np.asarray(dqd_hit, dtype=float),
                         -limits.velocity, limits.velocity)
        zero = np.zeros(7)
        q0, v0, a0 = hit_old.evaluate(hit_old.t0)
        hit = Quintic.fit(hit_old.t0, hit_old.duration, q0, v0, a0, q_hit, qd_hit, zero)
        t_follow = follow_through_time(q_hit, qd_hit, limits, times)
        q_end = limits.clip(q_hit + 0.5 * t_follow * qd_hit)
        follow = Quintic.fit(stroke.t_hit, t_follow, q_hit, qd_hit, zero, q_end, zero, zero)
        back = Quintic.fit(follow.t_end, return_duration(q_end, planner.q_await, limits, times),
                           q_end, zero, zero, planner.q_await, zero, zero)
        plan = type(old.plan)(old.plan.segments[:index] + [
            (HITTING, hit), (FOLLOW_THROUGH, follow), (AWAITING, back)])
        new_stroke = dataclasses.replace(stroke, q_hit=q_hit, qd_hit=qd_hit)
        state = PlayerState(plan, new_stroke, True, old.seen, old.bounces)
        context.get_mutable_abstract_state(self._state_index).set_value(state)
        return new_stroke


#: The window's step (s) when it follows the path from the robot-side bounce down to the table's
#: contact height: 2 ms, about 1 cm of the ball's travel.
WINDOW_STEP = 2e-3
#: The longest window (s) looked for after the bounce.
WINDOW_MAX = 1.0


@dataclasses.dataclass(frozen=True)
class Window:
    """The hittable part of a predicted path, times relative to the state it was predicted from
    (s): ``start`` the bounce on the robot's half (0 if it has bounced already), ``end`` where the
    ball's centre comes down to the table's contact height again: its second bounce if it is
    over the table, else below the playing surface beyond the robot's end. ``plane``: the ball's
    state (p, v) and time where it crosses the virtual hitting plane inside the window, or None.
    """

    start: float
    end: float
    plane: tuple[np.ndarray, np.ndarray, float] | None


def hittable_window(model: BallModel, state) -> Window | None:
    """When the ball may be hit (:class:`Window`; the rules allow one bounce on the receiver's
    half before the hit, ITTF Law 2.10.1.3), predicted from ``state`` = (p, v[, omega]) by
    ``model``; None if the ball is not predicted to bounce on the robot's half."""
    s = np.asarray(state, dtype=float).reshape(-1)
    s = np.r_[s, np.zeros(3)] if s.size == 6 else s
    if last_robot_bounce(model, s) is not None:
        start = 0.0
    else:
        bounce = model.first_bounce(s)
        if bounce is None or bounce.position[1] >= 0.0:
            return None
        start = bounce.t
    # From just after the bounce, in flight (flight_step: no table) until z falls to the contact
    # height z_c = table + r: the second bounce over the table, or under the table's height.
    after = model.predict_time(s, start + WINDOW_STEP)
    pos, vel, w = tuple(after.position), tuple(after.velocity), tuple(after.spin)
    contact_z = TABLE.surface_z + BALL.radius
    t, end = start + WINDOW_STEP, None
    while t < start + WINDOW_MAX:
        new_pos, new_vel = model.flight_step(pos, vel, w, WINDOW_STEP)
        if new_pos[2] <= contact_z:  # linear interpolation inside the step
            end = t + WINDOW_STEP * (pos[2] - contact_z) / (pos[2] - new_pos[2])
            break
        pos, vel, t = new_pos, new_vel, t + WINDOW_STEP
    end = t if end is None else end
    crossing = model.predict_plane(s, PLANES.hitting_y)
    plane = None
    if crossing is not None and start <= crossing.t <= end:
        plane = (crossing.position, crossing.velocity, float(crossing.t))
    return Window(float(start), float(end), plane)


@dataclasses.dataclass(frozen=True)
class AgentStroke:
    """The stroke an agent chose: the predicted ball position at the hit (``p_hit``, for the
    ``predicted_hit`` port), the hitting configuration and time (absolute)."""

    p_hit: np.ndarray
    q_hit: np.ndarray
    qd_hit: np.ndarray
    t_hit: float


class _Decision(Immutable):
    """The absolute player's state: its stage plan, the agent's stroke (None before it), whether
    it has reached its decision point, and there the estimate (p, v, omega, its time) and the
    window (absolute times; None: no window)."""

    __slots__ = ("plan", "stroke", "decided", "estimate", "window")

    def __init__(self, plan, stroke=None, decided=False, estimate=None, window=None):
        self.plan, self.stroke, self.decided = plan, stroke, decided
        self.estimate, self.window = estimate, window


class AbsoluteStrokePlayer(StagePlanPlayer):
    """An agent's stroke from scratch (module docstring). Inputs ``estimated_state`` (6),
    ``estimated_spin`` (3, optional: zeros if unconnected), ``estimator_status`` (2); the
    stage-plan player's outputs.

    Decision point: the first planning tick at which the estimator tracks a ball coming toward
    the robot (v_y < 0) whose estimate has crossed y = ``decision_y`` (default 0, the net);
    the update then returns ``EventStatus.ReachedTermination`` so that the simulator stops for
    the agent. ``planner``: a :class:`StrokePlanner`, of which only the parts that are not the
    teacher's choices serve: its ball model (the window's prediction), joint limits, stage
    durations and awaiting posture; it takes the teacher's place in the serve diagram
    (:func:`tt_drake.diagrams.episodes.add_analytical_player` wires it with ``player_type``)."""

    def __init__(self, planner: StrokePlanner | None = None, decision_y: float = 0.0,
                 rate: float = wp.PLANNING_RATE, setpoint_lead: float = 0.0,
                 setpoint_period: float | None = None):
        super().__init__(setpoint_lead, setpoint_period)
        self.planner = planner or StrokePlanner()
        self.model, self.limits = self.planner.model, self.planner.limits
        self.decision_y = float(decision_y)
        self._estimate = self.DeclareVectorInputPort("estimated_state", 6)
        self._spin = self.DeclareVectorInputPort("estimated_spin", 3)
        self._status = self.DeclareVectorInputPort("estimator_status", 2)
        self._state_index = self.DeclareAbstractState(
            AbstractValue.Make(_Decision(self.planner.awaiting_plan())))
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / rate, 0.0, self._update)

    def player_state(self, context) -> _Decision:
        return context.get_abstract_state(self._state_index).get_value()

    def _update(self, context, state):
        old = self.player_state(context)
        if old.decided:
            return EventStatus.Succeeded()
        status = self._status.Eval(context)
        estimate = self._estimate.Eval(context)
        if status[0] < 0.5 or estimate[4] >= 0.0 or estimate[1] > self.decision_y:
            return EventStatus.Succeeded()
        spin = self._spin.Eval(context) if self._spin.HasValue(context) else np.zeros(3)
        ball = np.r_[estimate, spin]
        window = hittable_window(self.model, ball)
        t_estimate = float(status[1])
        if window is not None:
            plane = window.plane
            window = Window(t_estimate + window.start, t_estimate + window.end,
                            None if plane is None else (plane[0], plane[1], t_estimate + plane[2]))
        state.get_mutable_abstract_state(self._state_index).set_value(
            _Decision(old.plan, None, True, (ball, t_estimate), window))
        return EventStatus.ReachedTermination(self, "decision point: the agent's stroke")

    def apply_stroke(self, context, q_hit, qd_hit, t_hit: float) -> AgentStroke:
        """Plan the stroke that reaches (``q_hit``, ``qd_hit``) at ``t_hit`` (absolute, s) from
        the awaiting posture: :func:`tt_drake.stages.plan_stroke` (a swing-back when there is
        time for one, else a direct hitting segment; follow-through; return), with q_hit
        clipped to the joint limits less their margin, qd_hit to the velocity limits and t_hit
        to at least one planning tick ahead."""
        old = self.player_state(context)
        if not old.decided:
            raise RuntimeError("the player has not reached its decision point")
        now = context.get_time()
        limits = self.limits
        q_hit = limits.clip(np.asarray(q_hit, dtype=float))
        qd_hit = np.clip(np.asarray(qd_hit, dtype=float), -limits.velocity, limits.velocity)
        t_hit = max(float(t_hit), now + 1.0 / wp.PLANNING_RATE)
        plan = plan_stroke(now, old.plan.evaluate(now), t_hit, q_hit, qd_hit,
                           self.planner.q_await, limits, self.planner.config.times,
                           preparing=False, allow_wait=False)
        ball, t_estimate = old.estimate
        p_hit = self.model.predict_time(ball, t_hit - t_estimate).position
        stroke = AgentStroke(np.asarray(p_hit), q_hit, qd_hit, t_hit)
        context.get_mutable_abstract_state(self._state_index).set_value(
            _Decision(plan, stroke, True, old.estimate, old.window))
        return stroke


class SetpointIncrementPlayer(LeafSystem):
    """Joint set-points moved by the agent: every ``1 / rate`` seconds it reads ``increment``
    a in [-1, 1]^7 and moves the set-point by dq = a * max_increment over the next period, along
    a straight line at constant velocity:

        q_d(t) = q_k + s dq,  q_dot_d = dq * rate,  q_ddot_d = 0,  s = (t - t_k) * rate in [0, 1],

    with q_{k+1} = q_k + dq; dq is shortened so that q_{k+1} stays within the joint limits (less
    the planner's 0.05 rad margin). ``max_increment`` defaults to the joint velocity limits times
    the period: a = +-1 moves the set-point at the WAM's speed limit. The set-point starts at the
    awaiting posture.

    The updates happen at k / rate + ``offset``. A Gymnasium step advances the simulation from
    t to t + 1 / rate in floating point: with ``offset`` = 0 an update can fall on either side of
    a step's end, so that the environment uses one servo tick as the offset (every step then
    holds exactly one update, reading that step's action).

    The discrete state is (t_k, q_k, dq); the outputs evaluate it at ``t + setpoint_lead`` with
    plain floats (O(1)), as the stage players.
    """

    def __init__(self, rate: float, setpoint_lead: float = 0.0, max_increment=None,
                 offset: float = 0.0):
        super().__init__()
        self.rate = float(rate)
        self.setpoint_lead = float(setpoint_lead)
        limit = np.asarray(wp.VELOCITY_LIMIT, dtype=float) / self.rate
        self.max_increment = limit if max_increment is None else np.asarray(max_increment, float)
        margin = 0.05
        self.lower = np.asarray(wp.JOINT_LOWER, dtype=float) + margin
        self.upper = np.asarray(wp.JOINT_UPPER, dtype=float) - margin
        self._action = self.DeclareVectorInputPort("increment", 7)
        x0 = np.r_[0.0, np.asarray(wp.AWAITING, dtype=float), np.zeros(7)]
        self._xd = self.DeclareDiscreteState(x0)
        self.DeclarePeriodicDiscreteUpdateEvent(1.0 / self.rate, float(offset), self._update)
        deps = {self.xd_ticket()}
        self.DeclareVectorOutputPort("desired_state", BasicVector(14), self._calc_state,
                                     prerequisites_of_calc=deps)
        self.DeclareVectorOutputPort("desired_acceleration", BasicVector(7), self._calc_accel,
                                     prerequisites_of_calc=deps)

    def _update(self, context, discrete_state):
        x = context.get_discrete_state(self._xd).get_value()
        q = np.clip(x[1:8] + x[8:15], self.lower, self.upper)
        a = np.clip(np.nan_to_num(self._action.Eval(context)), -1.0, 1.0)
        dq = np.clip(q + a * self.max_increment, self.lower, self.upper) - q
        discrete_state.set_value(self._xd, np.r_[context.get_time(), q, dq])

    def _calc_state(self, context, output):
        x = context.get_discrete_state(self._xd).get_value()
        s = min(max((context.get_time() + self.setpoint_lead - x[0]) * self.rate, 0.0), 1.0)
        out = output.get_mutable_value()
        for i in range(7):
            out[i] = x[1 + i] + s * x[8 + i]
            out[7 + i] = x[8 + i] * self.rate

    def _calc_accel(self, context, output):
        output.get_mutable_value()[:] = 0.0


class SetpointOffset(LeafSystem):
    """The agent's offset to another player's desired joint positions (the step environment's
    ``player`` option): every ``1 / rate`` seconds, at k / rate + ``offset``, it reads
    ``increment`` a in [-1, 1]^7 and adds a * ``max_increment`` to the offset dq, each joint's
    kept within +-``max_offset`` (rad). Output ``desired_state`` (14): (dq, 0), constant between
    updates (from the discrete state: no work inside the integrator's steps). ``max_increment``
    defaults to the joint velocity limits times the period, as :class:`SetpointIncrementPlayer`'s.
    """

    def __init__(self, rate: float, max_increment=None, max_offset: float = 0.5,
                 offset: float = 0.0):
        super().__init__()
        self.rate = float(rate)
        limit = np.asarray(wp.VELOCITY_LIMIT, dtype=float) / self.rate
        self.max_increment = limit if max_increment is None else np.asarray(max_increment, float)
        self.max_offset = float(max_offset)
        self._action = self.DeclareVectorInputPort("increment", 7)
        self._xd = self.DeclareDiscreteState(7)
        self.DeclarePeriodicDiscreteUpdateEvent(1.0 / self.rate, float(offset), self._update)
        self.DeclareVectorOutputPort("desired_state", BasicVector(14), self._calc_state,
                                     prerequisites_of_calc={self.xd_ticket()})

    def _update(self, context, discrete_state):
        dq = context.get_discrete_state(self._xd).get_value()
        a = np.clip(np.nan_to_num(self._action.Eval(context)), -1.0, 1.0)
        discrete_state.set_value(self._xd, np.clip(dq + a * self.max_increment,
                                                   -self.max_offset, self.max_offset))

    def _calc_state(self, context, output):
        output.SetFromVector(np.r_[context.get_discrete_state(self._xd).get_value(),
                                   np.zeros(7)])


class StepObservation(LeafSystem):
    """The step-based environment's observation (22): the arm's state (q, q_dot), the
    estimator's ball state (p, v) and status (tracking flag, time of the estimate: 0 before the
    first frame), each clipped to :attr:`high` (so that it always lies in the observation space:
    joints within +-2 pi rad and +-50 rad/s, the ball within +-10 m and +-50 m/s, times within
    [0, 60] s). Inputs ``arm_state`` (14), ``ball_state`` (6), ``ball_status`` (2); output
    ``observation``."""

    high = np.r_[np.full(7, 2 * np.pi), np.full(7, 50.0), np.full(3, 10.0), np.full(3, 50.0),
                 1.0, 60.0]
    low = np.r_[-high[:20], 0.0, 0.0]

    def __init__(self):
        super().__init__()
        self.DeclareVectorInputPort("arm_state", 14)
        self.DeclareVectorInputPort("ball_state", 6)
        self.DeclareVectorInputPort("ball_status", 2)
        self.DeclareVectorOutputPort("observation", BasicVector(22), self._calc)

    def _calc(self, context, output):
        x = np.r_[self.get_input_port(0).Eval(context), self.get_input_port(1).Eval(context),
                  self.get_input_port(2).Eval(context)]
        output.SetFromVector(np.clip(np.nan_to_num(x, nan=0.0), self.low, self.high))
