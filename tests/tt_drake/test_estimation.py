"""EKF on the ball model with spin: convergence, spin through the bounces, robustness to dropouts
and outliers, the bounce hypothesis of the gate, NEES consistency on three serve distributions.

The truth here is the compliant-bounce ball model itself (spin, Magnus, the bounce that changes
spin and velocity together) sampled at 60 Hz (the Drake comparison is in
tests/systems/test_vision_systems.py and docs/spin.md), so these tests are pure numpy.
"""

import dataclasses
from functools import cache

import numpy as np
import pytest
from scipy.stats import chi2

from tt_drake.ball_model import BallModelParams, CompliantBounceBallModel
from tt_drake.camera_model import CameraConfig, CameraModel
from tt_drake.constants import PLANES
from tt_drake.estimation import (
    BallFlightEKF,
    EstimatorConfig,
    nees,
    propagate_exact,
    propagate_flight_jacobian,
    run_filter,
)
from tt_drake.serves import ServeSampler, load_real_states

RATE = 60.0
MODEL = CompliantBounceBallModel(dt=2e-3)
N_SERVES = 200


def truth(launch, model=MODEL):
    """True (p, v, omega) at the camera frames from launch to the hitting plane."""
    x = np.asarray(launch, dtype=float)[:9].copy()
    out = [x]
    while x[1] > PLANES.hitting_y and x[2] > 0.1 and len(out) < 150:
        x, _ = propagate_exact(model, x, 1.0 / RATE)
        out.append(x)
    return np.arange(len(out)) / RATE, np.array(out)


def bounce_frames(x) -> np.ndarray:
    """Frames k with a bounce between k and k + 1 (v_z turns from down to up)."""
    return np.nonzero((x[:-1, 5] < 0.0) & (x[1:, 5] > 0.0))[0]


@cache
def launches(distribution: str) -> tuple:
    """``N_SERVES`` launch states: ``default`` (no spin), ``spin`` (the default launcher with
    spin up to 100 rad/s per axis) and ``real`` (serves.json states that bounce on the server's
    half and then on ours before the hitting plane, in file order)."""
    if distribution == "real":
        out = []
        for s in load_real_states():
            _, x = truth(s)
            if len(bounce_frames(x)) == 2 and x[-1, 1] <= PLANES.hitting_y:
                out.append(s)
            if len(out) == N_SERVES:
                break
        return tuple(out)
    sampler = ServeSampler("default", spin_max=100.0 if distribution == "spin" else 0.0)
    return tuple(sampler.sample(i).launch_state for i in range(N_SERVES))


@cache
def runs(distribution: str, dropout: float = 0.0, outlier: float = 0.0, n: int = N_SERVES):
    """(truth, filter run) per serve, camera noise seeded per serve."""
    camera = CameraConfig(dropout=dropout, outlier=outlier)
    out = []
    for i, launch in enumerate(launches(distribution)[:n]):
        t, x = truth(launch)
        z = CameraModel(camera).measure_sequence(500 + i, x[:, :3])
        out.append((x, run_filter(t, z, EstimatorConfig())))
    return out


def test_propagate_exact_lands_on_the_requested_time():
    x0 = np.array([0.0, 1.5, 0.9, 0.2, -5.0, 2.0, 80.0, -40.0, 60.0])
    x1, _ = propagate_exact(CompliantBounceBallModel(dt=4e-3), x0, 1.0 / 60)
    fine, _ = propagate_exact(CompliantBounceBallModel(dt=1e-4), x0, 1.0 / 60)
    assert np.allclose(x1, fine, atol=1e-7)
    assert x1[6:9] == pytest.approx(x0[6:9], abs=0.0)  # no bounce: the spin is constant
    assert len(propagate_exact(MODEL, x0[:6], 0.01)[0]) == 6  # (p, v) in, (p, v) out


