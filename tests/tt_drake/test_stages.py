"""Stage trajectories: boundary conditions and continuity of q, q_dot, q_ddot everywhere."""

import numpy as np
import pytest

from tt_drake.quintic_kernel import quintic_many_numpy
from tt_drake.stages import (
    AWAITING,
    FOLLOW_THROUGH,
    HITTING,
    PREPARATION,
    JointLimits,
    Quintic,
    StagePlan,
    StageTimes,
    correction_stages,
    hitting_duration,
    plan_extremes,
    plan_stroke,
)

RNG = np.random.default_rng(0)
LIMITS = JointLimits(lower=-2.5 * np.ones(7), upper=2.5 * np.ones(7), velocity=10 * np.ones(7))
Q_AWAIT = np.array([-0.8, 0.57, 1.5, 1.65, -2.0, -0.79, -1.06]) * 0.5


def test_quintic_meets_its_boundary_conditions():
    b = [RNG.normal(size=7) for _ in range(6)]
    seg = Quintic.fit(0.3, 0.7, *b)
    start, end = seg.evaluate(0.3), seg.evaluate(1.0)
    for got, want in zip((*start, *end), b, strict=True):
        np.testing.assert_allclose(got, want, atol=1e-10)


def test_quintic_derivatives_are_consistent():
    seg = Quintic.fit(0.0, 0.5, *[RNG.normal(size=3) for _ in range(6)])
    h = 1e-6
    for t in (0.1, 0.25, 0.4):
        (q0, v0, a0), (q1, v1, _) = seg.evaluate(t), seg.evaluate(t + h)
        np.testing.assert_allclose((q1 - q0) / h, v0, atol=1e-4)
        np.testing.assert_allclose((v1 - v0) / h, a0, atol=1e-3)


def jumps_at_boundaries(plan):
    """Largest jump in (q, q_dot, q_ddot) where one segment hands over to the next."""
    worst = np.zeros(3)
    for (_, a), (_, b) in zip(plan.segments[:-1], plan.segments[1:], strict=True):
        assert a.t_end == pytest.approx(b.t0)
        end_a = a.evaluate(a.t_end)
        start_b = b.evaluate(b.t0)
        worst = np.maximum(worst, [np.abs(x - y).max() for x, y in zip(end_a, start_b,
                                                                          strict=True)])
    return worst


def stroke(now=0.0, t_hit=0.8, state=None, preparing=False):
    state = state or (Q_AWAIT, np.zeros(7), np.zeros(7))
    q_hit = Q_AWAIT + RNG.uniform(-0.3, 0.3, 7)
    qd_hit = RNG.uniform(-3, 3, 7)
    plan = plan_stroke(now, state, t_hit, q_hit, qd_hit, Q_AWAIT, LIMITS, preparing=preparing)
    return plan, q_hit, qd_hit


def test_stroke_has_the_four_stages_in_order_and_arrives_at_the_hit():
    plan, q_hit, qd_hit = stroke()
    assert [s for s, _ in plan.segments] == [PREPARATION, HITTING, FOLLOW_THROUGH, AWAITING]
    q, qd, _ = plan.evaluate(0.8)
    np.testing.assert_allclose(q, q_hit, atol=1e-10)
    np.testing.assert_allclose(qd, qd_hit, atol=1e-10)
    assert plan.stage_at(0.8 - StageTimes().hitting - 0.01) == PREPARATION
    assert plan.stage_at(0.79) == HITTING and plan.stage_at(0.81) == FOLLOW_THROUGH
    np.testing.assert_allclose(plan.evaluate(10.0)[0], Q_AWAIT, atol=1e-10)  # back and at rest
    np.testing.assert_allclose(plan.evaluate(10.0)[1], 0.0, atol=1e-10)


def test_stage_boundaries_are_continuous_in_position_velocity_and_acceleration():
    for t_hit in np.r_[RNG.uniform(0.2, 0.4, 10), RNG.uniform(0.65, 1.0, 10)]:
        plan, _, _ = stroke(t_hit=t_hit)  # hit at once, or swing back first
        assert np.all(jumps_at_boundaries(plan) < 1e-9)


