"""The analytical player's spin inputs: it predicts with the estimated spin, and corrects its
hitting stage when the prediction moves more than the racket forgives after the commit."""

import numpy as np
import pytest

from tt_drake.constants import PLANES
from tt_drake.serves import FIXED_SERVE
from tt_drake.stages import HITTING
from tt_drake.systems.analytical_player import (
    AnalyticalPlayer,
    PlannerConfig,
    StrokePlanner,
    planner_ball_model,
)


def test_prediction_starts_from_the_estimated_spin():
    planner = StrokePlanner(arm=object())  # predict needs no arm
    model = planner_ball_model()
    state = np.array([0.1, -0.9, 0.85, 0.3, -4.5, 1.2])  # after the robot-side bounce
    spin = np.array([150.0, -20.0, 40.0])
    p, v, t, w, through = planner.predict(state, 0.5, spin)
    hit = model.predict_plane(np.r_[state, spin], PLANES.hitting_y)
    assert p == pytest.approx(hit.position) and v == pytest.approx(hit.velocity)
    assert t == pytest.approx(0.5 + hit.t) and w == pytest.approx(spin) and not through
    spinless = planner.predict(state, 0.5, None)
    assert np.linalg.norm(spinless[0] - p) > 0.005  # Magnus of 150 rad/s over ~0.2 s


def run_serve(spin_bias_after_commit, player=None):
    """The fixed serve's true flight (p, v, spin) fed as the estimate at 60 Hz; after the commit
    the spin estimate is offset by ``spin_bias_after_commit``. Returns the player (default: the
    teacher), its context and the desired states sampled every 2 ms."""
    player = player or AnalyticalPlayer()
    context = player.CreateDefaultContext()
    model = planner_ball_model()
    launch = np.array(FIXED_SERVE)
    t_cross = model.predict_plane(launch, PLANES.hitting_y).t
    frame, samples = 0, []
    for t in np.arange(0.0, t_cross + 0.1, 2e-3):
        context.SetTime(t)
        if t >= frame / 60.0 and t < t_cross - 0.02:
            s = model.predict_time(launch, frame / 60.0)
            committed = player.player_state(context).committed
            bias = spin_bias_after_commit if committed else 0.0
            player.GetInputPort("estimated_state").FixValue(context, np.r_[s.position,
                                                                          s.velocity])
            player.GetInputPort("estimated_spin").FixValue(context, s.spin + bias)
            player.GetInputPort("estimator_status").FixValue(context, [1.0, frame / 60.0])
            player.ExecuteForcedEvents(context)
            frame += 1
        samples.append((t, player.GetOutputPort("desired_state").Eval(context).copy()))
    return player, context, samples


def test_a_committed_stroke_is_corrected_when_the_spin_moves():
    player, context, _ = run_serve(0.0)
    kept = player.player_state(context)
    assert kept.committed
    player, context, samples = run_serve(np.array([40.0, 0.0, 0.0]))
    corrected = player.player_state(context)
    assert corrected.committed
    hits = [seg for stage, seg in corrected.plan.segments if stage == HITTING]
    assert len(hits) >= 2  # the committed hitting segment, cut, and its correction(s)
    assert hits[0].t0 == pytest.approx(
        next(seg for stage, seg in kept.plan.segments if stage == HITTING).t0)
    # The stroke was re-planned on the moved spin at impact, and the desired trajectory reaches
    # the corrected (theta_hit, theta_dot_hit) at the corrected t_hit without a jump on the way.
    stroke = corrected.stroke
    assert np.linalg.norm(stroke.spin - kept.stroke.spin) > 20.0
    assert np.abs(stroke.q_hit - kept.stroke.q_hit).max() > 1e-3
    q_end, qd_end, _ = hits[-1].evaluate(stroke.t_hit)
    np.testing.assert_allclose(q_end, stroke.q_hit, atol=1e-9)
    np.testing.assert_allclose(qd_end, stroke.qd_hit, atol=1e-9)
    q = np.array([s[1][:7] for s in samples])
    assert np.abs(np.diff(q, axis=0)).max() < 10.0 * 2e-3  # joint speed stays below 10 rad/s


class _WeakShoulder(StrokePlanner):
    """A planner whose effort check refuses every correction that compensates all the spin
    (``Stroke.spin_share`` 1): the shoulder has nothing left for it."""

    def correct(self, now, current, stroke):
        return None if stroke.spin_share == 1.0 else super().correct(now, current, stroke)