def test_propagation_bounces_spin_and_velocity_together():
    """Across a bounce the state equals the ball model's own event-driven prediction: the
    bounce map applied at the impact changes the spin (topspin from the friction impulse)."""
    model = CompliantBounceBallModel(dt=1e-4)
    x0 = np.array([0.1, -0.5, 0.80, 0.3, -5.0, -2.0, -30.0, 20.0, 50.0])
    x1, bounced = propagate_exact(model, x0, 0.03)
    ref = model.predict_time(x0, 0.03)  # ends on the step at or after 0.03 s: same dt grid
    assert bounced and len(ref.bounces) == 1
    assert x1[0:3] == pytest.approx(ref.position, abs=1e-9)
    assert x1[3:6] == pytest.approx(ref.velocity, abs=1e-9)
    assert x1[6:9] == pytest.approx(ref.spin, abs=1e-6)
    assert x1[6] - x0[6] > 50.0  # v_y < 0: friction spins the ball up about +x (topspin)
    assert x1[8] == x0[8]  # the spin about the table normal is untouched by the bounce


def test_variational_jacobian_matches_finite_differences():
    # In flight F comes from the variational equation, spin columns (Magnus forcing) included.
    # The forward differences it replaces (eps = 1e-6) are themselves accurate to about
    # eps |d2f/dx2| + 1e-16 |f| / eps ~ 1e-9 relative, so 1e-6 leaves a wide margin, while a
    # wrong drag term would be off by ~k |v| dt ~ 1e-2 and a missing Magnus forcing by
    # C_L |v| dt ~ 1e-4 in the spin columns (checked separately below).
    ekf = BallFlightEKF()
    dt = 1.0 / RATE
    n_flight = n_bounce = 0
    for launch in launches("spin")[:3]:
        _, x = truth(launch)
        for xk in x:
            fx, bounced, F = ekf.propagate_with_jacobian(xk, dt)
            ref_x, ref_bounced = propagate_exact(ekf.model, xk, dt)
            assert bounced == ref_bounced
            assert np.array_equal(fx, ref_x)
            F_fd = ekf.numerical_jacobian(xk, dt, ref_x)
            if propagate_flight_jacobian(ekf.model, xk, dt) is None:
                n_bounce += 1
                assert np.array_equal(F, F_fd)
            else:
                n_flight += 1
                assert np.linalg.norm(F - F_fd) < 1e-6 * np.linalg.norm(F_fd)
                spin_cols = F_fd[0:6, 6:9]
                assert np.linalg.norm(F[0:6, 6:9] - spin_cols) < 1e-3 * np.linalg.norm(spin_cols)
                assert np.linalg.norm(spin_cols[3:6]) > 1e-5  # Magnus: C_L |v| dt ~ 1e-4
    assert n_flight > 50 and n_bounce >= 3


def test_converges_with_default_noise():
    errs_p, errs_v = [], []
    for x, r in runs("spin")[:24]:
        ok = r.tracking.copy()
        ok[:8] = False  # after the start-up transient
        for b in bounce_frames(x):
            ok[b + 1:b + 4] = False  # and the few frames the filter needs to settle after a bounce
        errs_p.append(r.states[ok, :3] - x[ok, :3])
        errs_v.append(r.states[ok, 3:] - x[ok, 3:6])
    rmse_p = np.sqrt(np.mean(np.sum(np.concatenate(errs_p) ** 2, 1)))
    rmse_v = np.sqrt(np.mean(np.sum(np.concatenate(errs_v) ** 2, 1)))
    assert rmse_p < 0.004  # below the raw 3 mm x sqrt(3) = 5.2 mm of one measurement
    assert rmse_v < 0.08


@pytest.mark.parametrize("distribution", ["spin", "real"])
def test_never_diverges_with_dropouts_and_outliers(distribution):
    for i, (x, r) in enumerate(runs(distribution, dropout=0.2, outlier=0.02, n=40)):
        ok = r.tracking.copy()
        ok[:8] = False
        err = np.linalg.norm(r.states[ok, :3] - x[ok, :3], axis=1)
        assert err.max() < 0.05, f"serve {i}: position error {err.max():.3f} m"
        assert r.tracking[-5:].all(), f"serve {i}: lost the ball at the end"


@pytest.mark.parametrize("distribution", ["default", "spin", "real"])
def test_the_track_survives_every_bounce(distribution):
    """Once tracking, the filter never resets up to the hitting plane: through the server's-half
    and the robot-side bounces of all 200 real serves, and the one bounce of the launcher's."""
    for i, (x, r) in enumerate(runs(distribution)):
        first = int(np.argmax(r.tracking))
        assert first <= 4 and r.tracking[first:].all(), f"serve {i}: track lost"
        assert len(bounce_frames(x)) == (2 if distribution == "real" else 1)


