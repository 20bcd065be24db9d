"""The servo clock: set-points held for a tick, and the hitting configuration solved once per
prediction."""

import numpy as np
import pytest
from pydrake.common.value import AbstractValue
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from tt_drake import wam_params as wp
from tt_drake.stages import HITTING, Quintic, StagePlan
from tt_drake.systems.hitting_configuration import HittingConfiguration
from tt_drake.systems.immutable import Immutable
from tt_drake.systems.stage_player import StagePlanPlayer
from tt_drake.systems.wam import add_servo_hold

H = wp.SERVO_PERIOD
Q0 = np.asarray(wp.AWAITING, dtype=float)
# A fast move: 1 rad in 0.2 s on every joint (peak speed ~9.4 rad/s).
PLAN = StagePlan([(HITTING, Quintic.fit(0.0, 0.2, Q0, np.zeros(7), np.zeros(7), Q0 + 1.0,
                                        np.zeros(7), np.zeros(7)))])


class _Fixed(Immutable):
    __slots__ = ("plan", "stroke")

    def __init__(self, plan):
        self.plan, self.stroke = plan, None


class FixedPlanPlayer(StagePlanPlayer):
    def __init__(self, setpoint_lead):
        super().__init__(setpoint_lead)
        self._index = self.DeclareAbstractState(AbstractValue.Make(_Fixed(PLAN)))

    def player_state(self, context):
        return context.get_abstract_state(self._index).get_value()


def held_setpoints(lead, times):
    """The held (desired state (14), desired acceleration (7)) at ``times``."""
    held, _ = replayed_setpoints(FixedPlanPlayer(lead), times)
    return [(row[:14], row[14:]) for row in held]


def test_held_setpoint_is_the_plan_at_the_middle_of_its_tick():
    # Times inside ticks (never on a tick), from the first tick at t = 0 on.
    times = np.arange(0.0, 0.2, H) + 0.37 * H
    held = held_setpoints(0.5 * H, times)
    for t, (x, a) in zip(times, held, strict=True):
        tick = np.floor(t / H) * H
        q, v, acc = PLAN.evaluate(tick + 0.5 * H)
        np.testing.assert_allclose(x, np.r_[q, v], atol=1e-12)
        np.testing.assert_allclose(a, acc, atol=1e-12)


def test_half_tick_lead_removes_the_holds_lag():
    """Over a tick the held position differs from the plan by v (t_mid - t) + O(h^2): zero on
    average with the half-tick lead, v h / 2 (a lag) without it."""
    times = np.arange(0.0, 0.2, H / 8.0) + H / 16.0  # 8 samples centred in each tick
    plan_q = np.array([PLAN.evaluate(t)[0][0] for t in times])
    plan_v = np.array([PLAN.evaluate(t)[1][0] for t in times])
    for lead, expected_lag in ((0.5 * H, 0.0), (0.0, 0.5 * H)):
        held_q = np.array([x[0] for x, _ in held_setpoints(lead, times)])
        moving = plan_v > 1.0
        lag = np.mean((plan_q - held_q)[moving] / plan_v[moving])  # seconds behind the plan
        assert lag == pytest.approx(expected_lag, abs=0.02 * H)


class ReplanningPlayer(FixedPlanPlayer):
    """PLAN until its first 4 ms tick at or after ``switch_at``, then a re-plan from there: the
    rest of PLAN replaced by a quintic back towards Q0 (0.1 s)."""

    def __init__(self, setpoint_lead, setpoint_period=None, switch_at=0.05):
        StagePlanPlayer.__init__(self, setpoint_lead, setpoint_period)
        self._index = self.DeclareAbstractState(AbstractValue.Make(_Fixed(PLAN)))
        self.switch_at = switch_at
        self.DeclarePeriodicUnrestrictedUpdateEvent(2 * H, 0.0, self._switch)

    def _switch(self, context, state):
        t = context.get_time()
        if t < self.switch_at or self.player_state(context).plan is not PLAN:
            return
        zero = np.zeros(7)
        back = Quintic.fit(t, 0.1, *PLAN.evaluate(t), Q0 - 0.2, zero, zero)
        state.get_mutable_abstract_state(self._index).set_value(
            _Fixed(StagePlan(PLAN.truncated(t).segments + [(HITTING, back)])))


def replayed_setpoints(player, times):
    builder = DiagramBuilder()
    builder.AddSystem(player)
    hold = add_servo_hold(builder, player.GetOutputPort("setpoint"), None)
    builder.ExportOutput(hold.get_output_port(), "held")
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    simulator.Initialize()
    out = []
    for t in times:
        simulator.AdvanceTo(t)
        out.append(diagram.GetOutputPort("held").Eval(context).copy())
    return np.array(out), context


