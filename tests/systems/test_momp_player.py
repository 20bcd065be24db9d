"""MoMPTrajectorySource through its ports: a whole stroke with fixed inputs, and a re-plan."""

import numpy as np
import pytest

from tt_drake import wam_params as wp
from tt_drake.dmp import HittingDMP
from tt_drake.imitation import quintic_demonstration
from tt_drake.learned_player import StagePrimitive
from tt_drake.momp import MotorPrimitiveLibrary
from tt_drake.stages import AWAITING, FOLLOW_THROUGH, HITTING, PREPARATION, STAGES
from tt_drake.systems.momp_player import MoMPTrajectorySource

Q_AWAIT = np.asarray(wp.AWAITING, dtype=float)
Q_HIT = Q_AWAIT + np.array([0.3, 0.2, -0.1, -0.3, 0.1, -0.1, 0.2])
QD_HIT = np.array([2.0, 1.0, -0.5, -1.5, 0.5, 1.0, -1.0])
T_HIT = 0.9


def synthetic_library(n: int = 6, seed: int = 0):
    """A small library imitated from quintic hitting demonstrations with backswings, and stage
    DMPs from rest-to-rest (or from-velocity) quintics."""
    dmp = HittingDMP()
    rng = np.random.default_rng(seed)
    demos, stimuli = [], []
    for i in range(n):
        q_hit = Q_AWAIT + rng.uniform(-0.3, 0.3, 7)
        qd_hit = rng.uniform(-2.0, 2.0, 7)
        demos.append(quintic_demonstration(0.4, q_hit - 0.2 * qd_hit, q_hit, qd_hit,
                                           backswing=0.03 * i))
        stimuli.append(rng.normal(size=6))
    library = MotorPrimitiveLibrary.from_demonstrations(dmp, demos, np.array(stimuli))
    zero = np.zeros(7)
    follow = quintic_demonstration(0.3, Q_AWAIT, Q_AWAIT + 0.2, zero)
    stages = {PREPARATION: StagePrimitive.imitate(dmp, quintic_demonstration(0.5, Q_AWAIT,
                                                                             Q_AWAIT + 0.3, zero)),
              FOLLOW_THROUGH: StagePrimitive.imitate(dmp, follow),
              AWAITING: StagePrimitive.imitate(dmp, quintic_demonstration(0.8, Q_AWAIT + 0.2,
                                                                          Q_AWAIT, zero))}
    return library, stages, np.array(stimuli)


def fix_inputs(player, context, stimulus, t_hit, q_hit=Q_HIT, qd_hit=QD_HIT, valid=1.0):
    player.GetInputPort("p_hit").FixValue(context, stimulus[:3])
    player.GetInputPort("v_hit").FixValue(context, stimulus[3:6])
    player.GetInputPort("t_hit").FixValue(context, [t_hit])
    player.GetInputPort("theta_hit").FixValue(context, q_hit)
    player.GetInputPort("theta_dot_hit").FixValue(context, qd_hit)
    player.GetInputPort("configuration_valid").FixValue(context, [valid])


def outputs(player, context, t):
    context.SetTime(t)
    x = player.GetOutputPort("desired_state").Eval(context).copy()
    a = player.GetOutputPort("desired_acceleration").Eval(context).copy()
    return x[:7], x[7:], a, int(player.GetOutputPort("stage").Eval(context)[0])


@pytest.fixture(scope="module")
def stroke_run():
    library, stages, stimuli = synthetic_library()
    player = MoMPTrajectorySource(library, stages)
    context = player.CreateDefaultContext()
    fix_inputs(player, context, stimuli[2], T_HIT, valid=0.0)
    samples = []
    for frame, t in enumerate(np.arange(0.0, T_HIT + 1.6, 1e-3)):
        context.SetTime(t)
        if frame % 17 == 0:  # ~60 Hz
            if abs(t - 0.1) < 0.009:
                fix_inputs(player, context, stimuli[2], T_HIT)  # the prediction arrives
            player.ExecuteForcedEvents(context)
        samples.append((t, *outputs(player, context, t)))
    return player, context, samples, stimuli


def test_stage_order(stroke_run):
    *_, samples, _ = stroke_run
    stages = [STAGES[s[4]] for s in samples]
    order = [stages[0]] + [b for a, b in zip(stages, stages[1:], strict=False) if a != b]
    assert order == [AWAITING, PREPARATION, HITTING, FOLLOW_THROUGH, AWAITING]


