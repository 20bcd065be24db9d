"""The DMP sensitivity maps: CPU per map, and how many a run of momp serves has to compute.

    OPENBLAS_NUM_THREADS=1 python docs/examples/dmp_maps.py [--serves 100] [--cache 256]
        [--scenario S]

First the CPU time of computing one map (``HittingDMP._integrate_sensitivity``) for seven step
counts of the learned player's range, three passes; then ``--serves`` momp serves (seed 3, the
shipped artefacts) with ``--cache`` maps kept (``tt_drake.dmp._CACHED_MAPS``), printing per 20
serves how many maps the roll-outs asked for and how many had to be computed. Run it in two
checkouts to compare them (an older checkout ignores ``--cache``). Used for docs/performance.md.
"""

from __future__ import annotations

import argparse
import time

from tt_drake import dmp
from tt_drake.diagrams.commands.options import add_scenario_option

STEPS = (26, 74, 150, 200, 300, 400, 629)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--serves", type=int, default=100)
    ap.add_argument("--cache", type=int, default=256)
    add_scenario_option(ap)
    args = ap.parse_args()
    model = dmp.HittingDMP()
    for r in range(3):
        c0 = time.process_time()
        for n in STEPS:
            model._integrate_sensitivity(n)
        print(f"pass {r + 1}: {1e3 * (time.process_time() - c0) / len(STEPS):.2f} CPU ms per "
              f"map (mean over step counts {', '.join(map(str, STEPS))})")
    if args.serves <= 0:
        return
    from tt_drake.diagrams.episodes import ServeDiagram, episode_seed
    from tt_drake.diagrams.scenario import load_scenario
    from tt_drake.models import use_artefact_set

    dmp._CACHED_MAPS = args.cache
    asked, computed = [0], [0]
    sensitivity, integrate = dmp.HittingDMP.sensitivity, dmp.HittingDMP._integrate_sensitivity

    def counted_sensitivity(self, n):
        asked[0] += 1
        return sensitivity(self, n)

    def counted_integrate(self, n):
        computed[0] += 1
        return integrate(self, n)

    dmp.HittingDMP.sensitivity = counted_sensitivity
    dmp.HittingDMP._integrate_sensitivity = counted_integrate
    scenario = load_scenario(args.scenario)
    use_artefact_set(scenario.learned)  # the shipped paper set, as `tt-drake serve` plays it
    diagram = ServeDiagram(scenario, "momp")
    first, last_asked, last_computed = 1, 0, 0
    for i in range(args.serves):
        diagram.run(episode_seed(3, i))
        if (i + 1) % 20 == 0 or i + 1 == args.serves:
            print(f"serves {first}-{i + 1}: {asked[0] - last_asked} maps asked for, "
                  f"{computed[0] - last_computed} computed ({args.cache} kept)", flush=True)
            first, last_asked, last_computed = i + 2, asked[0], computed[0]


if __name__ == "__main__":
    main()
