"""The analytical player's cheaper planning (docs/performance.md, "The teacher"): each change
computes the same stroke as the work it saves."""

import numpy as np
import pytest

from tt_drake.constants import PLANES
from tt_drake.hitting_time import last_robot_bounce
from tt_drake.racket_law import aim_candidates
from tt_drake.serves import FIXED_SERVE
from tt_drake.systems.analytical_player import (
    BOUNCE_TEST_STEP,
    PREDICTION_STEP,
    AnalyticalPlayer,
    StrokePlanner,
    planner_ball_model,
)

# Estimates along a serve: before the net, over the robot's half before and after its bounce,
# spinning and not, and a ball crossing the hitting plane too low (a point along the path,
# tt_drake.hitting_time's rule 3).
STATES = [
    (np.array([0.05, 1.2, 0.95, -0.2, -5.5, -0.8]), np.zeros(3)),
    (np.array([0.05, 0.6, 0.90, -0.2, -5.2, -1.5]), np.array([80.0, 0.0, 10.0])),
    (np.array([-0.2, -0.3, 0.80, 0.4, -4.8, -2.0]), np.array([-60.0, 15.0, 0.0])),
    (np.array([0.1, -0.9, 0.85, 0.3, -4.5, 1.2]), np.array([150.0, -20.0, 40.0])),
    (np.array([0.0, -0.8, 0.80, 0.0, -3.5, 2.2]), np.zeros(3)),
]


@pytest.mark.parametrize("k", range(len(STATES)))
def test_the_prediction_step_moves_the_stimulus_by_less_than_a_micrometre(k):
    state, spin = STATES[k]
    fine = StrokePlanner(arm=object(), model=planner_ball_model(2e-3))
    coarse = StrokePlanner(arm=object())  # predict needs no arm
    assert coarse.model.dt == PREDICTION_STEP > 2e-3
    a, b = fine.predict(state, 0.3, spin), coarse.predict(state, 0.3, spin)
    assert a is not None and b is not None
    np.testing.assert_allclose(b[0], a[0], rtol=0, atol=1e-6)  # m
    np.testing.assert_allclose(b[1], a[1], rtol=0, atol=1e-5)  # m/s
    assert b[2] == pytest.approx(a[2], abs=1e-7)  # s
    np.testing.assert_allclose(b[3], a[3], rtol=0, atol=1e-4)  # rad/s
    assert b[4] == a[4]


def test_a_bounce_just_behind_the_net_is_seen_at_the_bounce_tests_step():
    """The ball bounced 3 cm behind the net and flew on for 0.1 s: the test for a bounce behind
    it, stepping back 2 ms at a time, finds it; at the prediction's 10 ms step it would reach the
    net's plane first and miss it (and the player would not strike). The player tests at 2 ms."""
    model = planner_ball_model()
    pos = (0.0, -0.03, model.params.table_z + model.params.radius)
    vel, w = (0.0, -5.0, 2.0), (0.0, 0.0, 0.0)
    for _ in range(1000):
        pos, vel = model.flight_step(pos, vel, w, 1e-4)
    state = np.r_[pos, vel, w]
    assert BOUNCE_TEST_STEP == 2e-3 < PREDICTION_STEP
    assert last_robot_bounce(model, state, step=BOUNCE_TEST_STEP) is not None
    assert last_robot_bounce(model, state, step=PREDICTION_STEP) is None
    hit = StrokePlanner(arm=object()).predict(state[:6], 0.0, state[6:])
    assert hit is not None and hit[0][1] == pytest.approx(PLANES.hitting_y)


def test_the_states_cover_a_point_off_the_plane():
    """At least one of STATES is hit along the path, not on the plane (rule 3)."""
    planner = StrokePlanner(arm=object())
    off = [abs(planner.predict(s, 0.0, w)[0][1] - PLANES.hitting_y) > 1e-6 for s, w in STATES]
    assert any(off) and not all(off)


def test_a_correction_aims_at_its_flight_time_as_aim_candidates_does():
    """A stroke close to the previous one keeps its flight time and solves its outgoing velocity
    alone: the same velocity, to the bit, as aim_candidates on that one flight time."""
    planner = StrokePlanner()
    p, v, w = np.array([0.1, -1.75, 0.9]), np.array([0.2, -4.5, 0.5]), np.array([60.0, 0.0, 5.0])
    first = planner.stroke(p, v, 0.8, w, None)
    assert first is not None and first.replans == 1
    moved = p + np.array([0.008, 0.0, -0.005])
    second = planner.stroke(moved, v, 0.8, w, first)
    assert second is not None and second.replans == 2
    assert second.flight_time == first.flight_time
    cfg = planner.config
    ranked = aim_candidates(moved, v, (cfg.target_x, cfg.target_y),
                            flight_times=(first.flight_time,), spin=w)
    assert np.array_equal(second.v_out, ranked[0].v_out)
    assert not np.array_equal(second.v_out, first.v_out)


class _CountingPlanner(StrokePlanner):
    def __init__(self):
        super().__init__()
        self.predicted_at: list[float] = []

    def predict(self, state6, t_state, spin=None, bounces_behind=None):
        self.predicted_at.append(t_state)
        return super().predict(state6, t_state, spin, bounces_behind)


def test_no_prediction_past_the_correction_cutoff_yet_every_frame_is_seen():
    """The fixed serve's true flight fed at 60 Hz up to just before the hit: once the committed
    stroke is within ``correct_lead`` of its hit, frames are recorded as seen but not predicted
    from; before that every frame was."""
    planner = _CountingPlanner()
    player = AnalyticalPlayer(planner)
    context = player.CreateDefaultContext()
    model = planner_ball_model()
    launch = np.array(FIXED_SERVE)
    t_cross = model.predict_plane(launch, PLANES.hitting_y).t
    frame, fed, cutoff = 0, [], None
    for t in np.arange(0.0, t_cross - 0.004, 2e-3):
        context.SetTime(t)
        if t >= frame / 60.0:
            s = model.predict_time(launch, frame / 60.0)
            player.GetInputPort("estimated_state").FixValue(context, np.r_[s.position,
                                                                          s.velocity])
            player.GetInputPort("estimated_spin").FixValue(context, s.spin)
            player.GetInputPort("estimator_status").FixValue(context, [1.0, frame / 60.0])
            old = player.player_state(context)
            if cutoff is None and old.committed:
                cutoff = old.stroke.t_hit - planner.config.correct_lead
            player.ExecuteForcedEvents(context)
            fed.append((t, frame / 60.0))
            frame += 1
        else:
            player.ExecuteForcedEvents(context)
    state = player.player_state(context)
    assert state.committed and cutoff is not None
    past = [seen for t, seen in fed if t > cutoff]
    before = [seen for t, seen in fed if t <= cutoff]
    assert len(past) >= 3 and len(before) > 20
    assert state.seen == fed[-1][1]  # the last frame was seen ...
    assert set(planner.predicted_at) == set(before)  # ... and only those before were predicted
