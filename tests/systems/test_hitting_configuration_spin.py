"""The analytical hitting configuration with the predicted spin (``use_spin``, the hard
protocol's player): its racket meets the spinning ball without slip and sends it to the target;
without ``use_spin`` the spin is ignored (the paper profile's configuration, unchanged)."""

import itertools

import numpy as np
import pytest

from tt_drake.constants import BALL
from tt_drake.racket_law import RacketState, landing_after_racket, racket_restitution
from tt_drake.systems.analytical_player import PlannerConfig, StrokePlanner
from tt_drake.systems.hitting_configuration import HittingConfiguration

# A ball at the hitting plane after the robot-side bounce of a `spin` serve (serve 10 of
# `--distribution spin --seed 2026`): heavy spin about x, as the bounce leaves it.
P_HIT = np.array([0.375, -1.82, 1.101])
V_HIT = np.array([0.473, -2.554, -0.035])
SPIN = np.array([140.2, 28.0, -57.5])
T_HIT = 0.84


@pytest.fixture(scope="module")
def planner():
    return StrokePlanner(config=PlannerConfig())


def configuration(planner, use_spin, spin=SPIN, velocities="theta_dot_hit"):
    """The racket (blade centre velocity, normal) of the configuration's (theta_hit,
    ``velocities``) for the prediction above, by forward kinematics."""
    config = HittingConfiguration("analytical", planner=planner, use_spin=use_spin)
    context = config.CreateDefaultContext()
    for name, value in (("p_hit", P_HIT), ("v_hit", V_HIT), ("t_hit", [T_HIT]),
                        ("valid", [1.0]), ("spin_hit", spin)):
        config.GetInputPort(name).FixValue(context, value)
    assert config.GetOutputPort("valid").Eval(context)[0] == 1.0
    q = config.GetOutputPort("theta_hit").Eval(context)
    qd = config.GetOutputPort(velocities).Eval(context)
    normal = planner.arm.racket_pose(q).rotation().matrix()[:, 1]
    return planner.arm.racket_velocity(q, qd)[3:], normal


def tangential(v, n):
    return v - (v @ n) * n


def landing(planner, velocity, normal):
    """Where the ball (with its spin) first lands after this racket: the racket law forward and
    the planner's ball model."""
    racket = RacketState(normal, velocity, racket_restitution(float(normal @ (velocity - V_HIT))))
    return landing_after_racket(P_HIT, V_HIT, racket, SPIN, planner.model)


def test_with_the_spin_the_racket_follows_the_balls_contact_point(planner):
    velocity, normal = configuration(planner, use_spin=True)
    contact = V_HIT + np.cross(SPIN, -BALL.radius * normal)  # the ball's contact point
    slip = np.linalg.norm(tangential(velocity, normal) - tangential(contact, normal))
    assert slip < 0.02  # m/s; the spin alone moves the contact point by ~2 m/s here
    assert np.linalg.norm(tangential(contact - V_HIT, normal)) > 1.0
    target = np.array([planner.config.target_x, planner.config.target_y])
    assert np.linalg.norm(landing(planner, velocity, normal) - target) < 0.01


def test_without_use_spin_the_spin_is_ignored(planner):
    velocity, normal = configuration(planner, use_spin=False)
    # The racket moves with the ball's centre, not its spinning contact point ...
    slip = np.linalg.norm(tangential(velocity, normal) - tangential(V_HIT, normal))
    assert slip < 0.02
    # ... and the same configuration whatever the spin input says.
    other_velocity, _ = configuration(planner, use_spin=False, spin=np.zeros(3))
    np.testing.assert_allclose(velocity, other_velocity, atol=1e-9)
    # Its aim leaves out the Magnus force of the ball's spin: it lands elsewhere.
    target = np.array([planner.config.target_x, planner.config.target_y])
    assert np.linalg.norm(landing(planner, velocity, normal) - target) > 0.05


