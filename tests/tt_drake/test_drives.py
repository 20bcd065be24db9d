"""The drives' torque-speed envelope (tt_drake.drives) against the DC motor's equations and
Barrett's motor data typed in here (docs/constants.md, "Drives"), not read from wam_params."""

import numpy as np
import pytest

from tt_drake import wam_params
from tt_drake.drives import DriveEnvelope, EffortBudget, drive_envelope, torque_bounds

# Barrett's motor data (J1-J4 motors, J5-J6, J7) and the arm's transmission ratios.
K = np.array([0.457] * 4 + [0.236] * 2 + [0.067])  # N m/A = V s/rad
R = np.array([3.473] * 4 + [6.213] * 2 + [5.205])  # ohm
N = np.array([42.0, 28.25, 28.25, 18.0, 9.48, 9.48, 14.93])
LISTED_NO_LOAD = np.array([100.218] * 4 + [192.309] * 2 + [569.022])  # motor rad/s at 48 V
EFFORT = np.array([75, 125, 39, 30, 3, 4, 1], dtype=float)


K_E = 48.0 / LISTED_NO_LOAD  # back-EMF constant through Barrett's listed no-load speed


def _voltage(tau, qdot):
    """The drive voltage the motor needs for joint torque tau at joint speed qdot:
    u = R i + k_e w, i = tau / (N k), w = N qdot."""
    return R * tau / (N * K) + K_E * N * qdot


def test_bounds_are_the_supply_voltage_or_the_current_limit():
    """Within the no-load speed, a bound below the effort limit needs exactly the supply
    voltage (the envelope is the voltage equation solved for the torque), and no bound needs
    more than the supply."""
    drive = DriveEnvelope(48.0)
    rng = np.random.default_rng(0)
    for _ in range(200):
        qdot = rng.uniform(-1.0, 1.0, 7) * drive.no_load_speed
        lower, upper = drive.bounds(qdot)
        for bound, supply in ((upper, 48.0), (lower, -48.0)):
            u = _voltage(bound, qdot)
            free = np.abs(bound) < EFFORT - 1e-9
            np.testing.assert_allclose(u[free], supply, rtol=1e-12, atol=1e-9)
            assert np.all(np.abs(u) <= 48.0 + 1e-9)
            assert np.all(np.abs(bound) <= EFFORT + 1e-12)
        assert np.all(lower <= upper)


def test_bounds_are_the_range_of_the_applied_torque():
    """At any speed, also past the no-load speed where the drive can only brake, the bounds
    are the smallest and largest torque the simulation's chain applies: a command clamped to
    the supply's [-a - b v, a - b v], then to the effort limit."""
    drive = DriveEnvelope(48.0)
    rng = np.random.default_rng(1)
    for _ in range(100):
        qdot = rng.uniform(-3.0, 3.0, 7) * drive.no_load_speed
        commands = rng.uniform(-400.0, 400.0, (2000, 7))
        emf = drive.back_emf * qdot
        applied = np.clip(np.clip(commands, -drive.stall - emf, drive.stall - emf),
                          -EFFORT, EFFORT)
        lower, upper = drive.bounds(qdot)
        assert np.all(applied >= lower - 1e-12) and np.all(applied <= upper + 1e-12)
        extremes = np.clip(np.clip(np.array([[-1e6] * 7, [1e6] * 7]), -drive.stall - emf,
                                   drive.stall - emf), -EFFORT, EFFORT)
        np.testing.assert_allclose(extremes, [lower, upper])
        assert np.all(lower <= upper)
        assert np.all(upper[qdot > drive.no_load_speed] <= 0.0)
        assert np.all(lower[qdot < -drive.no_load_speed] >= 0.0)


