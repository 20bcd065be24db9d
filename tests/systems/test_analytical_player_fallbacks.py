"""The teacher's fallbacks for a stroke the arm cannot make: a racket compensating less of the
spin, the ball met off the blade's centre (systems/analytical_player.py, PlannerConfig)."""

import numpy as np
import pytest

from tt_drake import wam_params as wp
from tt_drake.constants import BALL
from tt_drake.seeds import episode_seed
from tt_drake.serves import ServeSampler
from tt_drake.systems.analytical_player import (
    PlannerConfig,
    StrokePlanner,
    blade_centre,
    reach_point,
)
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


# A real serve after its bounce on the robot's half (p, v, omega), far to the robot's backhand:
# its hitting point 0.45 s later (on the band, x = -0.68 m) lies just beyond every stroke the arm
# makes, with every fallback.
WIDE = np.array([-0.3152, -0.6409, 0.8268, -0.8769, -2.52, 1.9264, 127.5672, -44.4026, 4.5772])


def test_the_reach_point_moves_toward_the_shoulder_within_the_plane():
    p = np.array([-0.68, -1.69, 0.65])
    assert np.array_equal(reach_point(p, 0.0), p)
    moved = reach_point(p, 0.06)
    assert moved[1] == p[1]  # on the same plane y
    assert np.linalg.norm(moved - p) == pytest.approx(0.06)
    to_shoulder = SHOULDER - p
    to_shoulder[1] = 0.0
    assert (moved - p) @ to_shoulder == pytest.approx(0.06 * np.linalg.norm(to_shoulder))


def test_a_ball_just_beyond_reach_is_met_with_the_blade_planned_nearer(planners):
    _, teacher = planners
    reaching = StrokePlanner(arm=teacher.arm, config=PlannerConfig(reach_in=(0.03, 0.06, 0.09)))
    hit = teacher.model.predict_time(WIDE, 0.45)
    args = (hit.position, hit.velocity, 0.45, hit.spin, None)
    assert teacher.stroke(*args) is None
    stroke = reaching.stroke(*args)
    assert stroke is not None and stroke.reach_in in (0.03, 0.06, 0.09)
    # planned for the point moved in: the blade's centre where blade_centre puts it for that
    # point, the recorded hitting point the predicted one
    contact = BALL.radius + 0.5 * wp.RACKET.blade_thickness
    target = blade_centre(reach_point(hit.position, stroke.reach_in), stroke.racket_normal,
                          contact, stroke.blade_offset)
    np.testing.assert_allclose(reaching.arm.racket_pose(stroke.q_hit).translation(), target,
                               atol=2e-4)
    np.testing.assert_array_equal(stroke.p_hit, hit.position)
    # the blade (76 mm in radius) still reaches the ball's centre
    assert np.linalg.norm(target - hit.position) < wp.RACKET.blade_radius + BALL.radius


@pytest.fixture(scope="module")
def long_stroke():
    """A teacher and its stroke for a ball whose hit needs a long direct stroke (rally-train
    ball 14 of seed 5101, 0.79 s to go at the launch), planned at the launch."""
    launch = ServeSampler("rally-train", run_seed=5101).sample(
        episode_seed(5101, 14)).launch_state
    teacher = StrokePlanner()
    p_hit, v_hit, t_hit, spin, _ = teacher.predict(launch[:6], 0.0, launch[6:9])
    return teacher, teacher.stroke(p_hit, v_hit, t_hit, spin, None)


def test_the_start_margin_leaves_the_stroke_a_window_of_several_frames(long_stroke):
    """A ball whose hit needs a long direct stroke (a rally ball, 0.79 s to go at the launch;
    its swing-back asks the arm for too much torque): at rest the player waits while a hit
    started ``start_margin`` later stays feasible. The times at which it starts, rather than
    waits, then span at least the margin, so a player acting once per camera frame (1/60 s)
    whose predicted t_hit moves by a few ms between frames still finds one; with a one-frame
    margin the window is about one frame."""
    teacher, stroke = long_stroke
    t_hit, rest = stroke.t_hit, teacher.awaiting_plan(0.0)
    step = 0.002
    for margin in (1.0 / 60.0, 0.05):
        planner = StrokePlanner(arm=teacher.arm,
                                config=PlannerConfig(start_margin=margin))
        starts = [now for now in np.arange(0.0, t_hit - 0.05, step)
                  if planner.schedule(now, rest, stroke)[0] is not None]
        assert starts, margin
        window = starts[-1] - starts[0] + step
        assert margin - step <= window <= margin + 2 * step
        assert all(np.diff(starts) < 1.5 * step)  # one window


def test_schedule_tells_waiting_from_a_stroke_the_arm_cannot_follow(long_stroke):
    """The same rally ball, from rest: 0.8 s before the hit the swing-back and stroke ask the
    arm for more torque than it has (refused); later the player waits (a direct hit started
    later is feasible); inside the start window it plans; after it the direct stroke is refused
    again. A refusal is not a wait: the player then keeps its plan and tries its next
    stroke."""
    planner, stroke = long_stroke
    rest = planner.awaiting_plan(0.0)
    kinds = []
    for now in np.arange(0.0, stroke.t_hit - 0.05, 0.004):
        plan, wait = planner.schedule(now, rest, stroke)
        assert not (wait and plan is not None)
        kinds.append("plan" if plan is not None else "wait" if wait else "refused")
        if plan is not None:
            assert planner.feasible(plan, now)
    # one run of each, in this order
    runs = [k for i, k in enumerate(kinds) if i == 0 or kinds[i - 1] != k]
    assert runs == ["refused", "wait", "plan", "refused"]