def test_the_spinless_velocities_take_out_the_contact_point_term_only(planner):
    velocity, normal = configuration(planner, use_spin=True)
    spinless, same_normal = configuration(planner, use_spin=True,
                                          velocities="theta_dot_hit_spinless")
    np.testing.assert_allclose(same_normal, normal, atol=1e-12)  # the same theta_hit
    # Same normal speed (the same push along the normal) ...
    assert abs((spinless - velocity) @ normal) < 1e-4  # m/s (the IK's angle error)
    # ... and tangentially the ball's centre, not its spinning contact point.
    slip = np.linalg.norm(tangential(spinless, normal) - tangential(V_HIT, normal))
    assert slip < 0.02 < np.linalg.norm(tangential(velocity - spinless, normal)) - 1.0
    # Without use_spin they are the configuration's own velocities.
    a, _ = configuration(planner, use_spin=False)
    b, _ = configuration(planner, use_spin=False, velocities="theta_dot_hit_spinless")
    np.testing.assert_allclose(a, b, atol=1e-12)


class _NoSpinReach:
    """A planner for which no spin-aware stroke is reachable (as for low real serves with 100+
    rad/s of topspin); spinless strokes are the real planner's."""

    def __init__(self, planner):
        self.planner, self.arm, self.calls = planner, planner.arm, []

    def stroke(self, p_hit, v_hit, t_hit, spin, previous):
        self.calls.append(np.array(spin))
        return None if np.any(spin) else self.planner.stroke(p_hit, v_hit, t_hit, spin, previous)


def test_without_a_reachable_spin_aware_stroke_the_configuration_is_the_spinless_one(planner):
    fake = _NoSpinReach(planner)
    a = HittingConfiguration("analytical", planner=fake, use_spin=True)
    b = HittingConfiguration("analytical", planner=planner, use_spin=False)
    outputs = []
    for config in (a, b):
        context = config.CreateDefaultContext()
        for name, value in (("p_hit", P_HIT), ("v_hit", V_HIT), ("t_hit", [T_HIT]),
                            ("valid", [1.0]), ("spin_hit", SPIN)):
            config.GetInputPort(name).FixValue(context, value)
        outputs.append([config.GetOutputPort(n).Eval(context).copy() for n in
                        ("theta_hit", "theta_dot_hit", "valid", "theta_dot_hit_spinless")])
    assert [bool(np.any(s)) for s in fake.calls] == [True, False]  # spin first, then without
    for x, y in zip(*outputs, strict=True):
        np.testing.assert_allclose(x, y, atol=1e-12)
    assert outputs[0][2][0] == 1.0


def test_fallback_strokes_are_the_teachers_strokes_after_the_configurations_own(planner):
    """``fallback_strokes`` lists the planner's strokes for the prediction in its fallbacks'
    order: the first is the configuration's (theta_hit, theta_dot_hit), the later ones other arm
    configurations the planner reaches; none without a valid prediction."""
    config = HittingConfiguration("analytical", planner=planner, use_spin=True)
    context = config.CreateDefaultContext()
    for name, value in (("p_hit", P_HIT), ("v_hit", V_HIT), ("t_hit", [T_HIT]),
                        ("valid", [1.0]), ("spin_hit", SPIN)):
        config.GetInputPort(name).FixValue(context, value)
    strokes = list(itertools.islice(config.GetOutputPort("fallback_strokes").Eval(context), 3))
    expected = itertools.islice(planner.strokes(P_HIT, V_HIT, T_HIT, SPIN, None), 3)
    for (q, qd), stroke in zip(strokes, expected, strict=True):
        np.testing.assert_array_equal(q, stroke.q_hit)
        np.testing.assert_array_equal(qd, stroke.qd_hit)
    np.testing.assert_array_equal(strokes[0][0], config.GetOutputPort("theta_hit").Eval(context))
    np.testing.assert_array_equal(strokes[0][1],
                                  config.GetOutputPort("theta_dot_hit").Eval(context))
    assert len(strokes) == 3 and np.abs(strokes[2][0] - strokes[0][0]).max() > 1e-3
    config.GetInputPort("valid").FixValue(context, [0.0])
    assert list(config.GetOutputPort("fallback_strokes").Eval(context)) == []
