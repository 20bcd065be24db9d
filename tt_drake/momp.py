"""Mixture of Motor Primitives (Eq. 6, Algorithm 1) and the primitive library.

Gating (Eq. 6)::

    pi(x) = sum_i pi_i gamma_i k(x - x_i) / sum_i gamma_i k(x - x_i),
    k(x - x_i) = exp(-1/2 sum_d ((x_d - x_i,d) / h_d)^2)

with one bandwidth ``h_d`` per stimulus dimension. Every primitive is run with the same task
parameters (start state, ``g_f``, ``g_dot``, ``T``) and its own weights; positions, velocities and
accelerations are mixed with the same normalised weights ``nu_i``.

Resolutions (pinned by tests in ``tests/tt_drake/test_momp.py``):

* The normalisation is computed in the log domain (a soft-max of ``ln gamma_i - d_i^2 / 2``), so a
  stimulus far from every ``x_i`` still gets a well-defined mixture dominated by the nearest
  primitives instead of ``0 / 0``. ``gamma_i = 0`` removes primitive ``i`` exactly.
* Primitives whose normalised weight is below ``min_weight`` (default ``1e-6``) are skipped and the
  rest renormalised; the trajectory changes by at most ``n_skipped * min_weight`` times the largest
  deviation between primitives.
* ``method="weights"`` (default) mixes the primitives in parameter space. The DMP is linear in
  ``eta_i w_i`` for fixed task parameters and all components share one canonical system, so the
  mixture of the rolled-out trajectories (Algorithm 1) equals one rollout of
  ``sum_i nu_i eta_i w_i`` up to round-off; ``method="trajectories"`` does Algorithm 1 literally
  (roll out every kept primitive, then mix) and is used by the tests to check the identity.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tt_drake.artefacts import ArtefactError, load_artefact, save_artefact
from tt_drake.dmp import HittingDMP, Trajectory
from tt_drake.imitation import Demonstration, imitate
from tt_drake.responsibility import ResponsibilityParams, responsibility_update
from tt_drake.stimulus import stimulus_layout, stimulus_size

__all__ = [
    "gating_log_kernel",
    "gating_weights",
    "mix_trajectories",
    "scott_bandwidths",
    "MotorPrimitiveLibrary",
    "LIBRARY_KIND",
]

FloatArray = NDArray[np.float64]
LIBRARY_KIND = "momp-library"


def gating_log_kernel(x: ArrayLike, stimuli: ArrayLike, bandwidths: ArrayLike) -> FloatArray:
    """``ln k(x - x_i) = -1/2 sum_d ((x_d - x_i,d) / h_d)^2`` per primitive, shape ``(P,)``."""
    d = (np.asarray(x, dtype=float) - np.asarray(stimuli, dtype=float)) / np.asarray(
        bandwidths, dtype=float
    )
    return -0.5 * np.einsum("...d,...d->...", d, d)


def gating_weights(
    x: ArrayLike,
    stimuli: ArrayLike,
    bandwidths: ArrayLike,
    gamma: ArrayLike | None = None,
) -> FloatArray:
    """Normalised gating weights of Eq. 6, ``nu_i = gamma_i k(x - x_i) / sum_j gamma_j k(x - x_j)``.

    Computed as a log-domain soft-max (well defined even where every kernel value underflows).
    ``gamma=None`` means all ones (the kernel-only weights of Eq. 9). Raises ``ValueError`` if every
    ``gamma_i`` is zero.
    """
    logk = gating_log_kernel(x, stimuli, bandwidths)
    if gamma is not None:
        g = np.asarray(gamma, dtype=float)
        if np.any(g < 0):
            raise ValueError("responsibilities gamma must be non-negative")
        with np.errstate(divide="ignore"):
            logk = logk + np.log(g)
    top = np.max(logk)
    if not np.isfinite(top):
        raise ValueError("no primitive has a positive responsibility: the mixture is empty")
    e = np.exp(logk - top)
    return e / e.sum()


def mix_trajectories(traj: Trajectory, nu: ArrayLike) -> Trajectory:
    """Algorithm 1's output: ``sum_i nu_i (q_i, qd_i, qdd_i)`` over the leading axis of ``traj``."""
    nu = np.asarray(nu, dtype=float)
    return Trajectory(
        traj.t,
        np.tensordot(nu, traj.q, axes=1),
        np.tensordot(nu, traj.qd, axes=1),
        np.tensordot(nu, traj.qdd, axes=1),
    )


