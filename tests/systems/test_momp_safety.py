"""The learned player's safety behaviours (docs/learned_player.md, "Serve 135"): the
arm holds when it no longer follows the plan, a refused move of the goal is retried only when
something that can change the verdict changed, and the moving goal's effort budget."""

import numpy as np
import pytest

import tt_drake.systems.momp_player as momp_player
from tt_drake.drives import DriveEnvelope
from tt_drake.stages import AWAITING
from tt_drake.systems.momp_player import (
    MOVING_GOAL_CUTOFF,
    MOVING_GOAL_TORQUE_FRACTION,
    MoMPConfig,
    MoMPTrajectorySource,
    arm_follows,
    momp_config,
)
from tt_drake.wam_params import EFFORT_LIMIT

from .test_momp_player import Q_AWAIT, Q_HIT, QD_HIT, T_HIT, fix_inputs
from .test_moving_goal import _stroke_under_way


def _measure(player, context, q, qd):
    player.GetInputPort("arm_state").FixValue(context, np.concatenate([q, qd]))


def _tick(player, context, dt=0.004):
    context.SetTime(context.get_time() + dt)
    player.ExecuteForcedEvents(context)
    return player.player_state(context)


def test_the_arm_holds_when_it_leaves_the_plan():
    player, context, *_ = _stroke_under_way()
    now = context.get_time() + 0.004
    q, qd, _ = player.player_state(context).plan.evaluate(now)
    # Within hold_error of the plan: nothing changes.
    _measure(player, context, q + 0.9 * player.config.hold_error, qd)
    before = player.player_state(context)
    after = _tick(player, context)
    assert after.plan is before.plan and not after.stroke.held
    # Past it (one joint 0.7 rad behind, the arm moving at 6 rad/s): the stroke is abandoned.
    q_arm, qd_arm = q.copy(), qd.copy()
    q_arm[2] -= 0.7
    qd_arm[0] = 6.0
    _measure(player, context, q_arm, qd_arm)
    held = _tick(player, context)
    now = context.get_time()
    assert held.committed and held.stroke.held and held.stroke.t_hit == before.stroke.t_hit
    q0, v0, a0 = held.plan.evaluate(now)
    np.testing.assert_allclose(q0, q_arm, atol=1e-12)
    np.testing.assert_allclose(v0, qd_arm, atol=1e-12)
    np.testing.assert_allclose(a0, 0.0, atol=1e-9)
    # It stops, then goes back to the awaiting posture at rest, inside every joint limit.
    end = held.plan.segments[-1][1].t_end
    times = np.linspace(now, end, 2000)
    samples = [held.plan.evaluate(t) for t in times]
    qs, vs, accs = (np.array(x) for x in zip(*samples, strict=True))
    lim = player.limits
    assert np.all(qs >= lim.lower) and np.all(qs <= lim.upper)
    assert np.all(np.abs(vs) <= lim.velocity + 1e-9)
    assert np.all(np.abs(accs) <= lim.acceleration + 1e-9)
    np.testing.assert_allclose(held.plan.evaluate(end)[0], Q_AWAIT, atol=1e-12)
    assert {stage for stage, _ in held.plan.segments} == {AWAITING}
    # Committed: a new prediction no longer starts a stroke.
    fix_inputs(player, context, np.full(6, 0.5), T_HIT + 0.02)
    assert _tick(player, context).plan is held.plan


def test_the_arm_holds_when_a_joint_is_faster_than_any_plan_asks():
    player, context, *_ = _stroke_under_way()
    now = context.get_time() + 0.004
    q, qd, _ = player.player_state(context).plan.evaluate(now)
    fast = qd.copy()
    fast[2] = 0.99 * player.config.hold_speed * player.limits.velocity[2]
    _measure(player, context, q, fast)
    assert not _tick(player, context).stroke.held
    fast[2] = 1.01 * player.config.hold_speed * player.limits.velocity[2]
    _measure(player, context, q, fast)
    held = _tick(player, context)
    assert held.stroke.held and held.committed
    np.testing.assert_allclose(held.plan.evaluate(context.get_time())[1], fast, atol=1e-12)


