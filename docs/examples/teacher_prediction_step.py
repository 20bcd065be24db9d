"""The teacher's predictions at several RK4 steps against its old 2 ms step.

    OPENBLAS_NUM_THREADS=1 python docs/examples/teacher_prediction_step.py [--serves 3]
        [--seed 3] [--perception oracle] [--distribution default] [--steps 0.004 0.01]

Plays ``--serves`` analytical serves (recorded, as the teacher stage plays them) and keeps every
(estimate, time, spin) the player predicted from; then predicts from each again
(``StrokePlanner.predict``: the hitting point along the path, ``bounced_on_robot_half`` included)
with the planner's model at 2 ms and at each ``--steps``, and prints the CPU time per prediction,
how many predictions differ in having a hitting point, and the largest difference to the 2 ms
prediction in position (m), velocity (m/s), time (s) and spin (rad/s). Used for
docs/performance.md (seventh pass: ``analytical_player.PREDICTION_STEP``).
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

import tt_drake.systems.analytical_player as ap
from tt_drake.diagrams.episodes import ServeDiagram, episode_seed
from tt_drake.diagrams.scenario import load_scenario


def recorded_predictions(serves: int, seed: int, perception: str, distribution: str) -> list:
    """The (estimate, time, spin) of every prediction the teacher made in ``serves`` serves."""
    scenario = load_scenario()
    scenario = dataclasses.replace(scenario, perception=perception, launcher=dataclasses.replace(
        scenario.launcher, distribution=distribution))
    calls = []
    original = ap.StrokePlanner.predict

    def predict(self, state6, t_state, spin=None):
        calls.append((np.array(state6), float(t_state), None if spin is None else np.array(spin)))
        return original(self, state6, t_state, spin)

    ap.StrokePlanner.predict = predict
    try:
        diagram = ServeDiagram(scenario, "analytical", record=True)
        for i in range(serves):
            diagram.run(episode_seed(seed, i))
    finally:
        ap.StrokePlanner.predict = original
    return calls


def main() -> None:
    ap_ = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap_.add_argument("--serves", type=int, default=3)
    ap_.add_argument("--seed", type=int, default=3)
    ap_.add_argument("--perception", default="oracle")
    ap_.add_argument("--distribution", default="default")
    ap_.add_argument("--steps", type=float, nargs="+", default=[0.004, 0.01])
    args = ap_.parse_args()
    calls = recorded_predictions(args.serves, args.seed, args.perception, args.distribution)

    def run(dt):
        planner = ap.StrokePlanner(arm=object(), model=ap.planner_ball_model(dt))
        c0 = time.process_time()
        out = [planner.predict(s, t, w) for s, t, w in calls]
        return out, (time.process_time() - c0) / len(calls)

    reference, cpu_ref = run(2e-3)
    hits = sum(r is not None for r in reference)
    print(f"{len(calls)} predictions of {args.serves} {args.distribution} serves "
          f"({args.perception}, seed {args.seed}), {hits} with a hitting point; "
          f"2 ms: {1e3 * cpu_ref:.3f} CPU ms per prediction")
    for dt in args.steps:
        out, cpu = run(dt)
        differ = sum((a is None) != (b is None) for a, b in zip(reference, out, strict=True))
        both = [(a, b) for a, b in zip(reference, out, strict=True)
                if a is not None and b is not None]
        worst = [max((float(np.max(np.abs(np.subtract(b[k], a[k])))) for a, b in both),
                     default=0.0) for k in range(4)]
        print(f"  {1e3 * dt:g} ms: {1e3 * cpu:.3f} CPU ms per prediction ({cpu_ref / cpu:.2f}x); "
              f"{differ} differ in having a hitting point; largest difference: position "
              f"{worst[0]:.1e} m, velocity {worst[1]:.1e} m/s, time {worst[2]:.1e} s, spin "
              f"{worst[3]:.1e} rad/s")


if __name__ == "__main__":
    main()
