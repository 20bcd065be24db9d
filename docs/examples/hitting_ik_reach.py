"""Reachability of the hitting region by the arm's IK (tt_drake.systems.hitting_ik).

Grid: 11 x 8 hitting points on the virtual hitting plane y = PLANES.hitting_y covering
HITTING_REGION. Normals at each point p: the *nominal* n0 = (target - p)/|target - p| toward the
centre of the opponent's half (TARGET), and n0 turned by +-15 deg in pitch (about the horizontal
axis n0 x z, positive = racket face turned up) and in yaw (about world z, positive = face turned
toward +x, the forehand side). Each request is solved from the comfort posture (no warm start), so
every cell is independent.

    .venv/bin/python docs/examples/hitting_ik_reach.py [--out docs/img/hitting_ik_reach.png]

prints a Markdown summary (the tables in docs/hitting_ik.md) and writes the figure.
"""

from __future__ import annotations

import argparse

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Rectangle  # noqa: E402

from tt_drake.constants import HITTING_REGION, PLANES, TARGET  # noqa: E402
from tt_drake.systems.hitting_ik import HittingIK  # noqa: E402

NX, NZ = 11, 8
TILT = np.radians(15.0)
NORMALS = ("nominal", "pitch +15", "pitch -15", "yaw +15", "yaw -15")


def _rotate(v: np.ndarray, axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues: v turned by ``angle`` about the unit ``axis`` (right-hand rule)."""
    return (v * np.cos(angle) + np.cross(axis, v) * np.sin(angle)
            + axis * (axis @ v) * (1.0 - np.cos(angle)))


def normals_at(p: np.ndarray) -> dict[str, np.ndarray]:
    """The five representative racket normals at hitting point ``p`` (module docstring)."""
    n0 = np.array([TARGET.x, TARGET.y, TARGET.z]) - p
    n0 /= np.linalg.norm(n0)
    up = np.array([0.0, 0.0, 1.0])
    # Right-hand rule about a = n0 x z turns n0 toward +z for a positive angle.
    pitch_axis = np.cross(n0, up)
    pitch_axis /= np.linalg.norm(pitch_axis)
    # About world z, a negative angle turns +y toward +x (the forehand side).
    return {"nominal": n0,
            "pitch +15": _rotate(n0, pitch_axis, TILT), "pitch -15": _rotate(n0, pitch_axis, -TILT),
            "yaw +15": _rotate(n0, up, -TILT), "yaw -15": _rotate(n0, up, TILT)}


def grid() -> tuple[np.ndarray, np.ndarray]:
    r = HITTING_REGION
    return np.linspace(r.x_min, r.x_max, NX), np.linspace(r.z_min, r.z_max, NZ)


def sweep(ik: HittingIK | None = None) -> dict[str, dict[str, np.ndarray]]:
    """For each normal: arrays (NZ, NX) of success, position/angle error, limit margin, cost and
    solve time, plus the joint closest to its limit (1-based)."""
    ik = ik or HittingIK()
    xs, zs = grid()
    keys = ("success", "position_error", "angle_error", "limit_margin", "cost", "solve_ms",
            "closest_joint", "attempts")
    out = {name: {k: np.zeros((NZ, NX)) for k in keys} for name in NORMALS}
    for iz, z in enumerate(zs):
        for ix, x in enumerate(xs):
            p = np.array([x, PLANES.hitting_y, z])
            for name, n in normals_at(p).items():
                s = ik.solve(p, n)
                gap = np.minimum(s.q - ik.lower + ik.margin, ik.upper + ik.margin - s.q)
                row = out[name]
                row["success"][iz, ix] = s.success
                row["position_error"][iz, ix] = s.position_error
                row["angle_error"][iz, ix] = s.angle_error
                row["limit_margin"][iz, ix] = s.limit_margin
                row["cost"][iz, ix] = s.cost
                row["solve_ms"][iz, ix] = s.solve_ms
                row["closest_joint"][iz, ix] = 1 + int(np.argmin(gap))
                row["attempts"][iz, ix] = s.attempts
    return out


def summary(out) -> str:
    xs, zs = grid()
    lines = ["| normal | reached | max position error (mm) | max angle error (deg) | "
             "min limit margin (rad) | cells < 0.3 rad from a limit (joint: count) | "
             "median / max ms | unreachable (x, z) |",
             "|---|---|---|---|---|---|---|---|"]
    for name in NORMALS:
        r = out[name]
        ok = r["success"].astype(bool)
        fails = [f"({xs[ix]:.1f}, {zs[iz]:.1f})" for iz, ix in zip(*np.nonzero(~ok), strict=True)]
        tight = ok & (r["limit_margin"] < 0.3)
        joints, counts = np.unique(r["closest_joint"][tight].astype(int), return_counts=True)
        near = ", ".join(f"J{j}: {c}" for j, c in zip(joints, counts, strict=True)) or "-"
        lines.append(
            f"| {name} | {ok.sum()}/{ok.size} | {1e3 * r['position_error'][ok].max():.3f} | "
            f"{np.degrees(r['angle_error'][ok].max()):.3f} | {r['limit_margin'][ok].min():.2f} | "
            f"{near} | "
            f"{np.median(r['solve_ms']):.1f} / {r['solve_ms'].max():.1f} | "
            f"{', '.join(fails) or '-'} |")
    return "\n".join(lines)


def plot(out, path: str) -> None:
    xs, zs = grid()
    r = HITTING_REGION
    fig, axes = plt.subplots(1, len(NORMALS), figsize=(14, 3.3), sharey=True, layout="constrained")
    dx, dz = xs[1] - xs[0], zs[1] - zs[0]
    extent = (xs[0] - dx / 2, xs[-1] + dx / 2, zs[0] - dz / 2, zs[-1] + dz / 2)
    image = None
    for ax, name in zip(axes, NORMALS, strict=True):
        res = out[name]
        margin = np.where(res["success"] > 0, res["limit_margin"], np.nan)
        image = ax.imshow(margin, origin="lower", extent=extent, cmap="viridis", vmin=0.0,
                          vmax=1.2, aspect="equal")
        iz, ix = np.nonzero(res["success"] == 0)
        ax.scatter(xs[ix], zs[iz], marker="x", c="red", s=60, label="unreachable")
        for jz in range(NZ):
            for jx in range(NX):
                if res["success"][jz, jx] and res["limit_margin"][jz, jx] < 0.3:
                    ax.text(xs[jx], zs[jz], f"J{int(res['closest_joint'][jz, jx])}",
                            ha="center", va="center", fontsize=7, color="w")
        ax.add_patch(Rectangle((r.x_min, r.z_min), r.x_max - r.x_min, r.z_max - r.z_min,
                               fill=False, ec="k", lw=1))
        ok = int(res["success"].sum())
        ax.set(title=f"{name}: {ok}/{NX * NZ}", xlabel="x (m)")
    axes[0].set_ylabel("z (m)")
    axes[0].legend(loc="lower left", fontsize=7)
    fig.colorbar(image, ax=axes, shrink=0.9, pad=0.01, label="min distance to a joint limit (rad)")
    fig.suptitle(f"IK on the hitting plane y = {PLANES.hitting_y:.2f} m: colour = joint-limit "
                 "margin; Jk = the joint within 0.3 rad of its limit; x = no solution", fontsize=10)
    fig.savefig(path, dpi=72)
    plt.close(fig)


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="docs/img/hitting_ik_reach.png")
    args = parser.parse_args(argv)
    out = sweep()
    print(summary(out))
    plot(out, args.out)
    print(f"wrote {args.out}")
    return out


if __name__ == "__main__":
    main()
