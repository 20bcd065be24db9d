"""The hitting DMP's moving goal (docs/learned_player.md): during the hitting stage, until the
cut-off, a new prediction moves the stroke's goal; the paper profile's player (no cut-off) stays
committed."""

import copy

import numpy as np

from tt_drake.learned_player import move_hitting_goal
from tt_drake.stages import HITTING
from tt_drake.systems.hitting_configuration import FallbackStrokes
from tt_drake.systems.momp_player import MoMPConfig, MoMPTrajectorySource

from .test_momp_player import Q_HIT, QD_HIT, T_HIT, fix_inputs, synthetic_library


def _stroke_preparing(config=None):
    """A player that planned its stroke to T_HIT at 0.1 s and is preparing it."""
    library, stages, stimuli = synthetic_library()
    player = MoMPTrajectorySource(library, stages, config=config)
    context = player.CreateDefaultContext()
    fix_inputs(player, context, stimuli[0], T_HIT)
    context.SetTime(0.1)
    player.ExecuteForcedEvents(context)
    return player, context, library, stages, stimuli


def _stroke_under_way(config=None):
    """A player whose hitting stage (0.4 s before T_HIT) has begun."""
    player, context, library, stages, stimuli = _stroke_preparing(config)
    hit = next(seg for stage, seg in player.player_state(context).plan.segments
               if stage == HITTING)
    context.SetTime(hit.t0 + 0.1)
    player.ExecuteForcedEvents(context)
    return player, context, library, stages, stimuli


def test_moved_goal_is_reached_and_the_motion_stays_c2():
    player, context, library, stages, stimuli = _stroke_under_way()
    plan = player.player_state(context).plan
    now = context.get_time()
    q_new, qd_new, t_new = Q_HIT + 0.04, QD_HIT - 0.2, T_HIT + 0.015
    moved, idx, nu = move_hitting_goal(now, plan, stimuli[1], t_new, q_new, qd_new, library,
                                       stages, player.q_await, player.limits,
                                       player.config.times)
    # The part executed before now is the old plan's, bit for bit.
    for t in np.linspace(0.0, now - 1e-3, 50):
        for a, b in zip(plan.evaluate(t), moved.evaluate(t), strict=True):
            np.testing.assert_array_equal(a, b)
    # At now: position, velocity and acceleration continuous.
    for a, b in zip(plan.evaluate(now - 1e-9), moved.evaluate(now + 1e-9), strict=True):
        np.testing.assert_allclose(a, b, atol=1e-5)
    # It arrives at the new goal at the new hitting time, still in the hitting stage.
    # (The DMP reaches its goal only asymptotically: to ~1e-6 rad and ~2e-4 rad/s here.)
    q, qd, _ = moved.evaluate(t_new)
    np.testing.assert_allclose(q, q_new, atol=1e-5)
    np.testing.assert_allclose(qd, qd_new, atol=1e-3)
    assert moved.stage_at(t_new - 1e-3) == HITTING
    assert np.isclose(nu.sum(), 1.0) and len(idx) == len(nu)


def test_an_unmoved_goal_leaves_the_stroke_as_it_was():
    """Same stimulus, goal and t_hit: the mixture's rollout from the hitting stage's start is the
    plan being executed, so the correction is zero."""
    player, context, library, stages, stimuli = _stroke_under_way()
    plan = player.player_state(context).plan
    now = context.get_time()
    moved, _, _ = move_hitting_goal(now, plan, stimuli[0], T_HIT, Q_HIT, QD_HIT, library, stages,
                                    player.q_await, player.limits, player.config.times)
    # Equal up to the resampling from now (one quintic per 2 ms interval on a shifted grid).
    for t in np.linspace(now, T_HIT, 40):
        for a, b, tol in zip(plan.evaluate(t), moved.evaluate(t), (1e-7, 1e-6, 1e-3),
                             strict=True):
            np.testing.assert_allclose(a, b, atol=tol)


def test_the_player_moves_its_goal_until_the_cutoff_only_with_a_cutoff():
    new_q = Q_HIT + 0.03
    for cutoff in (None, 0.08):
        player, context, _, _, stimuli = _stroke_under_way(MoMPConfig(goal_cutoff=cutoff))
        fix_inputs(player, context, stimuli[0] + 0.02, T_HIT + 0.01, new_q, QD_HIT)
        context.SetTime(context.get_time() + 0.004)
        player.ExecuteForcedEvents(context)
        state = player.player_state(context)
        if cutoff is None:  # the paper profile: committed at the hitting stage's start
            assert state.committed and state.stroke.replans == 1
            np.testing.assert_allclose(state.plan.evaluate(T_HIT)[0], Q_HIT, atol=1e-3)
            continue
        assert not state.committed and state.stroke.replans == 2
        np.testing.assert_allclose(state.plan.evaluate(T_HIT + 0.01)[0], new_q, atol=1e-5)
        # After the cut-off a new prediction no longer moves it.
        fix_inputs(player, context, stimuli[0], T_HIT + 0.01, Q_HIT, QD_HIT)
        context.SetTime(T_HIT + 0.01 - 0.07)
        player.ExecuteForcedEvents(context)
        state = player.player_state(context)
        assert state.committed and state.stroke.replans == 2
        np.testing.assert_allclose(state.plan.evaluate(T_HIT + 0.01)[0], new_q, atol=1e-5)