def test_replanning_from_the_current_desired_state_is_continuous():
    plan, _, _ = stroke(t_hit=0.8)
    now = 0.2
    state = plan.evaluate(now)
    replanned, q_hit, _ = stroke(now=now, t_hit=0.82, state=state, preparing=True)
    for before, after in zip(state, replanned.evaluate(now), strict=True):
        np.testing.assert_allclose(before, after, atol=1e-12)
    # The executed part followed by the re-plan: the re-plan is in force from `now` on.
    combined = type(plan)(plan.truncated(now).segments + replanned.segments)
    np.testing.assert_allclose(combined.evaluate(0.1)[0], plan.evaluate(0.1)[0])
    np.testing.assert_allclose(combined.evaluate(0.82)[0], q_hit, atol=1e-10)
    assert np.all(jumps_at_boundaries(combined) < 1e-9)


def test_too_little_time_skips_the_swing_back():
    plan, q_hit, _ = stroke(now=0.5, t_hit=0.75)
    assert plan.segments[0][0] == HITTING
    np.testing.assert_allclose(plan.evaluate(0.75)[0], q_hit, atol=1e-10)
    with pytest.raises(ValueError, match="no time left"):
        stroke(now=0.75, t_hit=0.75)


def test_at_rest_with_too_little_time_for_a_swing_back_the_player_waits():
    t = StageTimes()
    t_hit = 0.5 * t.min_preparation + t.hitting  # swing-back would have half the time it needs
    rest = (Q_AWAIT, np.zeros(7), np.zeros(7))
    assert plan_stroke(0.0, rest, t_hit, Q_AWAIT, np.ones(7), Q_AWAIT, LIMITS) is None
    direct = plan_stroke(0.0, rest, t_hit, Q_AWAIT, np.ones(7), Q_AWAIT, LIMITS, allow_wait=False)
    assert direct.segments[0][0] == HITTING and direct.segments[0][1].duration == t_hit
    # ...but an ongoing swing-back is re-planned with that little time left
    plan = plan_stroke(0.0, rest, t_hit, Q_AWAIT, np.ones(7), Q_AWAIT, LIMITS, preparing=True)
    assert plan.segments[0][0] == PREPARATION


def test_a_direct_hit_waits_no_later_than_its_lead_before_the_hit():
    """With ``direct_lead`` the arm at rest with no time for a swing-back waits only while more
    than that is left before the hit (and the hitting stage has not begun); then the direct hit
    starts from rest at ``now`` and arrives at (q_hit, qd_hit) at t_hit. With a swing-back's
    time the lead changes nothing."""
    rest = (Q_AWAIT, np.zeros(7), np.zeros(7))
    q_hit, qd_hit = Q_AWAIT + 0.3, np.ones(7)
    t = StageTimes(min_hitting=0.1, direct_lead=0.5)
    # joints with little room behind the hit shorten the hitting stage (2.5 room / |qd|)
    clipped = q_hit.copy()
    clipped[5] = LIMITS.lower[5] + LIMITS.margin + 0.1
    t_hitting = hitting_duration(clipped, 10 * qd_hit, LIMITS, t)
    assert t_hitting < 0.45  # so every t_hit below leaves the stage time to wait for
    for now, t_hit, waits in ((0.0, 0.55, True), (0.0, 0.5, False), (0.0, 0.45, False)):
        for times, expected in ((t, waits), (StageTimes(min_hitting=0.1), True)):
            if t_hit - now <= t_hitting:
                continue
            plan = plan_stroke(now, rest, t_hit, clipped, 10 * qd_hit, Q_AWAIT, LIMITS, times)
            if expected:
                assert plan is None
                continue
            stage, hit = plan.segments[0]
            assert stage == HITTING and hit.t0 == now and hit.duration == pytest.approx(t_hit)
            q_end, qd_end, _ = hit.evaluate(t_hit)
            np.testing.assert_allclose(q_end, clipped, atol=1e-10)
            np.testing.assert_allclose(qd_end, 10 * qd_hit, atol=1e-9)
    # time for a swing-back: the lead does not matter
    early = plan_stroke(0.0, rest, 1.2, q_hit, qd_hit, Q_AWAIT, LIMITS, t)
    assert early.segments[0][0] == PREPARATION
    np.testing.assert_array_equal(
        early.evaluate(0.9)[0],
        plan_stroke(0.0, rest, 1.2, q_hit, qd_hit, Q_AWAIT, LIMITS,
                    StageTimes(min_hitting=0.1)).evaluate(0.9)[0])


