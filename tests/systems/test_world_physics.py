"""The Drake world's ball physics against ITTF facts and the numpy model it is calibrated to."""

import numpy as np
import pytest

from tt_drake.ball_model import BallModel
from tt_drake.constants import BALL, NET, TABLE
from tt_drake.diagrams.ball_world import BallOnlyWorld


@pytest.fixture(scope="module", params=["recipe", "default scenario"])
def world(request):
    """The ball world at the simulation recipe of docs/design.md (accuracy 1e-4) and at the shipped
    default scenario's simulator settings (1e-4 near contacts, 1e-3 in flight: ContactAccuracy,
    docs/performance.md): every check holds at both."""
    if request.param == "recipe":
        return BallOnlyWorld()
    from tt_drake.diagrams.scenario import load_scenario

    config = load_scenario().world
    config.with_robot = False
    return BallOnlyWorld(config=config)


def rebound_height(world, drop: float) -> float:
    z0 = TABLE.surface_z + BALL.radius + drop
    _, p, _, _ = world.run([0.0, -0.6, z0, 0, 0, 0], 1.0)
    i = int(np.argmin(p[:, 2]))
    return float(p[i:, 2].max() - TABLE.surface_z - BALL.radius)


def test_table_bounce_matches_ittf(world):
    # ITTF Law 2.1.3: a ball dropped from 30 cm rebounds about 23 cm.
    assert rebound_height(world, 0.30) == pytest.approx(0.23, abs=0.01)


def test_free_flight_with_drag_matches_the_numpy_model_within_1mm(world):
    launch = np.array([0.2, 1.2, 1.3, -0.3, -6.0, 1.5])  # ~1.1 m of flight in 0.2 s, no contact
    t, p, _, _ = world.run(launch, 0.2)
    model = BallModel()
    travelled = np.linalg.norm(p[-1] - p[0])
    assert travelled > 1.0
    errors = [np.linalg.norm(model.predict_time(np.r_[launch, 0, 0, 0], ti).position - pi)
              for ti, pi in zip(t[::20], p[::20], strict=True)]
    assert max(errors) < 1e-3
    # and drag matters at this scale: without it the ball would be centimetres away
    drag_free = launch[0:3] + launch[3:6] * t[-1] + 0.5 * np.array([0, 0, -9.81]) * t[-1] ** 2
    assert np.linalg.norm(drag_free - p[-1]) > 0.01


def test_oblique_bounce_reaches_the_rolling_limit(world):
    # Enough friction to stop the slip: v_t' = 0.6 v_t (hollow sphere), then it rolls: v = -omega R.
    launch = [0.0, -0.3, TABLE.surface_z + BALL.radius + 0.01, 0.0, -2.0, -3.0]
    t, p, v, w = world.run(launch, 0.02)
    after = t > 0.01
    vy, wx = v[after][-1, 1], w[after][-1, 0]
    assert v[after][-1, 2] > 0  # bounced
    assert vy == pytest.approx(0.6 * -2.0, abs=0.02)
    assert vy == pytest.approx(-wx * BALL.radius, abs=0.02)  # rolling: slip v_y + omega_x R = 0


def test_drake_bounce_matches_the_numpy_model(world):
    launch = np.array([0.1, -0.2, 1.0, 0.4, -3.0, -1.0])
    t, p, v, _ = world.run(launch, 0.5)
    model = BallModel()
    predicted = model.predict_time(np.r_[launch, 0, 0, 0], 0.5)
    assert len(predicted.bounces) == 1
    assert np.linalg.norm(predicted.position - p[-1]) < 5e-3
    assert np.linalg.norm(predicted.velocity - v[-1]) < 0.03


@pytest.mark.parametrize("phase", np.linspace(0.0, 1.0, 12, endpoint=False))
def test_no_tunnelling_through_the_table_at_20_m_per_s(world, phase):
    # Launch straight down at 20 m/s from heights offset by fractions of a 2 ms step's travel.
    z0 = TABLE.surface_z + BALL.radius + 0.10 + phase * 0.04
    _, p, v, _ = world.run([0.3, -0.5, z0, 0.0, 0.0, -20.0], 0.03)
    assert p[:, 2].min() > TABLE.surface_z  # never below the playing surface
    assert v[-1, 2] > 0  # bounced back up


@pytest.mark.parametrize("phase", np.linspace(0.0, 1.0, 12, endpoint=False))
def test_no_tunnelling_through_the_net_at_20_m_per_s(world, phase):
    y0 = -0.3 - phase * 0.04
    z = TABLE.surface_z + 0.5 * NET.height
    _, p, _, _ = world.run([0.2, y0, z, 0.0, 20.0, 0.0], 0.05)
    assert p[:, 1].max() < 0.0  # stopped on the robot's side of the net