@pytest.mark.parametrize("fallbacks", [True, False])
def test_a_correction_the_arm_refuses_falls_back_to_a_smaller_spin_share(fallbacks):
    """With ``correction_fallbacks`` a refused correction tries the planner's fallbacks in order
    (:meth:`StrokePlanner.strokes`): the first the arm can follow is the stroke for the moved
    prediction that compensates half the spin, and the plan reaches its (theta_hit,
    theta_dot_hit) at its t_hit. Without, the committed stroke is kept."""
    kept_player, kept_context, _ = run_serve(0.0)
    kept = kept_player.player_state(kept_context)
    planner = _WeakShoulder(config=PlannerConfig(correction_fallbacks=fallbacks))
    player, context, samples = run_serve(np.array([40.0, 0.0, 0.0]), AnalyticalPlayer(planner))
    state = player.player_state(context)
    assert state.committed
    if not fallbacks:
        assert state.stroke.spin_share == 1.0
        np.testing.assert_array_equal(state.stroke.q_hit, kept.stroke.q_hit)
        return
    stroke = state.stroke
    assert stroke.spin_share == 0.5 and stroke.blade_offset == 0.0
    assert np.linalg.norm(stroke.spin - kept.stroke.spin) > 20.0  # planned on the moved spin
    # the planner's own fallback order: the full share's strokes came first
    first = next(planner.strokes(stroke.p_hit, stroke.v_hit, stroke.t_hit, stroke.spin, None))
    assert first.spin_share == 1.0
    hits = [seg for stage, seg in state.plan.segments if stage == HITTING]
    q_end, qd_end, _ = hits[-1].evaluate(stroke.t_hit)
    np.testing.assert_allclose(q_end, stroke.q_hit, atol=1e-9)
    np.testing.assert_allclose(qd_end, stroke.qd_hit, atol=1e-9)
    q = np.array([s[1][:7] for s in samples])
    assert np.abs(np.diff(q, axis=0)).max() < 10.0 * 2e-3


def test_strokes_begin_with_stroke_and_follow_the_fallbacks_order():
    """:meth:`StrokePlanner.strokes` starts with :meth:`StrokePlanner.stroke`'s stroke and goes
    through the spin shares outermost, each with the blade offsets in turn."""
    planner = StrokePlanner()
    model = planner_ball_model()
    hit = model.predict_plane(np.array(FIXED_SERVE), PLANES.hitting_y)
    args = (hit.position, hit.velocity, hit.t, np.array([60.0, 0.0, 10.0]), None)
    strokes = list(planner.strokes(*args))
    first = planner.stroke(*args)
    np.testing.assert_array_equal(strokes[0].q_hit, first.q_hit)
    kinds = [(s.spin_share, s.blade_offset) for s in strokes]
    order = [(a, b) for a in planner.config.stroke_spins for b in planner.config.blade_offsets]
    assert sorted(set(kinds), key=order.index) == list(dict.fromkeys(kinds))
    assert {s for s, _ in kinds} == set(planner.config.stroke_spins)


class _NoPlainStroke(StrokePlanner):
    """A planner whose limits refuse the plan of every plain stroke (all the spin compensated,
    the ball on the blade's centre): only its fallbacks can be played."""

    def schedule(self, now, current, stroke):
        if stroke.spin_share == 1.0 and stroke.blade_offset == 0.0:
            return None, False
        return super().schedule(now, current, stroke)


@pytest.mark.parametrize("fallbacks", [True, False])
def test_a_first_plan_the_arm_refuses_falls_back_when_asked(fallbacks):
    """With ``plan_fallbacks`` a first plan the limits refuse tries the planner's fallbacks in
    order (:meth:`StrokePlanner.strokes`): the stroke played is the first fallback (the ball off
    the blade's centre), and its plan reaches that stroke's (theta_hit, theta_dot_hit) at its
    t_hit. Without, the plain stroke is only recorded and the arm never leaves its posture."""
    planner = _NoPlainStroke(config=PlannerConfig(plan_fallbacks=fallbacks))
    player, context, samples = run_serve(0.0, AnalyticalPlayer(planner))
    state = player.player_state(context)
    q = np.array([s[1][:7] for s in samples])
    if not fallbacks:
        assert not state.committed
        assert (state.stroke.spin_share, state.stroke.blade_offset) == (1.0, 0.0)
        np.testing.assert_array_equal(q, np.repeat(q[:1], len(q), axis=0))
        return
    assert state.committed
    stroke = state.stroke
    assert (stroke.spin_share, stroke.blade_offset) == (1.0, planner.config.blade_offsets[1])
    hits = [seg for stage, seg in state.plan.segments if stage == HITTING]
    q_end, qd_end, _ = hits[-1].evaluate(stroke.t_hit)
    np.testing.assert_allclose(q_end, stroke.q_hit, atol=1e-9)
    np.testing.assert_allclose(qd_end, stroke.qd_hit, atol=1e-9)
    assert np.abs(np.diff(q, axis=0)).max() < 10.0 * 2e-3


def test_corrections_are_checked_against_their_own_share_of_the_effort_limits():
    """``correction_torque_fraction`` is the effort check of a correction only: with a share
    no motion can keep (1e-3 of the limits) every correction is refused and the committed
    stroke is played as planned, while the first plan, checked against ``torque_fraction``, is
    the one the default planner makes; unset, corrections share the first plan's budget."""
    kept_player, kept_context, _ = run_serve(0.0)
    kept = kept_player.player_state(kept_context)
    strict = StrokePlanner(config=PlannerConfig(correction_torque_fraction=1e-3))
    assert strict.correction_budget.fraction == 1e-3
    assert strict.effort_budget.fraction == strict.config.torque_fraction == 0.9
    player, context, _ = run_serve(np.array([40.0, 0.0, 0.0]), AnalyticalPlayer(strict))
    state = player.player_state(context)
    assert state.committed
    np.testing.assert_array_equal(state.stroke.q_hit, kept.stroke.q_hit)
    assert len([seg for stage, seg in state.plan.segments if stage == HITTING]) == 1
    # The same correction passes the default planner's check (the test above corrects).
    default, context, _ = run_serve(np.array([40.0, 0.0, 0.0]))
    assert np.abs(default.player_state(context).stroke.q_hit - kept.stroke.q_hit).max() > 1e-3
    shared = StrokePlanner(config=PlannerConfig(torque_fraction=0.8))
    assert shared.correction_budget == shared.effort_budget


