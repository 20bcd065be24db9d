"""Imitation learning of hitting DMPs (Eqs. 7-8, Algorithm 2).

From a demonstration sampled at times ``t_1 .. t_T`` with joint positions, velocities and
accelerations per DoF, compute the reference forcing term (Eq. 7, read with consistent units, see
``docs/equations.md``)::

    f_ref,t = [tau^2 thdd_t - (1 - z_t) alpha_y (beta_y (g_m,t - th_t) + tau (thd_T - thd_t))]
              / ((th_T - th_1) a)

with ``g_f = th_T``, ``g_dot = thd_T`` and ``g_m,t`` the moving target of Eq. 4 at ``t``, and fit
one weight per basis function by locally weighted regression (Eq. 8, Algorithm 2)::

    w_i = sum_t psi_i(z_t) z_t f_ref,t / sum_t psi_i(z_t) z_t^2

Since ``a = 1 / (th_T - th_1)`` (see :meth:`tt_drake.dmp.HittingDMP.eta`), the denominator of
Eq. 7 is ``eta_demo = 1`` (also in the tiny-amplitude case, where ``eta`` is 1 by definition).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tt_drake.dmp import HittingDMP, Trajectory

__all__ = [
    "Demonstration",
    "ImitationResult",
    "forcing_reference",
    "fit_weights",
    "imitate",
    "quintic_demonstration",
    "borrow_weak_shapes",
    "WEAK_AMPLITUDE_RATIO",
]

WEAK_AMPLITUDE_RATIO = 0.5

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Demonstration:
    """A demonstrated joint trajectory: ``t`` ``(K,)``, ``q, qd, qdd`` ``(K, n_dof)``."""

    t: FloatArray
    q: FloatArray
    qd: FloatArray
    qdd: FloatArray

    def __post_init__(self) -> None:
        t = np.asarray(self.t, dtype=float)
        arrays = [np.asarray(a, dtype=float) for a in (self.q, self.qd, self.qdd)]
        arrays = [a[:, None] if a.ndim == 1 else a for a in arrays]
        if t.ndim != 1 or t.size < 3 or np.any(np.diff(t) <= 0):
            raise ValueError("t must be a strictly increasing 1-D array with >= 3 samples")
        for a in arrays:
            if a.shape != arrays[0].shape or a.shape[0] != t.size or a.ndim != 2:
                raise ValueError("q, qd, qdd must have shape (len(t), n_dof)")
            if not np.all(np.isfinite(a)):
                raise ValueError("demonstration contains non-finite values")
        object.__setattr__(self, "t", t)
        for name, a in zip(("q", "qd", "qdd"), arrays, strict=True):
            object.__setattr__(self, name, a)

    @classmethod
    def from_positions(cls, t: ArrayLike, q: ArrayLike) -> Demonstration:
        """Build a demonstration from positions only (derivatives by second-order differences)."""
        t = np.asarray(t, dtype=float)
        q = np.asarray(q, dtype=float)
        q2 = q[:, None] if q.ndim == 1 else q
        qd = np.gradient(q2, t, axis=0, edge_order=2)
        qdd = np.gradient(qd, t, axis=0, edge_order=2)
        return cls(t, q2, qd, qdd)

    @classmethod
    def from_trajectory(cls, traj: Trajectory) -> Demonstration:
        """Wrap an unbatched :class:`~tt_drake.dmp.Trajectory` as a demonstration."""
        return cls(traj.t, traj.q, traj.qd, traj.qdd)

    @property
    def tau(self) -> float:
        return float(self.t[-1] - self.t[0])

    @property
    def n_dof(self) -> int:
        return int(self.q.shape[1])


@dataclass(frozen=True)
class ImitationResult:
    """Learned primitive: weights ``(n_dof, B)`` and the demonstration's task parameters."""

    weights: FloatArray
    amplitude: FloatArray  # theta_T - theta_1 per DoF (a = 1 / amplitude)
    y0: FloatArray
    yd0: FloatArray
    g_f: FloatArray
    g_dot: FloatArray
    tau: float

    def rollout(self, dmp: HittingDMP, **kwargs) -> Trajectory:
        """Reproduce the demonstration (same start, goal, final velocity and duration)."""
        return dmp.rollout(self.weights, self.y0, self.g_f, self.g_dot, self.tau,
                           yd0=self.yd0, amplitude=self.amplitude, **kwargs)


