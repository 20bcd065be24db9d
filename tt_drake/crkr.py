"""Cost-regularised kernel regression (CrKR; Kober et al., RSS 2010), used in Section II-C.2.

For training stimuli ``s_i`` with targets ``y_i`` and costs ``c_i > 0``::

    mean:      ybar(s)  = k(s)^T (K + lambda C)^-1 Y
    variance:  sigma^2(s) = k(s, s) + lambda - k(s)^T (K + lambda C)^-1 k(s)

with ``K_ij = k(s_i, s_j)``, ``C = diag(c_i)`` and a Gaussian kernel with one bandwidth per input
dimension, ``k(a, b) = exp(-1/2 sum_d ((a_d - b_d) / h_d)^2)`` (so ``k(s, s) = 1``). All output
dimensions share the kernel (one independent model per output, as in the paper, with a common
Gram matrix). With equal costs ``c_i = c`` this is kernel ridge regression with ridge
``lambda c``; a costly sample counts less in the mean and widens the variance near it, which is
what lets CrKR pick the low-cost branch of a multi-valued mapping instead of averaging branches.

The model keeps the Cholesky factor ``L`` of ``K + lambda C``; :meth:`CrKR.add` appends samples by
a block Cholesky update (``O(n^2 k)`` for ``k`` new samples instead of ``O(n^3)``).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.linalg import cho_solve, cholesky, solve_triangular

from tt_drake.artefacts import ArtefactError, load_artefact, save_artefact

__all__ = ["CrKR", "gaussian_kernel", "comfort_cost", "CRKR_KIND"]

FloatArray = NDArray[np.float64]
CRKR_KIND = "crkr-model"


def gaussian_kernel(a: ArrayLike, b: ArrayLike, bandwidths: ArrayLike) -> FloatArray:
    """``k(a_i, b_j) = exp(-1/2 sum_d ((a_id - b_jd) / h_d)^2)``, shape ``(len(a), len(b))``."""
    h = np.asarray(bandwidths, dtype=float)
    a = np.atleast_2d(np.asarray(a, dtype=float)) / h
    b = np.atleast_2d(np.asarray(b, dtype=float)) / h
    d2 = (a * a).sum(1)[:, None] + (b * b).sum(1)[None, :] - 2.0 * a @ b.T
    return np.exp(-0.5 * np.maximum(d2, 0.0))


def comfort_cost(
    theta: ArrayLike, theta_comfort: ArrayLike, weights: ArrayLike | None = None
) -> FloatArray:
    """The paper's CrKR cost: squared distance of joint angles from a comfort posture.

    ``c = sum_d w_d (theta_d - theta_comfort_d)^2`` over the last axis (``w_d = 1`` by default).
    Add the task error if there is one; keep costs strictly positive (e.g. add a small floor).
    """
    d = np.asarray(theta, dtype=float) - np.asarray(theta_comfort, dtype=float)
    w = 1.0 if weights is None else np.asarray(weights, dtype=float)
    return np.sum(w * d * d, axis=-1)


@dataclass
class CrKR:
    """Cost-regularised kernel regression with a Gaussian kernel.

    Args:
        bandwidths: kernel bandwidth per input dimension (or one scalar for all).
        lam: the regularisation ``lambda`` (scales the costs, adds to the prior variance).
    """

    bandwidths: FloatArray | float
    lam: float = 1.0
    x: FloatArray = field(default=None, repr=False)  # type: ignore[assignment]
    y: FloatArray = field(default=None, repr=False)  # type: ignore[assignment]
    costs: FloatArray = field(default=None, repr=False)  # type: ignore[assignment]
    _chol: FloatArray | None = field(default=None, init=False, repr=False)
    _alpha: FloatArray | None = field(default=None, init=False, repr=False)

    def __post_init__(self) -> None:
        if not (self.lam > 0 and np.isfinite(self.lam)):
            raise ValueError("lam must be finite and positive")
        self.bandwidths = np.atleast_1d(np.asarray(self.bandwidths, dtype=float)).copy()
        if np.any(self.bandwidths <= 0):
            raise ValueError("bandwidths must be positive")
        if self.x is not None:
            self.fit(self.x, self.y, self.costs)

    @property
    def n_samples(self) -> int:
        return 0 if self.x is None else int(self.x.shape[0])

    def check_samples(self, x: ArrayLike, y: ArrayLike, costs: ArrayLike) -> tuple[FloatArray, ...]:
        x = np.asarray(x, dtype=float)
        x = x[:, None] if x.ndim == 1 else x
        y = np.asarray(y, dtype=float)
        y = y[:, None] if y.ndim == 1 else y
        c = np.broadcast_to(np.asarray(costs, dtype=float), (x.shape[0],)).copy()
        if x.ndim != 2 or y.ndim != 2 or y.shape[0] != x.shape[0]:
            raise ValueError("x must be (n, d) and y (n, m) with the same n")
        if self.bandwidths.size not in (1, x.shape[1]):
            raise ValueError(f"{self.bandwidths.size} bandwidths for {x.shape[1]}-D inputs")
        if np.any(~np.isfinite(c)) or np.any(c <= 0):
            raise ValueError("costs must be finite and strictly positive")
        if self.x is not None and (x.shape[1] != self.x.shape[1] or y.shape[1] != self.y.shape[1]):
            raise ValueError("new samples do not match the model's input/output dimensions")
        return x, y, c

    def _k(self, a: FloatArray, b: FloatArray) -> FloatArray:
        return gaussian_kernel(a, b, self.bandwidths)

    def fit(self, x: ArrayLike, y: ArrayLike, costs: ArrayLike) -> CrKR:
        """Fit on ``x (n, d)``, ``y (n, m)`` (or ``(n,)``), ``costs (n,)``; returns ``self``."""
        self.x = None
        x, y, c = self.check_samples(x, y, costs)
        gram = self._k(x, x) + self.lam * np.diag(c)
        try:
            self._chol = cholesky(gram, lower=True)
        except np.linalg.LinAlgError as exc:
            raise ValueError(f"K + lambda C is not positive definite: {exc}") from exc
        self.x, self.y, self.costs = x, y, c
        self._alpha = cho_solve((self._chol, True), y)
        return self

    def add(self, x: ArrayLike, y: ArrayLike, costs: ArrayLike) -> CrKR:
        """Append samples by a block Cholesky update of ``K + lambda C`` (no full refit)."""
        if self.x is None:
            return self.fit(x, y, costs)
        x, y, c = self.check_samples(x, y, costs)
        b = self._k(self.x, x)
        l21 = solve_triangular(self._chol, b, lower=True).T  # (k, n)
        schur = self._k(x, x) + self.lam * np.diag(c) - l21 @ l21.T
        try:
            l22 = cholesky(schur, lower=True)
        except np.linalg.LinAlgError as exc:
            raise ValueError(f"update makes K + lambda C singular: {exc}") from exc
        n, k = self._chol.shape[0], x.shape[0]
        chol = np.zeros((n + k, n + k))
        chol[:n, :n] = self._chol
        chol[n:, :n] = l21
        chol[n:, n:] = l22
        self._chol = chol
        self.x = np.concatenate([self.x, x])
        self.y = np.concatenate([self.y, y])
        self.costs = np.concatenate([self.costs, c])
        self._alpha = cho_solve((self._chol, True), self.y)
        return self

    def predict(self, xq: ArrayLike, return_var: bool = True
                ) -> FloatArray | tuple[FloatArray, FloatArray]:
        """Predictive mean ``(q, m)`` and, if asked, variance ``(q,)`` at query stimuli."""
        if self.x is None:
            raise RuntimeError("CrKR model is not fitted")
        xq = np.asarray(xq, dtype=float)
        xq = xq.reshape(-1, self.x.shape[1]) if xq.ndim < 2 else xq
        kq = self._k(xq, self.x)  # (q, n)
        mean = kq @ self._alpha
        if not return_var:
            return mean
        v = solve_triangular(self._chol, kq.T, lower=True)  # (n, q)
        var = 1.0 + self.lam - np.einsum("nq,nq->q", v, v)
        return mean, var

    # ------------------------------------------------------------------ persistence
    def save(self, path: str | os.PathLike) -> None:
        """Save samples, hyperparameters and the factorisation (``.npz`` + JSON).

        The Cholesky factor and ``(K + lambda C)^-1 Y`` are stored too, so a model grown by
        :meth:`add` predicts bit-identically after loading.
        """
        if self.x is None:
            raise RuntimeError("cannot save an unfitted CrKR model")
        save_artefact(
            path,
            CRKR_KIND,
            {"x": self.x, "y": self.y, "costs": self.costs, "bandwidths": self.bandwidths,
             "chol": self._chol, "alpha": self._alpha},
            {"lam": self.lam, "n_samples": self.n_samples},
        )

    @classmethod
    def load(cls, path: str | os.PathLike) -> CrKR:
        """Load a model saved by :meth:`save`; raises :class:`ArtefactError` on a bad file."""
        arrays, meta = load_artefact(path, CRKR_KIND)
        try:
            model = cls(arrays["bandwidths"], float(meta["lam"]))
            x, y, c = model.check_samples(arrays["x"], arrays["y"], arrays["costs"])
            chol, alpha = arrays["chol"], arrays["alpha"]
            n = x.shape[0]
            if chol.shape != (n, n) or alpha.shape != y.shape or n != meta.get("n_samples"):
                raise ValueError("array sizes do not match each other or the metadata")
        except (KeyError, TypeError, ValueError) as exc:
            raise ArtefactError(f"{path}: inconsistent CrKR contents ({exc})") from exc
        model.x, model.y, model.costs, model._chol, model._alpha = x, y, c, chol, alpha
        return model
