"""Primitive adaptation by PoWER (Eq. 9) with an importance sampler.

Eq. 9 for primitive ``i`` of a library, over the rollouts ``j`` kept by the importance sampler::

    w_i <- w_i + sum_j eps_i^j nu_ij r^j / sum_j r^j,   nu_ij = k(x_j - x_i) / sum_l k(x_j - x_l)

Choices (pinned by tests in ``tests/tt_drake/test_power.py``):

* Exploration is Gaussian on the weights, ``eps ~ N(0, diag(sigma^2))`` (:func:`explore`); all
  randomness comes from a ``numpy.random.Generator`` passed in.
* The sampler stores the explored parameters ``theta^j = w + eps^j`` of each rollout and keeps the
  ``n_best`` rollouts with the highest reward. At an update ``eps^j`` is taken relative to the
  *current* weights, ``eps^j = theta^j - w`` (standard PoWER with importance sampling; after the
  first update the stored explorations would otherwise point from a stale mean). With a single
  primitive (``nu = 1``) the update is therefore the reward-weighted mean of the kept parameters.
* Rewards must be non-negative (PoWER's EM derivation needs an improper probability); a negative
  reward raises ``ValueError``. If every kept reward is zero the weights are returned unchanged.
* ``responsibility_weighted=False`` (default) is the paper's form with no ``nu`` in the
  denominator; ``True`` uses ``sum_j nu_ij r^j`` there, a per-primitive reward-weighted mean.
"""

from __future__ import annotations

import heapq
import itertools
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["explore", "PoWER"]

FloatArray = NDArray[np.float64]


def explore(weights: ArrayLike, sigma: ArrayLike, rng: np.random.Generator) -> FloatArray:
    """Explored parameters ``w + eps`` with ``eps ~ N(0, diag(sigma^2))`` (Eq. 9's exploration).

    ``sigma`` is broadcast to the shape of ``weights`` (scalar, per basis function, per DoF...).
    """
    w = np.asarray(weights, dtype=float)
    return w + np.broadcast_to(np.asarray(sigma, dtype=float), w.shape) * rng.standard_normal(
        w.shape
    )


@dataclass
class PoWER:
    """PoWER update (Eq. 9) over the best ``n_best`` rollouts seen so far.

    Parameters are arrays of any fixed shape. For a library, give them shape ``(P, ...)`` and
    pass the per-primitive weights ``nu`` (shape ``(P,)``) of each rollout to :meth:`add`; without
    ``nu`` the update treats the parameters as one policy (``nu = 1``).
    """

    n_best: int = 10
    responsibility_weighted: bool = False
    _heap: list = field(default_factory=list, init=False, repr=False)
    _counter: itertools.count = field(default_factory=itertools.count, init=False, repr=False)

    def __post_init__(self) -> None:
        if self.n_best < 1:
            raise ValueError("n_best must be >= 1")

    def __len__(self) -> int:
        return len(self._heap)

    @property
    def rewards(self) -> FloatArray:
        """Rewards of the kept rollouts, best first."""
        return np.array(sorted((item[0] for item in self._heap), reverse=True))

    def add(self, params: ArrayLike, reward: float, nu: ArrayLike | None = None) -> None:
        """Record a rollout with explored parameters ``theta = w + eps`` and reward ``r >= 0``."""
        r = float(reward)
        if not np.isfinite(r) or r < 0.0:
            raise ValueError(f"PoWER needs finite non-negative rewards, got {reward}")
        theta = np.array(params, dtype=float)
        if self._heap and theta.shape != self._heap[0][2].shape:
            raise ValueError("all rollouts must have parameters of the same shape")
        nu_arr = None if nu is None else np.array(nu, dtype=float)
        if nu_arr is not None and (
            theta.ndim == 0 or nu_arr.ndim != 1 or nu_arr.shape[0] != theta.shape[0]
        ):
            raise ValueError("nu must have shape (P,) matching the leading axis of params")
        if self._heap and (self._heap[0][3] is None) != (nu_arr is None):
            raise ValueError("give nu for every rollout or for none")
        # min-heap on (reward, arrival order): the worst (oldest on ties) is dropped first
        item = (r, next(self._counter), theta, nu_arr)
        if len(self._heap) < self.n_best:
            heapq.heappush(self._heap, item)
        elif r > self._heap[0][0]:
            heapq.heapreplace(self._heap, item)

    def update(self, weights: ArrayLike) -> FloatArray:
        """Eq. 9: new weights from the current ``weights`` and the kept rollouts."""
        w = np.asarray(weights, dtype=float)
        if not self._heap:
            return w.copy()
        # Summed in arrival order, whatever the heap's layout: a sampler restored from its
        # state() gives bit-identical updates.
        items = sorted(self._heap, key=lambda item: item[1])
        r = np.array([item[0] for item in items])
        theta = np.stack([item[2] for item in items])  # (J, *w.shape)
        if theta.shape[1:] != w.shape:
            raise ValueError(f"weights have shape {w.shape}, rollouts {theta.shape[1:]}")
        eps = theta - w
        if self._heap[0][3] is None:  # one policy: nu = 1
            total = r.sum()
            return w + np.tensordot(r, eps, axes=1) / total if total > 0 else w.copy()
        nu = np.stack([item[3] for item in items])  # (J, P)
        rn = nu * r[:, None]  # nu_ij r^j
        num = np.einsum("jp,jp...->p...", rn, eps)
        den = rn.sum(axis=0) if self.responsibility_weighted else np.full(nu.shape[1], r.sum())
        shape = (-1,) + (1,) * (w.ndim - 1)
        ok = (den > 0).reshape(shape)
        step = np.where(ok, num / np.where(den > 0, den, 1.0).reshape(shape), 0.0)
        return w + step

    def clear(self) -> None:
        """Forget every rollout (e.g. after changing the task)."""
        self._heap.clear()

    def state(self) -> dict[str, FloatArray]:
        """The kept rollouts as arrays (``reward``, ``order``, ``theta`` and, if given, ``nu``)
        in arrival order, and the arrival number of the ``next`` rollout: for saving a learning
        run; :meth:`restore` reads them back."""
        items = sorted(self._heap, key=lambda item: item[1])
        following = next(self._counter)  # the arrival number of the next rollout
        self._counter = itertools.count(following)
        out = {"reward": np.array([item[0] for item in items]),
               "order": np.array([item[1] for item in items], dtype=float),
               "next": np.array(float(following))}
        if items:
            out["theta"] = np.stack([item[2] for item in items])
            if items[0][3] is not None:
                out["nu"] = np.stack([item[3] for item in items])
        return out

    @classmethod
    def restore(cls, state: dict, n_best: int = 10, responsibility_weighted: bool = False
                ) -> PoWER:
        """A sampler holding the rollouts of :meth:`state` (the same later updates)."""
        learner = cls(n_best=n_best, responsibility_weighted=responsibility_weighted)
        order = np.asarray(state["order"], dtype=float)
        if order.size > n_best:
            raise ValueError(f"{order.size} kept rollouts, more than n_best = {n_best}")
        for k in range(order.size):
            nu = None if "nu" not in state else np.array(state["nu"][k], dtype=float)
            item = (float(state["reward"][k]), int(order[k]),
                    np.array(state["theta"][k], dtype=float), nu)
            heapq.heappush(learner._heap, item)
        following = int(state["next"]) if "next" in state else (
            int(order.max()) + 1 if order.size else 0)
        learner._counter = itertools.count(following)
        return learner