def test_arrives_at_the_hitting_configuration_at_t_hit(stroke_run):
    player, context, _, _ = stroke_run
    q, qd, _, _ = outputs(player, context, T_HIT)
    np.testing.assert_allclose(q, Q_HIT, atol=1e-3)
    np.testing.assert_allclose(qd, QD_HIT, atol=2e-2)
    stroke = player.GetOutputPort("stroke").Eval(context)
    assert stroke.t_hit == T_HIT and len(stroke.primitives) >= 1 and not stroke.fallback
    assert np.isclose(stroke.mixture.sum(), 1.0)
    predicted = player.GetOutputPort("predicted_hit").Eval(context)
    assert predicted[3] == 1.0


def test_continuous_at_stage_boundaries(stroke_run):
    player, context, _, _ = stroke_run
    plan = player.player_state(context).plan
    for _, seg in plan.segments[:-1]:
        before = plan.evaluate(seg.t_end - 1e-9)
        after = plan.evaluate(seg.t_end + 1e-9)
        for x, y, tol in zip(before, after, (1e-6, 1e-5, 1e-3), strict=True):
            np.testing.assert_allclose(x, y, atol=tol)
    # and sampled at 1 kHz: no jumps anywhere (bounded by the largest acceleration / jerk)
    _, _, samples, _ = stroke_run
    q = np.array([s[1] for s in samples])
    qd = np.array([s[2] for s in samples])
    qdd = np.array([s[3] for s in samples])
    assert np.abs(np.diff(q, axis=0)).max() <= 1e-3 * np.abs(qd).max() + 1e-6
    assert np.abs(np.diff(qd, axis=0)).max() <= 1e-3 * np.abs(qdd).max() + 1e-6
    assert np.abs(np.diff(qdd, axis=0)).max() < 5.0  # rad/s^2 per ms: no acceleration jump
    # back at rest in the awaiting posture
    np.testing.assert_allclose(q[-1], Q_AWAIT, atol=1e-3)
    np.testing.assert_allclose(qd[-1], 0.0, atol=1e-2)


def test_replans_from_the_current_state_until_the_hitting_stage():
    library, stages, stimuli = synthetic_library()
    player = MoMPTrajectorySource(library, stages)
    context = player.CreateDefaultContext()
    fix_inputs(player, context, stimuli[0], T_HIT)
    context.SetTime(0.1)
    player.ExecuteForcedEvents(context)
    context.SetTime(0.3)  # mid-preparation: a better prediction moves the hit
    before = player.player_state(context).plan.evaluate(0.3)
    fix_inputs(player, context, stimuli[0] + 0.05, T_HIT + 0.02, Q_HIT + 0.05, QD_HIT)
    player.ExecuteForcedEvents(context)
    state = player.player_state(context)
    assert state.stroke.replans == 2
    after = state.plan.evaluate(0.3 + 1e-9)
    for x, y in zip(before, after, strict=True):
        np.testing.assert_allclose(x, y, atol=1e-4)
    np.testing.assert_allclose(state.plan.evaluate(T_HIT + 0.02)[0], Q_HIT + 0.05, atol=1e-3)
    # once the hitting stage has begun the plan is kept
    context.SetTime(T_HIT - 0.1)
    player.ExecuteForcedEvents(context)
    fix_inputs(player, context, stimuli[1], T_HIT + 0.1)
    context.SetTime(T_HIT - 0.08)
    player.ExecuteForcedEvents(context)
    assert player.player_state(context).committed
    assert player.player_state(context).stroke.replans == 2