def forcing_reference(dmp: HittingDMP, demo: Demonstration) -> FloatArray:
    """Reference forcing term ``f_ref,t`` of Eq. 7 for every sample and DoF, shape ``(K, n_dof)``.

    Uses ``g_f = theta_T``, ``g_dot = thd_T`` and the moving target ``g_m,t`` of Eq. 4, and divides
    by ``eta_demo = (theta_T - theta_1) a`` as given by :meth:`HittingDMP.eta`.
    """
    t = demo.t - demo.t[0]
    tau = demo.tau
    th, thd, thdd = demo.q, demo.qd, demo.qdd
    g_f, g_dot, y0 = th[-1], thd[-1], th[0]
    z = dmp.phase(t, tau)[:, None]
    g_m = dmp.moving_target(t, tau, g_f, g_dot)
    spring = (1.0 - z) * dmp.alpha_y * (dmp.beta_y * (g_m - th) + tau * (g_dot - thd))
    eta = dmp.eta(g_f, y0, g_f - y0)
    return (tau**2 * thdd - spring) / eta


def fit_weights(
    dmp: HittingDMP,
    z: ArrayLike,
    f_ref: ArrayLike,
    *,
    method: str = "ls",
    ridge: float = 1e-10,
) -> FloatArray:
    """Fit the weights of Eq. 5 to a reference forcing term; returns ``(n_dof, B)``.

    ``method="lwr"`` is Eq. 8 / Algorithm 2, one locally weighted regression per basis function:
    ``w_i = (Z^T Psi_i Z)^-1 Z^T Psi_i f_ref``. ``method="ls"`` solves the global least-squares
    problem ``min_w ||F w - f_ref||^2 + ridge ||w||^2`` with the normalised features ``F`` of Eq. 5
    (not in the paper; fits the normalised mixture exactly rather than locally, which is more
    accurate with few basis functions). ``ridge`` is relative to the trace of ``F^T F / B``.
    """
    z = np.asarray(z, dtype=float).ravel()
    f = np.asarray(f_ref, dtype=float)
    f2 = f[:, None] if f.ndim == 1 else f
    if method == "lwr":
        psi = dmp.basis(z)  # (K, B)
        num = np.einsum("kb,k,kd->db", psi, z, f2)
        den = np.einsum("kb,k->b", psi, z**2)
        return num / den
    if method == "ls":
        feats = dmp.features(z)
        gram = feats.T @ feats
        lam = ridge * np.trace(gram) / gram.shape[0]
        return np.linalg.solve(gram + lam * np.eye(gram.shape[0]), feats.T @ f2).T
    raise ValueError(f"unknown method {method!r}; use 'lwr' or 'ls'")


def imitate(dmp: HittingDMP, demo: Demonstration, *, method: str = "ls") -> ImitationResult:
    """Learn one primitive from a demonstration, all DoFs at once (Eqs. 7-8, Algorithm 2).

    ``method="lwr"`` is Algorithm 2 verbatim (locally weighted regression per basis function).
    The default ``"ls"`` fits the same features by global least squares: with the default 30
    basis functions LWR reproduces a smooth 0.5 s hitting demonstration with ~1e-2 rad RMSE (the
    normalised mixture of local fits is not the local fit), global least squares with ~3e-5 rad;
    ``tests/tt_drake/test_imitation.py`` pins both numbers' order of magnitude.
    """
    f_ref = forcing_reference(dmp, demo)
    z = dmp.phase(demo.t - demo.t[0], demo.tau)
    w = fit_weights(dmp, z, f_ref, method=method)
    q, qd = demo.q, demo.qd
    return ImitationResult(
        weights=w,
        amplitude=q[-1] - q[0],
        y0=q[0].copy(),
        yd0=qd[0].copy(),
        g_f=q[-1].copy(),
        g_dot=qd[-1].copy(),
        tau=demo.tau,
    )