def test_a_fast_hit_near_a_limit_stops_inside_it():
    q_hit = np.full(7, 2.2)  # 0.25 rad from the margin, moving toward the limit at 3 rad/s
    plan = plan_stroke(0.0, (Q_AWAIT, np.zeros(7), np.zeros(7)), 0.8, q_hit, np.full(7, 3.0),
                       Q_AWAIT, LIMITS, allow_wait=False)
    follow = next(seg for stage, seg in plan.segments if stage == FOLLOW_THROUGH)
    assert follow.duration < StageTimes().follow_through  # shortened to stop in time
    ext = plan_extremes(plan)
    assert np.all(ext["q_max"] <= LIMITS.upper - LIMITS.margin + 1e-9)
    assert np.all(ext["q_min"] >= LIMITS.lower + LIMITS.margin - 1e-9)


def _segments():
    from tt_drake.dmp import Trajectory
    from tt_drake.learned_player import SampledSegment

    rng = np.random.default_rng(4)
    t = np.linspace(0.0, 0.5, 251)
    sampled = SampledSegment.from_trajectory(0.1, Trajectory(t, *rng.normal(size=(3, 251, 7))))
    return [Quintic.fit(0.3, 0.7, *rng.normal(size=(6, 7))), sampled]


@pytest.mark.parametrize("index", [0, 1])
def test_evaluate_many_gives_the_values_of_evaluate(index):
    seg = _segments()[index]
    # Before, inside, a hair past and well past the end (continued at zero acceleration).
    times = np.r_[seg.t0 - 0.05, np.arange(seg.t0, seg.t_end + 1e-9, 0.013), seg.t_end + 5e-10,
                  seg.t_end + 0.2]
    q, v, a = seg.evaluate_many(times)
    for i, t in enumerate(times):
        for got, want in zip((q[i], v[i], a[i]), seg.evaluate(t), strict=True):
            np.testing.assert_array_equal(got, want)
    assert not np.any(a[-1]) and np.any(a[1])


def test_the_compiled_quintic_is_the_numpy_arithmetic_to_the_bit():
    """The compiled kernel does the numpy expressions' IEEE operations in their order: equal to
    the last bit on random segments (coefficients over six orders of magnitude) at times
    before, inside and past them, a non-contiguous coefficient view included."""
    rng = np.random.default_rng(11)
    for _ in range(300):
        scale = 10.0 ** rng.uniform(-3, 3, size=(7, 1))
        seg = Quintic.fit(rng.uniform(-1, 3), rng.uniform(0.01, 1.5),
                          *(scale[:, 0] * rng.normal(size=7) for _ in range(6)))
        times = rng.uniform(seg.t0 - 0.3, seg.t_end + 0.3, rng.integers(1, 60))
        want = quintic_many_numpy(seg.coeffs, seg.t0, seg.duration, times)
        for got, expected in zip(seg.evaluate_many(times), want, strict=True):
            np.testing.assert_array_equal(got, expected)
    wide = np.asfortranarray(seg.coeffs)  # any memory layout
    view = Quintic(seg.t0, seg.duration, wide)
    want = quintic_many_numpy(seg.coeffs, seg.t0, seg.duration, times)
    for got, expected in zip(view.evaluate_many(times), want, strict=True):
        np.testing.assert_array_equal(got, expected)


