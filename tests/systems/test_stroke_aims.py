"""Per-stroke aims for the learned players (the rally's competitive aim): the hitting
configuration plays each ball's drawn aim, the ball's index coming from the hitting-point
predictor, which counts the balls it has let go with ``play_again``."""

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from tt_drake.ball_model import BallModel
from tt_drake.racket_impact import topspin
from tt_drake.rally_aim import CompetitiveAim, draw_aims
from tt_drake.systems.analytical_player import PlannerConfig, StrokeAims, StrokePlanner
from tt_drake.systems.hitting_configuration import HittingConfiguration
from tt_drake.systems.hitting_point_predictor import HittingPointPredictor

# A rally ball at the hitting plane (the striker's frame), topspin as a robot's drive leaves it.
P_HIT = np.array([0.1, -1.82, 0.95])
V_HIT = np.array([0.2, -4.0, 0.6])
SPIN = np.array([90.0, 10.0, 0.0])
T_HIT = 0.8


@pytest.fixture(scope="module")
def planner():
    return StrokePlanner(config=PlannerConfig(target_x=-0.3, target_y=0.9))


def answer(config, context, balls):
    config.GetInputPort("balls").FixValue(context, [float(balls)])
    return (config.GetOutputPort("theta_hit").Eval(context).copy(),
            config.GetOutputPort("theta_dot_hit").Eval(context).copy())


def test_each_ball_plays_its_drawn_aim_and_lands_there(planner):
    """Ball k of the rally with seed s is struck for the aim StrokeAims chooses from the draws
    of (s, k): the configuration's (theta_hit, theta_dot_hit) are that aim's stroke (which the
    next test lands on its target); another ball index or seed gives another stroke; without
    aims the planner's own aim."""
    aims = CompetitiveAim()
    config = HittingConfiguration("analytical", planner=planner, use_spin=True)
    config.aims = aims
    context = config.CreateDefaultContext()
    for name, value in (("p_hit", P_HIT), ("v_hit", V_HIT), ("t_hit", [T_HIT]),
                        ("valid", [1.0]), ("spin_hit", SPIN)):
        config.GetInputPort(name).FixValue(context, value)
    config.set_seed(context, 77)
    chooser = StrokeAims(planner, aims)
    strokes = []
    for ball in (0, 1, 2):
        q, qd = answer(config, context, ball)
        first = chooser.stroke(77, ball, P_HIT, V_HIT, T_HIT, SPIN)
        chosen = chooser.chosen(77, ball)
        assert chosen is not None and chosen.config.topspin is not None
        assert first.aimed and np.array_equal(first.q_hit, chooser.stroke(
            77, ball, P_HIT, V_HIT, T_HIT, SPIN).q_hit)  # chosen once, then kept
        assert chosen.config.target_x in [a.target_x for a in draw_aims(aims, 77, ball)]
        expected = chosen.stroke(P_HIT, V_HIT, T_HIT, SPIN, None)
        np.testing.assert_allclose(q, expected.q_hit, atol=1e-12)
        np.testing.assert_allclose(qd, expected.qd_hit, atol=1e-12)
        strokes.append(q)
    assert not np.allclose(strokes[0], strokes[1])
    config.set_seed(context, 78)
    assert not np.allclose(answer(config, context, 0)[0], strokes[0])
    own = planner.stroke(P_HIT, V_HIT, T_HIT, SPIN, None)
    config.aims = None
    np.testing.assert_allclose(answer(config, context, 0)[0], own.q_hit, atol=1e-12)


def test_the_aimed_stroke_sends_the_ball_to_its_target_with_its_topspin(planner):
    """The chosen aim's stroke: its outgoing velocity and spin, flown with drag and Magnus,
    land on the aim's target, with the aim's topspin."""
    aims = CompetitiveAim()
    for seed in (5, 6, 7):
        chooser = StrokeAims(planner, aims)
        stroke = chooser.stroke(seed, 0, P_HIT, V_HIT, T_HIT, SPIN)
        chosen = chooser.chosen(seed, 0)
        bounce = BallModel().first_bounce(np.r_[P_HIT, stroke.v_out, stroke.spin_out], 2.0)
        target = (chosen.config.target_x, chosen.config.target_y)
        np.testing.assert_allclose(bounce.position[:2], target, atol=0.02)
        assert topspin(np.r_[P_HIT, stroke.v_out, stroke.spin_out]) == pytest.approx(
            chosen.config.topspin, abs=1e-3)


def test_aims_need_the_analytical_configuration():
    with pytest.raises(ValueError, match="analytical"):
        HittingConfiguration("crkr", model=object()).aims = CompetitiveAim()


def test_the_predictor_counts_the_balls_it_lets_go():
    """With ``play_again`` the predictor drops its prediction when it sees the ball fly away
    (v_y > 0) and counts that ball; estimates of the ball still flying away count nothing more,
    and the next ball coming in is ball 1 until it too flies away."""
    predictor = HittingPointPredictor(play_again=True)
    context = predictor.CreateDefaultContext()
    simulator = Simulator(predictor, context)
    predictor.GetInputPort("spin").FixValue(context, np.zeros(3))
    balls = predictor.GetOutputPort("balls")
    tick = 1.0 / 180.0
    coming = np.array([0.0, -0.3, 1.0, 0.0, -5.0, 0.5])  # past the net, toward the robot
    away = np.array([0.0, -1.5, 1.0, 0.0, 5.0, 0.5])
    counts = []
    t = 0.0
    for estimate in (coming, coming, away, away, coming, coming, away):
        t += 3 * tick
        predictor.GetInputPort("state").FixValue(context, estimate)
        predictor.GetInputPort("status").FixValue(context, [1.0, t])
        simulator.AdvanceTo(t + tick)
        counts.append(int(balls.Eval(context)[0]))
    assert counts == [0, 0, 1, 1, 1, 1, 2]
