"""Responsibility learning and pruning (Eqs. 10-11, Algorithm 3)."""

from __future__ import annotations

import numpy as np
import pytest

from tt_drake.dmp import HittingDMP
from tt_drake.momp import MotorPrimitiveLibrary
from tt_drake.responsibility import (
    ResponsibilityParams,
    asymptotic_gamma,
    responsibility_update,
)

P = ResponsibilityParams()


def test_update_is_algorithm_3():
    s, n = np.array([0.5, 0.0]), np.array([1.0, 0.0])
    nu, r = np.array([0.25, 0.75]), 0.4
    s2, n2, g, prune = responsibility_update(s, n, nu, r, P)
    np.testing.assert_allclose(s2, s + nu * r)
    np.testing.assert_allclose(n2, n + nu)
    np.testing.assert_allclose(g, np.exp(P.kappa * (s2 - n2) / (P.zeta * n2 + 1)))
    np.testing.assert_array_equal(prune, g < P.threshold)


def test_blamed_failures_decay_monotonically_until_pruned():
    s, n = np.zeros(2), np.zeros(2)
    nu = np.array([0.9, 0.1])  # primitive 0 is mostly responsible
    history = []
    for _ in range(100):
        s, n, g, prune = responsibility_update(s, n, nu, 0.0, P)
        history.append(g.copy())
        if prune[0]:
            break
    h = np.array(history)
    assert np.all(np.diff(h[:, 0]) < 0) and np.all(np.diff(h[:, 1]) < 0)
    assert h[-1, 0] < P.threshold and h[-1, 1] > h[-1, 0]
    assert len(history) <= 10  # pruned after a handful of complete failures (defaults documented)


def test_only_successes_keep_gamma_one():
    s, n = np.zeros(3), np.zeros(3)
    rng = np.random.default_rng(0)
    for _ in range(50):
        nu = rng.dirichlet(np.ones(3))
        s, n, g, prune = responsibility_update(s, n, nu, 1.0, P)
    np.testing.assert_allclose(g, 1.0)
    assert not prune.any()


def test_asymptote_and_pruning_reward_level():
    """gamma -> exp(-kappa (1 - rbar) / zeta); pruned eventually iff rbar < prune_below_reward."""
    rbar_cut = P.prune_below_reward
    assert 0.3 < rbar_cut < 0.5  # documented defaults prune primitives below ~0.42 mean reward
    for rbar in (rbar_cut - 0.05, rbar_cut + 0.05):
        s, n = np.zeros(1), np.zeros(1)
        for _ in range(20000):
            s, n, g, _ = responsibility_update(s, n, np.ones(1), rbar, P)
        assert g[0] == pytest.approx(asymptotic_gamma(rbar, P), rel=0.01)
        assert (g[0] < P.threshold) == (rbar < rbar_cut)


def test_kappa_and_zeta_effect():
    def after(k, params):
        s, n = np.zeros(1), np.zeros(1)
        for _ in range(k):
            s, n, g, _ = responsibility_update(s, n, np.ones(1), 0.0, params)
        return g[0]

    assert after(3, ResponsibilityParams(kappa=2.0)) < after(3, P)  # faster learning
    assert after(50, ResponsibilityParams(zeta=1.0)) > after(50, P)  # more forgiving asymptote


def test_reward_outside_unit_interval_is_refused():
    with pytest.raises(ValueError):
        responsibility_update(np.zeros(1), np.zeros(1), np.ones(1), 1.5)
    with pytest.raises(ValueError):
        ResponsibilityParams(kappa=0.0)


def test_library_prunes_the_failing_primitive_only():
    dmp = HittingDMP()
    stimuli = np.array([[0.0, 0.0], [3.0, 0.0], [0.0, 3.0]])
    lib = MotorPrimitiveLibrary(dmp, np.zeros((3, 1, dmp.n_basis)), np.ones((3, 1)), stimuli,
                                np.ones(2))
    rng = np.random.default_rng(1)
    for _ in range(60):
        i = rng.integers(len(lib))
        x = lib.stimuli[i] + 0.3 * rng.standard_normal(2)
        near_bad = np.linalg.norm(x - stimuli[1]) < 1.5
        lib.update_responsibilities(x, 0.0 if near_bad else 1.0)
    assert len(lib) == 2
    assert not any(np.allclose(xi, stimuli[1]) for xi in lib.stimuli)
    assert np.all(lib.gamma > 0.5)
