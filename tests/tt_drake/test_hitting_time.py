"""The choice of hitting point along the predicted path (tt_drake.hitting_time)."""

import math

import numpy as np
import pytest

from tt_drake.ball_model import BallModel, CompliantBounceBallModel
from tt_drake.constants import PLANES
from tt_drake.hitting_time import HittingBand, choose_hitting_point, robot_half_bounces, unbounce
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


def test_robot_half_bounces_by_following_the_flight_back():
    state, plane = _real("low")
    bounce = next(b for b in plane.bounces if b.position[1] < 0.0)
    assert robot_half_bounces(MODEL, state) == 0  # the opponent's half
    assert robot_half_bounces(MODEL, MODEL.predict_time(state, bounce.t - 0.02).state) == 0
    assert robot_half_bounces(MODEL, MODEL.predict_time(state, bounce.t + 0.02).state) == 1
    assert robot_half_bounces(MODEL, plane.state) == 1  # at the hitting plane, behind the table


@pytest.mark.parametrize("model", [MODEL, CompliantBounceBallModel(dt=2e-3)])
def test_unbounce_inverts_the_bounce(model):
    """A sliding bounce has one pre-image: unbounce finds it; a ball that leaves rolling has
    many, and unbounce returns one that the bounce maps to the same state."""
    rng = np.random.default_rng(3)
    rolled = 0
    for _ in range(200):
        v = (rng.uniform(-2, 2), rng.uniform(-7, -1), rng.uniform(-6, -1))
        w = tuple(rng.uniform(-150, 150, 3))
        v1, w1 = model.bounce(v, w)
        v0, w0 = unbounce(model, v1, w1)
        again = model.bounce(v0, w0)
        np.testing.assert_allclose(again[0], v1, atol=1e-9)
        np.testing.assert_allclose(again[1], w1, atol=1e-7)
        # sliding throughout: the friction impulse reached its Coulomb limit mu J_n
        jn = (1.0 + model.table_restitution(-v[2])) * -v[2]
        rolling = math.hypot(v1[0] - v[0], v1[1] - v[1]) < model.params.table_friction * jn - 1e-6
        rolled += rolling
        r = model.params.radius
        if not rolling and math.hypot(v1[0] - r * w1[1], v1[1] + r * w1[0]) > 0.5:
            # clearly sliding (near the rolling limit the pre-image is ill-conditioned)
            np.testing.assert_allclose(v0, v, atol=1e-5)
            np.testing.assert_allclose(w0, w, atol=1e-3)
        else:
            assert v0[2] == pytest.approx(v[2], abs=1e-9)  # the normal part is always exact
    assert 0 < rolled < 200


def test_a_ball_that_bounced_twice_on_the_robots_half_has_no_hitting_point():
    """The rules end the hitting window at the second bounce on the robot's half: between the
    bounces the chosen point comes before the second; after it there is none (the player lets
    the ball go), however high the ball flies on."""
    state, plane = _real("short")
    first, second = [b for b in plane.bounces if b.position[1] < 0.0][:2]
    for t in np.linspace(first.t + 0.01, second.t - 0.01, 6):
        later = MODEL.predict_time(state, t).state
        assert robot_half_bounces(MODEL, later) == 1
        hit = choose_hitting_point(MODEL, later)
        assert hit is None or t + hit.t <= second.t + 1e-9
    for dt in (0.01, 0.05, 0.1):
        after = MODEL.predict_time(state, second.t + dt).state
        assert robot_half_bounces(MODEL, after) == 2
        assert choose_hitting_point(MODEL, after) is None
