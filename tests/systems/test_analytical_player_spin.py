"""The analytical player's spin inputs: it predicts with the estimated spin, and corrects its
hitting stage when the prediction moves more than the racket forgives after the commit."""

import numpy as np
import pytest

from tt_drake.constants import PLANES
from tt_drake.serves import FIXED_SERVE
from tt_drake.stages import HITTING
from tt_drake.systems.analytical_player import AnalyticalPlayer, StrokePlanner, planner_ball_model


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


def run_serve(spin_bias_after_commit):
    """The fixed serve's true flight (p, v, spin) fed as the estimate at 60 Hz; after the commit
    the spin estimate is offset by ``spin_bias_after_commit``. Returns the player, its context and
    the desired states sampled every 2 ms."""
    player = AnalyticalPlayer()
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
