"""Plot where `default` (and `real`) serves bounce and cross the virtual hitting plane.

    python docs/examples/plot_serve_region.py [--serves 1000] [--out docs/img/serve_region.png]
"""

import argparse

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Rectangle  # noqa: E402

from tt_drake.constants import HITTING_REGION, PLANES, TABLE  # noqa: E402
from tt_drake.serves import ServeSampler  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--serves", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default="docs/img/serve_region.png")
    args = parser.parse_args()
    default = [ServeSampler("default").sample(args.seed + i) for i in range(args.serves)]
    real = [c for _, _, c in ServeSampler("real").real_pool()
            if abs(c.position[1] - PLANES.hitting_y) < 1e-9]  # those reaching the plane
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.8))
    r = HITTING_REGION
    for crossings, colour, label in (
        (np.array([s.crossing.position for s in default]), "tab:blue", "default"),
        (np.array([c.position for c in real]), "tab:orange", "real (reaching the plane)"),
    ):
        ax1.scatter(crossings[:, 0], crossings[:, 2], s=4, c=colour, label=label, alpha=0.6)
    ax1.add_patch(Rectangle((r.x_min, r.z_min), r.x_max - r.x_min, r.z_max - r.z_min,
                            fill=False, lw=2, ec="k", label=f"hitting region {r.area:.2f} m²"))
    ax1.axhline(TABLE.surface_z, c="grey", ls="--", lw=1, label="table height")
    ax1.set(xlabel="x (m, forehand +)", ylabel="z (m)", aspect="equal",
            title=f"crossing of the virtual hitting plane y = {PLANES.hitting_y:.2f} m")
    ax1.legend(loc="upper left", fontsize=8)
    bounces = np.array([s.crossing.bounces[-1].position for s in default])
    ax2.add_patch(Rectangle((-TABLE.width / 2, -TABLE.length / 2), TABLE.width, TABLE.length,
                            fc="#0d3b73", ec="w"))
    ax2.axhline(0.0, c="w", lw=2)
    ax2.scatter(bounces[:, 0], bounces[:, 1], s=4, c="yellow", label="default: bounce")
    ax2.axhline(PLANES.hitting_y, c="k", ls=":", label="virtual hitting plane")
    ax2.set(xlabel="x (m)", ylabel="y (m, robot at -y)", aspect="equal", xlim=(-1.2, 1.2),
            ylim=(-2.1, 1.6), title="bounce points of default serves")
    ax2.legend(loc="upper right", fontsize=8)
    fig.suptitle(f"{args.serves} default serves (seeds {args.seed}..{args.seed + args.serves - 1})"
                 f" and the {len(real)} real serves that reach the plane")
    fig.tight_layout()
    fig.savefig(args.out, dpi=80)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
