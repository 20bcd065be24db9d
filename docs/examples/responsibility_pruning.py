"""Learn responsibilities and prune bad primitives (Eqs. 10-11, Algorithm 3).

Five primitives on a 1-D stimulus (x_i = 0..4, bandwidth 0.3); primitive 3 is a "bad
demonstration" (succeeds with probability 0.1), the others succeed with probability 0.9. The
outcome of a rollout is decided by the primitive that dominates the mixture.

    python docs/examples/responsibility_pruning.py [out.png]
"""

from __future__ import annotations

import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from tt_drake.dmp import HittingDMP  # noqa: E402
from tt_drake.momp import MotorPrimitiveLibrary  # noqa: E402
from tt_drake.responsibility import ResponsibilityParams, asymptotic_gamma  # noqa: E402


def main(out: str = "docs/img/responsibility_pruning.png") -> None:
    dmp = HittingDMP()
    x_i = np.arange(5.0)[:, None]
    success = np.array([0.9, 0.9, 0.9, 0.1, 0.9])
    lib = MotorPrimitiveLibrary(dmp, np.zeros((5, 1, dmp.n_basis)), np.ones((5, 1)), x_i, [0.3])
    ids = np.arange(5)  # original index of each remaining primitive
    rng = np.random.default_rng(0)
    history = np.full((400, 5), np.nan)
    for k in range(400):
        x = rng.uniform(-0.5, 4.5, 1)
        # the outcome is decided by the primitive that dominates the mixture
        main_prim = ids[np.argmax(lib.gating(x))]
        r = float(rng.random() < success[main_prim])
        removed = lib.update_responsibilities(x, r)
        ids = np.delete(ids, removed)
        history[k, ids] = lib.gamma
    p = lib.responsibility
    fig, ax = plt.subplots(1, 2, figsize=(8, 3.2), dpi=90)
    for i in range(5):
        ax[0].plot(history[:, i], label=f"primitive {i} (success {success[i]:.0%})")
    ax[0].axhline(p.threshold, color="k", lw=0.5, ls=":")
    ax[0].set(xlabel="rollout", ylabel="γ_i", title="responsibilities (pruned below 0.1)")
    ax[0].legend(fontsize=7)
    r = np.linspace(0, 1, 100)
    for params in (p, ResponsibilityParams(zeta=0.5), ResponsibilityParams(zeta=0.1)):
        ax[1].plot(r, asymptotic_gamma(r, params),
                   label=f"κ={params.kappa}, ζ={params.zeta}")
    ax[1].axhline(p.threshold, color="k", lw=0.5, ls=":")
    ax[1].set(xlabel="mean reward of a primitive", ylabel="γ after many rollouts",
              title="asymptote exp(-κ(1-r̄)/ζ)")
    ax[1].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out)
    print(f"kept primitives {ids.tolist()}, gamma {np.round(lib.gamma, 2).tolist()}")


if __name__ == "__main__":
    main(*sys.argv[1:2])
