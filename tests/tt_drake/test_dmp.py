"""Hitting DMP (Eqs. 1-5): integrator, moving target, amplitude rule, temporal scaling."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from tt_drake.dmp import HittingDMP, n_steps_for

DMP = HittingDMP()


def _reference_rollout(dmp, w, y0, yd0, g_f, g_dot, tau, eta, t_eval):
    """Eq. 4 integrated by a high-order adaptive solver (independent of the fast path)."""

    def rhs(t, x):
        n = len(y0)
        y, yd = x[:n], x[n:]
        z = np.exp(-dmp.alpha_z * t / tau)
        g_m0 = g_f - g_dot * (dmp.alpha_z / dmp.alpha_h) * tau
        g_m = g_m0 - g_dot * tau * np.log(z) / dmp.alpha_h
        psi = np.exp(-dmp.widths * (z - dmp.centres) ** 2)
        f = (w @ psi) * z / psi.sum()
        ydd = ((1 - z) * dmp.alpha_y * (dmp.beta_y * (g_m - y) + tau * (g_dot - yd)) + eta * f)
        return np.concatenate([yd, ydd / tau**2])

    sol = solve_ivp(rhs, (0, tau), np.concatenate([y0, yd0]), t_eval=t_eval, method="DOP853",
                    rtol=1e-11, atol=1e-12)
    n = len(y0)
    acc = np.array([rhs(t, x)[n:] for t, x in zip(sol.t, sol.y.T, strict=True)])
    return sol.y[:n].T, sol.y[n:].T, acc


def test_defaults_are_critically_damped_and_target_rate_matches_phase():
    assert DMP.beta_y == pytest.approx(DMP.alpha_y / 4)
    assert DMP.alpha_h == DMP.alpha_z


def test_phase_decays_from_one():
    z = DMP.phase(np.linspace(0, 0.8, 50), 0.8)
    assert z[0] == 1.0 and np.all(np.diff(z) < 0)
    assert z[-1] == pytest.approx(np.exp(-DMP.alpha_z))


def test_moving_target_closed_form_passes_goal_with_final_velocity():
    tau, g_f, g_dot = 0.6, np.array([0.4, -1.0]), np.array([2.0, -0.5])
    t = np.linspace(0, tau, 31)
    g_m = DMP.moving_target(t, tau, g_f, g_dot)
    g_m0 = g_f - g_dot * tau
    expected = g_m0 - g_dot * tau * np.log(DMP.phase(t, tau))[:, None] / DMP.alpha_h  # Eq. 4
    np.testing.assert_allclose(g_m, expected, atol=1e-12)
    np.testing.assert_allclose(g_m[-1], g_f, atol=1e-12)
    np.testing.assert_allclose(np.gradient(g_m, t, axis=0), np.broadcast_to(g_dot, g_m.shape),
                               atol=1e-9)


def test_forcing_is_normalised_phase_gated_mixture():
    w = np.random.default_rng(1).normal(size=DMP.n_basis)
    z = np.array([1.0, 0.5, 0.1])
    psi = np.exp(-DMP.widths * (z[:, None] - DMP.centres) ** 2)
    np.testing.assert_allclose(DMP.forcing(w, z), (psi @ w) * z / psi.sum(1))
    # constant weights give f = w z exactly (partition of unity)
    np.testing.assert_allclose(DMP.forcing(np.full(DMP.n_basis, 3.0), z), 3.0 * z)


def test_fast_rollout_matches_adaptive_integration_of_eq4():
    rng = np.random.default_rng(0)
    w = rng.normal(0, 300, (3, DMP.n_basis))
    y0, yd0 = np.array([0.1, -0.3, 0.5]), np.array([0.0, 0.5, -1.0])
    g_f, g_dot, eta, tau = np.array([1.0, 0.2, -0.4]), np.array([2.0, -1.0, 0.0]), \
        np.array([1.0, 0.5, -2.0]), 0.6
    tr = DMP.rollout(w, y0, g_f, g_dot, tau, yd0=yd0, eta=eta, rate=500)
    q, qd, qdd = _reference_rollout(DMP, w, y0, yd0, g_f, g_dot, tau, eta, tr.t)
    np.testing.assert_allclose(tr.q, q, atol=1e-6)
    np.testing.assert_allclose(tr.qd, qd, atol=1e-4)
    np.testing.assert_allclose(tr.qdd, qdd, atol=1e-4 * np.abs(qdd).max())
    # starts exactly at the given state and reaches the moving target's end state
    np.testing.assert_allclose(tr.q[0], y0)
    np.testing.assert_allclose(tr.qd[0], yd0)


def test_low_rate_uses_substeps_and_stays_accurate():
    w = np.random.default_rng(2).normal(0, 300, (1, DMP.n_basis))
    fine = DMP.rollout(w, 0.0, 1.0, 2.0, 0.5, eta=1.0, n_steps=400)
    coarse = DMP.rollout(w, 0.0, 1.0, 2.0, 0.5, eta=1.0, rate=20)  # 10 intervals
    assert coarse.t.size == 11
    np.testing.assert_allclose(coarse.q, fine.q[::40], atol=1e-5)
    no_sub = HittingDMP(min_steps=1).rollout(w, 0.0, 1.0, 2.0, 0.5, eta=1.0, rate=20)
    assert np.abs(no_sub.q - fine.q[::40]).max() > 100 * np.abs(coarse.q - fine.q[::40]).max()


def test_sensitivity_map_is_rk4_stepped_one_fine_step_at_a_time():
    """The cached map (all fine steps composed at once) is classical RK4 on Eq. 4 in normalised
    time, stepped one fine step after the other, for any start state and inputs."""
    rng = np.random.default_rng(4)
    x = np.r_[0.3, -0.8, 1.1, 0.7, rng.normal(0, 300, DMP.n_basis)]  # (y0, v0, g_m0, tau g_dot, w)
    r = DMP.alpha_z / DMP.alpha_h

    def accel(s, y, v):  # dv/ds of Eq. 4 with these inputs
        z = np.exp(-DMP.alpha_z * s)
        g_m = x[2] + r * s * x[3]
        return ((1 - z) * DMP.alpha_y * (DMP.beta_y * (g_m - y) + x[3] - v)
                + DMP.features(z) @ x[4:])

    for n_steps in (7, 37, 250):
        m = int(np.ceil(DMP.min_steps / n_steps))
        h = 1.0 / (n_steps * m)
        y, v = x[0], x[1]
        expected = [(y, v, accel(0.0, y, v))]
        for j in range(n_steps * m):
            s = j * h
            k1 = (v, accel(s, y, v))
            k2 = (v + 0.5 * h * k1[1], accel(s + 0.5 * h, y + 0.5 * h * k1[0], v + 0.5 * h * k1[1]))
            k3 = (v + 0.5 * h * k2[1], accel(s + 0.5 * h, y + 0.5 * h * k2[0], v + 0.5 * h * k2[1]))
            k4 = (v + h * k3[1], accel(s + h, y + h * k3[0], v + h * k3[1]))
            y = y + h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
            v = v + h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
            if (j + 1) % m == 0:
                expected.append((y, v, accel((j + 1) * h, y, v)))
        np.testing.assert_allclose(DMP.sensitivity(n_steps) @ x, np.array(expected),
                                   rtol=1e-11, atol=1e-9)


def test_grid_ends_exactly_at_tau():
    assert n_steps_for(0.5, 500.0) == 250
    assert n_steps_for(0.4999, 500.0) == 250
    tr = DMP.rollout(np.zeros((1, DMP.n_basis)), 0, 1, 0, 0.3333, rate=500)
    assert tr.t[-1] == pytest.approx(0.3333) and np.diff(tr.t).max() <= 1 / 500 + 1e-12


def test_library_rollout_equals_rollouts_one_by_one():
    rng = np.random.default_rng(3)
    w = rng.normal(0, 200, (5, 2, DMP.n_basis))
    amp = rng.uniform(0.5, 1.0, (5, 2))
    y0, g_f, g_dot = np.array([0.0, 0.2]), np.array([0.8, -0.5]), np.array([1.0, -1.0])
    batch = DMP.rollout(w, y0, g_f, g_dot, 0.5, amplitude=amp)
    assert batch.q.shape == (5, 251, 2)
    for i in range(5):
        single = DMP.rollout(w[i], y0, g_f, g_dot, 0.5, amplitude=amp[i])
        np.testing.assert_allclose(batch[i].q, single.q, atol=1e-12)
        np.testing.assert_allclose(batch[i].qdd, single.qdd, atol=1e-9)


def test_temporal_scaling_by_tau():
    """Same weights, tau -> c tau with g_dot -> g_dot / c: the same path, c times slower."""
    w = np.random.default_rng(4).normal(0, 200, (2, DMP.n_basis))
    y0, g_f, g_dot = np.array([0.0, 1.0]), np.array([1.0, 0.0]), np.array([2.0, -1.0])
    a = DMP.rollout(w, y0, g_f, g_dot, 0.5, eta=1.0, n_steps=200)
    b = DMP.rollout(w, y0, g_f, g_dot / 2.0, 1.0, eta=1.0, n_steps=200)
    np.testing.assert_allclose(b.t, 2 * a.t)
    np.testing.assert_allclose(b.q, a.q, atol=1e-12)
    np.testing.assert_allclose(b.qd, a.qd / 2, atol=1e-10)
    np.testing.assert_allclose(b.qdd, a.qdd / 4, atol=1e-8)


def test_eta_rule_scale_mirror_small_amplitude_and_clip():
    dmp = HittingDMP(amp_eps=0.05, eta_max=5.0)
    amp = np.array([1.0, 1.0, 0.01, -0.5, 0.2])
    g_f = np.array([0.5, -2.0, 3.0, 1.0, 2.0])
    eta = dmp.eta(g_f, 0.0, amp)
    np.testing.assert_allclose(eta, [0.5, -2.0, 1.0, -2.0, 5.0])  # scale, mirror, unscaled, clip
    assert np.all(dmp.eta(g_f, 0.0, None) == 1.0)


def test_sign_flipped_goal_mirrors_the_movement_exactly():
    w = np.random.default_rng(5).normal(0, 300, (1, DMP.n_basis))
    up = DMP.rollout(w, 0.0, 1.0, 2.0, 0.5, amplitude=1.0)
    down = DMP.rollout(w, 0.0, -1.0, -2.0, 0.5, amplitude=1.0)
    np.testing.assert_allclose(down.q, -up.q, atol=1e-12)
    np.testing.assert_allclose(down.qdd, -up.qdd, atol=1e-9)


def test_zero_weights_give_smooth_spring_motion_to_the_moving_target():
    tr = DMP.rollout(np.zeros((1, DMP.n_basis)), 0.0, 1.0, 1.5, 0.5)
    assert tr.qdd[0, 0] == 0.0  # (1 - z) switches the spring on gradually
    assert abs(tr.q[-1, 0] - 1.0) < 1e-3 and abs(tr.qd[-1, 0] - 1.5) < 1e-2


def test_invalid_arguments_raise():
    with pytest.raises(ValueError):
        HittingDMP(n_basis=1)
    with pytest.raises(ValueError):
        HittingDMP(alpha_z=-1.0)
    with pytest.raises(ValueError):
        DMP.rollout(np.zeros((2, 3)), 0, 1, 0, 0.5)
    with pytest.raises(ValueError):
        DMP.rollout(np.zeros((1, DMP.n_basis)), 0, 1, 0, -0.5)


def test_hyperparameters_round_trip_through_dict():
    dmp = HittingDMP(n_basis=12, alpha_z=2.5, alpha_y=30.0)
    again = HittingDMP.from_dict(dmp.to_dict())
    assert again == dmp and again.beta_y == 7.5