def test_a_plans_evaluate_many_gives_the_values_of_evaluate():
    """A re-planned plan (a cut quintic, a sampled segment, a quintic after it): every time goes
    to the segment ``segment_at`` picks, ends included, before the first and past the last."""
    quintic, sampled = _segments()
    rng = np.random.default_rng(5)
    after = Quintic.fit(sampled.t_end, 0.3, *rng.normal(size=(6, 7)))
    plan = StagePlan([(PREPARATION, quintic.cut(0.45)),
                      (HITTING, sampled),
                      (AWAITING, after)])
    ends = [seg.t_end for _, seg in plan.segments]
    times = np.r_[0.0, np.arange(0.3, after.t_end + 0.1, 0.0021), ends, after.t_end + 1e-12]
    q, v, a = plan.evaluate_many(times)
    for i, t in enumerate(times):
        for got, want in zip((q[i], v[i], a[i]), plan.evaluate(t), strict=True):
            np.testing.assert_array_equal(got, want)
    one = plan.evaluate_many(np.array([ends[1]]))  # a single time, on a boundary
    np.testing.assert_array_equal(one[0][0], plan.evaluate(ends[1])[0])


def test_effort_check_is_the_sampled_bound_and_stops_at_the_first_segment_over_it():
    """Every 50 Hz sample of every segment from ``now`` on is held to the budget, a segment's
    samples in one call of ``torques``; a segment over budget ends the check, the segments
    after it are not evaluated."""
    from tt_drake.stages import StagePlan, within_effort

    seg = _segments()[0]
    later = Quintic.fit(seg.t_end, 0.3, *np.random.default_rng(3).normal(size=(6, 7)))
    calls = []

    def law(q, qd, qdd):  # a stand-in for inverse dynamics
        return 3.0 * qdd + qd

    def torques(q, qd, qdd):
        calls.append(q.copy())
        return law(q, qd, qdd)

    times = np.arange(seg.t0, seg.t_end + 1e-9, 1.0 / 50.0)
    sampled = [np.abs(law(*seg.evaluate(t))).max() for t in times]
    peak = max(sampled)
    plan = StagePlan([(HITTING, seg)])
    assert within_effort(plan, torques, np.full(7, peak))
    assert len(calls) == 1 and len(calls[0]) == times.size  # one call, every sample
    calls.clear()
    assert not within_effort(plan, torques, np.full(7, 0.999 * peak))
    # Over budget in the first segment: the second is never evaluated.
    calls.clear()
    assert not within_effort(StagePlan([(HITTING, seg), (AWAITING, later)]), torques,
                             np.full(7, 0.999 * peak))
    assert len(calls) == 1


def test_effort_check_with_the_drives_bounds_each_sample_at_its_speed():
    """With a budget that has ``bounds(q_dot)`` (the drives'), each sample's torque is held to
    the bounds at that sample's joint speed: a plan accepted by a constant budget equal to the
    stall-side bound is refused when the bound falls with speed, exactly when some sample's
    torque exceeds a - b |q_dot| in its direction."""
    from tt_drake.stages import StagePlan, within_effort

    seg = _segments()[0]
    plan = StagePlan([(HITTING, seg)])

    def law(q, qd, qdd):
        return 3.0 * qdd + qd

    class Falling:
        def __init__(self, stall, slope):
            self.stall, self.slope = stall, slope

        def bounds(self, qd):
            return -self.stall - self.slope * qd, self.stall - self.slope * qd

    times = np.arange(seg.t0, seg.t_end + 1e-9, 1.0 / 50.0)
    samples = [seg.evaluate(t) for t in times]
    stall = max(np.abs(law(*s)).max() for s in samples)
    assert within_effort(plan, law, Falling(stall, 0.0))
    # The smallest stall torque that keeps every sample inside the falling bounds.
    slope = 0.5
    needed = max(np.max(np.abs(law(*s) + slope * s[1])) for s in samples)
    assert within_effort(plan, law, Falling(needed * (1 + 1e-9), slope))
    assert not within_effort(plan, law, Falling(needed * (1 - 1e-6), slope))


