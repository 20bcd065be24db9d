"""The choice of hitting point along the predicted path (tt_drake.hitting_time)."""

import numpy as np
import pytest

from tt_drake.ball_model import BallModel
from tt_drake.constants import PLANES
from tt_drake.hitting_point import PhysicalPredictor
from tt_drake.hitting_time import (
    BounceCount,
    HittingBand,
    choose_hitting_point,
    closest_approach,
    last_robot_bounce,
    robot_bounces_by,
)
from tt_drake.serves import ServeSampler

MODEL = BallModel(dt=2e-3)
BAND = HittingBand()


def _real(kind: str):
    """The first real-train serve whose plane crossing is of ``kind``: ``low`` (one bounce on the
    robot's half, crossing below plane_z_min, still above z_min at y_max) or ``short`` (two
    bounces there before it)."""
    for ball in ServeSampler("real-train").pool():
        c = MODEL.predict_plane(ball.state, PLANES.hitting_y)
        if c is None:
            continue
        robot = [b for b in c.bounces if b.position[1] < 0.0]
        if kind == "low" and len(robot) == 1 and c.position[2] < BAND.plane_z_min - 0.05:
            at_reach = MODEL.predict_plane(ball.state, BAND.y_max)
            if at_reach.position[2] > BAND.z_min + 0.02:
                return ball.state, c
        if kind == "short" and len(robot) == 2:
            return ball.state, c
    raise AssertionError(f"no {kind} serve in the pool")


def test_default_serves_keep_the_plane_crossing():
    sampler = ServeSampler("default")
    for seed in range(10):
        state = sampler.sample(seed).launch_state
        chosen = choose_hitting_point(MODEL, state)
        plane = MODEL.predict_plane(state, PLANES.hitting_y)
        assert chosen.t == plane.t
        np.testing.assert_array_equal(chosen.position, plane.position)


def test_a_ball_crossing_too_low_is_hit_where_it_falls_through_the_band():
    state, plane = _real("low")
    hit = choose_hitting_point(MODEL, state)
    assert hit is not None and hit.t < plane.t
    # In the band, after the robot-side bounce, where the ball falls through z_min.
    assert hit.position[2] == pytest.approx(BAND.z_min, abs=1e-6)
    assert hit.velocity[2] < 0.0 and hit.position[1] <= BAND.y_max
    robot = [b for b in hit.bounces if b.position[1] < 0.0]
    assert len(robot) == 1 and robot[0].t < hit.t
    # It is the last such point: 2 ms later the ball is below the band.
    assert MODEL.predict_time(state, hit.t + 2e-3).position[2] < BAND.z_min
    # The same point from a later estimate of the same flight (after the bounce), to 1e-6.
    later = MODEL.predict_time(state, robot[0].t + 0.05)
    again = choose_hitting_point(MODEL, later.state)
    assert again.t + robot[0].t + 0.05 == pytest.approx(hit.t, abs=1e-6)
    np.testing.assert_allclose(again.position, hit.position, atol=1e-6)
    np.testing.assert_allclose(again.spin, hit.spin, atol=1e-9)


def test_a_short_ball_bouncing_twice_before_reach_has_no_hitting_point():
    state, _ = _real("short")
    assert choose_hitting_point(MODEL, state) is None


def test_last_robot_bounce_by_following_the_flight_back():
    state, plane = _real("low")
    bounce = next(b for b in plane.bounces if b.position[1] < 0.0)
    assert last_robot_bounce(MODEL, state) is None  # the opponent's half
    assert last_robot_bounce(MODEL, MODEL.predict_time(state, bounce.t - 0.02).state) is None
    ago = last_robot_bounce(MODEL, MODEL.predict_time(state, bounce.t + 0.02).state)
    assert ago == pytest.approx(0.02, abs=MODEL.dt)


def test_bounce_count_counts_a_later_bounce_as_the_second():
    count = BounceCount()
    assert count.seen(None) == count and count.count == 0
    one = count.seen(0.61)
    assert (one.first, one.count) == (0.61, 1)
    assert one.seen(0.615) == one and one.seen(None) == one  # the same bounce, seen again
    two = one.seen(0.9)
    assert two.count == 2 and two.seen(1.3) == two and two.seen(None) == two


def test_a_ball_that_bounced_twice_on_the_robots_half_has_no_hitting_point():
    """The rules end the hitting window at the second bounce on the robot's half: between the
    bounces the chosen point comes before the second; after it there is none (the player lets
    the ball go), however high the ball flies on; a player that counts the bounces as it sees
    them (one estimate per camera frame) counts two only after the second."""
    state, plane = _real("short")
    first, second = [b for b in plane.bounces if b.position[1] < 0.0][:2]
    count = BounceCount()
    for t in np.arange(0.0, second.t + 0.15, 1.0 / 60.0):
        now = MODEL.predict_time(state, t).state
        ago = last_robot_bounce(MODEL, now)
        count = count.seen(None if ago is None else t - ago)
        assert count.count == int(t > first.t) + int(t > second.t)
        hit = choose_hitting_point(MODEL, now, bounces_behind=count.count)
        if count.count == 2:
            assert hit is None
        elif count.count == 1:
            assert hit is None or t + hit.t <= second.t + 1e-9
    # after the second bounce the look-back alone sees one bounce behind: without the count the
    # hitting point would come after it
    after = MODEL.predict_time(state, second.t + 0.05).state
    assert last_robot_bounce(MODEL, after) == pytest.approx(0.05, abs=MODEL.dt)


def test_robot_bounces_by_counts_only_the_robots_half():
    """A short ball bounces at y = 0.15 m (the opponent's half), -0.52 m and -1.01 m: reaching
    the hitting plane it has bounced twice on the robot's half, plus any counted before."""
    model = PhysicalPredictor().model
    hit = model.predict_plane(np.array([0.0, 0.6, 0.95, 0.0, -3.2, -0.5, 0.0, 0.0, 0.0]),
                              PLANES.hitting_y)
    assert [round(float(b.position[1]), 2) for b in hit.bounces] == [0.15, -0.52, -1.01]
    assert robot_bounces_by(hit, 0) == 2 and robot_bounces_by(hit, 1) == 3


def test_closest_approach_is_the_distance_along_the_path_in_play():
    """The least distance of the ball's centre from a point while in play on the robot's half:
    zero (to a step's travel) for a point on the path there, the path's distance for a point
    beside it, and the path after the second bounce on the robot's half left out."""
    model = BallModel(dt=2e-3)
    launch = np.array([0.0, 0.6, 0.95, 0.0, -3.2, -0.5, 0.0, 0.0, 0.0])  # bounces twice short
    plane = model.predict_plane(launch, PLANES.hitting_y)
    robot = [b for b in plane.bounces if b.position[1] < 0.0]
    assert len(robot) == 2
    between = model.predict_time(launch, 0.5 * (robot[0].t + robot[1].t))
    step = 2e-3 * float(np.linalg.norm(between.velocity))
    assert closest_approach(model, launch, between.position) <= step
    beside = between.position + np.array([0.4, 0.0, 0.0])  # the path runs along x = 0
    assert closest_approach(model, launch, beside) == pytest.approx(0.4, abs=step)
    # the plane crossing comes after the second bounce: out of play, so the path in play stays
    # at least as far from it as its distance to the second bounce's point
    after = closest_approach(model, launch, plane.position)
    assert after >= float(np.linalg.norm(plane.position - robot[1].position)) - step
