"""The spin EKF against the numpy ball model as truth (docs/spin.md): NEES, spin error at the last
frame before the hitting plane, track losses, and the filter's time per frame.

    .venv/bin/python docs/examples/spin_filter_stats.py [--serves 200] [--dropout 0] [--outlier 0]

The serves are those of tests/tt_drake/test_estimation.py: ``default`` (no spin), ``spin`` (the
default launcher with spin up to 100 rad/s per axis) and ``real`` (serves.json states that bounce
on both halves before the hitting plane, in file order); camera seed 500 + i.
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from scipy.stats import chi2

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests" / "tt_drake"))

from test_estimation import bounce_frames, launches, truth  # noqa: E402

from tt_drake.camera_model import CameraConfig, CameraModel  # noqa: E402
from tt_drake.estimation import nees, run_filter  # noqa: E402


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--serves", type=int, default=200)
    p.add_argument("--dropout", type=float, default=0.0)
    p.add_argument("--outlier", type=float, default=0.0)
    args = p.parse_args()
    camera = CameraConfig(dropout=args.dropout, outlier=args.outlier)
    for dist in ("default", "spin", "real"):
        errs, values, lost, seconds, frames = [], [], 0, 0.0, 0
        for i, launch in enumerate(launches(dist)[:args.serves]):
            t, x = truth(launch)
            z = CameraModel(camera).measure_sequence(500 + i, x[:, :3])
            t0 = time.perf_counter()
            r = run_filter(t, z)
            seconds += time.perf_counter() - t0
            frames += len(t)
            first = int(np.argmax(r.tracking))
            lost += not r.tracking[first:].all()
            k = len(t) - 2
            errs.append(r.spins[k] - x[k, 6:9])
            ok = r.tracking.copy()
            ok[:first + 5] = False
            for b in bounce_frames(x):
                ok[b:b + 2] = False
            e = np.c_[r.states[ok] - x[ok, :6], r.spins[ok] - x[ok, 6:9]]
            values.append(nees(e, r.full_covariances[ok]))
        errs, a = np.abs(np.array(errs)), np.concatenate(values)
        tangential = np.linalg.norm(errs[:, :2], axis=1)
        print(f"{dist}: {len(errs)} serves, tracks lost {lost}; spin error before the hitting "
              f"plane: |omega_x, omega_y| median {np.median(tangential):.1f} rad/s, p95 "
              f"{np.percentile(tangential, 95):.1f}; |omega_z| median {np.median(errs[:, 2]):.1f},"
              f" norm median {np.median(np.linalg.norm(errs, axis=1)):.1f}; NEES (9 dof) mean "
              f"{a.mean():.2f}, median {np.median(a):.2f}, beyond chi2_9(0.999) "
              f"{100 * np.mean(a > chi2.ppf(0.999, 9)):.2f} %; {1e3 * seconds / frames:.2f} ms "
              f"per frame")


if __name__ == "__main__":
    main()
