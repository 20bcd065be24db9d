"""How consistent a teacher dataset's hitting configurations are for neighbouring stimuli.

For every hit serve of ``tt-drake collect`` datasets, its nearest neighbour in the standardised
paper stimulus (p_hit, v_hit); prints the median differences of the spin at impact, of the hitting
joint velocities theta_dot_hit and of the hitting configuration theta_hit (joints 1-3) over those
pairs. A mapping from the 6-D stimulus (CrKR, the library) can only learn what these pairs agree
on (docs/reproducing.md, "The teacher's perception").

    python docs/examples/teacher_consistency.py DATASET [DATASET ...] [--serves N]
"""

import argparse

import numpy as np
from scipy.spatial import cKDTree

from tt_drake.diagrams.collect import load_dataset


def consistency(folder: str, serves: int | None) -> dict:
    data = load_dataset(folder)
    n = serves or len(data["hit"])
    hit = data["hit"][:n].astype(bool) & np.isfinite(data["qd_hit"][:n]).all(axis=1)
    stimulus = data["stimulus"][:n][hit, :6]
    z = (stimulus - stimulus.mean(axis=0)) / stimulus.std(axis=0)
    nearest = cKDTree(z).query(z, k=2)[1][:, 1]  # the first neighbour is the point itself
    median = {key: np.median(np.abs(data[key][:n][hit] - data[key][:n][hit][nearest]), axis=0)
              for key in ("q_hit", "qd_hit")}
    spin = data["spin_hit"][:n][hit]
    return {"manifest": data["manifest"], "pairs": int(hit.sum()),
            "return_rate": float(data["returned"][:n].mean()),
            "target_rate": float(data["on_target"][:n].mean()),
            "spin": float(np.median(np.linalg.norm(spin - spin[nearest], axis=1))),
            "q_hit": median["q_hit"][:3], "qd_hit": median["qd_hit"][:3]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("datasets", nargs="+")
    parser.add_argument("--serves", type=int, default=None, help="the first N serves of each")
    args = parser.parse_args()
    for folder in args.datasets:
        c = consistency(folder, args.serves)
        perception = c["manifest"].get("perception", "camera")
        print(f"{folder} ({perception}, {c['pairs']} hit serves): legal return "
              f"{c['return_rate']:.1%}, on target {c['target_rate']:.1%}; median over nearest "
              f"pairs: spin {c['spin']:.1f} rad/s, theta_dot_hit {np.round(c['qd_hit'], 3)} "
              f"rad/s, theta_hit {np.round(c['q_hit'], 3)} rad (joints 1-3)")


if __name__ == "__main__":
    main()
