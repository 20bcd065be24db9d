"""Time serve episodes with the aerodynamics as a Python LeafSystem against the C++ one, in one
process, interleaved (docs/performance.md, "The serve diagram's Python").

    python docs/examples/lever_aerodynamics.py OLD.py [--player idle]
        [--serves 10] [--seed 3] [--rounds 3] [--library ... --crkr ... --predictor ...]
        [--scenario S]
    python docs/examples/lever_aerodynamics.py OLD.py --ball-only

``OLD.py``: a module defining ``add_aerodynamics`` with the signature of
:func:`tt_drake.systems.aerodynamics.add_aerodynamics` that adds the same drag and Magnus force
as a Python LeafSystem.

``--ball-only``: a spinning serve in the ball-only world (table, net, floor, ball) instead, 1.5 s,
``--serves`` times per round.

Prints, per round, CPU ms per serve of each variant (process time: robust to a loaded machine)
and their ratio, and the largest landing-point difference between the two on the same serves.
"""

from __future__ import annotations

import argparse
import importlib.util
import time

import numpy as np

import tt_drake.diagrams.episodes as episodes
from tt_drake.diagrams.commands.options import add_scenario_option
from tt_drake.diagrams.episodes import ServeDiagram, episode_seed
from tt_drake.diagrams.scenario import load_scenario


def _build(scenario, player, add_aerodynamics):
    saved = episodes.add_aerodynamics
    episodes.add_aerodynamics = add_aerodynamics
    try:
        return ServeDiagram(scenario, player)
    finally:
        episodes.add_aerodynamics = saved


def _ball_only(old, rounds: int, repeats: int) -> None:
    import tt_drake.diagrams.ball_world as ball_world

    saved = ball_world.add_aerodynamics
    ball_world.add_aerodynamics = old.add_aerodynamics
    try:
        python = ball_world.BallOnlyWorld()
    finally:
        ball_world.add_aerodynamics = saved
    worlds = {"python": python, "c++": ball_world.BallOnlyWorld()}
    launch = [0.1, 1.57, 0.91, 0.25, -5.2, 3.0, 10.0, -30.0, 5.0]
    for r in range(rounds):
        cpu, end = {}, {}
        for name, world in worlds.items():
            c0 = time.process_time()
            for _ in range(repeats):
                _, p, _, _ = world.run(launch, 1.5)
            cpu[name] = 1e3 * (time.process_time() - c0) / repeats
            end[name] = p[-1]
        print(f"round {r}: python {cpu['python']:.1f} ms, c++ {cpu['c++']:.1f} ms, ratio "
              f"{cpu['python'] / cpu['c++']:.3f}; end positions differ by "
              f"{np.abs(end['python'] - end['c++']).max():.1e} m")


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
    ap.add_argument("--ball-only", action="store_true")
    add_scenario_option(ap)
    args = ap.parse_args()
    spec = importlib.util.spec_from_file_location("old_aerodynamics", args.old)
    old = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(old)
    if args.ball_only:
        _ball_only(old, args.rounds, args.serves)
        return
    scenario = load_scenario(args.scenario)
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
