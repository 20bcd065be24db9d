"""The compiled prediction noise of the estimator, table interpolation and net crossing: each
against the numpy or Python-float arithmetic it replaced, to the bit."""

import math

import numpy as np
import pytest

from tt_drake.ball_model import BallModel, restitution_table
from tt_drake.constants import BALL, NET, TABLE
from tt_drake.estimation import N_STATE, BallFlightEKF
from tt_drake.filter_kernel import add_process_noise
from tt_drake.flight_kernel import net_crossing_height
from tt_drake.interp_kernel import interp_one
from tt_drake.racket_law import net_clearance

MODEL = BallModel()


def _numpy_noise(ekf: BallFlightEKF, dt: float, bounced: bool) -> np.ndarray:
    """Q(dt) [+ Q_bounce] of the estimation module's docstring, in numpy arrays."""
    c = ekf.config
    q = c.accel_noise
    Q = np.zeros((N_STATE, N_STATE))
    i3 = np.eye(3)
    Q[:3, :3] = q * dt**3 / 3.0 * i3
    Q[:3, 3:6] = Q[3:6, :3] = q * dt**2 / 2.0 * i3
    Q[3:6, 3:6] = q * dt * i3
    Q[6:9, 6:9] = c.spin_noise * dt * i3
    if bounced:
        Q[3:6, 3:6] += c.bounce_velocity_sigma**2 * i3
        Q[6:9, 6:9] += c.bounce_spin_sigma**2 * i3
    return Q


def test_the_process_noise_is_added_and_symmetrised_to_the_bit():
    rng = np.random.default_rng(2)
    ekf = BallFlightEKF()
    for bounced in (False, True):
        for dt in (1 / 60, 1 / 30, 0.004):
            P = rng.normal(0.0, 1.0, (N_STATE, N_STATE))  # not symmetric: the sum makes it so
            M = P + _numpy_noise(ekf, dt, bounced)
            expected = 0.5 * (M + M.T)
            out = np.empty((N_STATE, N_STATE))
            add_process_noise(P, *ekf.noise_terms(dt, bounced), out)
            assert np.array_equal(out, expected)


def test_table_interpolation_is_numpys_to_the_bit():
    xp, fp = restitution_table()
    rng = np.random.default_rng(3)
    xs = np.concatenate([rng.uniform(-0.5, 3.5, 20000), xp, [0.0, 3.0, -1e-300, 3.0 + 1e-12]])
    for x in xs:
        assert interp_one(float(x), xp, fp) == float(np.interp(x, xp, fp))
    assert math.isnan(interp_one(math.nan, xp, fp))


def _python_clearance(p, v, spin):
    pos, vel = tuple(p), tuple(v)
    contact_z = TABLE.surface_z + BALL.radius
    for _ in range(200):
        new_p, new_v = MODEL.flight_step(pos, vel, tuple(spin), 0.01)
        if new_p[1] >= 0.0 > pos[1]:
            s = -pos[1] / (new_p[1] - pos[1])
            z = pos[2] + s * (new_p[2] - pos[2])
            return z - BALL.radius - (TABLE.surface_z + NET.height)
        if new_p[2] < contact_z:
            return -math.inf
        pos, vel = new_p, new_v
    return -math.inf


def test_the_compiled_net_crossing_is_the_python_steps_to_the_bit():
    rng = np.random.default_rng(5)
    inf = 0
    for _ in range(500):
        p = (rng.uniform(-0.7, 0.7), rng.uniform(-1.9, -1.2), rng.uniform(0.8, 1.3))
        v = (rng.uniform(-1.0, 1.0), rng.uniform(1.0, 8.0), rng.uniform(-2.0, 3.0))
        spin = tuple(rng.normal(0.0, 60.0, 3))
        expected = _python_clearance(p, v, spin)
        assert net_clearance(MODEL, p, v, spin) == expected
        inf += math.isinf(expected)
    assert 0 < inf < 500  # both branches were exercised
    # Straight over the net in the vacuum-like limit: a ball at net height moving level.
    z = net_crossing_height(0.0, -0.1, 1.0, 0.0, 5.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
                            0.01, 200, 0.0)
    assert z == pytest.approx(1.0)