def test_the_return_to_awaiting_takes_the_time_the_joint_limits_ask_for():
    """The awaiting stage lasts ``return_to_awaiting`` unless the rest-to-rest move needs
    longer at the joints' speed limits; the planned return then peaks within them."""
    from tt_drake.stages import StageTimes, plan_extremes, plan_stroke, return_duration

    times = StageTimes()
    q_await = np.zeros(7)
    fast = JointLimits(np.full(7, -3.0), np.full(7, 3.0), np.full(7, 10.0), np.full(7, 200.0))
    slow = JointLimits(fast.lower, fast.upper, np.full(7, 1.0), fast.acceleration)
    q_end = np.full(7, 0.6)
    assert return_duration(q_end, q_await, fast, times) == times.return_to_awaiting
    assert return_duration(q_end, q_await, slow, times) == pytest.approx(1.25 * 1.875 * 0.6)
    state = (np.zeros(7), np.zeros(7), np.zeros(7))
    q_hit, qd_hit = np.full(7, 0.5), np.full(7, 0.5)
    for limits in (fast, slow):
        plan = plan_stroke(0.0, state, 1.5, q_hit, qd_hit, q_await, limits, times)
        stage, back = plan.segments[-1]
        assert stage == "awaiting"
        q_end = back.evaluate(back.t0)[0]
        assert back.duration == pytest.approx(return_duration(q_end, q_await, limits, times))
        peak = plan_extremes(type(plan)([plan.segments[-1]]))["qd_max"].max()
        assert peak <= limits.velocity.max() / 1.25 + 1e-9


def _wrist_stroke(room: float, speed: float = 8.0):
    """A stroke whose joint 6 hits at ``room`` inside its lower limit (less the margin), moving
    up at ``speed``: its swing-back q_hit - (T / 2) qd_hit is clipped at the limit when
    ``room`` < T speed / 2."""
    limits = JointLimits(np.full(7, -1.6), np.full(7, 1.6), np.full(7, 10.0))
    q_hit, qd_hit = np.zeros(7), np.full(7, 0.5)
    q_hit[5], qd_hit[5] = limits.lower[5] + limits.margin + room, speed
    return limits, q_hit, qd_hit


def _hitting_segment(plan):
    return next(seg for stage, seg in plan.segments if stage == HITTING)


def test_a_clipped_swing_back_makes_the_fixed_hitting_stage_move_the_joint_back_first():
    """Why :func:`hitting_duration` exists: with room d = 0.35 rad behind the hit and v = 8
    rad/s, d < 0.4 v T (T = 0.4 s), so the quintic from rest at the clipped q_prep first moves
    the joint backward, past the swing-back posture toward the limit."""
    limits, q_hit, qd_hit = _wrist_stroke(0.35)
    state = (np.zeros(7), np.zeros(7), np.zeros(7))
    plan = plan_stroke(0.0, state, 1.5, q_hit, qd_hit, np.zeros(7), limits, StageTimes())
    hit = _hitting_segment(plan)
    assert hit.duration == pytest.approx(StageTimes().hitting)
    _, q, _, _ = hit.sample(2000.0)
    q_prep = limits.lower[5] + limits.margin
    assert q[:, 5].min() < q_prep - 0.05  # (30 d - 12 v T) < 0: it starts backward