@pytest.mark.parametrize("distribution", ["default", "spin", "real"])
def test_nees_within_band(distribution):
    """The 9-state NEES over 200 serves, after the start-up (5 frames) and leaving out the two
    frames around each true bounce (there the filter and the truth may disagree about whether
    the bounce has happened yet: a velocity error of ~2 |v_z| that no Gaussian describes).

    Band: mean in [3, 12], i.e. between a third and 4/3 of the 9 dof. A filter that is
    consistent in (p, v) but carries the honest, loose spin prior (100 rad/s per axis, wider
    than the spin any serve here has before its first bounce) shows a mean below 9: an
    unobserved spin axis adds E[omega^2] / 100^2 instead of 1 (0 for the spinless launcher,
    1/3 for the uniform +-100 rad/s). Overconfidence is what would break a filter, so the upper
    tail is held tight: at most 0.5 % of frames beyond chi2_9's 99.9 % quantile."""
    values = []
    for x, r in runs(distribution):
        ok = r.tracking.copy()
        ok[:int(np.argmax(r.tracking)) + 5] = False
        for b in bounce_frames(x):
            ok[b:b + 2] = False
        e = np.c_[r.states[ok] - x[ok, :6], r.spins[ok] - x[ok, 6:9]]
        values.append(nees(e, r.full_covariances[ok]))
    a = np.concatenate(values)
    assert len(a) > 5000
    assert 3.0 < a.mean() < 12.0, a.mean()
    assert np.mean(a > chi2.ppf(0.999, 9)) < 0.005


@pytest.mark.parametrize("distribution", ["default", "spin", "real"])
def test_spin_is_learnt_from_the_robot_side_bounce(distribution):
    """At the last frame before the hitting plane: the tangential spin (omega_x, omega_y) the
    robot-side bounce gave the ball is known to a median 10 rad/s (about a tenth of the
    80-170 rad/s it has there), and the error is within the filter's own covariance
    (2-dof NEES below chi2_2's 99.9 % quantile on 95 % of the serves).

    Why 10 rad/s: when the contact ends rolling, the post-bounce tangential spin is fixed by the
    post-bounce tangential velocity (slip zero), which ~15 frames of 3 mm positions give to
    ~0.01 m/s, i.e. ~0.5 rad/s; when the ball slides throughout, the bounce adds a known
    impulse and only the slip's direction is seen, so one tangential component keeps what the
    Magnus curvature told before (tens of rad/s). 10 rad/s of spin moves the racket contact
    point's velocity by R omega = 0.2 m/s, what the racket law can absorb."""
    err, n2, true_spin = [], [], []
    for x, r in runs(distribution):
        k = len(x) - 2
        e = r.spins[k, 0:2] - x[k, 6:8]
        err.append(np.linalg.norm(e))
        n2.append(float(e @ np.linalg.solve(r.full_covariances[k, 6:8, 6:8], e)))
        true_spin.append(np.linalg.norm(x[k, 6:8]))
    assert np.median(true_spin) > 60.0
    assert np.median(err) < 10.0, np.median(err)
    assert np.mean(np.array(n2) < chi2.ppf(0.999, 2)) > 0.95


def test_spin_observability_comes_from_the_bounce():
    """Numerical observability: the filter's spin covariance just before the robot-side bounce
    and six frames after it, on launcher serves. In the table plane (omega_x, omega_y) the
    best-known direction (the smaller principal standard deviation) falls below 10 rad/s in
    the median (the floor is the 5 rad/s of bounce model error the filter adds) and the
    uncertainty area (sqrt det) shrinks at least fivefold in the median; when the ball slides
    through the contact the other direction stays as loose as the flight left it (only the
    slip's direction is seen). The spin about the table normal, which no bounce changes and
    only Magnus shows, barely moves."""
    best, area, normal = [], [], []
    for x, r in runs("default"):
        b = bounce_frames(x)[-1]
        before, after = r.full_covariances[b, 6:9, 6:9], r.full_covariances[b + 6, 6:9, 6:9]
        best.append(np.sqrt(np.linalg.eigvalsh(after[:2, :2])[0]))
        area.append(np.sqrt(np.linalg.det(after[:2, :2]) / np.linalg.det(before[:2, :2])))
        normal.append(np.sqrt(after[2, 2] / before[2, 2]))
    assert np.median(best) < 10.0
    assert np.median(area) < 0.2
    assert np.median(normal) > 0.9