def test_a_refused_move_is_tried_with_the_spinless_velocities_when_connected():
    """A move whose goal velocities leave the joint limits (12 rad/s on joint 1 against 10) is
    refused; with ``theta_dot_hit_spinless`` connected the player then moves to the same
    theta_hit with those velocities (feasible) and arrives there at the new t_hit, and keeps
    to the spinless velocities until the hit; without the input it keeps its goal."""
    new_q, new_t = Q_HIT + 0.03, T_HIT + 0.01
    too_fast = QD_HIT.copy()
    too_fast[0] = 12.0
    spinless = QD_HIT - 0.2
    for connected in (False, True):
        player, context, _, _, stimuli = _stroke_under_way(MoMPConfig(goal_cutoff=0.08))
        fix_inputs(player, context, stimuli[0] + 0.02, new_t, new_q, too_fast)
        if connected:
            player.GetInputPort("theta_dot_hit_spinless").FixValue(context, spinless)
        context.SetTime(context.get_time() + 0.004)
        player.ExecuteForcedEvents(context)
        state = player.player_state(context)
        if not connected:  # refused: the stroke keeps its first goal
            assert state.refused is not None and state.stroke.replans == 1
            np.testing.assert_allclose(state.plan.evaluate(T_HIT)[0], Q_HIT, atol=1e-3)
            continue
        assert state.refused is None and state.stroke.spinless and state.stroke.replans == 2
        np.testing.assert_array_equal(state.stroke.qd_hit, spinless)
        q, qd, _ = state.plan.evaluate(new_t)
        np.testing.assert_allclose(q, new_q, atol=1e-5)
        np.testing.assert_allclose(qd, spinless, atol=1e-3)
        # From then on the stroke follows the spinless velocities, even when the spin-aware
        # goal becomes feasible (no switching between the two goals until the hit).
        fix_inputs(player, context, stimuli[0] + 0.02, new_t, new_q, QD_HIT)
        context.SetTime(context.get_time() + 0.004)
        player.ExecuteForcedEvents(context)
        state = player.player_state(context)
        assert state.stroke.spinless and state.stroke.replans == 2
        later = spinless + 0.1  # a new spinless goal is moved to
        player.GetInputPort("theta_dot_hit_spinless").FixValue(context, later)
        context.SetTime(context.get_time() + 0.004)
        player.ExecuteForcedEvents(context)
        state = player.player_state(context)
        assert state.stroke.spinless and state.stroke.replans == 3
        np.testing.assert_allclose(state.plan.evaluate(new_t)[1], later, atol=1e-3)


def test_a_first_plan_outside_the_limits_takes_the_spinless_velocities_when_connected():
    """No primitive plan fits the joint limits with the configuration's velocities (12 rad/s on
    joint 1): without ``theta_dot_hit_spinless`` the player falls back to the teacher's quintics;
    with it, the primitives carry the stroke to theta_hit with those velocities."""
    library, stages, stimuli = synthetic_library()
    too_fast = QD_HIT.copy()
    too_fast[0] = 12.0
    spinless = QD_HIT - 0.2
    for connected in (False, True):
        player = MoMPTrajectorySource(library, stages, config=MoMPConfig(goal_cutoff=0.08))
        context = player.CreateDefaultContext()
        fix_inputs(player, context, stimuli[0], T_HIT, Q_HIT, too_fast)
        if connected:
            player.GetInputPort("theta_dot_hit_spinless").FixValue(context, spinless)
        context.SetTime(0.1)
        player.ExecuteForcedEvents(context)
        stroke = player.player_state(context).stroke
        assert stroke.fallback != connected and stroke.spinless == connected
        if connected:
            np.testing.assert_array_equal(stroke.qd_hit, spinless)
            q, qd, _ = player.player_state(context).plan.evaluate(T_HIT)
            np.testing.assert_allclose(q, Q_HIT, atol=1e-3)
            np.testing.assert_allclose(qd, spinless, atol=2e-2)


def _refuse_every_dmp_move(*args, **kwargs):
    raise ValueError("the moved hitting DMP leaves the limits")


