"""Algorithm 3 (primitive and responsibility adaptation) over a library of hitting primitives.

After every rollout with stimulus ``x``, reward ``r in [0, 1]`` and explored weights
``w_i + eps_i`` (``eps_i ~ N(0, Sigma)`` for every primitive, Algorithm 3's "Set eps_i^N"), for
each primitive ``i`` that contributed to the stroke:

* responsibilities (Eqs. 10-11 in Algorithm 3's form, :func:`tt_drake.responsibility.
  responsibility_update`): ``s_i += nu_i r``, ``n_i += nu_i`` with the stroke's gating weights
  ``nu_i = gamma_i k(x - x_i) / sum_j gamma_j k(x - x_j)`` (Eq. 6), ``gamma_i = exp(kappa (s_i -
  n_i) / (zeta n_i + 1))``; a primitive whose ``gamma_i`` falls below the threshold is pruned
  (``gamma_i = 0`` for good);
* weights (PoWER, Eq. 9): the rollout joins primitive ``i``'s importance sampler with its explored
  weights and Eq. 9's share ``k(x - x_i) / sum_l k(x - x_l)`` (the kernel alone, over the
  primitives not pruned), and ``w_i <- w_i + sum_j eps_i^j share_ij r^j / sum_j r^j`` over the
  ``n_best`` best rollouts that primitive took part in (:class:`tt_drake.power.PoWER`).

Choices (the paper gives none of them; pinned by ``tests/tt_drake/test_mixture_learning.py``):

* Batches. Rollouts run in batches with fixed mean weights and responsibilities (so they can run in
  parallel). Responsibilities are updated after every rollout, in rollout order, as Algorithm 3
  does; Eq. 9 is applied once per batch to every primitive whose sampler gained a rollout (applying
  it after each rollout of a batch would move the same mean several times towards the same kept
  rollouts). With batches of one rollout this is Algorithm 3 exactly.
* Exploration ``Sigma = diag(sigma_d^2)``: one standard deviation per joint, ``sigma_d =
  relative_sigma * std_d`` where ``std_d`` is the spread of joint ``d``'s weights over the library
  (the weights' scale differs between joints). Pruned primitives are not explored.
* A rollout joins primitive ``i``'s sampler only when Eq. 9's share is at least ``min_share``:
  a rollout far from ``x_i`` would otherwise take one of its ``n_best`` places with a step of
  almost zero.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tt_drake.momp import gating_weights
from tt_drake.power import PoWER
from tt_drake.responsibility import ResponsibilityParams, responsibility_update

__all__ = ["PowerParams", "MixtureLearner", "exploration_sigma", "explored_weights"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class PowerParams:
    """PoWER's meta-parameters in Algorithm 3: the exploration ``relative_sigma`` (a fraction of
    each joint's weight spread), the importance sampler's ``n_best`` and the smallest Eq. 9 share
    ``min_share`` with which a rollout counts for a primitive."""

    relative_sigma: float = 0.1
    n_best: int = 10
    min_share: float = 0.01

    def __post_init__(self) -> None:
        if self.relative_sigma < 0 or self.n_best < 1 or not 0.0 <= self.min_share < 1.0:
            raise ValueError("need relative_sigma >= 0, n_best >= 1 and 0 <= min_share < 1")

    def to_dict(self) -> dict:
        return {"relative_sigma": self.relative_sigma, "n_best": self.n_best,
                "min_share": self.min_share}


def exploration_sigma(weights: ArrayLike, relative_sigma: float) -> FloatArray:
    """``sigma`` of shape ``(D, 1)``: ``relative_sigma`` times the spread of each joint's weights
    over the library's primitives and basis functions (``weights`` is ``(P, D, B)``)."""
    w = np.asarray(weights, dtype=float)
    spread = w.std(axis=(0, 2)) if w.shape[0] * w.shape[2] > 1 else np.abs(w).mean(axis=(0, 2))
    return (relative_sigma * np.where(spread > 0, spread, 1.0))[:, None]


