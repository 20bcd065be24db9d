"""Improve a perturbed hitting primitive with PoWER (Eq. 9) on a toy task.

Task: reach q = 1 rad with q̇ = 2 rad/s at the hitting time T = 0.5 s; reward
exp(-½((Δq/0.03)² + (Δq̇/0.3)²)).

    python docs/examples/power_toy.py [out.png]
"""

from __future__ import annotations

import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from tt_drake.dmp import HittingDMP  # noqa: E402
from tt_drake.imitation import imitate, quintic_demonstration  # noqa: E402
from tt_drake.power import PoWER, explore  # noqa: E402


def main(out: str = "docs/img/power_toy.png") -> None:
    dmp = HittingDMP()
    demo = quintic_demonstration(0.5, 0.0, 1.0, 2.0)
    res = imitate(dmp, demo)

    def run(w):
        return dmp.rollout(w, res.y0, res.g_f, res.g_dot, 0.5, amplitude=res.amplitude)

    def reward(w):
        tr = run(w)
        e, v = (tr.q[-1, 0] - 1.0) / 0.03, (tr.qd[-1, 0] - 2.0) / 0.3
        return float(np.exp(-0.5 * (e * e + v * v)))

    fig, ax = plt.subplots(1, 2, figsize=(8, 3.2), dpi=90)
    for seed in range(5):
        rng = np.random.default_rng(seed)
        w = res.weights + 1000.0 * rng.standard_normal(res.weights.shape)
        start = w.copy()
        learner, curve = PoWER(n_best=10), [reward(w)]
        for _ in range(200):
            theta = explore(w, 300.0, rng)
            learner.add(theta, reward(theta))
            w = learner.update(w)
            curve.append(reward(w))
        ax[1].plot(curve, lw=1, label=f"seed {seed}")
        if seed == 0:
            t = run(start).t
            ax[0].plot(demo.t, demo.q[:, 0], "k", lw=3, alpha=0.35, label="demonstration")
            ax[0].plot(t, run(start).q[:, 0], "C3", label="perturbed")
            ax[0].plot(t, run(w).q[:, 0], "C0", label="after 200 PoWER rollouts")
        print(f"seed {seed}: reward {curve[0]:.3f} -> {curve[-1]:.3f}, "
              f">= 0.9 after {int(np.argmax(np.array(curve) >= 0.9))} rollouts")
    ax[0].set(xlabel="t [s]", ylabel="q [rad]", title="primitive (seed 0)")
    ax[0].legend(fontsize=7)
    ax[1].axhline(0.9, color="k", lw=0.5, ls=":")
    ax[1].set(xlabel="rollout", ylabel="reward of the mean policy", title="PoWER, best 10 kept")
    ax[1].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out)


if __name__ == "__main__":
    main(*sys.argv[1:2])