def test_a_refused_move_is_made_as_the_teachers_correction_when_asked(monkeypatch):
    """A move the hitting DMP cannot make (every rolled-out move refused) is, with
    ``correction_fallback``, made by the teacher's quintic stages from the current desired
    state: continuous in position, velocity and acceleration at the move, arriving exactly at
    the new (theta_hit, theta_dot_hit) at the new t_hit; the stroke records the fallback and
    the mixture that failed. A goal the quintic cannot reach within the limits either (12 rad/s
    on joint 1 against 10) is refused, and without the setting every refused move keeps the
    goal."""
    monkeypatch.setattr("tt_drake.systems.momp_player.move_hitting_goal",
                        _refuse_every_dmp_move)
    new_q, new_qd, new_t = Q_HIT + 0.03, QD_HIT - 0.2, T_HIT + 0.01
    too_fast = QD_HIT.copy()
    too_fast[0] = 12.0
    for fallback, qd_goal in ((False, new_qd), (True, too_fast), (True, new_qd)):
        player, context, _, _, stimuli = _stroke_under_way(
            MoMPConfig(goal_cutoff=0.08, correction_fallback=fallback))
        before = player.player_state(context).plan
        fix_inputs(player, context, stimuli[0] + 0.02, new_t, new_q, qd_goal)
        now = context.get_time() + 0.004
        context.SetTime(now)
        player.ExecuteForcedEvents(context)
        state = player.player_state(context)
        if not (fallback and qd_goal is new_qd):
            assert state.refused is not None and state.stroke.replans == 1
            assert not state.stroke.fallback
            np.testing.assert_allclose(state.plan.evaluate(T_HIT)[0], Q_HIT, atol=1e-3)
            continue
        assert state.refused is None and state.stroke.replans == 2 and state.stroke.fallback
        idx, nu = player.library.active(state.stroke.stimulus)  # the mixture that failed
        np.testing.assert_array_equal(state.stroke.primitives, idx)
        for a, b in zip(before.evaluate(now), state.plan.evaluate(now), strict=True):
            np.testing.assert_allclose(a, b, atol=1e-9)
        q, qd, _ = state.plan.evaluate(new_t)
        np.testing.assert_allclose(q, new_q, atol=1e-9)
        np.testing.assert_allclose(qd, new_qd, atol=1e-9)
        assert state.plan.stage_at(new_t - 1e-3) == HITTING


class _Stroke:
    def __init__(self, q_hit, qd_hit):
        self.q_hit, self.qd_hit = q_hit, qd_hit


class _Planner:
    """A planner whose strokes are given, counting how many were solved."""

    def __init__(self, strokes):
        self._strokes, self.solved = strokes, 0

    def strokes(self, p_hit, v_hit, t_hit, spin, previous):
        for q, qd in self._strokes:
            self.solved += 1
            yield _Stroke(q, qd)


def test_a_move_refused_as_a_correction_too_plays_the_first_other_stroke_that_fits(monkeypatch):
    """With ``stroke_fallbacks``, a move the hitting DMP and the teacher's correction both refuse
    (12 rad/s on joint 1 against 10) is made as the correction to the first of the teacher's
    other strokes that fits the limits: the configuration's own goal is passed over, a second
    too-fast stroke refused, the third played, arriving exactly at its (theta_hit,
    theta_dot_hit) at the new t_hit, and the strokes after it never solved. The spinless
    racket, feasible here, is not tried: the other strokes take its place (without the setting
    it is played). The same prediction at the next tick re-plans nothing."""
    monkeypatch.setattr("tt_drake.systems.momp_player.move_hitting_goal",
                        _refuse_every_dmp_move)
    new_q, new_t = Q_HIT + 0.03, T_HIT + 0.01
    too_fast = QD_HIT.copy()
    too_fast[0] = 12.0
    played = (Q_HIT + 0.05, QD_HIT - 0.2)
    strokes = [(new_q, too_fast), (Q_HIT - 0.05, too_fast), played, (Q_HIT, QD_HIT)]
    for enabled in (False, True):
        player, context, _, _, stimuli = _stroke_under_way(MoMPConfig(
            goal_cutoff=0.08, correction_fallback=True, stroke_fallbacks=enabled))
        planner = _Planner(strokes)
        fix_inputs(player, context, stimuli[0] + 0.02, new_t, new_q, too_fast)
        player.GetInputPort("theta_dot_hit_spinless").FixValue(context, QD_HIT - 0.1)
        player.GetInputPort("fallback_strokes").FixValue(
            context, FallbackStrokes(planner, stimuli[0][:3], stimuli[0][3:6], new_t,
                                     np.zeros(3)))
        before = player.player_state(context).plan
        now = context.get_time() + 0.004
        context.SetTime(now)
        player.ExecuteForcedEvents(context)
        state = player.player_state(context)
        if not enabled:  # the spinless racket's move
            assert state.refused is None and state.stroke.spinless and planner.solved == 0
            continue
        assert state.refused is None and state.stroke.fallback and not state.stroke.spinless
        assert planner.solved == 3
        np.testing.assert_array_equal(state.stroke.q_hit, played[0])
        np.testing.assert_array_equal(state.stroke.qd_hit, played[1])
        np.testing.assert_array_equal(state.stroke.configuration[0], new_q)
        np.testing.assert_array_equal(state.stroke.configuration[1], too_fast)
        for a, b in zip(before.evaluate(now), state.plan.evaluate(now), strict=True):
            np.testing.assert_allclose(a, b, atol=1e-9)
        q, qd, _ = state.plan.evaluate(new_t)
        np.testing.assert_allclose(q, played[0], atol=1e-9)
        np.testing.assert_allclose(qd, played[1], atol=1e-9)
        context.SetTime(now + 0.004)
        player.ExecuteForcedEvents(context)
        assert player.player_state(context).stroke.replans == 2