def explored_weights(weights: ArrayLike, sigma: ArrayLike, pruned: ArrayLike,
                     rng: np.random.Generator) -> FloatArray:
    """``w_i + eps_i`` with ``eps_i ~ N(0, diag(sigma^2))`` for every primitive ``i`` not
    ``pruned`` (Algorithm 3's exploration); ``weights`` is ``(P, D, B)``, ``sigma`` broadcasts to
    ``(D, B)``."""
    w = np.asarray(weights, dtype=float)
    eps = np.broadcast_to(np.asarray(sigma, dtype=float), w.shape[1:]) * rng.standard_normal(
        w.shape)
    eps[np.asarray(pruned, dtype=bool)] = 0.0
    return w + eps


class MixtureLearner:
    """The state of Algorithm 3: weights ``(P, D, B)``, ``s``, ``n``, ``gamma`` and one PoWER
    importance sampler per primitive. ``stimuli (P, S)`` and ``bandwidths (S,)`` are the gating
    network's (Eq. 6)."""

    def __init__(self, weights: ArrayLike, stimuli: ArrayLike, bandwidths: ArrayLike,
                 responsibility: ResponsibilityParams | None = None,
                 power: PowerParams | None = None, gamma: ArrayLike | None = None,
                 s: ArrayLike | None = None, n: ArrayLike | None = None,
                 sigma: ArrayLike | None = None):
        self.weights = np.array(weights, dtype=float)
        if self.weights.ndim != 3:
            raise ValueError(f"weights must have shape (P, D, B), got {self.weights.shape}")
        p = self.weights.shape[0]
        self.stimuli = np.array(stimuli, dtype=float)
        self.bandwidths = np.array(bandwidths, dtype=float)
        if self.stimuli.shape[0] != p:
            raise ValueError(f"{self.stimuli.shape[0]} stimuli for {p} primitives")
        self.responsibility = responsibility or ResponsibilityParams()
        self.power = power or PowerParams()
        self.gamma = np.ones(p) if gamma is None else np.array(gamma, dtype=float)
        self.s = np.zeros(p) if s is None else np.array(s, dtype=float)
        self.n = np.zeros(p) if n is None else np.array(n, dtype=float)
        for name in ("gamma", "s", "n"):
            if getattr(self, name).shape != (p,):
                raise ValueError(f"{name} must have shape ({p},)")
        self.sigma = (exploration_sigma(self.weights, self.power.relative_sigma)
                      if sigma is None else np.array(sigma, dtype=float))
        self.samplers: dict[int, PoWER] = {}
        self._touched: set[int] = set()

    @property
    def n_primitives(self) -> int:
        return int(self.weights.shape[0])

    @property
    def pruned(self) -> NDArray[np.bool_]:
        return self.gamma == 0.0

    # ------------------------------------------------------------------ one rollout
    def explore(self, rng: np.random.Generator) -> FloatArray:
        """Explored weights ``w_i + eps_i`` for every primitive (``eps_i ~ N(0, Sigma)``; none
        for a pruned one), shape ``(P, D, B)``."""
        return explored_weights(self.weights, self.sigma, self.pruned, rng)

    def power_shares(self, x: ArrayLike) -> FloatArray:
        """Eq. 9's share of every primitive in a rollout with stimulus ``x``: ``k(x - x_i) /
        sum_l k(x - x_l)`` over the primitives not pruned (0 for a pruned one)."""
        return gating_weights(x, self.stimuli, self.bandwidths, (~self.pruned).astype(float))

    def credit(self, x: ArrayLike, primitives: ArrayLike, mixture: ArrayLike, reward: float,
               explored: ArrayLike | None = None) -> NDArray[np.intp]:
        """Algorithm 3 after one rollout: ``primitives`` contributed to the stroke with gating
        weights ``mixture`` (Eq. 6, the responsibilities' ``nu``), the stroke earned ``reward``,
        and ran with ``explored`` weights (``(P, D, B)``, or None: responsibilities only).
        Returns the primitives pruned by this rollout."""
        idx = np.asarray(primitives, dtype=np.intp)
        nu = np.zeros(self.n_primitives)
        nu[idx] = np.asarray(mixture, dtype=float)
        self.s, self.n, g, _ = responsibility_update(self.s, self.n, nu, reward,
                                                     self.responsibility)
        alive = self.gamma > 0
        if explored is not None and idx.size:
            theta = np.asarray(explored, dtype=float)
            if theta.shape != self.weights.shape:
                raise ValueError(f"explored weights must have shape {self.weights.shape}")
            share = self.power_shares(x)
            for i in idx[alive[idx]]:
                if share[i] < self.power.min_share:
                    continue
                sampler = self.samplers.setdefault(int(i), PoWER(n_best=self.power.n_best))
                sampler.add(theta[i][None], reward, [share[i]])
                self._touched.add(int(i))
        gamma = np.where(alive, g, 0.0)
        newly = np.flatnonzero(alive & (gamma < self.responsibility.threshold))
        gamma[newly] = 0.0
        self.gamma = gamma
        return newly

    def update_weights(self) -> NDArray[np.intp]:
        """Eq. 9 for every primitive whose sampler gained a rollout since the last call (and is
        not pruned); returns their indices."""
        done = []
        for i in sorted(self._touched):
            if self.gamma[i] > 0:
                self.weights[i] = self.samplers[i].update(self.weights[i][None])[0]
                done.append(i)
        self._touched.clear()
        return np.array(done, dtype=np.intp)

    # ------------------------------------------------------------------ persistence
    def state(self) -> dict[str, FloatArray]:
        """Every array of the learning state (see :meth:`from_state`); no objects."""
        p, k = self.n_primitives, self.power.n_best
        reward = np.full((p, k), -1.0)  # -1: an empty place (rewards are >= 0)
        order = np.full((p, k), -1.0)
        share = np.zeros((p, k))
        following = np.zeros(p)
        theta = np.zeros((p, k) + self.weights.shape[1:])
        for i, sampler in self.samplers.items():
            st = sampler.state()
            m = st["reward"].size
            reward[i, :m], order[i, :m] = st["reward"], st["order"]
            following[i] = st["next"]
            if m:
                theta[i, :m] = st["theta"][:, 0]
                share[i, :m] = st["nu"][:, 0]
        return {"weights": self.weights.copy(), "gamma": self.gamma.copy(), "s": self.s.copy(),
                "n": self.n.copy(), "sigma": self.sigma.copy(), "kept_reward": reward,
                "kept_order": order, "kept_next": following, "kept_share": share,
                "kept_theta": theta,
                "touched": np.array(sorted(self._touched), dtype=float)}

    @classmethod
    def from_state(cls, state: dict, stimuli: ArrayLike, bandwidths: ArrayLike,
                   responsibility: ResponsibilityParams | None = None,
                   power: PowerParams | None = None) -> MixtureLearner:
        """The learner :meth:`state` saved (further rollouts give the same updates)."""
        learner = cls(state["weights"], stimuli, bandwidths, responsibility, power,
                      gamma=state["gamma"], s=state["s"], n=state["n"], sigma=state["sigma"])
        reward = np.asarray(state["kept_reward"], dtype=float)
        for i in range(reward.shape[0]):
            m = int(np.count_nonzero(reward[i] >= 0.0))
            if m or state["kept_next"][i] > 0:
                learner.samplers[i] = PoWER.restore(
                    {"reward": reward[i, :m], "order": state["kept_order"][i, :m],
                     "theta": np.asarray(state["kept_theta"][i, :m])[:, None],
                     "nu": np.asarray(state["kept_share"][i, :m])[:, None],
                     "next": state["kept_next"][i]},
                    n_best=learner.power.n_best)
        learner._touched = {int(i) for i in np.asarray(state["touched"])}
        return learner