def test_no_load_speed_is_barretts_at_the_design_voltage():
    """At 48 V the drive has no torque left at Barrett's listed no-load speed over the joint's
    ratio; the stall torque is k V / R through the ratio."""
    drive = DriveEnvelope(48.0)
    np.testing.assert_allclose(drive.no_load_speed, LISTED_NO_LOAD / N, rtol=1e-12)
    _, upper = drive.bounds(drive.no_load_speed)
    np.testing.assert_allclose(upper, 0.0, atol=1e-9)
    np.testing.assert_allclose(drive.stall, N * K * 48.0 / R, rtol=1e-12)
    # J1 of a stock WAM: no torque at all beyond 2.39 rad/s; the full 75 N m only below 1.71.
    assert drive.no_load_speed[0] == pytest.approx(2.386, abs=1e-3)
    full = (drive.stall - EFFORT) / drive.back_emf
    assert full[0] == pytest.approx(1.712, abs=1e-3)


def test_braking_gets_more_torque_than_driving():
    drive = DriveEnvelope(48.0)
    qdot = 0.5 * drive.no_load_speed
    lower, upper = drive.bounds(qdot)
    assert np.all(-lower >= upper)
    assert np.all(-lower > upper) or np.all(-lower == EFFORT)


def test_voltage_scales_speed_not_current_limit():
    low, high = DriveEnvelope(24.0), DriveEnvelope(90.0)
    np.testing.assert_allclose(high.no_load_speed / low.no_load_speed, 90.0 / 24.0)
    np.testing.assert_allclose(high.back_emf, low.back_emf)
    lo0, hi0 = high.bounds(np.zeros(7))
    np.testing.assert_allclose(hi0, np.minimum(EFFORT, N * K * 90.0 / R))


def test_effort_budget_with_and_without_drives():
    ideal = EffortBudget(0.9)
    lower, upper = ideal.bounds(np.full(7, 50.0))
    np.testing.assert_allclose(upper, 0.9 * EFFORT)
    np.testing.assert_allclose(lower, -0.9 * EFFORT)
    drive = DriveEnvelope(48.0)
    budget = EffortBudget(0.9, drive)
    qdot = 0.8 * drive.no_load_speed
    lower, upper = budget.bounds(qdot)
    # 90 % of the supply and of the current: the voltage equation at 0.9 V where the current
    # limit does not bind.
    free = upper < 0.9 * EFFORT - 1e-9
    assert free.any()
    np.testing.assert_allclose(_voltage(upper, qdot)[free], 0.9 * 48.0, rtol=1e-12)
    np.testing.assert_array_less(upper, drive.bounds(qdot)[1] + 1e-12)
    # The supply's share apart from the current's: 1.5 of the supply, 0.9 of the current.
    lax = EffortBudget(0.9, drive, supply_fraction=1.5)
    lower, upper = lax.bounds(qdot)
    free = upper < 0.9 * EFFORT - 1e-9
    np.testing.assert_allclose(_voltage(upper, qdot)[free], 1.5 * 48.0, rtol=1e-12)
    assert np.all(np.abs(upper) <= 0.9 * EFFORT + 1e-12)


def test_torque_bounds_is_elementwise():
    lower, upper = torque_bounds([0.0, 2.0, 30.0], [10.0, 10.0, 10.0], [1.0, 1.0, 1.0],
                                 [5.0, 50.0, 5.0])
    np.testing.assert_allclose(lower, [-5.0, -12.0, -5.0])
    np.testing.assert_allclose(upper, [5.0, 8.0, -5.0])


def test_bad_voltage_and_ideal_drives():
    assert drive_envelope(0.0) is None
    assert drive_envelope(48.0) == DriveEnvelope(48.0)
    for bad in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="supply voltage"):
            DriveEnvelope(bad)


def test_motor_data_in_wam_params():
    np.testing.assert_allclose(wam_params.MOTOR_TORQUE_CONSTANT, K)
    np.testing.assert_allclose(wam_params.MOTOR_RESISTANCE, R)
    np.testing.assert_allclose(wam_params.MOTOR_NO_LOAD_SPEED, LISTED_NO_LOAD)
    np.testing.assert_allclose(wam_params.TRANSMISSION_RATIO, N)
