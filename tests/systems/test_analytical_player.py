"""AnalyticalPlayer through its ports: a whole stroke from estimator outputs fed frame by frame."""

import numpy as np
import pytest

from tt_drake import wam_params as wp
from tt_drake.ball_model import CompliantBounceBallModel
from tt_drake.constants import BALL, PLANES
from tt_drake.serves import FIXED_SERVE
from tt_drake.stages import AWAITING, FOLLOW_THROUGH, HITTING, PREPARATION, STAGES
from tt_drake.systems.analytical_player import AnalyticalPlayer


@pytest.fixture(scope="module")
def stroke_run():
    """Feed the true flight of the fixed serve (p, v and spin) as the estimate at 60 Hz; sample
    the outputs at 1 kHz until the stroke is over."""
    player = AnalyticalPlayer()
    context = player.CreateDefaultContext()
    model = CompliantBounceBallModel(dt=1e-3)
    launch = np.array(FIXED_SERVE)
    t_cross = model.predict_plane(launch, PLANES.hitting_y).t
    samples = []
    frame = 0
    for t in np.arange(0.0, t_cross + 1.5, 1e-3):
        context.SetTime(t)
        if t >= frame / 60.0 and t < t_cross - 0.02:
            s = model.predict_time(launch, frame / 60.0)
            player.GetInputPort("estimated_state").FixValue(context, np.r_[s.position,
                                                                          s.velocity])
            player.GetInputPort("estimated_spin").FixValue(context, s.spin)
            player.GetInputPort("estimator_status").FixValue(context, [1.0, frame / 60.0])
            player.ExecuteForcedEvents(context)
            frame += 1
        x = player.GetOutputPort("desired_state").Eval(context).copy()
        a = player.GetOutputPort("desired_acceleration").Eval(context).copy()
        stage = int(player.GetOutputPort("stage").Eval(context)[0])
        samples.append((t, x, a, stage))
    stroke = player.GetOutputPort("stroke").Eval(context)
    return samples, stroke, t_cross, player


def test_stages_come_in_order_and_return_to_awaiting(stroke_run):
    samples, stroke, _, _ = stroke_run
    assert stroke is not None
    order = [STAGES[s] for _, _, _, s in samples]
    runs = [order[0]] + [b for a, b in zip(order[:-1], order[1:], strict=True) if a != b]
    # awaiting (possibly skipped: a stroke can start at the first frame) -> preparation
    # (possibly skipped) -> hitting -> follow-through -> awaiting (the return), each once
    assert runs[-3:] == [HITTING, FOLLOW_THROUGH, AWAITING]
    assert runs[:-3] in ([], [AWAITING], [PREPARATION], [AWAITING, PREPARATION])
    np.testing.assert_allclose(samples[-1][1][:7], wp.AWAITING, atol=1e-9)


def test_desired_trajectory_is_continuous_to_the_acceleration(stroke_run):
    samples, _, _, _ = stroke_run
    t = np.array([s[0] for s in samples])
    q = np.array([s[1][:7] for s in samples])
    qd = np.array([s[1][7:] for s in samples])
    qdd = np.array([s[2] for s in samples])
    dt = np.diff(t)[:, None]
    # Velocity is the derivative of position and acceleration that of velocity, everywhere:
    # a jump in q, q_dot or q_ddot (at a stage boundary or a re-plan) would break these.
    np.testing.assert_allclose(np.diff(q, axis=0) / dt, 0.5 * (qd[1:] + qd[:-1]), atol=2e-3)
    # (1 ms differences of a quintic with jerk up to ~10^3 rad/s^3 are exact to ~0.1 rad/s^2)
    np.testing.assert_allclose(np.diff(qd, axis=0) / dt, 0.5 * (qdd[1:] + qdd[:-1]), atol=0.2)
    assert np.abs(np.diff(qdd, axis=0)).max() < 3.0  # no acceleration step (< 3 rad/s^2 per ms)


def test_it_arrives_at_the_hitting_configuration_at_t_hit(stroke_run):
    samples, stroke, t_cross, player = stroke_run
    assert stroke.t_hit == pytest.approx(t_cross, abs=2e-3)
    arm = player.planner.arm
    q_hit, qd_hit = stroke.q_hit, stroke.qd_hit
    # The hitting configuration puts the blade face where the ball's centre will be.
    pose = arm.racket_pose(q_hit)
    offset = BALL.radius + 0.5 * wp.RACKET.blade_thickness
    np.testing.assert_allclose(pose.translation() + offset * stroke.racket_normal, stroke.p_hit,
                               atol=1e-3)
    assert np.degrees(np.arccos(np.clip(pose.rotation().col(1) @ stroke.racket_normal, -1, 1))) < 1
    # ...and the joint velocities give the planned racket velocity.
    np.testing.assert_allclose(arm.racket_velocity(q_hit, qd_hit)[3:], stroke.racket_velocity,
                               atol=1e-6)
    # The desired trajectory passes through (q_hit, qd_hit) at t_hit.
    t = np.array([s[0] for s in samples])
    k = int(np.argmin(np.abs(t - stroke.t_hit)))
    dt = stroke.t_hit - t[k]
    q_at = samples[k][1][:7] + samples[k][1][7:] * dt
    np.testing.assert_allclose(q_at, q_hit, atol=2e-3)
    np.testing.assert_allclose(samples[k][1][7:], qd_hit, atol=0.05)


def test_ending_the_episode_when_the_outcome_is_decided_changes_no_outcome():
    """The referee may stop at the first contact after the hit (the landing): the same serves
    give the same outcomes as episodes run until the ball reaches the floor, and shorter ones."""
    from tt_drake.diagrams.episodes import ServeDiagram, episode_seed
    from tt_drake.diagrams.scenario import load_scenario

    scenario = load_scenario()
    full = ServeDiagram(scenario, "analytical", end_when_decided=False)
    short = ServeDiagram(scenario, "analytical", end_when_decided=True)
    saved = 0.0
    for i in range(3):
        a, b = full.run(episode_seed(77, i)), short.run(episode_seed(77, i))
        assert a.outcome.as_dict() == b.outcome.as_dict()
        if a.outcome.returned:
            assert b.duration < a.duration - 0.2
        saved += a.duration - b.duration
    assert saved > 0.5