def scott_bandwidths(stimuli: ArrayLike, factor: float = 1.0) -> FloatArray:
    """A default gating bandwidth per stimulus dimension (Scott's rule of thumb).

    ``h_d = factor * std_d * P^(-1 / (S + 4))`` for ``P`` stimuli of dimension ``S``; dimensions
    with zero spread get ``h_d = factor`` (in that dimension's unit). The paper does not give the
    bandwidths; this is the project's choice (see ``docs/motor_primitives.md``).
    """
    x = np.atleast_2d(np.asarray(stimuli, dtype=float))
    p, s = x.shape
    sd = x.std(axis=0) if p > 1 else np.zeros(s)
    h = factor * sd * p ** (-1.0 / (s + 4))
    return np.where(h > 0, h, factor)


def _as_1d(a: ArrayLike, size: int, name: str) -> FloatArray:
    a = np.asarray(a, dtype=float)
    if a.shape != (size,):
        raise ValueError(f"{name} must have shape ({size},), got {a.shape}")
    return a


@dataclass
class MotorPrimitiveLibrary:
    """A library of hitting primitives with stimuli and responsibilities (Eq. 6, Algorithm 3).

    Arrays (``P`` primitives, ``D`` DoFs, ``B`` basis functions, ``S`` stimulus dimensions):
    ``weights (P, D, B)``, ``amplitude (P, D)`` (demonstrated ``theta_T - theta_1``, ``a = 1 /
    amplitude``), ``stimuli (P, S)`` (``x_i``), ``bandwidths (S,)`` (``h_d``), ``gamma (P,)``
    (responsibilities, initialised to 1), ``s (P,)`` and ``n (P,)`` (success and usage counts of
    Algorithm 3). ``stimulus_layout`` optionally names the parts of ``x`` (:mod:`tt_drake.stimulus`,
    e.g. ``("p_hit", "v_hit")``); ``None`` leaves it unnamed.
    """

    dmp: HittingDMP
    weights: FloatArray
    amplitude: FloatArray
    stimuli: FloatArray
    bandwidths: FloatArray
    gamma: FloatArray | None = None
    s: FloatArray | None = None
    n: FloatArray | None = None
    responsibility: ResponsibilityParams = field(default_factory=ResponsibilityParams)
    min_weight: float = 1e-6
    stimulus_layout: tuple[str, ...] | None = None

    def __post_init__(self) -> None:
        self.weights = np.array(self.weights, dtype=float)
        if self.weights.ndim != 3 or self.weights.shape[2] != self.dmp.n_basis:
            raise ValueError(
                f"weights must have shape (P, D, {self.dmp.n_basis}), got {self.weights.shape}"
            )
        p, d, _ = self.weights.shape
        self.amplitude = np.array(self.amplitude, dtype=float)
        if self.amplitude.shape != (p, d):
            raise ValueError(f"amplitude must have shape ({p}, {d}), got {self.amplitude.shape}")
        self.stimuli = np.array(self.stimuli, dtype=float)
        if self.stimuli.ndim != 2 or self.stimuli.shape[0] != p:
            raise ValueError(f"stimuli must have shape ({p}, S), got {self.stimuli.shape}")
        self.bandwidths = _as_1d(self.bandwidths, self.stimuli.shape[1], "bandwidths").copy()
        if np.any(self.bandwidths <= 0):
            raise ValueError("bandwidths must be positive")
        self.gamma = np.ones(p) if self.gamma is None else _as_1d(self.gamma, p, "gamma").copy()
        self.s = np.zeros(p) if self.s is None else _as_1d(self.s, p, "s").copy()
        self.n = np.zeros(p) if self.n is None else _as_1d(self.n, p, "n").copy()
        if not 0.0 <= self.min_weight < 1.0:
            raise ValueError("min_weight must lie in [0, 1)")
        if self.stimulus_layout is not None:
            self.stimulus_layout = stimulus_layout(self.stimulus_layout)
            if stimulus_size(self.stimulus_layout) != self.stimuli.shape[1]:
                raise ValueError(f"stimulus layout {list(self.stimulus_layout)} has "
                                 f"{stimulus_size(self.stimulus_layout)} values, the stimuli "
                                 f"{self.stimuli.shape[1]}")

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_demonstrations(
        cls,
        dmp: HittingDMP,
        demos: list[Demonstration],
        stimuli: ArrayLike,
        bandwidths: ArrayLike | None = None,
        *,
        method: str = "ls",
        **kwargs: Any,
    ) -> MotorPrimitiveLibrary:
        """Learn one primitive per demonstration (Algorithm 2) and pair it with its stimulus.

        ``bandwidths=None`` uses :func:`scott_bandwidths` of the stimuli.
        """
        results = [imitate(dmp, demo, method=method) for demo in demos]
        x = np.atleast_2d(np.asarray(stimuli, dtype=float))
        h = scott_bandwidths(x) if bandwidths is None else bandwidths
        return cls(
            dmp,
            np.stack([r.weights for r in results]),
            np.stack([r.amplitude for r in results]),
            x,
            h,
            **kwargs,
        )

    @property
    def n_primitives(self) -> int:
        return int(self.weights.shape[0])

    @property
    def n_dof(self) -> int:
        return int(self.weights.shape[1])

    def __len__(self) -> int:
        return self.n_primitives

    # ------------------------------------------------------------------ gating / planning
    def gating(self, x: ArrayLike, *, use_gamma: bool = True) -> FloatArray:
        """Normalised gating weights ``nu_i(x)`` of Eq. 6 for every primitive, shape ``(P,)``.

        ``use_gamma=False`` gives the kernel-only weights ``k(x - x_i) / sum_l k(x - x_l)`` of
        Eq. 9 (PoWER). ``x`` must have the library's stimulus size ``S`` (ValueError otherwise).
        """
        x = np.asarray(x, dtype=float)
        if x.shape != self.stimuli.shape[1:]:
            raise ValueError(f"stimulus of shape {x.shape} for a library whose stimuli have "
                             f"{self.stimuli.shape[1]} values"
                             + ("" if self.stimulus_layout is None
                                else f" ({', '.join(self.stimulus_layout)})"))
        return gating_weights(x, self.stimuli, self.bandwidths, self.gamma if use_gamma else None)

    def active(self, x: ArrayLike) -> tuple[NDArray[np.intp], FloatArray]:
        """Indices of the primitives that contribute (``nu_i >= min_weight``) and their
        renormalised weights (Algorithm 1 after skipping negligible components)."""
        nu = self.gating(x)
        idx = np.flatnonzero(nu >= self.min_weight)
        if idx.size == 0:  # only possible if min_weight > max(nu)
            idx = np.array([int(np.argmax(nu))])
        w = nu[idx]
        return idx, w / w.sum()

    def plan(
        self,
        x: ArrayLike,
        y0: ArrayLike,
        g_f: ArrayLike,
        g_dot: ArrayLike,
        tau: float,
        *,
        yd0: ArrayLike | None = None,
        rate: float = 500.0,
        n_steps: int | None = None,
        method: str = "weights",
        weights: ArrayLike | None = None,
    ) -> Trajectory:
        """The MoMP movement ``pi(x)`` (Eq. 6, Algorithm 1) for stimulus ``x``.

        All primitives share the task parameters ``y0, yd0, g_f, g_dot`` (each ``(D,)``) and
        ``tau = T``. ``weights`` optionally replaces the library weights ``(P, D, B)`` (e.g. with
        PoWER's explored weights ``w + eps``). Returns an unbatched :class:`Trajectory` with
        ``q, qd, qdd`` of shape ``(K, D)``.
        """
        w_all = self.weights if weights is None else np.asarray(weights, dtype=float)
        if w_all.shape != self.weights.shape:
            raise ValueError(f"weights must have shape {self.weights.shape}, got {w_all.shape}")
        idx, nu = self.active(x)
        y0 = np.broadcast_to(np.asarray(y0, dtype=float), (self.n_dof,))
        g_f = np.broadcast_to(np.asarray(g_f, dtype=float), (self.n_dof,))
        g_dot = np.broadcast_to(np.asarray(g_dot, dtype=float), (self.n_dof,))
        eta = self.dmp.eta(g_f, y0, self.amplitude[idx])  # (k, D)
        if method == "weights":
            mixed = np.einsum("p,pd,pdb->db", nu, eta, w_all[idx])
            return self.dmp.rollout(mixed, y0, g_f, g_dot, tau, yd0=yd0, eta=1.0, rate=rate,
                                    n_steps=n_steps)
        if method == "trajectories":
            traj = self.dmp.rollout(w_all[idx], y0, g_f, g_dot, tau, yd0=yd0, eta=eta, rate=rate,
                                    n_steps=n_steps)
            return mix_trajectories(traj, nu)
        raise ValueError(f"unknown method {method!r}; use 'weights' or 'trajectories'")

    def rollout_all(
        self,
        y0: ArrayLike,
        g_f: ArrayLike,
        g_dot: ArrayLike,
        tau: float,
        **kwargs: Any,
    ) -> Trajectory:
        """Roll out every primitive with the same task parameters; ``q`` is ``(P, K, D)``."""
        return self.dmp.rollout(self.weights, y0, g_f, g_dot, tau, amplitude=self.amplitude,
                                **kwargs)

    # ------------------------------------------------------------------ library edits
    def append(
        self, weights: ArrayLike, amplitude: ArrayLike, stimulus: ArrayLike
    ) -> int:
        """Add one primitive (``gamma = 1``, ``s = n = 0``); returns its index."""
        w = np.asarray(weights, dtype=float).reshape(1, self.n_dof, self.dmp.n_basis)
        a = np.asarray(amplitude, dtype=float).reshape(1, self.n_dof)
        x = np.asarray(stimulus, dtype=float).reshape(1, self.stimuli.shape[1])
        self.weights = np.concatenate([self.weights, w])
        self.amplitude = np.concatenate([self.amplitude, a])
        self.stimuli = np.concatenate([self.stimuli, x])
        self.gamma = np.append(self.gamma, 1.0)
        self.s = np.append(self.s, 0.0)
        self.n = np.append(self.n, 0.0)
        return self.n_primitives - 1

    def remove(self, indices: ArrayLike) -> None:
        """Delete primitives by index."""
        keep = np.ones(self.n_primitives, dtype=bool)
        keep[np.asarray(indices, dtype=np.intp)] = False
        if not keep.any():
            raise ValueError("refusing to delete every primitive of the library")
        for name in ("weights", "amplitude", "stimuli", "gamma", "s", "n"):
            setattr(self, name, getattr(self, name)[keep])

    def update_responsibilities(self, x: ArrayLike, reward: float, *, prune: bool = True
                                ) -> NDArray[np.intp]:
        """Algorithm 3's responsibility step after a rollout with stimulus ``x`` and reward ``r``.

        Updates ``s``, ``n`` and ``gamma`` (Eqs. 10-11 in Algorithm 3's form) with the gating
        weights computed from the responsibilities before the update. With ``prune=True`` deletes
        the primitives whose ``gamma`` fell below ``responsibility.threshold`` (never the last one)
        and returns their former indices.
        """
        nu = self.gating(x)
        self.s, self.n, self.gamma, low = responsibility_update(
            self.s, self.n, nu, reward, self.responsibility
        )
        removed = np.flatnonzero(low)
        if prune and removed.size:
            if removed.size == self.n_primitives:
                removed = np.delete(removed, int(np.argmax(self.gamma[removed])))
            if removed.size:
                self.remove(removed)
        return removed if prune else np.array([], dtype=np.intp)

    # ------------------------------------------------------------------ persistence
    def save(self, path: str | os.PathLike) -> None:
        """Save as ``.npz`` + JSON metadata (see :mod:`tt_drake.artefacts`)."""
        save_artefact(
            path,
            LIBRARY_KIND,
            {
                "weights": self.weights,
                "amplitude": self.amplitude,
                "stimuli": self.stimuli,
                "bandwidths": self.bandwidths,
                "gamma": self.gamma,
                "s": self.s,
                "n": self.n,
            },
            {
                "dmp": self.dmp.to_dict(),
                "responsibility": self.responsibility.to_dict(),
                "min_weight": self.min_weight,
                "n_primitives": self.n_primitives,
                "n_dof": self.n_dof,
                **({} if self.stimulus_layout is None
                   else {"stimulus": list(self.stimulus_layout)}),
            },
        )

    @classmethod
    def load(cls, path: str | os.PathLike) -> MotorPrimitiveLibrary:
        """Load a library saved by :meth:`save`; raises :class:`ArtefactError` on a bad file."""
        arrays, meta = load_artefact(path, LIBRARY_KIND)
        try:
            dmp = HittingDMP.from_dict(meta["dmp"])
            lib = cls(
                dmp,
                arrays["weights"],
                arrays["amplitude"],
                arrays["stimuli"],
                arrays["bandwidths"],
                gamma=arrays["gamma"],
                s=arrays["s"],
                n=arrays["n"],
                responsibility=ResponsibilityParams(**meta["responsibility"]),
                min_weight=float(meta["min_weight"]),
                stimulus_layout=meta.get("stimulus"),
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise ArtefactError(f"{path}: inconsistent library contents ({exc})") from exc
        if lib.n_primitives != meta.get("n_primitives") or lib.n_dof != meta.get("n_dof"):
            raise ArtefactError(f"{path}: array sizes do not match the metadata")
        return lib
