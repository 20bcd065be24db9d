"""CPU time per serve episode of one player, in this process (docs/performance.md).

    OPENBLAS_NUM_THREADS=1 python docs/examples/serve_cpu.py momp [--serves 10] [--seed 3]
        [--scenario S]

Builds the serve diagram once (learned players: the shipped artefacts in models/learned/), runs
one warm-up episode and prints the CPU time (``time.process_time``) per episode over ``--serves``
episodes, and that of building the diagram. Run it alternately in two checkouts to compare them
on a loaded machine, where wall times mostly measure the other processes.
"""

from __future__ import annotations

import argparse
import time

from tt_drake.diagrams.commands.options import add_scenario_option
from tt_drake.diagrams.episodes import ServeDiagram, episode_seed
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.models import use_artefact_set


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("player")
    ap.add_argument("--serves", type=int, default=10)
    ap.add_argument("--seed", type=int, default=3)
    add_scenario_option(ap)
    args = ap.parse_args()
    scenario = load_scenario(args.scenario)
    use_artefact_set(scenario.learned)  # the shipped paper set, as `tt-drake serve` plays it
    c0 = time.process_time()
    diagram = ServeDiagram(scenario, args.player)
    build = time.process_time() - c0
    diagram.run(episode_seed(args.seed, 0))
    c0 = time.process_time()
    for i in range(args.serves):
        diagram.run(episode_seed(args.seed, i))
    cpu = 1e3 * (time.process_time() - c0) / args.serves
    print(f"{args.player}: {cpu:.1f} CPU ms per serve over {args.serves} serves (seed "
          f"{args.seed}); building the diagram (and loading a learned player) {build:.2f} CPU s")


if __name__ == "__main__":
    main()
