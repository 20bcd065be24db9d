"""Cost-regularised kernel regression."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.kernel_ridge import KernelRidge

from tt_drake.crkr import CrKR, comfort_cost, gaussian_kernel


def _data(n=40, seed=0):
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1, 1, (n, 2))
    y = np.column_stack([np.sin(2 * x[:, 0]) + x[:, 1], np.cos(x[:, 1])])
    return x, y


def test_equal_costs_give_kernel_ridge_regression():
    x, y = _data()
    h, lam, c = np.array([0.5, 0.8]), 0.3, 0.2
    model = CrKR(h, lam).fit(x, y, np.full(len(x), c))
    krr = KernelRidge(alpha=lam * c, kernel="rbf", gamma=0.5).fit(x / h, y)
    xq = np.random.default_rng(1).uniform(-1, 1, (25, 2))
    mean, var = model.predict(xq)
    np.testing.assert_allclose(mean, krr.predict(xq / h), atol=1e-9)
    kq = gaussian_kernel(xq, x, h)
    inv = np.linalg.inv(gaussian_kernel(x, x, h) + lam * c * np.eye(len(x)))
    np.testing.assert_allclose(var, 1 + lam - np.einsum("qi,ij,qj->q", kq, inv, kq), atol=1e-9)


def test_variance_grows_with_a_samples_cost():
    x, y = _data(n=15)
    variances = []
    for c0 in (0.01, 0.1, 1.0, 10.0):
        costs = np.full(len(x), 0.05)
        costs[0] = c0
        _, var = CrKR(0.4, 0.5).fit(x, y, costs).predict(x[:1])
        variances.append(var[0])
    assert np.all(np.diff(variances) > 0)
    assert variances[-1] < 1.5 + 1e-12  # bounded by the prior k(s, s) + lambda


def test_picks_low_cost_branch_instead_of_averaging():
    """Two valid solutions y = +-(1 + s/2) for every s (think elbow up / elbow down). The cost is
    the squared distance from the comfort posture y_c = 1.25 (plus a floor), so + is cheap."""
    rng = np.random.default_rng(2)
    s = rng.uniform(0, 1, 120)
    y = rng.choice([-1.0, 1.0], s.size) * (1 + 0.5 * s)
    costs = comfort_cost(y[:, None], np.array([1.25])) + 1e-2
    sq = np.linspace(0.05, 0.95, 19)[:, None]
    crkr = CrKR(0.15, 1.0).fit(s[:, None], y, costs)
    krr = CrKR(0.15, 1.0).fit(s[:, None], y, np.full(s.size, costs.mean()))
    low = 1 + 0.5 * sq[:, 0]
    assert np.abs(crkr.predict(sq, return_var=False)[:, 0] - low).max() < 0.1
    averaged = krr.predict(sq, return_var=False)[:, 0]
    assert np.abs(averaged).max() < 0.6  # KRR sits between the branches, on neither
    # the variance is larger where only costly samples exist: drop the cheap ones above s = 0.5
    keep = (y > 0) & (s < 0.5) | (y < 0)
    _, var = CrKR(0.15, 1.0).fit(s[keep, None], y[keep], costs[keep]).predict(np.array([[0.2],
                                                                                      [0.8]]))
    assert var[1] > var[0]


def test_incremental_update_equals_full_fit():
    x, y = _data(n=30)
    c = np.random.default_rng(3).uniform(0.1, 2, 30)
    full = CrKR([0.5, 0.6], 0.7).fit(x, y, c)
    inc = CrKR([0.5, 0.6], 0.7).fit(x[:10], y[:10], c[:10]).add(x[10:25], y[10:25], c[10:25])
    inc.add(x[25:], y[25:], c[25:])
    xq = np.random.default_rng(4).uniform(-1, 1, (20, 2))
    for a, b in zip(full.predict(xq), inc.predict(xq), strict=True):
        np.testing.assert_allclose(a, b, atol=1e-10)
    assert inc.n_samples == 30


def test_invalid_inputs():
    x, y = _data(n=5)
    with pytest.raises(ValueError):
        CrKR(0.5).fit(x, y, np.zeros(5))
    with pytest.raises(ValueError):
        CrKR(0.5, lam=0.0)
    with pytest.raises(ValueError):
        CrKR([1.0, 1.0, 1.0]).fit(x, y, np.ones(5))
    with pytest.raises(RuntimeError):
        CrKR(0.5).predict(x)