def test_tabled_setpoints_are_the_plans_values_across_a_replan():
    """With ``setpoint_period`` the servo reads a table made per plan (and per 32 ticks): the
    held set-points equal, to the last bit, those of one plan evaluation per tick, before and
    after a re-plan and past the plan's end; off the servo ticks the port evaluates the plan."""
    times = np.arange(0.0, 0.3, H) + 0.37 * H  # 150 ticks: the table is made anew on the way
    per_tick, _ = replayed_setpoints(ReplanningPlayer(0.5 * H), times)
    player = ReplanningPlayer(0.5 * H, setpoint_period=H)
    tabled, root = replayed_setpoints(player, times)
    np.testing.assert_array_equal(tabled, per_tick)
    context = player.GetMyContextFromRoot(root)
    plan = player.player_state(context).plan
    assert plan is not PLAN and player.setpoint_table.plan is plan  # the re-plan's table was read
    np.testing.assert_allclose(tabled[-1, :7], Q0 - 0.2, atol=1e-9)  # the re-plan's end, at rest
    np.testing.assert_allclose(tabled[-1, 7:], 0.0, atol=1e-9)
    off_tick = 0.1007  # inside the re-plan, between two ticks
    root.SetTime(off_tick)
    np.testing.assert_array_equal(player.GetOutputPort("setpoint").Eval(context),
                                  np.hstack(plan.evaluate(off_tick + 0.5 * H)))


def test_plan_table_rows_are_the_plans_values_at_the_ticks():
    """PlanTable (the MoMP hold's check reads one at the 250 Hz planning ticks, lead 0): at a
    tick k * period its row is the plan's (q, q_dot, q_ddot) to the last bit, past the table's
    end and for another plan too; off the ticks, or switched off, it has no row."""
    from tt_drake.systems.stage_player import PlanTable

    period = 2 * H
    table = PlanTable(period, ticks=8)
    replanned = StagePlan(PLAN.truncated(0.1).segments
                          + [(HITTING, Quintic.fit(0.1, 0.1, *PLAN.evaluate(0.1), Q0,
                                                   np.zeros(7), np.zeros(7)))])
    for plan, ks in ((PLAN, range(0, 30)), (replanned, range(25, 70))):
        for k in ks:
            np.testing.assert_array_equal(table.row(plan, k * period),
                                          np.hstack(plan.evaluate(k * period)))
        assert table.plan is plan
    assert table.row(replanned, 0.1001) is None
    table.ticks = 0
    assert table.row(replanned, 0.1) is None


class CountingModel:
    """A stand-in ConfigurationModel: theta = (s[:3], s[:3] + 1, 0), theta_dot = 2 s[:3] ..."""

    def __init__(self):
        self.calls = 0

    def predict(self, s, variance=True):
        self.calls += 1
        s = np.asarray(s, dtype=float)
        q = np.r_[s[:3], s[:3] + 1.0, 0.0]
        return q, 2.0 * q, float("nan")


def test_hitting_configuration_is_solved_once_per_prediction():
    model = CountingModel()
    config = HittingConfiguration("crkr", model=model)
    context = config.CreateDefaultContext()

    def predict(p, v, t, valid):
        config.GetInputPort("p_hit").FixValue(context, p)
        config.GetInputPort("v_hit").FixValue(context, v)
        config.GetInputPort("t_hit").FixValue(context, [t])
        config.GetInputPort("valid").FixValue(context, [valid])
        return [config.GetOutputPort(n).Eval(context).copy()
                for n in ("theta_hit", "theta_dot_hit", "valid")]

    q, qd, valid = predict([0.1, -1.9, 1.0], [0.5, -4.0, 1.0], 0.6, 0.0)
    assert valid[0] == 0.0 and model.calls == 0
    for _ in range(3):  # the same prediction read again (a tick later): no new solve
        q, qd, valid = predict([0.1, -1.9, 1.0], [0.5, -4.0, 1.0], 0.6, 1.0)
    assert model.calls == 1 and valid[0] == 1.0
    np.testing.assert_allclose(q, [0.1, -1.9, 1.0, 1.1, -0.9, 2.0, 0.0])
    np.testing.assert_allclose(qd, 2.0 * q)
    q, _, _ = predict([0.2, -1.9, 1.0], [0.5, -4.0, 1.0], 0.6, 1.0)
    assert model.calls == 2 and q[0] == pytest.approx(0.2)