def test_the_stop_is_inside_the_acceleration_limit_at_the_velocity_limit():
    """T = 2 |q_dot| / a_max: the stopping quintic (its velocity falls as 1 - 3 s^2 + 2 s^3, s = t
    / T) decelerates at most 1.5 |q_dot| / T = 0.75 a_max."""
    player = MoMPTrajectorySource(None, None)
    lim = player.limits
    qd = lim.velocity * np.array([1, -1, 1, -1, 1, -1, 1.0])
    plan = player.hold_plan(0.3, Q_HIT, qd)
    stop = plan.segments[0][1]
    a = np.array([stop.evaluate(t)[2] for t in np.linspace(stop.t0, stop.t_end, 1001)])
    peak = np.abs(a).max(axis=0)
    np.testing.assert_allclose(peak, 1.5 * lim.velocity / stop.duration, rtol=1e-4)
    assert np.all(peak <= lim.acceleration)
    np.testing.assert_allclose(stop.evaluate(stop.t_end)[1], 0.0, atol=1e-9)


def test_no_hold_without_the_measured_arm_or_with_it_off():
    for config, connect in ((MoMPConfig(), False), (MoMPConfig(hold_error=None), True)):
        player, context, *_ = _stroke_under_way(config)
        q, qd, _ = player.player_state(context).plan.evaluate(context.get_time())
        if connect:
            _measure(player, context, q + 1.0, qd)
        before = player.player_state(context)
        after = _tick(player, context)
        assert not after.stroke.held and after.plan is before.plan


def test_the_check_on_floats_gives_the_array_expressions_verdict():
    """arm_follows: every joint within hold_speed v_max and within hold_error of the plan, as
    the array expressions (|q_dot| <= s v).all() and max |q - q_plan| <= e decide it, on random
    arms, arms exactly at either bound, and a NaN (which fails)."""
    velocity = MoMPTrajectorySource(None, None).limits.velocity
    speed, error = 1.5, 0.5  # with q in eighths, q + error and speed * v_max are exact
    rng = np.random.default_rng(7)

    def numpy_verdict(x, q):
        return bool((np.abs(x[7:]) <= speed * velocity).all()
                    and float(np.abs(x[:7] - q).max()) <= error)

    cases = []
    for _ in range(2000):
        q = rng.uniform(-2.0, 2.0, 7)
        x = np.concatenate([q + rng.uniform(-0.55, 0.55, 7),
                            rng.uniform(-1.6, 1.6, 7) * velocity])
        cases.append((x, q))
    q = np.round(rng.uniform(-2.0, 2.0, 7) * 8.0) / 8.0
    at_bounds = np.concatenate([q, speed * velocity])
    at_bounds[3] = q[3] + error
    cases += [(at_bounds, q), (-at_bounds, -q)]
    for j in (0, 6, 9, 13):
        x = at_bounds.copy()
        x[j] = np.nextafter(x[j], np.inf)
        cases.append((x, q))
        x = at_bounds.copy()
        x[j] = np.nan
        cases.append((x, q))
    verdicts = [arm_follows(x, q, velocity, speed, error) for x, q in cases]
    assert verdicts == [numpy_verdict(x, q) for x, q in cases]
    assert 200 < sum(verdicts) < len(cases) - 200  # both verdicts, many times
    assert arm_follows(at_bounds, q, velocity, speed, error)


@pytest.fixture
def counted_moves(monkeypatch):
    calls = []
    real = momp_player.move_hitting_goal

    def counting(now, *args, **kwargs):
        calls.append(now)
        return real(now, *args, **kwargs)

    monkeypatch.setattr(momp_player, "move_hitting_goal", counting)
    return calls


