"""Smooth synthetic demonstrations for the tests (exact derivatives, no finite differences)."""

from __future__ import annotations

import numpy as np

from tt_drake.imitation import Demonstration


def quintic(t, tau, p0, v0, a0, p1, v1, a1):
    """Quintic polynomial through the given boundary states; returns (q, qd, qdd) at ``t``."""
    m = np.array(
        [
            [1, 0, 0, 0, 0, 0],
            [0, 1, 0, 0, 0, 0],
            [0, 0, 2, 0, 0, 0],
            [1, tau, tau**2, tau**3, tau**4, tau**5],
            [0, 1, 2 * tau, 3 * tau**2, 4 * tau**3, 5 * tau**4],
            [0, 0, 2, 6 * tau, 12 * tau**2, 20 * tau**3],
        ],
        dtype=float,
    )
    c = np.linalg.solve(m, np.array([p0, v0, a0, p1, v1, a1], dtype=float))
    poly = np.polynomial.polynomial
    return poly.polyval(t, c), poly.polyval(t, poly.polyder(c)), poly.polyval(t, poly.polyder(c, 2))


def hitting_demo(n_dof=7, tau=0.5, rate=500.0, seed=0, backswing=0.3):
    """A 7-DoF hitting-like demonstration: quintic start-at-rest to (g_f, g_dot) plus a smooth
    sin^3 backswing bump, sampled at ``rate``."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, tau, int(round(tau * rate)) + 1)
    q, qd, qdd = (np.empty((t.size, n_dof)) for _ in range(3))
    om = np.pi / tau
    s, c = np.sin(om * t), np.cos(om * t)
    for d in range(n_dof):
        p0 = rng.uniform(-1, 1)
        p1 = p0 + rng.choice([-1, 1]) * rng.uniform(0.3, 1.2)
        v1 = np.sign(p1 - p0) * rng.uniform(0.5, 3.0)
        b = rng.uniform(-backswing, backswing)
        a, ad, add = quintic(t, tau, p0, 0, 0, p1, v1, 0)
        q[:, d] = a + b * s**3
        qd[:, d] = ad + b * 3 * s**2 * c * om
        qdd[:, d] = add + b * om**2 * (6 * s * c**2 - 3 * s**3)
    return Demonstration(t, q, qd, qdd)


def monotone_demo(tau=0.5, rate=500.0, p0=0.0, p1=1.0, v1=2.0):
    """One-DoF monotone hitting demonstration (quintic, rest start, final velocity ``v1``)."""
    t = np.linspace(0.0, tau, int(round(tau * rate)) + 1)
    return Demonstration(t, *quintic(t, tau, p0, 0, 0, p1, v1, 0))