def quintic_demonstration(
    tau: float,
    y0: ArrayLike,
    g_f: ArrayLike,
    g_dot: ArrayLike,
    *,
    rate: float = 500.0,
    backswing: ArrayLike = 0.0,
) -> Demonstration:
    """A synthetic smooth hitting demonstration (for examples and tests).

    Per DoF: the quintic polynomial from rest at ``y0`` to ``g_f`` with velocity ``g_dot`` and zero
    acceleration at ``tau``, plus an optional backswing bump ``backswing * sin^3(pi t / tau)``
    (which leaves both end states unchanged). Derivatives are exact.
    """
    y0, g_f, g_dot, b = (np.atleast_1d(np.asarray(a, dtype=float)) for a in
                         (y0, g_f, g_dot, backswing))
    y0, g_f, g_dot, b = np.broadcast_arrays(y0, g_f, g_dot, b)
    t = np.linspace(0.0, tau, max(2, int(round(tau * rate))) + 1)
    u = t / tau
    # quintic with q(0)=y0, qd(0)=qdd(0)=0, q(1)=g_f, qd(1)=tau g_dot, qdd(1)=0 in u = t / tau
    d, v = g_f - y0, tau * g_dot
    c3, c4, c5 = 10 * d - 4 * v, -15 * d + 7 * v, 6 * d - 3 * v
    up = np.stack([u**3, u**4, u**5], axis=-1)
    upd = np.stack([3 * u**2, 4 * u**3, 5 * u**4], axis=-1) / tau
    updd = np.stack([6 * u, 12 * u**2, 20 * u**3], axis=-1) / tau**2
    coef = np.stack([c3, c4, c5])  # (3, D)
    om = np.pi / tau
    sn, cs = np.sin(om * t)[:, None], np.cos(om * t)[:, None]
    q = y0 + up @ coef + b * sn**3
    qd = upd @ coef + b * 3 * sn**2 * cs * om
    qdd = updd @ coef + b * om**2 * (6 * sn * cs**2 - 3 * sn**3)
    return Demonstration(t, q, qd, qdd)


def borrow_weak_shapes(weights: ArrayLike, amplitude: ArrayLike,
                       ratio: float = WEAK_AMPLITUDE_RATIO) -> tuple[FloatArray, FloatArray]:
    """Give the DoFs of one primitive that barely moved in its demonstration the normalised shape
    of the DoF that moved most: returns new ``(weights (D, B), amplitude (D,))``.

    Why: the amplitude factor ``eta_j = (g_j - y0_j) / A_j`` (Eq. 4, ``a = 1 / A``) is
    ill-conditioned where the demonstrated amplitude ``A_j`` is small. A new movement of that DoF
    over a larger distance scales the demonstration's (small, noisy) forcing term by up to
    ``eta_max`` and the rest is left to the spring, so the replay is fast and jerky. For DoFs with
    ``|A_j| < ratio * max_k |A_k|`` this stores the dominant DoF ``m``'s weights and amplitude
    instead, so the replay is ``(g_j - y0_j) / A_m * w_m``: DoF m's movement shape scaled to DoF
    j's distance. For a rest-to-rest quintic (the teacher's stage movements), every DoF has the same
    normalised shape, so the substitution changes nothing there except the conditioning.

    Measured on 100 teacher strokes (300 primitives, planned from rest 0.45 s before the hit):
    plans leaving the joint limits fell from 41 % to 16 % (0.6 s before: 16 % to 0 %); the worst
    preparation acceleration from 405 to under the 200 rad/s^2 limit.
    """
    w = np.array(weights, dtype=float)
    a = np.array(amplitude, dtype=float)
    if w.ndim != 2 or a.shape != (w.shape[0],):
        raise ValueError(f"expected weights (D, B) and amplitude (D,), got {w.shape}, {a.shape}")
    m = int(np.argmax(np.abs(a)))
    weak = np.abs(a) < ratio * abs(a[m])
    w[weak] = w[m]
    a[weak] = a[m]
    return w, a