@pytest.mark.parametrize("period", [0.02, None])
def test_a_refused_move_is_retried_only_when_the_verdict_can_change(counted_moves, period):
    player, context, _, _, stimuli = _stroke_under_way(
        MoMPConfig(goal_cutoff=0.08, retry_period=period))
    # A goal 1.5 rad away 0.3 s before the hit: the move leaves the velocity limit: refused.
    far = Q_HIT + 1.5
    fix_inputs(player, context, stimuli[0] + 0.02, T_HIT, far, QD_HIT)
    state = _tick(player, context)
    assert counted_moves == [context.get_time()] and state.stroke.replans == 1
    assert state.refused is not None and state.refused[0] == context.get_time()
    # The same prediction at the next ticks: retried only retry_period after the refusal.
    refused_at = context.get_time()
    for _ in range(6):
        _tick(player, context)
    tried = [t - refused_at for t in counted_moves[1:]]
    if period is None:
        assert len(tried) == 6  # every tick
    else:
        assert len(tried) == 1 and tried[0] >= period - 1e-12
    # A prediction that moved past the re-planning thresholds is tried at once.
    n = len(counted_moves)
    fix_inputs(player, context, stimuli[0] + 0.03, T_HIT, far, QD_HIT)
    _tick(player, context)
    assert len(counted_moves) == n + 1
    # An accepted move clears the refusal.
    fix_inputs(player, context, stimuli[0] + 0.02, T_HIT, Q_HIT + 0.02, QD_HIT)
    state = _tick(player, context)
    assert state.refused is None and state.stroke.replans == 2


def test_the_paper_profile_keeps_its_player():
    """Moving goal off: the paper profile's settings (no cut-off, 1.5x effort budget)."""
    assert momp_config(False) == MoMPConfig()
    assert MoMPConfig().goal_cutoff is None and MoMPConfig().torque_fraction == 1.5
    hard = momp_config(True)
    assert hard.goal_cutoff == MOVING_GOAL_CUTOFF and hard.torque_fraction < 1.5


def test_the_supply_share_bounds_a_plans_torque_at_speed_apart_from_its_effort_budget():
    """With drives, a plan may ask ``torque_fraction`` of the effort limits and ``supply_share``
    of the supply: at joint speed q_dot the bound is min(f E, s a - b q_dot) (tt_drake.drives),
    so at a joint's no-load speed a / b a plan keeps (s - 1) a of torque, and no joint is
    planned faster than s a / b. None shares the effort budget's multiple (the paper profile:
    1.5 both); bad shares are refused."""
    drive = DriveEnvelope(48.0)
    base_speed = drive.no_load_speed[0]
    stall, effort = drive.stall[0], EFFORT_LIMIT[0]
    assert MoMPConfig().supply_share == MoMPConfig().torque_fraction == 1.5
    assert momp_config(True, 48.0).supply_share == MOVING_GOAL_TORQUE_FRACTION
    for share in (None, 1.5):
        config = momp_config(True, 48.0, supply_fraction=share)
        player = MoMPTrajectorySource(None, None, config)
        s = MOVING_GOAL_TORQUE_FRACTION if share is None else share
        assert config.supply_share == s
        qdot = np.zeros(7)
        qdot[0] = base_speed
        lower, upper = player.effort_budget.bounds(qdot)
        # at the no-load speed the supply's line leaves (s - 1) a, capped at f E
        assert upper[0] == pytest.approx(min(MOVING_GOAL_TORQUE_FRACTION * effort,
                                             (s - 1.0) * stall))
        assert lower[0] == pytest.approx(-MOVING_GOAL_TORQUE_FRACTION * effort)
        assert player.limits.velocity[0] == pytest.approx(s * base_speed)
    # 1.2 of the supply leaves a fifth of the stall torque at the no-load speed, 1.5 the whole
    # moving-goal budget (half the stall torque is more than 1.2 E)
    assert 0.5 * stall > MOVING_GOAL_TORQUE_FRACTION * effort > 0.2 * stall
    for bad in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="supply_fraction"):
            MoMPConfig(supply_fraction=bad)
        with pytest.raises(ValueError, match="torque_fraction"):
            MoMPConfig(torque_fraction=bad)
