"""Learn a hitting DMP from one demonstration, reproduce it and generalise it (Eqs. 1-8).

    python docs/examples/dmp_imitation.py [out.png]
"""

from __future__ import annotations

import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from tt_drake.dmp import HittingDMP  # noqa: E402
from tt_drake.imitation import imitate, quintic_demonstration  # noqa: E402


def main(out: str = "docs/img/dmp_imitation.png") -> None:
    dmp = HittingDMP()  # 30 basis functions, alpha_z = 3, alpha_y = 35, beta_y = alpha_y / 4
    # one joint: from rest at 0 rad to the hitting posture 1 rad with 2 rad/s after a backswing
    demo = quintic_demonstration(0.5, 0.0, 1.0, 2.0, backswing=-0.25)
    learned = imitate(dmp, demo)
    reproduction = learned.rollout(dmp, n_steps=demo.t.size - 1)
    rmse = np.sqrt(np.mean((reproduction.q - demo.q) ** 2))
    # new start, hitting posture, hitting velocity and duration
    new = dmp.rollout(learned.weights, 0.2, 1.4, 3.0, 0.6, amplitude=learned.amplitude)
    print(f"reproduction RMSE {rmse:.1e} rad; generalised end error "
          f"{abs(new.q[-1, 0] - 1.4):.1e} rad, {abs(new.qd[-1, 0] - 3.0):.1e} rad/s")

    fig, ax = plt.subplots(1, 2, figsize=(8, 3.2), dpi=90)
    ax[0].plot(demo.t, demo.q[:, 0], "k", lw=3, alpha=0.35, label="demonstration")
    ax[0].plot(reproduction.t, reproduction.q[:, 0], "C0--", label=f"reproduction ({rmse:.0e} rad)")
    ax[0].plot(new.t, new.q[:, 0], "C3", label="new g_f=1.4, ġ=3, T=0.6, y0=0.2")
    ax[0].plot([0.5, 0.6], [1.0, 1.4], "ko", ms=4)
    ax[0].set(xlabel="t [s]", ylabel="q [rad]", title="position")
    ax[1].plot(demo.t, demo.qd[:, 0], "k", lw=3, alpha=0.35)
    ax[1].plot(reproduction.t, reproduction.qd[:, 0], "C0--")
    ax[1].plot(new.t, new.qd[:, 0], "C3")
    ax[1].plot([0.5, 0.6], [2.0, 3.0], "ko", ms=4)
    ax[1].set(xlabel="t [s]", ylabel="q̇ [rad/s]", title="velocity (dots: g_f, ġ at T)")
    ax[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out)


if __name__ == "__main__":
    main(*sys.argv[1:2])
