"""CrKR picks the comfortable branch of a two-valued mapping where KRR averages.

    python docs/examples/crkr_two_branch.py [out.png]
"""

from __future__ import annotations

import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from tt_drake.crkr import CrKR, comfort_cost  # noqa: E402


def main(out: str = "docs/img/crkr_two_branch.png") -> None:
    rng = np.random.default_rng(2)
    s = rng.uniform(0, 1, 120)
    y = rng.choice([-1.0, 1.0], s.size) * (1 + 0.5 * s)  # e.g. elbow up / elbow down
    costs = comfort_cost(y[:, None], np.array([1.25])) + 1e-2  # comfort posture 1.25
    sq = np.linspace(0, 1, 200)[:, None]
    crkr = CrKR(0.15, 1.0).fit(s[:, None], y, costs)
    krr = CrKR(0.15, 1.0).fit(s[:, None], y, np.full(s.size, costs.mean()))
    mean, var = crkr.predict(sq)
    fig, ax = plt.subplots(figsize=(5.5, 3.4), dpi=90)
    sc = ax.scatter(s, y, c=np.log10(costs), s=10, cmap="viridis")
    fig.colorbar(sc, label="log10 cost")
    ax.plot(sq, krr.predict(sq, return_var=False), "C3", label="equal costs (= KRR)")
    ax.plot(sq, mean, "C0", label="CrKR mean ± σ (σ² includes λ)")
    ax.fill_between(sq[:, 0], mean[:, 0] - np.sqrt(var), mean[:, 0] + np.sqrt(var), color="C0",
                    alpha=0.2)
    ax.set(xlabel="stimulus s", ylabel="joint angle", title="cost-regularised kernel regression")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out)


if __name__ == "__main__":
    main(*sys.argv[1:2])
