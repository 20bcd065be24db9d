"""Mixture of Motor Primitives (Eq. 6, Algorithm 1) and the library."""

from __future__ import annotations

import numpy as np
import pytest

from tests.tt_drake._demos import hitting_demo
from tt_drake.dmp import HittingDMP
from tt_drake.momp import (
    MotorPrimitiveLibrary,
    gating_weights,
    mix_trajectories,
    scott_bandwidths,
)

DMP = HittingDMP()
TASK = {"y0": np.zeros(3), "g_f": np.array([0.8, -0.4, 0.3]), "g_dot": np.array([1.5, -1.0, 0.5]),
        "tau": 0.5}


def _library(n=6, seed=0, **kwargs):
    rng = np.random.default_rng(seed)
    return MotorPrimitiveLibrary(
        DMP,
        rng.normal(0, 300, (n, 3, DMP.n_basis)),
        rng.uniform(0.5, 1.0, (n, 3)),
        rng.normal(0, 1, (n, 6)),
        np.full(6, 0.7),
        **kwargs,
    )


def test_mixture_of_one_primitive_is_that_primitive():
    lib = _library(n=1)
    x = np.array([5.0, -3, 2, 0, 1, 9])  # anywhere: one component gets all the weight
    mixed = lib.plan(x, **TASK)
    alone = DMP.rollout(lib.weights[0], amplitude=lib.amplitude[0], **TASK)
    np.testing.assert_allclose(mixed.q, alone.q, atol=1e-12)
    np.testing.assert_allclose(mixed.qd, alone.qd, atol=1e-10)
    np.testing.assert_allclose(mixed.qdd, alone.qdd, atol=1e-8)


def test_identical_stimuli_get_equal_weights():
    lib = _library(n=4)
    lib.stimuli[1] = lib.stimuli[2] = lib.stimuli[3]
    nu = lib.gating(np.array([0.3, 0.1, -0.2, 0.0, 0.5, 0.4]))
    assert nu[1] == pytest.approx(nu[2]) == pytest.approx(nu[3])
    assert nu.sum() == pytest.approx(1.0)


def test_stimulus_at_x_i_is_dominated_by_i_as_bandwidth_shrinks():
    lib = _library(n=8, seed=1)
    i = 5
    shares = []
    for h in (2.0, 1.0, 0.5, 0.2, 0.05):
        lib.bandwidths = np.full(6, h)
        shares.append(lib.gating(lib.stimuli[i])[i])
    assert np.all(np.diff(shares) >= 0) and shares[-1] > 1 - 1e-9
    mixed = lib.plan(lib.stimuli[i], **TASK)
    alone = DMP.rollout(lib.weights[i], amplitude=lib.amplitude[i], **TASK)
    np.testing.assert_allclose(mixed.q, alone.q, atol=1e-9)


def test_zero_responsibility_removes_a_primitive():
    lib = _library(n=3, seed=2)
    x = lib.stimuli[0]
    lib.gamma[:] = [0.0, 1.0, 1.0]
    nu = lib.gating(x)
    assert nu[0] == 0.0
    without = MotorPrimitiveLibrary(DMP, lib.weights[1:], lib.amplitude[1:], lib.stimuli[1:],
                                    lib.bandwidths)
    np.testing.assert_allclose(lib.plan(x, **TASK).q, without.plan(x, **TASK).q, atol=1e-12)
    lib.gamma[:] = 0.0
    with pytest.raises(ValueError):
        lib.gating(x)


def test_gating_is_eq6_with_per_dimension_bandwidths():
    rng = np.random.default_rng(3)
    xi, gamma, h = rng.normal(size=(5, 6)), rng.uniform(0.1, 1, 5), rng.uniform(0.5, 2, 6)
    x = rng.normal(size=6)
    k = np.exp(-0.5 * (((x - xi) / h) ** 2).sum(1))
    np.testing.assert_allclose(gating_weights(x, xi, h, gamma), gamma * k / (gamma * k).sum())
    # scaling one stimulus dimension and its bandwidth together changes nothing
    s = np.array([1, 1, 10, 1, 1, 1.0])
    np.testing.assert_allclose(gating_weights(x * s, xi * s, h * s, gamma),
                               gating_weights(x, xi, h, gamma))


def test_far_stimulus_is_well_defined_and_picks_nearest():
    lib = _library(n=5, seed=4)
    lib.bandwidths = np.full(6, 0.01)  # every linear-domain kernel value underflows to 0
    x = lib.stimuli[2] + 1.0
    nu = lib.gating(x)
    assert np.all(np.isfinite(nu)) and nu.sum() == pytest.approx(1.0)
    d = np.linalg.norm(lib.stimuli - x, axis=1)
    assert np.argmax(nu) == np.argmin(d)