def test_a_bounce_between_frames_is_not_rejected():
    """The table 8 mm higher than the filter believes: the ball bounces ~3 ms early and the
    first frame after the bounce is ~2 cm from the prediction. The plain chi-square gate
    rejects it; the bounce hypothesis (P- + Q_hyp) accepts it, and the track goes on."""
    high = CompliantBounceBallModel(
        dataclasses.replace(BallModelParams(), table_z=BallModelParams().table_z + 0.008),
        dt=2e-3)
    launch = launches("spin")[0]
    t, x = truth(launch, high)
    b = bounce_frames(x)[0]
    z = CameraModel(CameraConfig()).measure_sequence(7, x[:, :3])
    ekf = BallFlightEKF()
    for k in range(b + 1):
        ekf.step(t[k], z[k])
    plain = BallFlightEKF()
    plain.load_vector(ekf.to_vector())
    plain.predict(t[b + 1])
    assert not plain.update(z[b + 1])  # the plain gate: an outlier
    rejected_before = ekf.rejections
    ekf.step(t[b + 1], z[b + 1])
    assert ekf.rejections == rejected_before == 0
    for k in range(b + 2, len(t)):
        ekf.step(t[k], z[k])
        assert ekf.tracking
    assert np.linalg.norm(ekf.x[0:3] - x[-1, 0:3]) < 0.01


def test_gate_rejects_a_gross_outlier_and_state_round_trips():
    t, x = truth(launches("spin")[3])
    ekf = BallFlightEKF()
    for k in range(6):
        ekf.step(t[k], x[k, :3])
    x_before = ekf.x.copy()
    ekf.predict(t[6])
    x_pred = ekf.x.copy()
    assert not ekf.update(x[6, :3] + np.array([0.3, 0.0, 0.0]), 1.0 / RATE)
    assert np.array_equal(ekf.x, x_pred) and not np.array_equal(x_pred, x_before)
    other = BallFlightEKF()
    other.load_vector(ekf.to_vector())
    assert np.array_equal(other.to_vector(), ekf.to_vector(), equal_nan=True)
    assert len(ekf.to_vector()) == ekf.vector_size


def test_a_gross_outlier_just_after_a_bounce_is_still_rejected():
    t, x = truth(launches("spin")[5])
    b = bounce_frames(x)[0]
    ekf = BallFlightEKF()
    for k in range(b + 1):
        ekf.step(t[k], x[k, :3])
    ekf.predict(t[b + 1])
    assert ekf.near_bounce(t[b + 1], 1.0 / RATE)
    assert not ekf.update(x[b + 1, :3] + np.array([0.0, 0.0, 0.2]), 1.0 / RATE)


def test_crosses_the_hitting_plane_side():
    _, x = truth(launches("default")[0])
    assert x[-1, 1] > PLANES.hitting_y - 0.2


def test_an_artefact_saved_before_spin_gets_the_spinless_filter():
    """The shipped GPR predictor's estimator settings have no spin prior: it is fed a filter whose
    spin stays at zero in flight (the (p, v) estimates it was trained on); newer settings keep
    theirs; a setting this code does not know is an error."""
    from tt_drake.estimation import SPINLESS_PRIOR, config_from_dict
    from tt_drake.hitting_point import HittingPointGPR

    meta = HittingPointGPR.load("models/learned/predictor.npz").meta["estimator"]
    assert "spin_sigma0" not in meta
    assert config_from_dict(meta).spin_sigma0 == SPINLESS_PRIOR
    assert config_from_dict({"spin_sigma0": 40.0}).spin_sigma0 == 40.0
    with pytest.raises(ValueError, match="unknown estimator settings"):
        config_from_dict({"spin_sigma": 40.0})
    x, r = runs("default")[0]
    t = np.arange(len(x)) / RATE
    z = CameraModel(CameraConfig()).measure_sequence(500, x[:, :3])
    spinless = run_filter(t, z, config_from_dict(meta))
    before = slice(0, bounce_frames(x)[0])
    assert np.nanmax(np.abs(spinless.spins[before])) < 0.5  # Magnus of 0.5 rad/s: 3 mm/s^2
    assert np.nanmax(np.abs(r.spins[before])) > 1.0  # the 50 rad/s prior lets Magnus move it
