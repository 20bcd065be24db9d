"""Time serve episodes with the aerodynamics as a Python LeafSystem against the C++ one, in one
process, interleaved (docs/performance.md).

    git show 962fa0c:systems/aerodynamics.py > /tmp/old_aerodynamics.py
    python docs/examples/lever_aerodynamics.py /tmp/old_aerodynamics.py [--player idle]
        [--serves 10] [--seed 3] [--rounds 3] [--library ... --crkr ... --predictor ...]

Prints, per round, CPU ms per serve of each variant (process time: robust to a loaded machine)
and their ratio, and the largest landing-point difference between the two on the same serves.
"""

from __future__ import annotations

import argparse
import importlib.util
import time

import numpy as np

import tt_drake.diagrams.episodes as episodes
from tt_drake.diagrams.episodes import ServeDiagram, episode_seed
from tt_drake.diagrams.scenario import load_scenario


def _build(scenario, player, add_aerodynamics):
    saved = episodes.add_aerodynamics
    episodes.add_aerodynamics = add_aerodynamics
    try:
        return ServeDiagram(scenario, player)
    finally:
        episodes.add_aerodynamics = saved


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("old", help="a copy of the Python-LeafSystem aerodynamics module")
    ap.add_argument("--player", default="idle")
    ap.add_argument("--serves", type=int, default=10)
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--library", default="")
    ap.add_argument("--crkr", default="")
    ap.add_argument("--predictor", default="")
    args = ap.parse_args()
    spec = importlib.util.spec_from_file_location("old_aerodynamics", args.old)
    old = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(old)
    scenario = load_scenario()
    scenario.learned.library, scenario.learned.crkr = args.library, args.crkr
    scenario.learned.predictor = args.predictor
    variants = {"python": _build(scenario, args.player, old.add_aerodynamics),
                "c++": _build(scenario, args.player, episodes.add_aerodynamics)}
    seeds = [episode_seed(args.seed, i) for i in range(args.serves)]
    landings = {}
    for diagram in variants.values():
        diagram.run(seeds[0])  # warm-up
    for r in range(args.rounds):
        ms = {}
        for name, diagram in variants.items():
            t0 = time.process_time()
            results = [diagram.run(s) for s in seeds]
            ms[name] = 1e3 * (time.process_time() - t0) / len(seeds)
            landings[name] = [res.outcome.landing for res in results]
        print(f"round {r}: python {ms['python']:.1f} ms/serve, c++ {ms['c++']:.1f} ms/serve, "
              f"ratio {ms['python'] / ms['c++']:.3f}")
    shifts = [float(np.linalg.norm(np.subtract(a, b)))
              for a, b in zip(landings["python"], landings["c++"], strict=True)
              if a is not None and b is not None]
    same = all((a is None) == (b is None)
               for a, b in zip(landings["python"], landings["c++"], strict=True))
    print(f"landing points: same presence {same}, largest difference "
          f"{1e3 * max(shifts, default=0.0):.2e} mm")


if __name__ == "__main__":
    main()
