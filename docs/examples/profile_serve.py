"""Where a serve episode's CPU time goes: cProfile in CPU time (docs/performance.md).

    OPENBLAS_NUM_THREADS=1 python docs/examples/profile_serve.py momp [--serves 8] [--seed 3]
        [--scenario S]

Builds the serve diagram once (learned players: the shipped artefacts in models/learned/), runs
one warm-up episode, then profiles ``--serves`` episodes with
``cProfile.Profile(time.process_time)`` and prints each system's share of the CPU time (the
cumulative time of its update or output function, per serve) and the most expensive functions.
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import time

from tt_drake.diagrams.commands.options import add_scenario_option
from tt_drake.diagrams.episodes import ServeDiagram, episode_seed
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.models import use_artefact_set

# (label, file suffix, function name): the parts docs/performance.md tabulates.
PARTS = [
    ("Simulator.AdvanceTo (total)", "", "AdvanceTo"),
    ("EKF (BallFlightEstimator._update)", "ball_flight_estimator.py", "_update"),
    ("hitting-point predictor (_update)", "hitting_point_predictor.py", "_update"),
    ("MoMP planning tick (_update)", "momp_player.py", "_update"),
    ("analytical planning tick (_update)", "analytical_player.py", "_update"),
    ("servo holds' set-points (StagePlanPlayer)", "stage_player.py", "_calc_setpoint"),
    ("referee (_update)", "referee.py", "_update"),
    ("aerodynamics / launcher / camera (Python)", "camera.py", "_update"),
]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("player")
    ap.add_argument("--serves", type=int, default=8)
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--top", type=int, default=25)
    add_scenario_option(ap)
    args = ap.parse_args()
    scenario = load_scenario(args.scenario)
    use_artefact_set(scenario.learned)  # the shipped paper set, as `tt-drake serve` plays it
    diagram = ServeDiagram(scenario, args.player)
    diagram.run(episode_seed(args.seed, 0))
    prof = cProfile.Profile(time.process_time)
    c0 = time.process_time()
    prof.enable()
    for i in range(args.serves):
        diagram.run(episode_seed(args.seed, i))
    prof.disable()
    total = time.process_time() - c0
    stats = pstats.Stats(prof)
    print(f"{args.player}: {1e3 * total / args.serves:.1f} CPU ms per serve under the profiler "
          f"({args.serves} serves, seed {args.seed}); {stats.total_calls / args.serves:.0f} "
          f"Python calls per serve")
    cum = {}
    for (file, _, name), (_, _, _, ct, _) in stats.stats.items():
        for label, suffix, fn in PARTS:
            if name == fn and file.endswith(suffix) and (suffix or "AdvanceTo" in name):
                cum[label] = cum.get(label, 0.0) + ct
    for label, _, _ in PARTS:
        if label in cum:
            print(f"  {label:45s} {1e3 * cum[label] / args.serves:7.1f} ms "
                  f"{100 * cum[label] / total:5.1f} %")
    stats.sort_stats("tottime").print_stats(args.top)


if __name__ == "__main__":
    main()