def test_planning_ticks_without_anything_new_report_that_they_did_nothing():
    """A tick with no valid configuration, with the prediction already acted on, or once
    committed returns "did nothing" and leaves the state it was given as it was (the simulator
    then skips writing it back); a tick with a new prediction, or the one that commits, does
    not."""
    from pydrake.systems.framework import EventStatus

    nothing = EventStatus.Severity.kDidNothing
    library, stages, stimuli = synthetic_library()
    player = MoMPTrajectorySource(library, stages)
    context = player.CreateDefaultContext()

    def tick(t):
        """(the update's status, whether it replaced the state) at ``t``, on a scratch copy."""
        context.SetTime(t)
        scratch = context.Clone()
        before = player.player_state(context)
        status = player._update(context, scratch.get_mutable_state())
        did_nothing = status is not None and status.severity() == nothing
        return did_nothing, player.player_state(scratch) is not before

    fix_inputs(player, context, stimuli[0], T_HIT, valid=0.0)
    assert tick(0.1) == (True, False)  # no valid configuration
    fix_inputs(player, context, stimuli[0], T_HIT)
    assert tick(0.1) == (False, True)  # a new prediction: planned
    player.ExecuteForcedEvents(context)
    assert player.player_state(context).stroke is not None
    assert tick(0.104) == (True, False)  # the same prediction again
    assert tick(T_HIT - 0.1) == (False, True)  # the hitting stage has begun: commits
    player.ExecuteForcedEvents(context)
    assert player.player_state(context).committed
    assert tick(T_HIT - 0.096) == (True, False)


def test_output_evaluation_is_constant_time(stroke_run):
    """The same work per evaluation early and late in a long segment: one stored row read (the
    row of the sample interval holding t), whatever the time."""
    from tt_drake.learned_player import SampledSegment

    player, context, _, _ = stroke_run
    plan = player.player_state(context).plan
    seg = plan.segments[-1][1]
    assert isinstance(seg, SampledSegment) and seg.coeffs.shape[0] > 100

    class CountingRows:
        def __init__(self, rows):
            self.rows, self.read = rows, []
            self.shape = rows.shape

        def __getitem__(self, k):
            self.read.append(k)
            return self.rows[k]

    counting = CountingRows(seg.coeffs)
    probe = SampledSegment(seg.t0, seg.dt, counting, seg.duration)
    for t in (seg.t0 + 1e-3, seg.t_end - 1e-3):
        counting.read.clear()
        for got, want in zip(probe.evaluate(t), seg.evaluate(t), strict=True):
            np.testing.assert_array_equal(got, want)
        assert counting.read == [int((t - seg.t0) / seg.dt)]


def test_a_late_prediction_shortens_the_hitting_stage_and_still_arrives():
    library, stages, stimuli = synthetic_library()
    player = MoMPTrajectorySource(library, stages)
    context = player.CreateDefaultContext()
    fix_inputs(player, context, stimuli[3], T_HIT)
    context.SetTime(T_HIT - 0.5)  # 0.5 s left: no room for a preparation and a 0.4 s hit
    player.ExecuteForcedEvents(context)
    state = player.player_state(context)
    assert not state.stroke.fallback
    hit = next(seg for stage, seg in state.plan.segments if stage == HITTING)
    assert hit.duration < 0.4 - 1e-9
    q, qd, _ = state.plan.evaluate(T_HIT)
    np.testing.assert_allclose(q, Q_HIT, atol=1e-3)
    np.testing.assert_allclose(qd, QD_HIT, atol=2e-2)


@pytest.fixture(scope="module")
def arm():
    from tt_drake.systems.hitting_ik import HittingIK

    return HittingIK()


def _plan_torques(arm, plan, t0):
    ts = [t for _, seg in plan.segments for t in np.arange(max(seg.t0, t0), seg.t_end, 0.02)]
    return np.array([np.abs(arm.torques(*plan.evaluate(t))) for t in ts])


def test_effort_budget_decides_between_the_primitives_and_the_fallback(arm):
    """With an arm, the executed primitive plan's inverse dynamics stay within the budget (1.5x
    the effort limits); a budget below that plan's peak leaves only the teacher's fallback."""
    from tt_drake.systems.momp_player import MoMPConfig

    library, stages, stimuli = synthetic_library()
    effort = np.asarray(wp.EFFORT_LIMIT, dtype=float)
    peaks = {}
    for fraction in (1.5, 0.05):
        player = MoMPTrajectorySource(library, stages, MoMPConfig(torque_fraction=fraction),
                                      arm=arm)
        context = player.CreateDefaultContext()
        fix_inputs(player, context, stimuli[2], T_HIT)
        context.SetTime(0.1)
        player.ExecuteForcedEvents(context)
        state = player.player_state(context)
        peaks[fraction] = (state.stroke.fallback,
                           (_plan_torques(arm, state.plan, 0.1).max(axis=0) / effort).max())
    fallback, peak = peaks[1.5]
    assert not fallback and 0.05 < peak <= 1.5
    assert peaks[0.05][0]  # the same stroke is refused within 5 % of the effort limits
