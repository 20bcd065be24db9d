"""Imitation learning (Eqs. 7-8, Algorithm 2) and generalisation of the learned primitive."""

from __future__ import annotations

import numpy as np
import pytest

from tests.tt_drake._demos import hitting_demo, monotone_demo
from tt_drake.dmp import HittingDMP
from tt_drake.imitation import Demonstration, fit_weights, forcing_reference, imitate

DMP = HittingDMP()

# Documented bound (docs/motor_primitives.md): for a monotone demonstration, the generalised
# movement stays inside hull{y0, g_f, g_m0} widened by OVERSHOOT_BOUND of the hull's width.
OVERSHOOT_BOUND = 0.01


def _rmse(a, b):
    return float(np.sqrt(np.mean((a - b) ** 2)))


@pytest.fixture(scope="module")
def demo():
    return hitting_demo(n_dof=7, tau=0.5, rate=500.0, seed=0)


@pytest.fixture(scope="module")
def learned(demo):
    return imitate(DMP, demo)


def test_reproduces_demonstration(demo, learned):
    tr = learned.rollout(DMP, n_steps=demo.t.size - 1)
    np.testing.assert_allclose(tr.t, demo.t, atol=1e-12)
    assert _rmse(tr.q, demo.q) <= 1e-3
    assert np.abs(tr.q[-1] - demo.q[-1]).max() <= 1e-3  # reaches g_f ...
    assert np.abs(tr.qd[-1] - demo.qd[-1]).max() <= 1e-2  # ... with velocity g_dot at T
    assert _rmse(tr.qd, demo.qd) <= 2e-2


def test_reference_forcing_is_eq7(demo):
    f = forcing_reference(DMP, demo)
    t, tau = demo.t, demo.tau
    z = np.exp(-DMP.alpha_z * t / tau)[:, None]
    g_f, g_dot = demo.q[-1], demo.qd[-1]
    g_m = (g_f - g_dot * tau) - g_dot * tau * np.log(z) / DMP.alpha_h
    a = 1.0 / (demo.q[-1] - demo.q[0])
    expected = (tau**2 * demo.qdd - (1 - z) * DMP.alpha_y * (
        DMP.beta_y * (g_m - demo.q) + tau * (g_dot - demo.qd))) / ((demo.q[-1] - demo.q[0]) * a)
    np.testing.assert_allclose(f, expected, rtol=1e-10, atol=1e-9)


def test_lwr_is_algorithm_2_and_global_fit_is_more_accurate(demo):
    f = forcing_reference(DMP, demo)
    z = DMP.phase(demo.t, demo.tau)
    w = fit_weights(DMP, z, f, method="lwr")
    psi = DMP.basis(z)
    for i in (0, 7, DMP.n_basis - 1):  # w_i = (Z^T Psi_i Z)^-1 Z^T Psi_i f_ref
        zt_psi = z * psi[:, i]
        np.testing.assert_allclose(w[:, i], (zt_psi @ f) / (zt_psi @ z), rtol=1e-10)
    lwr = imitate(DMP, demo, method="lwr").rollout(DMP, n_steps=demo.t.size - 1)
    ls = imitate(DMP, demo, method="ls").rollout(DMP, n_steps=demo.t.size - 1)
    assert _rmse(ls.q, demo.q) < 0.1 * _rmse(lwr.q, demo.q)
    assert _rmse(lwr.q, demo.q) < 0.05  # LWR is usable, only less exact


def test_generalises_to_new_goal_velocity_duration_and_start(demo, learned):
    rng = np.random.default_rng(7)
    for _ in range(10):
        y0 = demo.q[0] + rng.uniform(-0.3, 0.3, 7)
        g_f = demo.q[-1] + rng.uniform(-0.4, 0.4, 7)
        g_dot = demo.qd[-1] * rng.uniform(0.5, 1.5, 7)
        tau = rng.uniform(0.35, 0.7)
        tr = DMP.rollout(learned.weights, y0, g_f, g_dot, tau, amplitude=learned.amplitude)
        assert np.abs(tr.q[-1] - g_f).max() <= 1e-3
        assert np.abs(tr.qd[-1] - g_dot).max() <= 1e-2
        np.testing.assert_allclose(tr.q[0], y0)
        # smooth: accelerations continuous (no jumps between samples beyond the local trend)
        jerk = np.diff(tr.qdd, axis=0) / np.diff(tr.t)[:, None]
        assert np.all(np.isfinite(jerk))
        assert np.abs(np.diff(jerk, axis=0)).max() * (tr.t[1] ** 2) < 0.05 * np.abs(tr.qdd).max()


def test_overshoot_bound_for_monotone_demonstration():
    d = monotone_demo(tau=0.5, p0=0.0, p1=1.0, v1=2.0)
    res = imitate(DMP, d)
    rng = np.random.default_rng(11)
    worst = 0.0
    for _ in range(200):
        y0 = rng.uniform(-0.5, 0.5)
        amp = rng.choice([-1, 1]) * rng.uniform(0.2, 2.0)
        g_f, tau = y0 + amp, rng.uniform(0.3, 0.8)
        g_dot = rng.uniform(-4.0, 4.0)
        tr = DMP.rollout(res.weights, [y0], [g_f], [g_dot], tau, amplitude=res.amplitude)
        q = tr.q[:, 0]
        assert abs(q[-1] - g_f) <= 1e-3 and abs(tr.qd[-1, 0] - g_dot) <= 1e-2
        lo, hi = min(y0, g_f, g_f - g_dot * tau), max(y0, g_f, g_f - g_dot * tau)
        worst = max(worst, max(q.max() - hi, lo - q.min(), 0.0) / (hi - lo))
    assert worst <= OVERSHOOT_BOUND


