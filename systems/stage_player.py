"""The output side shared by the players that execute a stage plan.

A player keeps, in its abstract state, an object with ``plan`` (a
:class:`tt_drake.stages.StagePlan` or anything with ``evaluate(t)`` and ``stage_at(t)``) and
``stroke`` (its planned stroke, or None). This base declares the ports the serve diagram wires:
``desired_state`` (14: q, q_dot) and ``desired_acceleration`` (7) for the
InverseDynamicsController, ``setpoint`` (21: both at once, what the servo hold samples),
``stage`` (1: index into :data:`tt_drake.stages.STAGES`), ``stroke`` (abstract) and
``predicted_hit`` (4: where the stroke meets the ball, and a valid flag).

The desired-value ports share one plan evaluation per (plan, time), an O(1) polynomial evaluation
(docs/design.md, "Clocks"). In the serve diagram ``setpoint`` feeds the controller through the
servo's zero-order hold (:func:`tt_drake.systems.wam.add_servo_hold`), so it is evaluated once per
servo tick, at ``t + setpoint_lead`` (half a tick: the held value is the plan at the middle of its
tick). With ``setpoint_period`` (the servo's), ``setpoint`` is read from a table of the plan at the
next :data:`SETPOINT_TABLE_TICKS` servo ticks, computed in one vectorised evaluation
(:meth:`tt_drake.stages.StagePlan.evaluate_many`, the same numbers as one evaluation per tick) when
a tick finds a new plan or runs past the table: a servo tick then costs one row copy
(docs/performance.md, "The players' Python").
"""

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, LeafSystem

from tt_drake.stages import STAGES, StagePlan

# Servo ticks per set-point table (64 ms at 500 Hz): a momp serve re-plans ~13 times over ~760
# ticks, the teacher ~34 times (its corrections), so most tables are used to their end.
SETPOINT_TABLE_TICKS = 32


class PlanTable:
    """A plan's (q, q_dot, q_ddot) at the ticks ``k * period`` of a periodic event, evaluated at
    ``k * period + lead``: made for the next ``ticks`` ticks at once
    (:meth:`tt_drake.stages.StagePlan.evaluate_many`, the same numbers as one ``evaluate`` per
    tick) when a tick finds another plan than the table's or runs past its end."""

    def __init__(self, period: float, lead: float = 0.0, ticks: int = SETPOINT_TABLE_TICKS):
        self.period, self.lead, self.ticks = float(period), float(lead), int(ticks)
        self._table = None  # (plan, first tick index, (ticks, 3 n_dof) values)

    @property
    def plan(self):
        """The plan of the table made last (None before the first)."""
        return None if self._table is None else self._table[0]

    def row(self, plan, now: float):
        """``np.hstack(plan.evaluate(now + lead))`` when ``now`` is a tick (the simulator's
        periodic event times are k * period exactly), from the table; None when it is not a
        tick, ``ticks`` is 0 (off) or ``plan`` has no ``evaluate_many``."""
        if not self.ticks:
            return None
        period = self.period
        k = round(now / period)
        if k * period != now:
            return None
        table = self._table
        if table is not None and table[0] is plan:
            i = k - table[1]
            if 0 <= i < table[2].shape[0]:
                return table[2][i]
        if not hasattr(plan, "evaluate_many"):
            return None
        rows = np.hstack(plan.evaluate_many((k + np.arange(self.ticks)) * period + self.lead))
        self._table = (plan, k, rows)
        return rows[0]


class StagePlanPlayer(LeafSystem):
    def __init__(self, setpoint_lead: float = 0.0, setpoint_period: float | None = None):
        """``setpoint_lead``: the ports evaluate the plan at ``t + setpoint_lead``.
        ``setpoint_period``: the servo period whose ticks (k * period) sample ``setpoint``;
        with it the set-points are tabulated (module docstring); None: evaluated per call."""
        super().__init__()
        self._memo = None
        self.setpoint_lead = float(setpoint_lead)
        self.setpoint_table = (None if setpoint_period is None
                               else PlanTable(setpoint_period, self.setpoint_lead))
        self.DeclareVectorOutputPort("desired_state", BasicVector(14), self._calc_state)
        self.DeclareVectorOutputPort("desired_acceleration", BasicVector(7), self._calc_accel)
        self.DeclareVectorOutputPort("setpoint", BasicVector(21), self._calc_setpoint)
        self.DeclareVectorOutputPort("stage", BasicVector(1), self._calc_stage)
        self.DeclareVectorOutputPort("predicted_hit", BasicVector(4), self._calc_predicted_hit)
        self.DeclareAbstractOutputPort("stroke", lambda: AbstractValue.Make(object()),
                                       self._calc_stroke)

    def player_state(self, context):
        """The abstract state holding ``plan`` and ``stroke`` (subclasses)."""
        raise NotImplementedError

    @staticmethod
    def hit_point(stroke):
        """Where ``stroke`` expects to meet the ball (3 floats)."""
        return stroke.p_hit

    def _evaluate(self, context):
        """(q, q_dot, q_ddot) of the stored plan at ``t + setpoint_lead``, evaluated once per
        (plan, time)."""
        plan = self.player_state(context).plan
        t = context.get_time() + self.setpoint_lead
        memo = self._memo
        if memo is not None and memo[0] is plan and memo[1] == t:
            return memo[2]
        result = plan.evaluate(t)
        self._memo = (plan, t, result)
        return result

    def _calc_state(self, context, output):
        q, qd, _ = self._evaluate(context)
        out = output.get_mutable_value()
        out[:7] = q
        out[7:] = qd

    def _calc_accel(self, context, output):
        output.get_mutable_value()[:] = self._evaluate(context)[2]

    def _calc_setpoint(self, context, output):
        table = self.setpoint_table
        row = None if table is None else table.row(self.player_state(context).plan,
                                                   context.get_time())
        if row is not None:
            output.get_mutable_value()[:] = row
            return
        q, qd, qdd = self._evaluate(context)
        out = output.get_mutable_value()
        out[:7] = q
        out[7:14] = qd
        out[14:] = qdd

    def _calc_stage(self, context, output):
        stage = self.player_state(context).plan.stage_at(context.get_time())
        output.get_mutable_value()[0] = STAGES.index(stage)

    def _calc_predicted_hit(self, context, output):
        stroke = self.player_state(context).stroke
        out = output.get_mutable_value()
        if stroke is None:
            out[:] = 0.0
        else:
            out[:3] = self.hit_point(stroke)
            out[3] = 1.0

    def _calc_stroke(self, context, output):
        output.set_value(self.player_state(context).stroke)


def remaining(plan: StagePlan, now: float) -> StagePlan:
    """The segments of ``plan`` not over at ``now`` (the last one if all are): a player free to
    play again keeps moving as planned, and its next stroke's stages are the only hitting stage
    its plan holds."""
    return StagePlan([(s, q) for s, q in plan.segments if q.t_end > now] or plan.segments[-1:])
