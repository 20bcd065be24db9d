"""Served balls in the Drake world do what the launcher promised: one bounce on the robot's half,
then a crossing of the virtual hitting plane inside the hitting region."""

import numpy as np
import pytest

from tt_drake.constants import HITTING_REGION, PLANES, TABLE
from tt_drake.diagrams.ball_world import BallOnlyWorld
from tt_drake.serves import ServeSampler


@pytest.fixture(scope="module")
def world():
    return BallOnlyWorld(log_period=1e-3)


@pytest.mark.parametrize("distribution", ["default", "real", "fixed"])
def test_served_balls_bounce_once_on_the_robot_half_and_reach_the_region(world, distribution):
    sampler = ServeSampler(distribution)
    margin = 0.1 if distribution == "real" else 0.005  # real serves qualify with a 0.1 m margin
    for seed in range(8):
        serve = sampler.sample(seed)
        t, p, v, _ = world.run(serve.launch_state, serve.crossing.t + 0.02)
        i = int(np.argmax(p[:, 1] < PLANES.hitting_y))
        assert i > 0, "the ball never reached the hitting plane"
        # Bounces: the vertical velocity turns from down to up at table height.
        ups = np.where((v[:-1, 2] < 0) & (v[1:, 2] >= 0))[0]
        robot_half = [k for k in ups[ups < i] if p[k, 1] < 0]
        assert len(robot_half) == 1
        assert abs(p[robot_half[0], 2] - TABLE.surface_z - 0.02) < 0.01
        x, z = p[i, 0], p[i, 2]
        r = HITTING_REGION
        assert r.x_min - margin <= x <= r.x_max + margin
        assert r.z_min - margin <= z <= r.z_max + margin