def test_mixing_in_weight_space_equals_algorithm_1():
    lib = _library(n=10, seed=5)
    lib.gamma[:] = np.random.default_rng(0).uniform(0.2, 1.0, 10)
    x = lib.stimuli[3] + 0.3
    a = lib.plan(x, method="weights", yd0=np.array([0.1, 0, -0.2]), **TASK)
    b = lib.plan(x, method="trajectories", yd0=np.array([0.1, 0, -0.2]), **TASK)
    np.testing.assert_allclose(a.q, b.q, atol=1e-10)
    np.testing.assert_allclose(a.qd, b.qd, atol=1e-8)
    np.testing.assert_allclose(a.qdd, b.qdd, atol=1e-6)
    # and both equal the explicit mixture of all primitives' rollouts (nothing skipped here)
    lib.min_weight = 0.0
    every = lib.rollout_all(yd0=np.array([0.1, 0, -0.2]), **TASK)
    ref = mix_trajectories(every, lib.gating(x))
    np.testing.assert_allclose(lib.plan(x, yd0=np.array([0.1, 0, -0.2]), **TASK).q, ref.q,
                               atol=1e-10)


def test_negligible_primitives_are_skipped_with_bounded_effect():
    lib = _library(n=30, seed=6)
    x = lib.stimuli[0]
    idx, nu = lib.active(x)
    full = lib.gating(x)
    assert idx.size < 30 and np.all(full[idx] >= lib.min_weight)
    assert nu.sum() == pytest.approx(1.0)
    pruned = lib.plan(x, **TASK)
    lib.min_weight = 0.0
    exact = lib.plan(x, **TASK)
    spread = np.abs(lib.rollout_all(**TASK).q - exact.q).max()
    assert np.abs(pruned.q - exact.q).max() <= 2 * 30 * 1e-6 * spread


def test_plan_starts_at_start_state_and_arrives_at_goal():
    demos = [hitting_demo(n_dof=3, seed=s, backswing=0.1) for s in range(4)]
    stimuli = np.random.default_rng(0).normal(size=(4, 6))
    lib = MotorPrimitiveLibrary.from_demonstrations(DMP, demos, stimuli)
    y0 = demos[0].q[0] + 0.05
    g_f, g_dot = demos[0].q[-1] - 0.05, demos[0].qd[-1]
    tr = lib.plan(stimuli[0] + 0.2, y0, g_f, g_dot, 0.45)
    np.testing.assert_allclose(tr.q[0], y0)
    assert np.abs(tr.q[-1] - g_f).max() <= 1e-3 and np.abs(tr.qd[-1] - g_dot).max() <= 1e-2
    # each demo is reproduced by the mixture at its own stimulus once bandwidths are small
    lib.bandwidths = np.full(6, 0.05)
    d = demos[2]
    rep = lib.plan(stimuli[2], d.q[0], d.q[-1], d.qd[-1], d.tau, n_steps=d.t.size - 1)
    assert np.sqrt(np.mean((rep.q - d.q) ** 2)) <= 1e-3


def test_scott_bandwidths():
    x = np.random.default_rng(7).normal(0, [1, 2, 0.5, 1, 1, 1], (300, 6))
    h = scott_bandwidths(x)
    np.testing.assert_allclose(h, x.std(0) * 300 ** (-0.1))
    assert np.all(scott_bandwidths(np.ones((3, 2))) == 1.0)


def test_append_and_remove():
    lib = _library(n=3)
    i = lib.append(np.zeros((3, DMP.n_basis)), np.ones(3), np.zeros(6))
    assert i == 3 and len(lib) == 4 and lib.gamma[3] == 1.0 and lib.n[3] == 0.0
    lib.remove([0, 2])
    assert len(lib) == 2 and np.all(lib.weights[1] == 0)
    with pytest.raises(ValueError):
        lib.remove([0, 1])


def test_shape_validation():
    with pytest.raises(ValueError):
        MotorPrimitiveLibrary(DMP, np.zeros((2, 3, 5)), np.ones((2, 3)), np.zeros((2, 6)),
                              np.ones(6))
    with pytest.raises(ValueError):
        MotorPrimitiveLibrary(DMP, np.zeros((2, 3, DMP.n_basis)), np.ones((2, 3)),
                              np.zeros((2, 6)), np.zeros(6))
    with pytest.raises(ValueError):
        _library().plan(np.zeros(6), method="nope", **TASK)
