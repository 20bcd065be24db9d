"""CPU per physical prediction and per EKF propagation, and their results (docs/performance.md).

    OPENBLAS_NUM_THREADS=1 python docs/examples/lever_predictions.py [--save out.npz]
    OPENBLAS_NUM_THREADS=1 python docs/examples/lever_predictions.py --compare out.npz

States: 60 default and 60 spin serves (100 rad/s per axis), each at launch and every 0.05 s of
its model flight up to 0.75 s. Times (``time.process_time``, three passes) the learned player's
physical prediction to the hitting plane (``PhysicalPredictor`` at a 5 ms step) and the
EKF's 60 Hz propagation with its Jacobian (``propagate_flight_jacobian``). ``--save`` writes every
result; ``--compare`` (run in another checkout) prints the largest difference to a saved run.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from tt_drake.ball_model import CompliantBounceBallModel
from tt_drake.estimation import EstimatorConfig, propagate_flight_jacobian
from tt_drake.hitting_point import PhysicalPredictor
from tt_drake.serves import ServeSampler


def states() -> list[np.ndarray]:
    fine = CompliantBounceBallModel(dt=1e-3)
    out = []
    for kind, spin in (("default", 0.0), ("spin", 100.0)):
        sampler = ServeSampler(kind, spin_max=spin)
        for i in range(60):
            s = sampler.sample(i).launch_state
            for t in np.arange(0.0, 0.76, 0.05):
                try:
                    out.append(fine.predict_time(s, float(t)).state)
                except ValueError:
                    break  # on the floor
    return out


def timed(fn, xs, passes: int = 3):
    results = [fn(x) for x in xs]
    t0 = time.process_time()
    for _ in range(passes):
        for x in xs:
            fn(x)
    return 1e6 * (time.process_time() - t0) / (passes * len(xs)), results


def as_array(results, size: int) -> np.ndarray:
    return np.array([np.full(size, np.nan) if r is None else np.ravel(r) for r in results])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--save")
    ap.add_argument("--compare")
    args = ap.parse_args()
    xs = states()
    predictor = PhysicalPredictor(CompliantBounceBallModel(dt=5e-3))
    ekf_model = CompliantBounceBallModel(dt=EstimatorConfig().model_dt)

    def propagate(x):
        r = propagate_flight_jacobian(ekf_model, x, 1.0 / 60.0)
        return None if r is None else np.r_[r[0], r[1].ravel()]

    us_pred, pred = timed(predictor.predict, xs)
    us_prop, prop = timed(propagate, xs)
    pred, prop = as_array(pred, 7), as_array(prop, 9 + 81)
    print(f"{len(xs)} states: physical prediction {us_pred:.0f} µs, EKF propagation with "
          f"Jacobian {us_prop:.1f} µs (CPU, mean of 3 passes)")
    if args.save:
        np.savez(args.save, pred=pred, prop=prop)
    if args.compare:
        old = np.load(args.compare)
        for name, new in (("pred", pred), ("prop", prop)):
            same_nan = np.array_equal(np.isnan(old[name]), np.isnan(new))
            diff = np.nanmax(np.abs(old[name] - new))
            print(f"  {name}: same None pattern {same_nan}, largest difference {diff:.3g}")


if __name__ == "__main__":
    main()
