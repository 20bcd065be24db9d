"""The teacher's fallbacks for a stroke the arm cannot make: a racket compensating less of the
spin, the ball met off the blade's centre (systems/analytical_player.py, PlannerConfig)."""

import numpy as np
import pytest

from tt_drake import wam_params as wp
from tt_drake.constants import BALL
from tt_drake.systems.analytical_player import PlannerConfig, StrokePlanner, blade_centre
from tt_drake.systems.hitting_ik import SHOULDER

# A real-train serve after its bounce on the robot's half, heavy topspin (p, v, omega): the
# hitting point 0.46 s later lies where the plain stroke (all the spin compensated, the ball on
# the blade's centre) asks the arm for more than it has.
STATE = np.array([-0.0355, -0.6268, 0.8217, 0.3852, -2.1576, 2.0512, 108.74, 19.43, -7.17])
AHEAD = 0.46


@pytest.fixture(scope="module")
def planners():
    plain = StrokePlanner(config=PlannerConfig(stroke_spins=(1.0,), blade_offsets=(0.0,)))
    return plain, StrokePlanner(arm=plain.arm)


def test_the_blade_centre_moves_within_the_face_toward_the_shoulder():
    p = np.array([0.2, -1.6, 0.7])
    n = np.array([0.1, 0.9, 0.3]) / np.linalg.norm([0.1, 0.9, 0.3])
    r = 0.025
    centre = blade_centre(p, n, r)
    np.testing.assert_allclose(centre, p - r * n)
    moved = blade_centre(p, n, r, 0.06)
    d = moved - centre
    assert np.linalg.norm(d) == pytest.approx(0.06)
    assert d @ n == pytest.approx(0.0, abs=1e-12)  # within the face's plane
    # toward the shoulder: the shoulder's direction, projected on the face, is d's
    to_shoulder = (SHOULDER - p) - ((SHOULDER - p) @ n) * n
    assert d @ to_shoulder == pytest.approx(0.06 * np.linalg.norm(to_shoulder))


def test_a_stroke_the_plain_racket_cannot_make_falls_back(planners):
    plain, teacher = planners
    hit = teacher.model.predict_time(STATE, AHEAD)
    args = (hit.position, hit.velocity, AHEAD, hit.spin, None)
    assert plain.stroke(*args) is None
    stroke = teacher.stroke(*args)
    assert stroke is not None
    assert stroke.spin_share < 1.0 or stroke.blade_offset > 0.0
    # the arm solution puts the blade's centre where blade_centre says, facing the racket normal
    contact = BALL.radius + 0.5 * wp.RACKET.blade_thickness
    target = blade_centre(hit.position, stroke.racket_normal, contact, stroke.blade_offset)
    pose = teacher.arm.racket_pose(stroke.q_hit)
    np.testing.assert_allclose(pose.translation(), target, atol=2e-4)
    assert np.all(np.abs(stroke.qd_hit) <= teacher.limits.velocity)


def test_the_plain_stroke_comes_first_when_the_arm_makes_it(planners):
    plain, teacher = planners
    state = STATE.copy()
    state[6:] = 0.0  # no spin: the plain stroke is within reach here
    hit = teacher.model.predict_time(state, 0.48)
    args = (hit.position, hit.velocity, 0.48, hit.spin, None)
    expected = plain.stroke(*args)
    stroke = teacher.stroke(*args)
    assert expected is not None and stroke is not None
    assert (stroke.spin_share, stroke.blade_offset) == (1.0, 0.0)
    np.testing.assert_allclose(stroke.q_hit, expected.q_hit)
