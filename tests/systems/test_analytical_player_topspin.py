"""The teacher choosing its return's spin (PlannerConfig.topspin): the planned racket, through
the impact law with friction, sends the ball to the target with the topspin asked for, and the
arm reaches that racket within its joint speed limits."""

import numpy as np
import pytest

from tt_drake.ball_model import BallModel
from tt_drake.racket_impact import racket_impact, topspin
from tt_drake.racket_law import racket_restitution
from tt_drake.spin_stroke import RACKET_MU
from tt_drake.systems.analytical_player import PlannerConfig, StrokePlanner

# A ball after its bounce on the robot's half, with the topspin a bounce gives it (p, v, omega).
STATE = np.array([-0.05, -0.65, 0.84, 0.35, -4.3, 1.9, 90.0, 10.0, -5.0])
AHEAD = 0.22


@pytest.mark.parametrize("wanted", [-30.0, 40.0])
def test_the_planned_racket_sends_the_ball_to_the_target_with_the_spin_asked_for(wanted):
    planner = StrokePlanner(config=PlannerConfig(topspin=wanted, stroke_spins=(1.0,),
                                                 blade_offsets=(0.0,)))
    hit = planner.model.predict_time(STATE, AHEAD)
    stroke = planner.stroke(hit.position, hit.velocity, AHEAD, hit.spin, None)
    assert stroke is not None
    e = racket_restitution(-(stroke.racket_normal @ (hit.velocity - stroke.racket_velocity)))
    out = racket_impact(hit.velocity, hit.spin, stroke.racket_normal, stroke.racket_velocity, e,
                        RACKET_MU)
    assert out.rolling
    np.testing.assert_allclose(out.velocity, stroke.v_out, atol=1e-6)
    assert topspin(np.r_[hit.position, out.velocity, out.spin]) == pytest.approx(wanted, abs=1e-3)
    landing = BallModel().first_bounce(np.r_[hit.position, out.velocity, out.spin])
    cfg = planner.config
    np.testing.assert_allclose(landing.position[:2], (cfg.target_x, cfg.target_y), atol=5e-3)
    assert np.all(np.abs(stroke.qd_hit) <= planner.limits.velocity)


def test_without_a_topspin_the_teacher_plays_the_flat_stroke():
    flat = StrokePlanner()
    hit = flat.model.predict_time(STATE, AHEAD)
    stroke = flat.stroke(hit.position, hit.velocity, AHEAD, hit.spin, None)
    e = racket_restitution(-(stroke.racket_normal @ (hit.velocity - stroke.racket_velocity)))
    out = racket_impact(hit.velocity, hit.spin, stroke.racket_normal, stroke.racket_velocity, e,
                        RACKET_MU)
    np.testing.assert_allclose(out.spin, hit.spin, atol=1e-6)  # no slip: the spin passes
