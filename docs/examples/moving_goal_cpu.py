"""CPU per serve and the moving goal's tries, serve by serve (docs/learned_player.md, "Refused
moves: when they are tried again").

    OPENBLAS_NUM_THREADS=1 python docs/examples/moving_goal_cpu.py --distribution real-test \\
        --seed 13 --serves 60 --out F.json [--scenario S]

Plays the serves of ``tt-drake serve --player momp --artefacts hard --distribution D --seed S``
(pools dealt as that command deals them) in this process and writes its JSON (same layout, so
``compare_serves.py`` compares two runs) with ``per_serve``: CPU time (``time.process_time``),
the number of ``move_hitting_goal`` calls (tries of a move of the goal) and the CPU spent in
the player's moving-goal step (which also evaluates the hitting configuration of a new
prediction). One line per serve on stderr.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import tt_drake.systems.momp_player as momp_player
from tt_drake.diagrams.commands.options import add_scenario_option
from tt_drake.diagrams.episodes import ServeDiagram, episode_seed
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.diagrams.serve import _report
from tt_drake.models import use_artefact_set


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--artefacts", default="hard")
    ap.add_argument("--distribution", default="spin")
    ap.add_argument("--serves", type=int, default=60)
    ap.add_argument("--seed", type=int, default=2027)
    ap.add_argument("--out", required=True)
    add_scenario_option(ap)
    args = ap.parse_args()

    counts = {"tries": 0, "move_cpu": 0.0}
    step = momp_player.MoMPTrajectorySource._move_goal
    move = momp_player.move_hitting_goal

    def timed_step(self, *a, **k):
        c0 = time.process_time()
        try:
            return step(self, *a, **k)
        finally:
            counts["move_cpu"] += time.process_time() - c0

    def counted_move(*a, **k):
        counts["tries"] += 1
        return move(*a, **k)

    momp_player.MoMPTrajectorySource._move_goal = timed_step
    momp_player.move_hitting_goal = counted_move

    scenario = load_scenario(args.scenario)
    use_artefact_set(scenario.learned, args.artefacts)
    scenario.launcher.distribution = args.distribution
    scenario.launcher.run_seed = args.seed  # as `tt-drake serve --seed S` deals a pool
    diagram = ServeDiagram(scenario, "momp")
    results, per_serve = [], []
    for i in range(args.serves):
        counts.update(tries=0, move_cpu=0.0)
        c0 = time.process_time()
        result = diagram.run(episode_seed(args.seed, i))
        per_serve.append({"index": i, "cpu": time.process_time() - c0, **counts})
        results.append(result)
        print(i, f"{per_serve[-1]['cpu']:.2f} s", counts, result.outcome.as_dict()["outcome"],
              file=sys.stderr, flush=True)
    data = _report(scenario, "momp", args.seed, results)
    data["per_serve"] = per_serve
    with open(args.out, "w") as f:
        json.dump(data, f)
    n = len(per_serve)
    print(f"{n} serves: {sum(r.outcome.returned for r in results)} returned, "
          f"{sum(p['cpu'] for p in per_serve) / n:.3f} CPU s per serve, "
          f"{sum(p['tries'] for p in per_serve)} tries of a move")


if __name__ == "__main__":
    main()