def test_an_arm_solution_nearest_the_committed_posture_turns_the_slow_base_less():
    """``near_previous`` solves each arm nearest the previous stroke's posture in units of the
    joints' speed limits (:meth:`StrokePlanner.committed_posture`): for a hitting point the
    bounce moved 8 cm toward the forehand, the answer minimises sum_j ((q_j - q_prev,j) / v_j)^2
    for the stock drives' speed limits v_j (the base's the smallest), so by that measure it is
    no worse than the comfort posture's answer, and it turns the base less, for the same racket
    state at the same point. Without it every stroke is the comfort posture's."""
    planner = StrokePlanner(config=PlannerConfig(drive_voltage=48.0))
    speed = planner.limits.velocity
    assert np.argmin(speed) == 0  # the base is the slowest joint
    hit = planner_ball_model().predict_plane(np.array(FIXED_SERVE), PLANES.hitting_y)
    p, v, t, w = hit.position, hit.velocity, hit.t, hit.spin
    first = planner.stroke(p, v, t, w, None)
    np.testing.assert_array_equal(planner.stroke(p, v, t, w, None, near_previous=True).q_hit,
                                  first.q_hit)  # nothing to be near: the comfort posture's
    moved = p + np.array([0.08, 0.0, 0.0])
    plain = planner.stroke(moved, v, t, w, first)
    near = planner.stroke(moved, v, t, w, first, near_previous=True)
    q_c, weights = planner.committed_posture(first)
    np.testing.assert_array_equal(q_c, first.q_hit)
    np.testing.assert_allclose(weights, 1.0 / speed**2)

    def time_cost(q):
        return float(np.sum(((q - first.q_hit) / speed) ** 2))

    assert time_cost(near.q_hit) <= time_cost(plain.q_hit) + 1e-9
    assert abs(near.q_hit[0] - first.q_hit[0]) < abs(plain.q_hit[0] - first.q_hit[0])
    np.testing.assert_allclose(near.racket_normal, plain.racket_normal, atol=1e-12)
    np.testing.assert_allclose(planner.arm.racket_pose(near.q_hit).translation(),
                               planner.arm.racket_pose(plain.q_hit).translation(), atol=2e-4)


class _SlowBase(StrokePlanner):
    """A planner whose limits refuse every correction solved nearest the comfort posture: the
    committed plan's base cannot turn as far as that posture asks."""

    def correct(self, now, current, stroke):
        near = np.allclose(stroke.q_hit, self.last_near) if self.last_near is not None else False
        return super().correct(now, current, stroke) if near else None

    def _solutions(self, p_hit, v_hit, t_hit, spin, previous, near_previous=False):
        for stroke in super()._solutions(p_hit, v_hit, t_hit, spin, previous, near_previous):
            self.last_near = stroke.q_hit if (near_previous and stroke is not None) else None
            yield stroke

    last_near = None


@pytest.mark.parametrize("fallback", [True, False])
def test_a_correction_refused_in_every_stroke_is_tried_nearest_the_committed_posture(fallback):
    """With ``posture_fallback`` a correction whose every stroke (and fallback) the limits
    refuse is tried again with the arm nearest the committed posture, and that plan is played
    to its (theta_hit, theta_dot_hit) at its t_hit; without it the committed stroke is kept."""
    kept_player, kept_context, _ = run_serve(0.0)
    kept = kept_player.player_state(kept_context)
    planner = _SlowBase(config=PlannerConfig(correction_fallbacks=True, posture_fallback=fallback))
    player, context, samples = run_serve(np.array([40.0, 0.0, 0.0]), AnalyticalPlayer(planner))
    state = player.player_state(context)
    assert state.committed
    if not fallback:
        np.testing.assert_array_equal(state.stroke.q_hit, kept.stroke.q_hit)
        return
    stroke = state.stroke
    assert np.linalg.norm(stroke.spin - kept.stroke.spin) > 20.0  # planned on the moved spin
    hits = [seg for stage, seg in state.plan.segments if stage == HITTING]
    assert len(hits) >= 2
    q_end, qd_end, _ = hits[-1].evaluate(stroke.t_hit)
    np.testing.assert_allclose(q_end, stroke.q_hit, atol=1e-9)
    np.testing.assert_allclose(qd_end, stroke.qd_hit, atol=1e-9)
    q = np.array([s[1][:7] for s in samples])
    assert np.abs(np.diff(q, axis=0)).max() < 10.0 * 2e-3
