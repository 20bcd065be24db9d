"""EKF on the ball model: convergence, robustness to dropouts and outliers, NEES consistency.

The truth here is the compliant-bounce ball model itself sampled at 60 Hz (the Drake comparison is
in tests/systems/test_vision_systems.py), so these tests are fast and pure numpy.
"""

import numpy as np
import pytest
from scipy.stats import chi2

from tt_drake.ball_model import CompliantBounceBallModel
from tt_drake.camera_model import CameraConfig, CameraModel
from tt_drake.constants import PLANES
from tt_drake.estimation import BallFlightEKF, EstimatorConfig, nees, propagate_exact, run_filter
from tt_drake.serves import ServeSampler

RATE = 60.0


def truth(seed):
    """True (p, v) at the camera frames from launch to the hitting plane."""
    serve = ServeSampler("default").sample(seed)
    model = CompliantBounceBallModel(dt=2e-3)
    n = int(serve.crossing.t * RATE)
    x = serve.launch_state[:6].copy()
    out = [x]
    for _ in range(n):
        x, _ = propagate_exact(model, x, 1.0 / RATE)
        out.append(x)
    return np.arange(n + 1) / RATE, np.array(out)


@pytest.fixture(scope="module")
def flights():
    return [truth(s) for s in range(12)]


def run(flight, camera, seed):
    t, x = flight
    z = CameraModel(camera).measure_sequence(seed, x[:, :3])
    return run_filter(t, z, EstimatorConfig())


def test_propagate_exact_lands_on_the_requested_time():
    model = CompliantBounceBallModel(dt=4e-3)
    x0 = np.array([0.0, 1.5, 0.9, 0.2, -5.0, 2.0])
    x1, _ = propagate_exact(model, x0, 1.0 / 60)
    fine, _ = propagate_exact(CompliantBounceBallModel(dt=1e-4), x0, 1.0 / 60)
    assert np.allclose(x1, fine, atol=1e-7)


def test_converges_with_default_noise(flights):
    errs_p, errs_v = [], []
    for i, f in enumerate(flights):
        r = run(f, CameraConfig(), i)
        ok = r.tracking.copy()
        ok[:8] = False  # after the start-up transient
        vz = f[1][:, 5]
        for b in np.nonzero((vz[:-1] < 0) & (vz[1:] > 0))[0]:
            ok[b + 1:b + 4] = False  # and the few frames the filter needs to settle after a bounce
        errs_p.append(r.states[ok, :3] - f[1][ok, :3])
        errs_v.append(r.states[ok, 3:] - f[1][ok, 3:])
    rmse_p = np.sqrt(np.mean(np.sum(np.concatenate(errs_p) ** 2, 1)))
    rmse_v = np.sqrt(np.mean(np.sum(np.concatenate(errs_v) ** 2, 1)))
    assert rmse_p < 0.004  # below the raw 3 mm x sqrt(3) = 5.2 mm of one measurement
    assert rmse_v < 0.08


def test_never_diverges_with_dropouts_and_outliers(flights):
    cam = CameraConfig(dropout=0.2, outlier=0.02)
    for i, f in enumerate(flights * 2):
        r = run(f, cam, 100 + i)
        ok = r.tracking.copy()
        ok[:8] = False
        err = np.linalg.norm(r.states[ok, :3] - f[1][ok, :3], axis=1)
        assert err.max() < 0.05, f"flight {i}: position error {err.max():.3f} m"
        assert r.tracking[-5:].all(), f"flight {i}: lost the ball at the end"


def test_covariance_is_consistent(flights):
    values = []
    for i, f in enumerate(flights):
        r = run(f, CameraConfig(), 200 + i)
        ok = r.tracking
        e = r.states[ok] - f[1][ok]
        values.append(nees(e, r.covariances[ok]))
    a = np.concatenate(values)
    inside = np.mean((a >= chi2.ppf(0.025, 6)) & (a <= chi2.ppf(0.975, 6)))
    assert inside > 0.8
    assert 3.0 < a.mean() < 9.0


def test_gate_rejects_a_gross_outlier_and_state_round_trips():
    f = truth(3)
    ekf = BallFlightEKF()
    for k in range(6):
        ekf.step(f[0][k], f[1][k, :3])
    x_before = ekf.x.copy()
    assert not ekf.update(f[1][6, :3] + np.array([0.3, 0.0, 0.0])) or False
    assert np.array_equal(ekf.x, x_before)
    other = BallFlightEKF()
    other.load_vector(ekf.to_vector())
    assert np.array_equal(other.to_vector(), ekf.to_vector(), equal_nan=True)


def test_crosses_the_hitting_plane_side(flights):
    t, x = flights[0]
    assert x[-1, 1] > PLANES.hitting_y - 0.2


def test_variational_jacobian_matches_finite_differences(flights):
    # In flight F comes from the variational equation. The forward differences it replaces
    # (eps = 1e-6) are themselves accurate to about eps |d2f/dx2| + 1e-16 |f| / eps ~ 1e-9
    # relative, so 1e-6 leaves a wide margin, while a wrong drag term would be off by
    # ~k |v| dt ~ 1e-2. Across a bounce the filter falls back to those finite differences.
    ekf = BallFlightEKF()
    dt = 1.0 / RATE
    n_flight = n_bounce = 0
    for _, x in flights[:3]:
        for xk in x:
            fx, bounced, F = ekf.propagate_with_jacobian(xk, dt)
            ref_x, ref_bounced = propagate_exact(ekf.model, xk, dt)
            assert bounced == ref_bounced
            assert np.array_equal(fx, ref_x)
            F_fd = ekf.numerical_jacobian(xk, dt, ref_x)
            if bounced:
                n_bounce += 1
                assert np.array_equal(F, F_fd)
            else:
                n_flight += 1
                assert np.linalg.norm(F - F_fd) < 1e-6 * np.linalg.norm(F_fd)
            assert np.array_equal(ekf.jacobian(xk, dt), F)
    assert n_flight > 50 and n_bounce >= 3
