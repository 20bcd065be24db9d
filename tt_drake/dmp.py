"""Hitting dynamic movement primitive (Muelling, Kober & Peters 2010, Eqs. 1-5).

Canonical system (Eq. 3, with the decaying sign; see ``docs/equations.md``)::

    tau z' = -alpha_z z,        z(t) = exp(-alpha_z t / tau),   z(0) = 1

Transformed system (Eq. 4, units made consistent: the printed ``g_dot - y_dot tau`` is read as
``tau (g_dot - y_dot)``)::

    tau v' = (1 - z) alpha_y (beta_y (g_m - y) + tau (g_dot - y_dot)) + eta f(z),   tau y' = v
    g_m    = g_m0 - g_dot tau ln(z) / alpha_h = g_m0 + g_dot (alpha_z / alpha_h) t
    eta    = (g_f - y0) a

Forcing term (Eq. 5)::

    f(z) = sum_i w_i psi_i(z) z / sum_i psi_i(z),     psi_i(z) = exp(-rho_i (z - mu_i)^2)

Resolved ambiguities (each pinned by a test in ``tests/tt_drake/test_dmp.py``):

* ``g_m0`` is chosen as ``g_f - g_dot (alpha_z / alpha_h) tau`` so that the moving target passes
  ``g_f`` at ``t = tau``; with the default ``alpha_h = alpha_z`` it does so with velocity ``g_dot``.
  The movement duration ``T`` is the time constant ``tau``.
* The amplitude modifier is ``a = 1 / A`` where ``A = theta_T - theta_1`` is the demonstration's
  amplitude, so ``eta = (g_f - y0) / A`` rescales (and mirrors, when the new goal lies on the other
  side of the start) the demonstrated shape. Two guards: if ``|A| < amp_eps`` the shape is *not*
  scaled (``eta = 1``, the forcing term was learned in absolute units) and ``eta`` is clipped to
  ``[-eta_max, eta_max]``. See :meth:`HittingDMP.eta`.

Integration. In normalised time ``s = t / tau`` the system reads
``y'' = (1 - z)(alpha_y beta_y (g_m - y) + alpha_y (tau g_dot - y')) + eta f(z)`` with
``z = exp(-alpha_z s)``: it does not depend on ``tau`` except through its inputs. It is linear in
the start state ``(y0, tau y_dot0)`` and in the input vector
``u = (g_m0, tau g_dot, eta w_1 ... eta w_B)``. The module therefore integrates the system once per
number of steps with classical Runge-Kutta (RK4) on the fixed grid for identity inputs (a
"sensitivity" map), caches it, and a rollout of any batch of primitives and degrees of freedom is
one matrix product. This is exact for the discretised system (RK4 applied to a linear system is
itself a linear map), not an extra approximation.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass, field
from functools import cached_property
from threading import Lock

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["HittingDMP", "Trajectory", "n_steps_for"]

FloatArray = NDArray[np.float64]

# Sensitivity maps kept per HittingDMP (least recently used dropped). The learned player's
# roll-outs ask for ~600 different step counts (26-629 over 30 momp serves, ~6 new ones per serve
# at first); a map is ~0.8 kB per step (at most ~0.5 MB), so 256 of them are at most ~130 MB
# and on average ~60 MB (docs/performance.md, "The players' Python").
_CACHED_MAPS = 256
# The most RK4 steps a movement's map may ask for as its minimum (``min_steps``): ~8 MB per map.
_MAX_STEPS = 10_000


@dataclass(frozen=True)
class Trajectory:
    """A sampled joint trajectory.

    ``t`` has shape ``(K,)``; ``q``, ``qd`` and ``qdd`` have shape ``(*batch, K, n_dof)``
    (positions in rad, velocities in rad/s, accelerations in rad/s^2).
    """

    t: FloatArray
    q: FloatArray
    qd: FloatArray
    qdd: FloatArray

    @property
    def duration(self) -> float:
        return float(self.t[-1] - self.t[0])

    def __getitem__(self, index: int | slice | tuple) -> Trajectory:
        """Index the batch dimensions, e.g. ``traj[3]`` is primitive 3 of a library rollout."""
        return Trajectory(self.t, self.q[index], self.qd[index], self.qdd[index])


def n_steps_for(tau: float, rate: float) -> int:
    """Number of intervals of a grid over ``[0, tau]`` whose step does not exceed ``1 / rate``.

    The grid is ``linspace(0, tau, n + 1)``: it ends exactly at the hitting time ``tau``; its step
    ``tau / n`` is ``1 / rate`` whenever ``tau * rate`` is an integer.
    """
    if not (tau > 0 and rate > 0):
        raise ValueError(f"tau and rate must be positive, got tau={tau}, rate={rate}")
    return max(1, math.ceil(tau * rate - 1e-9))


@dataclass(frozen=True)
class HittingDMP:
    """Hyperparameters and integrator of the hitting DMP (Eqs. 1-5); shared by all DoFs.

    Parameters (the paper's symbols):
        n_basis: number ``B`` of Gaussian basis functions ``psi_i`` (Eq. 5).
        alpha_z: canonical-system rate (Eq. 3); ``z(tau) = exp(-alpha_z)``.
        alpha_y: transformed-system gain (Eq. 4).
        beta_y: spring gain; ``None`` gives critical damping ``alpha_y / 4``.
        alpha_h: moving-target rate (Eq. 4); ``None`` gives ``alpha_z`` (target reaches ``g_f``
            with velocity ``g_dot`` at ``tau``).
        overlap: height of basis ``i`` at the centre of its neighbour (sets ``rho_i``).
        amp_eps: demonstrations whose amplitude ``|theta_T - theta_1|`` is below this (rad) are
            learned and replayed without amplitude scaling (``eta = 1``).
        eta_max: bound on ``|eta|`` when the shape is scaled.
        min_steps: the integrator subdivides the output grid so it takes at least this many RK4
            steps per movement (accuracy at low sample rates).

    Basis centres are equally spaced in normalised time ``c_i = i / (B - 1)`` and mapped to phase,
    ``mu_i = exp(-alpha_z c_i)``; the widths are ``rho_i = -ln(overlap) / (mu_{i+1} - mu_i)^2``.
    """

    n_basis: int = 30
    alpha_z: float = 3.0
    alpha_y: float = 35.0
    beta_y: float | None = None
    alpha_h: float | None = None
    overlap: float = 0.5
    amp_eps: float = 0.05
    eta_max: float = 5.0
    min_steps: int = 200
    _cache: OrderedDict = field(
        default_factory=OrderedDict, init=False, repr=False, compare=False, hash=False
    )
    _lock: Lock = field(default_factory=Lock, init=False, repr=False, compare=False, hash=False)

    def __post_init__(self) -> None:
        if self.beta_y is None:
            object.__setattr__(self, "beta_y", self.alpha_y / 4.0)
        if self.alpha_h is None:
            object.__setattr__(self, "alpha_h", self.alpha_z)
        if self.n_basis < 2:
            raise ValueError("n_basis must be at least 2")
        gains = (self.alpha_z, self.alpha_y, self.beta_y, self.alpha_h, self.eta_max)
        if not all(math.isfinite(g) for g in gains) or not math.isfinite(self.amp_eps):
            raise ValueError("alpha_z, alpha_y, beta_y, alpha_h, amp_eps and eta_max must be "
                             "finite")
        if not (self.alpha_z > 0 and self.alpha_y > 0 and self.beta_y > 0 and self.alpha_h > 0):
            raise ValueError("alpha_z, alpha_y, beta_y and alpha_h must be positive")
        if self.min_steps > _MAX_STEPS:
            raise ValueError(f"min_steps must be at most {_MAX_STEPS}")
        if not 0.0 < self.overlap < 1.0:
            raise ValueError("overlap must lie in (0, 1)")
        if self.amp_eps < 0 or self.eta_max <= 0 or self.min_steps < 1:
            raise ValueError("amp_eps >= 0, eta_max > 0 and min_steps >= 1 are required")

    # ------------------------------------------------------------------ hyperparameters / I/O
    def to_dict(self) -> dict:
        """Hyperparameters as a JSON-serialisable dict (inverse of :meth:`from_dict`)."""
        keys = ("n_basis", "alpha_z", "alpha_y", "beta_y", "alpha_h", "overlap", "amp_eps",
                "eta_max", "min_steps")
        return {k: getattr(self, k) for k in keys}

    @classmethod
    def from_dict(cls, d: dict) -> HittingDMP:
        return cls(**d)

    # ------------------------------------------------------------------ canonical system / basis
    @cached_property
    def centres(self) -> FloatArray:
        """Basis centres ``mu_i`` in phase (Eq. 5), equally spaced in normalised time."""
        return np.exp(-self.alpha_z * np.linspace(0.0, 1.0, self.n_basis))

    @cached_property
    def widths(self) -> FloatArray:
        """Basis widths ``rho_i`` (Eq. 5): ``psi_i`` equals ``overlap`` at the next centre."""
        d = np.abs(np.diff(self.centres))
        d = np.append(d, d[-1])
        return -math.log(self.overlap) / d**2

    def phase(self, t: ArrayLike, tau: float) -> FloatArray:
        """Canonical system, Eq. 3 (decaying form): ``z(t) = exp(-alpha_z t / tau)``."""
        return np.exp(-self.alpha_z * np.asarray(t, dtype=float) / tau)

    def basis(self, z: ArrayLike) -> FloatArray:
        """Gaussian basis functions of Eq. 5, ``psi_i(z)``; shape ``(*z.shape, n_basis)``."""
        z = np.asarray(z, dtype=float)[..., None]
        return np.exp(-self.widths * (z - self.centres) ** 2)

    def features(self, z: ArrayLike) -> FloatArray:
        """Normalised, phase-gated features of Eq. 5: ``psi_i(z) z / sum_j psi_j(z)``.

        ``f(z) = features(z) @ w``.
        """
        z = np.asarray(z, dtype=float)
        psi = self.basis(z)
        return psi * (z[..., None] / psi.sum(axis=-1, keepdims=True))

    def forcing(self, weights: ArrayLike, z: ArrayLike) -> FloatArray:
        """Forcing term ``f(z)`` of Eq. 5 for weights ``(..., B)``; shape ``(..., *z.shape)``."""
        w = np.asarray(weights, dtype=float)
        return np.einsum("...b,kb->...k", w, self.features(np.ravel(z))).reshape(
            w.shape[:-1] + np.shape(z)
        )

    def moving_target(
        self, t: ArrayLike, tau: float, g_f: ArrayLike, g_dot: ArrayLike
    ) -> FloatArray:
        """Moving target of Eq. 4 in closed form; shape ``(*t.shape, *g_f.shape)``.

        ``g_m(t) = g_m0 - g_dot tau ln(z) / alpha_h = g_m0 + g_dot (alpha_z / alpha_h) t`` with
        ``g_m0 = g_f - g_dot (alpha_z / alpha_h) tau``, so that ``g_m(tau) = g_f``.
        """
        r = self.alpha_z / self.alpha_h
        t = np.asarray(t, dtype=float)
        g_f = np.asarray(g_f, dtype=float)
        g_dot = np.asarray(g_dot, dtype=float)
        return g_f + g_dot * r * (t.reshape(t.shape + (1,) * g_f.ndim) - tau)

    def eta(self, g_f: ArrayLike, y0: ArrayLike, amplitude: ArrayLike | None) -> FloatArray:
        """Amplitude factor ``eta = (g_f - y0) a`` of Eq. 4 with ``a = 1 / amplitude``.

        ``amplitude`` is the demonstration's ``theta_T - theta_1`` per DoF (as returned by
        imitation learning). Resolution of the known weak spot:

        * ``|amplitude| < amp_eps``: the demonstrated joint barely moved, the ratio is
          ill-conditioned, so the shape is replayed unscaled: ``eta = 1``.
        * otherwise ``eta = (g_f - y0) / amplitude``, clipped to ``[-eta_max, eta_max]``. A new
          goal on the other side of the start gives ``eta < 0`` (the shape is mirrored); a new goal
          at the start gives ``eta = 0`` (pure spring-damper movement to the moving target).
        * ``amplitude=None`` means "no scaling" (``eta = 1``) for every DoF.
        """
        g_f, y0 = np.broadcast_arrays(np.asarray(g_f, float), np.asarray(y0, float))
        if amplitude is None:
            return np.ones_like(g_f)
        amp = np.asarray(amplitude, dtype=float)
        small = np.abs(amp) < self.amp_eps
        safe = np.where(small, 1.0, amp)
        eta = np.clip((g_f - y0) / safe, -self.eta_max, self.eta_max)
        return np.where(small, 1.0, eta)

    # ------------------------------------------------------------------ integration
    def sensitivity(self, n_steps: int) -> FloatArray:
        """Linear map from inputs to the sampled solution in normalised time (cached).

        Returns ``S`` with shape ``(n_steps + 1, 3, 4 + n_basis)``: for an input vector
        ``x = (y0, v0, g_m0, tau g_dot, eta w_1 .. eta w_B)`` (``v0 = tau y_dot0``) the state at
        ``s_k = k / n_steps`` is ``y_k = S[k, 0] @ x``, ``v_k = S[k, 1] @ x`` and
        ``dv/ds_k = S[k, 2] @ x``; physical velocity and acceleration are ``v / tau`` and
        ``(dv/ds) / tau^2``. Integrates Eq. 4 with RK4, ``ceil(min_steps / n_steps)`` substeps per
        output interval.
        """
        with self._lock:
            hit = self._cache.get(n_steps)
            if hit is not None:
                self._cache.move_to_end(n_steps)
                return hit
        out = self._integrate_sensitivity(n_steps)
        out.setflags(write=False)
        with self._lock:
            self._cache[n_steps] = out
            while len(self._cache) > _CACHED_MAPS:
                self._cache.popitem(last=False)
        return out

    def _system_matrices(self, s: FloatArray) -> tuple[FloatArray, FloatArray]:
        """``A(s)`` (``(n, 2, 2)``) and input matrix ``Bu(s)`` (``(n, 2, 2 + B)``) of Eq. 4."""
        z = np.exp(-self.alpha_z * s)
        on = 1.0 - z
        k = on * self.alpha_y * self.beta_y
        c = on * self.alpha_y
        n = s.shape[0]
        a = np.zeros((n, 2, 2))
        a[:, 0, 1] = 1.0
        a[:, 1, 0] = -k
        a[:, 1, 1] = -c
        b = np.zeros((n, 2, 2 + self.n_basis))
        b[:, 1, 0] = k
        b[:, 1, 1] = k * (self.alpha_z / self.alpha_h) * s + c
        b[:, 1, 2:] = self.features(z)
        return a, b

    def _integrate_sensitivity(self, n_steps: int) -> FloatArray:
        m = max(1, math.ceil(self.min_steps / n_steps))
        n_fine = n_steps * m
        h = 1.0 / n_fine
        a, b = self._system_matrices(np.linspace(0.0, 1.0, 2 * n_fine + 1))
        a0, am, a1 = a[0:-1:2], a[1::2], a[2::2]
        b0, bm, b1 = b[0:-1:2], b[1::2], b[2::2]
        eye = np.eye(2)
        # RK4 applied to x' = A x + Bu u (u constant) is the linear map x+ = Phi x + Gam u.
        k1x, k1u = a0, b0
        k2x = am @ (eye + 0.5 * h * k1x)
        k2u = am @ (0.5 * h * k1u) + bm
        k3x = am @ (eye + 0.5 * h * k2x)
        k3u = am @ (0.5 * h * k2u) + bm
        k4x = a1 @ (eye + h * k3x)
        k4u = a1 @ (h * k3u) + b1
        phi = eye + (h / 6.0) * (k1x + 2.0 * k2x + 2.0 * k3x + k4x)
        gam = (h / 6.0) * (k1u + 2.0 * k2u + 2.0 * k3u + k4u)
        # The state after fine step j is the composition of the steps' affine maps
        # x -> Phi_j x + Gam_j u up to j, applied to the identity start. All the compositions
        # at once by doubling (an inclusive prefix scan, log2(n_fine) rounds of stacked 2 x 2
        # products): the same numbers as stepping one at a time up to rounding (~1e-14 on
        # entries up to ~50), at ~2.5x less CPU (docs/performance.md). Row j of
        # ``maps`` is [P_j | Q_j]: the state after step j is P_j (y0, v0) + Q_j u.
        maps = np.concatenate([phi, gam], axis=2)  # (n_fine, 2, 4 + B)
        shift = 1
        while shift < n_fine:
            later = maps[shift:, :, :2] @ maps[:-shift]  # step j after the steps up to j - shift
            later[:, :, 2:] += maps[shift:, :, 2:]
            maps[shift:] = later
            shift *= 2
        n_in = 4 + self.n_basis
        states = np.empty((n_steps + 1, 2, n_in))
        states[0] = 0.0
        states[0, 0, 0] = 1.0
        states[0, 1, 1] = 1.0
        states[1:] = maps[m - 1::m]
        # Acceleration dv/ds = A(s) x + Bu(s) u at the output samples.
        a_out, b_out = self._system_matrices(np.linspace(0.0, 1.0, n_steps + 1))
        acc = np.einsum("kj,kjn->kn", a_out[:, 1, :], states)
        acc[:, 2:] += b_out[:, 1, :]
        return np.concatenate([states, acc[:, None, :]], axis=1)

    def rollout(
        self,
        weights: ArrayLike,
        y0: ArrayLike,
        g_f: ArrayLike,
        g_dot: ArrayLike,
        tau: float,
        *,
        yd0: ArrayLike | None = None,
        amplitude: ArrayLike | None = None,
        eta: ArrayLike | None = None,
        rate: float = 500.0,
        n_steps: int | None = None,
    ) -> Trajectory:
        """Integrate Eqs. 3-5 for a batch of primitives and DoFs at once.

        Args:
            weights: ``w``, shape ``(*batch, n_dof, n_basis)``; e.g. a whole library
                ``(n_prim, n_dof, n_basis)``.
            y0, yd0: start positions and velocities, broadcastable to ``(*batch, n_dof)``
                (``yd0`` defaults to rest).
            g_f, g_dot: final position and velocity (the hitting posture and joint velocity),
                broadcastable to ``(*batch, n_dof)``.
            tau: movement duration ``T`` (s), the time constant of Eqs. 3-4.
            amplitude: demonstration amplitudes ``theta_T - theta_1`` for :meth:`eta`,
                broadcastable to ``(*batch, n_dof)``; ignored if ``eta`` is given.
            eta: explicit amplitude factor ``eta`` (overrides ``amplitude``).
            rate: sample rate (Hz) of the output grid ``linspace(0, tau, n + 1)``.
            n_steps: number of output intervals (overrides ``rate``).

        Returns:
            :class:`Trajectory` with ``q, qd, qdd`` of shape ``(*batch, n_steps + 1, n_dof)``.
        """
        w = np.asarray(weights, dtype=float)
        if w.ndim < 2 or w.shape[-1] != self.n_basis:
            raise ValueError(f"weights must have shape (..., n_dof, {self.n_basis}), got {w.shape}")
        tau = float(tau)
        n = n_steps_for(tau, rate) if n_steps is None else int(n_steps)
        if n < 1:
            raise ValueError("n_steps must be >= 1")
        lead = w.shape[:-1]
        y0b = np.broadcast_to(np.asarray(y0, float), lead)
        gfb = np.broadcast_to(np.asarray(g_f, float), lead)
        gdb = np.broadcast_to(np.asarray(g_dot, float), lead)
        yd0b = np.zeros(lead) if yd0 is None else np.broadcast_to(np.asarray(yd0, float), lead)
        if eta is None:
            etab = np.broadcast_to(self.eta(gfb, y0b, amplitude), lead)
        else:
            etab = np.broadcast_to(np.asarray(eta, float), lead)
        r = self.alpha_z / self.alpha_h
        inputs = np.empty(lead + (4 + self.n_basis,))
        inputs[..., 0] = y0b
        inputs[..., 1] = tau * yd0b
        inputs[..., 2] = gfb - gdb * r * tau
        inputs[..., 3] = tau * gdb
        np.multiply(w, etab[..., None], out=inputs[..., 4:])
        return self._apply(inputs, tau, n)

    def _apply(self, inputs: FloatArray, tau: float, n: int) -> Trajectory:
        """Evaluate the cached sensitivity map on inputs ``(*batch, n_dof, 4 + B)``."""
        sens = self.sensitivity(n)
        lead = inputs.shape[:-1]
        flat = inputs.reshape(-1, inputs.shape[-1])
        out = flat @ sens.reshape(-1, sens.shape[-1]).T  # (M, (n+1)*3)
        out = out.reshape(lead + (n + 1, 3))
        out = np.moveaxis(out, -3, -2)  # (*batch, n+1, n_dof, 3)
        q = np.ascontiguousarray(out[..., 0])
        qd = out[..., 1] / tau
        qdd = out[..., 2] / tau**2
        return Trajectory(np.linspace(0.0, tau, n + 1), q, qd, qdd)