def test_small_amplitude_demonstration_is_learned_unscaled():
    """A joint that barely moves (|theta_T - theta_1| < amp_eps): eta = 1, weights stay finite,
    the demonstration is reproduced, and a new goal adds the same small shape unscaled."""
    t = np.linspace(0, 0.5, 251)
    om = np.pi / 0.5
    b = 0.05  # a 5 cm-rad wiggle that returns almost to its start
    q = 0.2 + b * np.sin(om * t) ** 3 + 0.01 * t
    qd = 3 * b * om * np.sin(om * t) ** 2 * np.cos(om * t) + 0.01
    qdd = b * om**2 * (6 * np.sin(om * t) * np.cos(om * t) ** 2 - 3 * np.sin(om * t) ** 3)
    d = Demonstration(t, q, qd, qdd)
    assert abs(q[-1] - q[0]) < DMP.amp_eps
    res = imitate(DMP, d)
    assert np.all(np.isfinite(res.weights)) and np.abs(res.weights).max() < 1e4
    tr = res.rollout(DMP, n_steps=250)
    assert _rmse(tr.q, d.q) <= 1e-3
    # new goal 0.5 rad away: the shape is added unscaled on top of the spring's motion
    kw = {"yd0": res.yd0, "n_steps": 250}
    shaped = DMP.rollout(res.weights, 0.2, 0.7, 0.01, 0.5, amplitude=res.amplitude, **kw)
    plain = DMP.rollout(np.zeros_like(res.weights), 0.2, 0.7, 0.01, 0.5, **kw)
    same_goal_shape = tr.q - DMP.rollout(np.zeros_like(res.weights), 0.2, q[-1], 0.01, 0.5, **kw).q
    np.testing.assert_allclose(shaped.q - plain.q, same_goal_shape, atol=1e-9)
    assert abs(shaped.q[-1, 0] - 0.7) <= 1e-3


def test_goal_at_start_gives_pure_spring_movement(learned, demo):
    """New g_f == y0 for a scaled DoF: eta = 0, the forcing term vanishes (documented)."""
    y0 = demo.q[0]
    tr = DMP.rollout(learned.weights, y0, y0, demo.qd[-1], 0.5, amplitude=learned.amplitude)
    plain = DMP.rollout(np.zeros_like(learned.weights), y0, y0, demo.qd[-1], 0.5)
    np.testing.assert_allclose(tr.q, plain.q, atol=1e-12)
    assert np.abs(tr.q[-1] - y0).max() <= 1e-3


def test_demonstration_from_positions_matches_exact_derivatives(demo):
    approx = Demonstration.from_positions(demo.t, demo.q)
    np.testing.assert_allclose(approx.qd[2:-2], demo.qd[2:-2], atol=1e-3)
    res = imitate(DMP, approx)
    tr = res.rollout(DMP, n_steps=demo.t.size - 1)
    assert _rmse(tr.q, demo.q) <= 2e-3


def test_bad_demonstrations_raise():
    t = np.linspace(0, 1, 10)
    with pytest.raises(ValueError):
        Demonstration(t[::-1], np.zeros(10), np.zeros(10), np.zeros(10))
    with pytest.raises(ValueError):
        Demonstration(t, np.zeros(9), np.zeros(10), np.zeros(10))
    with pytest.raises(ValueError):
        Demonstration(t, np.full(10, np.nan), np.zeros(10), np.zeros(10))
    with pytest.raises(ValueError):
        fit_weights(DMP, np.ones(3), np.ones(3), method="magic")


def test_borrowed_shape_keeps_a_weak_joint_near_its_quintic_acceleration():
    """A rest-to-rest quintic in which joint 1 barely moves (A = 0.06 rad, above amp_eps): sent
    0.8 rad the other way in the same time, the learned primitive replays joint 1 with eta
    clipped at -5 and an acceleration far above the quintic's 5.77 D / T^2; with the dominant
    joint's shape borrowed it is the quintic's peak (within 10 %), and the demonstration's own
    goal is still reached."""
    from tt_drake.imitation import borrow_weak_shapes, quintic_demonstration

    tau = 0.4
    demo = quintic_demonstration(tau, [0.0, 0.0], [1.0, 0.06], [0.0, 0.0])
    res = imitate(DMP, demo)
    goal = np.array([1.0, -0.8])
    quintic_peak = 5.7735 * 0.8 / tau**2
    raw = DMP.rollout(res.weights, np.zeros(2), goal, np.zeros(2), tau, amplitude=res.amplitude)
    w, a = borrow_weak_shapes(res.weights, res.amplitude)
    new = DMP.rollout(w, np.zeros(2), goal, np.zeros(2), tau, amplitude=a)
    assert np.abs(raw.qdd[:, 1]).max() > 2.0 * quintic_peak
    assert np.abs(new.qdd[:, 1]).max() == pytest.approx(quintic_peak, rel=0.1)
    assert np.abs(new.q[-1] - goal).max() < 0.01
    # The dominant joint is untouched, and a joint above the ratio keeps its own shape.
    np.testing.assert_array_equal(w[0], res.weights[0])
    w2, a2 = borrow_weak_shapes(res.weights, np.array([1.0, 0.6]))
    np.testing.assert_array_equal(w2, res.weights)
    with pytest.raises(ValueError):
        borrow_weak_shapes(res.weights, np.ones(3))
