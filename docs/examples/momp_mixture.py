"""Mix a small library of primitives with the gating network (Eq. 6, Algorithm 1).

    python docs/examples/momp_mixture.py [out.png]
"""

from __future__ import annotations

import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from tt_drake.dmp import HittingDMP  # noqa: E402
from tt_drake.imitation import quintic_demonstration  # noqa: E402
from tt_drake.momp import MotorPrimitiveLibrary  # noqa: E402


def main(out: str = "docs/img/momp_mixture.png") -> None:
    dmp = HittingDMP()
    # three demonstrations with different backswings, stimulus = a 1-D "hitting point" 0, 1, 2
    backswings = [-0.4, 0.0, 0.4]
    demos = [quintic_demonstration(0.5, 0.0, 1.0, 2.0, backswing=b) for b in backswings]
    lib = MotorPrimitiveLibrary.from_demonstrations(dmp, demos, [[0.0], [1.0], [2.0]], [0.4])
    fig, ax = plt.subplots(1, 2, figsize=(8, 3.2), dpi=90)
    for i, d in enumerate(demos):
        ax[0].plot(d.t, d.q[:, 0], color="0.6", lw=3, alpha=0.5,
                   label="demonstrations" if i == 0 else None)
    for x, c in zip([0.0, 0.5, 1.5, 2.0], ["C0", "C1", "C2", "C3"], strict=True):
        tr = lib.plan([x], 0.0, 1.0, 2.0, 0.5)
        ax[0].plot(tr.t, tr.q[:, 0], c, label=f"π(x={x})")
    ax[0].set(xlabel="t [s]", ylabel="q [rad]", title="mixture at four stimuli")
    ax[0].legend(fontsize=7)
    xs = np.linspace(-0.5, 2.5, 200)
    nu = np.array([lib.gating([x]) for x in xs])
    for i in range(3):
        ax[1].plot(xs, nu[:, i], label=f"ν_{i} (x_{i}={i})")
    lib.gamma[1] = 0.2  # a less trusted middle primitive
    nu = np.array([lib.gating([x]) for x in xs])
    ax[1].plot(xs, nu[:, 1], "C1--", label="ν_1 with γ_1 = 0.2")
    ax[1].set(xlabel="stimulus x", ylabel="gating weight", title="gating, h = 0.4")
    ax[1].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out)


if __name__ == "__main__":
    main(*sys.argv[1:2])