@pytest.mark.parametrize("room", [0.35, 0.6, 0.0])
def test_the_shortened_hitting_stage_never_moves_a_joint_back(room):
    """With ``min_hitting`` the hitting stage lasts T = 2.5 d / |v| (d: the room behind the
    hit to the limit less the margin) when that is shorter than T_hit, at least ``min_hitting``:
    the clipped joint's velocity v s^3 (4 - 3 s) never changes sign, it stays at or ahead of its
    swing-back posture, and the segment still ends at (q_hit, qd_hit) at t_hit."""
    limits, q_hit, qd_hit = _wrist_stroke(room)
    times = StageTimes(min_hitting=0.1)
    t_hit = 1.5
    plan = plan_stroke(0.0, (np.zeros(7), np.zeros(7), np.zeros(7)), t_hit, q_hit, qd_hit,
                       np.zeros(7), limits, times)
    hit = _hitting_segment(plan)
    expected = float(np.clip(2.5 * room / qd_hit[5], times.min_hitting, times.hitting))
    assert hitting_duration(q_hit, qd_hit, limits, times) == pytest.approx(expected)
    assert hit.duration == pytest.approx(expected) and hit.t_end == pytest.approx(t_hit)
    q_end, qd_end, _ = hit.evaluate(t_hit)
    np.testing.assert_allclose(q_end, q_hit, atol=1e-9)
    np.testing.assert_allclose(qd_end, qd_hit, atol=1e-9)
    _, q, qd, _ = hit.sample(2000.0)
    if room > 0.0:
        assert qd[:, 5].min() >= -1e-9
        assert q[:, 5].min() >= limits.lower[5] + limits.margin - 1e-9
    else:  # no room at all: the floor, and the plan's own checks decide
        assert expected == times.min_hitting


def test_an_unclipped_swing_back_keeps_the_hitting_stage():
    """A stroke whose swing-back fits inside the limits is planned the same with and without
    ``min_hitting``: T_hit, and the same segments."""
    limits, q_hit, qd_hit = _wrist_stroke(2.0, speed=3.0)  # (T / 2) v = 0.6 < 2.0
    state = (np.zeros(7), np.zeros(7), np.zeros(7))
    fixed = plan_stroke(0.0, state, 1.5, q_hit, qd_hit, np.zeros(7), limits, StageTimes())
    shortened = plan_stroke(0.0, state, 1.5, q_hit, qd_hit, np.zeros(7), limits,
                            StageTimes(min_hitting=0.1))
    assert hitting_duration(q_hit, qd_hit, limits, StageTimes(min_hitting=0.1)) == 0.4
    for (stage_a, a), (stage_b, b) in zip(fixed.segments, shortened.segments, strict=True):
        assert stage_a == stage_b and a.t0 == b.t0 and a.t_end == b.t_end
        np.testing.assert_array_equal(a.evaluate(a.t_end)[0], b.evaluate(b.t_end)[0])


def test_a_correction_continues_the_plan_c2_and_arrives_at_the_new_goal():
    """correction_stages re-plans from the plan's desired state at ``now`` (a swing under way:
    no waiting) to the new (q_hit, qd_hit) at t_hit; the plan continued with it keeps its past
    bit for bit and is C2 at ``now``. With no time left there is no correction."""
    limits = JointLimits(lower=-2.5 * np.ones(7), upper=2.5 * np.ones(7),
                         velocity=10 * np.ones(7), acceleration=200 * np.ones(7))
    q_hit, qd_hit = Q_AWAIT + 0.3, np.array([2.0, -1.0, 0.5, 3.0, -2.0, 1.0, 0.0])
    plan = plan_stroke(0.0, (Q_AWAIT, np.zeros(7), np.zeros(7)), 1.0, q_hit, qd_hit, Q_AWAIT,
                       limits)
    now, q_new, qd_new, t_new = 0.7, q_hit + 0.02, qd_hit - 0.1, 1.005
    stages = correction_stages(now, plan, t_new, q_new, qd_new, Q_AWAIT, limits, StageTimes())
    corrected = plan.continued(now, stages)
    for t in np.linspace(0.0, now - 1e-3, 20):
        for a, b in zip(plan.evaluate(t), corrected.evaluate(t), strict=True):
            np.testing.assert_array_equal(a, b)
    for a, b in zip(plan.evaluate(now), corrected.evaluate(now), strict=True):
        np.testing.assert_allclose(a, b, atol=1e-9)
    q, qd, _ = corrected.evaluate(t_new)
    np.testing.assert_allclose(q, q_new, atol=1e-9)
    np.testing.assert_allclose(qd, qd_new, atol=1e-9)
    assert corrected.stage_at(t_new - 1e-3) == HITTING
    assert correction_stages(1.0, plan, 1.0005, q_new, qd_new, Q_AWAIT, limits,
                             StageTimes()) is None