def test_fallback_strokes_are_solved_lazily_and_once():
    """Iterating solves each stroke the first time any iteration reaches it; a second iteration
    and a deep copy (a cloned context) solve nothing again; no planner: no strokes."""
    strokes = [(np.full(7, float(i)), np.full(7, -float(i))) for i in range(4)]
    planner = _Planner(strokes)
    lazy = FallbackStrokes(planner, np.zeros(3), np.zeros(3), 0.5, np.zeros(3))
    assert planner.solved == 0
    first = next(iter(lazy))
    assert planner.solved == 1 and np.array_equal(first[0], strokes[0][0])
    assert [q[0] for q, _ in lazy] == [0.0, 1.0, 2.0, 3.0] and planner.solved == 4
    assert [q[0] for q, _ in copy.deepcopy(lazy)] == [0.0, 1.0, 2.0, 3.0]
    assert planner.solved == 4
    assert list(FallbackStrokes()) == []


def _refuse_every_primitive_plan(*args, **kwargs):
    raise ValueError("the primitive plan leaves the limits")


def test_a_replan_refused_before_the_hitting_stage_takes_the_teachers_fallbacks(monkeypatch):
    """Before the hitting stage, a new prediction whose primitive plans the limits refuse
    (every hitting duration) keeps the plan made before unless ``correction_fallback`` is set;
    with it, the teacher's quintic stages from the current desired state carry the stroke to
    the new (theta_hit, theta_dot_hit) at the new t_hit (continuous at the re-plan, still
    preparing), and with ``stroke_fallbacks`` a configuration too fast for the quintic too
    (12 rad/s on joint 1) is played as the first of the teacher's other strokes that fits."""
    new_q, new_qd, new_t = Q_HIT + 0.03, QD_HIT - 0.2, T_HIT + 0.01
    too_fast = QD_HIT.copy()
    too_fast[0] = 12.0
    played = (Q_HIT + 0.05, QD_HIT - 0.2)
    cases = ((MoMPConfig(goal_cutoff=0.08), new_qd, None),
             (MoMPConfig(goal_cutoff=0.08, correction_fallback=True), new_qd, (new_q, new_qd)),
             (MoMPConfig(goal_cutoff=0.08, correction_fallback=True), too_fast, None),
             (MoMPConfig(goal_cutoff=0.08, correction_fallback=True, stroke_fallbacks=True),
              too_fast, played))
    for config, qd_goal, expected in cases:
        player, context, _, _, stimuli = _stroke_preparing(config)
        before = player.player_state(context).plan
        monkeypatch.setattr("tt_drake.systems.momp_player.plan_momp_stroke",
                            _refuse_every_primitive_plan)
        fix_inputs(player, context, stimuli[0] + 0.02, new_t, new_q, qd_goal)
        player.GetInputPort("fallback_strokes").FixValue(
            context, FallbackStrokes(_Planner([(new_q, too_fast), played]), stimuli[0][:3],
                                     stimuli[0][3:6], new_t, np.zeros(3)))
        now = 0.2
        context.SetTime(now)
        player.ExecuteForcedEvents(context)
        monkeypatch.undo()
        state = player.player_state(context)
        assert state.plan.stage_at(now) != HITTING
        if expected is None:
            assert state.plan is before and state.stroke.replans == 1
            assert not state.stroke.fallback
            continue
        assert state.stroke.fallback and state.stroke.replans == 2
        np.testing.assert_array_equal(state.stroke.q_hit, expected[0])
        np.testing.assert_array_equal(state.stroke.qd_hit, expected[1])
        assert (state.stroke.configuration is None) == (expected[1] is new_qd)
        for a, b in zip(before.evaluate(now), state.plan.evaluate(now), strict=True):
            np.testing.assert_allclose(a, b, atol=1e-9)
        q, qd, _ = state.plan.evaluate(new_t)
        np.testing.assert_allclose(q, expected[0], atol=1e-9)
        np.testing.assert_allclose(qd, expected[1], atol=1e-9)
