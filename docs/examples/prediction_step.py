"""The learned player's physical predictions at several RK4 steps against a fine one.

    OPENBLAS_NUM_THREADS=1 python docs/examples/prediction_step.py [--steps 0.005 0.01]

The states of ``lever_predictions.py`` (60 default and 60 spin serves, 100 rad/s per axis, at
launch and every 0.05 s of their model flight): each is predicted to the hitting plane
(``PhysicalPredictor`` with ``CompliantBounceBallModel``) at a 0.25 ms reference step and at each
``--steps``; prints the CPU time per prediction, whether the same states miss the plane, and the
largest difference to the reference in position (m), velocity (m/s) and time (s). Used for
docs/performance.md ("The players' Python": the step of ``diagrams/episodes.py``'s predictions).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from tt_drake.ball_model import CompliantBounceBallModel
from tt_drake.hitting_point import PhysicalPredictor

sys.path.insert(0, str(Path(__file__).resolve().parent))
from lever_predictions import states  # noqa: E402


def predictions(dt: float, xs) -> tuple[float, np.ndarray]:
    predictor = PhysicalPredictor(CompliantBounceBallModel(dt=dt))
    c0 = time.process_time()
    out = [predictor.predict(x) for x in xs]
    cpu = (time.process_time() - c0) / len(xs)
    return cpu, np.array([np.full(7, np.nan) if r is None else np.ravel(r) for r in out])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--steps", type=float, nargs="+", default=[0.005, 0.01])
    ap.add_argument("--reference", type=float, default=2.5e-4)
    args = ap.parse_args()
    xs = states()
    cpu, ref = predictions(args.reference, xs)
    print(f"{len(xs)} states, {int(np.isnan(ref[:, 0]).sum())} never reach the plane; "
          f"reference step {1e3 * args.reference:g} ms: {1e6 * cpu:.0f} µs per prediction")
    for dt in args.steps:
        cpu, out = predictions(dt, xs)
        d = np.abs(out - ref)
        print(f"  step {1e3 * dt:g} ms: {1e6 * cpu:.0f} µs per prediction; same misses "
              f"{np.array_equal(np.isnan(out), np.isnan(ref))}; largest difference: position "
              f"{np.nanmax(d[:, :3]):.2g} m, velocity {np.nanmax(d[:, 3:6]):.2g} m/s, time "
              f"{np.nanmax(d[:, 6]):.2g} s")


if __name__ == "__main__":
    main()
