"""Responsibility learning and pruning (Eqs. 10-11 in the form of Algorithm 3).

After each rollout with stimulus ``x`` and reward ``r in [0, 1]``, with the gating weights
``nu_i(x) = gamma_i k(x - x_i) / sum_j gamma_j k(x - x_j)`` of Eq. 6::

    s_i <- s_i + nu_i(x) r,    n_i <- n_i + nu_i(x),
    gamma_i = exp(kappa (s_i - n_i) / (zeta n_i + 1))

and primitive ``i`` is deleted when ``gamma_i`` falls below a threshold. Eq. 11 as printed
normalises with ``k(x_i - x_j)``; Algorithm 3's ``k(x - x_j)`` is used (the printed form looks
like a slip).

Effect of the hyperparameters: ``s_i - n_i = -sum nu_i (1 - r)`` is the failure mass blamed on
primitive ``i``. For small ``n_i`` the log-responsibility falls by ``kappa`` per unit of blamed
failure (``kappa`` is the learning rate). For large ``n_i`` it tends to
``-kappa (1 - rbar_i) / zeta`` where ``rbar_i`` is the primitive's responsibility-weighted mean
reward, so ``zeta`` sets how forgiving the asymptote is: a primitive is eventually pruned iff
``rbar_i < 1 + zeta ln(threshold) / kappa``. The defaults ``kappa = 1``, ``zeta = 0.25``,
``threshold = 0.1`` prune primitives whose mean reward stays below ~0.42 and do so after about six
rollouts that fail completely under its sole responsibility; a primitive with only successes keeps
``gamma = 1`` (``s_i = n_i``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["ResponsibilityParams", "responsibility_update", "asymptotic_gamma"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class ResponsibilityParams:
    """``kappa`` (learning rate), ``zeta`` (exploration/exploitation trade-off) of Eq. 10 and the
    pruning ``threshold`` of Algorithm 3."""

    kappa: float = 1.0
    zeta: float = 0.25
    threshold: float = 0.1

    def __post_init__(self) -> None:
        if self.kappa <= 0 or self.zeta < 0 or not 0.0 <= self.threshold < 1.0:
            raise ValueError("need kappa > 0, zeta >= 0 and 0 <= threshold < 1")

    @property
    def prune_below_reward(self) -> float:
        """Mean reward below which a primitive is eventually pruned (the asymptote of Eq. 10)."""
        if self.threshold == 0.0 or self.zeta == 0.0:
            return 1.0 if self.zeta == 0.0 else -math.inf
        return 1.0 + self.zeta * math.log(self.threshold) / self.kappa

    def to_dict(self) -> dict:
        return {"kappa": self.kappa, "zeta": self.zeta, "threshold": self.threshold}


def responsibility_update(
    s: ArrayLike,
    n: ArrayLike,
    nu: ArrayLike,
    reward: float,
    params: ResponsibilityParams | None = None,
) -> tuple[FloatArray, FloatArray, FloatArray, NDArray[np.bool_]]:
    """One step of Algorithm 3 (Eqs. 10-11): returns ``(s, n, gamma, prune)``.

    ``nu`` are the normalised gating weights of the rollout (Eq. 6, computed with the current
    ``gamma``), ``reward`` in ``[0, 1]``. ``prune`` marks primitives with
    ``gamma < params.threshold``. Inputs are not modified.
    """
    params = ResponsibilityParams() if params is None else params
    r = float(reward)
    if not 0.0 <= r <= 1.0:
        raise ValueError(f"reward must lie in [0, 1], got {r}")
    nu = np.asarray(nu, dtype=float)
    s_new = np.asarray(s, dtype=float) + nu * r
    n_new = np.asarray(n, dtype=float) + nu
    gamma = np.exp(params.kappa * (s_new - n_new) / (params.zeta * n_new + 1.0))
    return s_new, n_new, gamma, gamma < params.threshold


def asymptotic_gamma(mean_reward: ArrayLike, params: ResponsibilityParams) -> FloatArray:
    """Limit of Eq. 10 for ``n_i -> inf`` at a given mean reward: ``exp(-kappa (1 - r) / zeta)``."""
    r = np.asarray(mean_reward, dtype=float)
    if params.zeta == 0.0:
        return np.where(r < 1.0, 0.0, 1.0)
    return np.exp(-params.kappa * (1.0 - r) / params.zeta)
