"""Time the learned player's effort check per sample against the evaluation it replaced, on the
plans of real momp serves (docs/performance.md).

    python docs/examples/lever_effort_check.py --library models/learned/library.npz \
        --crkr models/learned/crkr.npz --predictor models/learned/predictor.npz [--serves 5]
        [--scenario S]

Records every (plan, now) the player checks during ``--serves`` serves, then times
:func:`tt_drake.stages.within_effort` and the former per-sample loop (``segment.evaluate`` at
each time, then inverse dynamics) on them in CPU time, interleaved, and checks both give the same
verdict on every plan.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import tt_drake.systems.momp_player as momp_player
from tt_drake.diagrams.commands.options import add_scenario_option
from tt_drake.diagrams.episodes import ServeDiagram, episode_seed
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.stages import within_effort


def per_sample_loop(plan, torques, budget, now=-np.inf, rate=50.0) -> bool:
    """The effort check before the vectorised evaluation (the same samples and bound)."""
    budget = np.asarray(budget, dtype=float)
    for _, seg in plan.segments:
        if seg.t_end <= now:
            continue
        for t in np.arange(max(seg.t0, now), seg.t_end + 1e-9, 1.0 / rate):
            if np.any(np.abs(torques(*seg.evaluate(t))) > budget):
                return False
    return True


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--library", required=True)
    ap.add_argument("--crkr", required=True)
    ap.add_argument("--predictor", default="")
    ap.add_argument("--serves", type=int, default=5)
    ap.add_argument("--rounds", type=int, default=3)
    add_scenario_option(ap)
    args = ap.parse_args()
    scenario = load_scenario(args.scenario)
    scenario.learned.library, scenario.learned.crkr = args.library, args.crkr
    scenario.learned.predictor = args.predictor
    checked = []

    def recording(plan, torques, budget, now=-np.inf, rate=50.0):
        checked.append((plan, torques, budget, now))
        return within_effort(plan, torques, budget, now, rate)

    momp_player.within_effort = recording
    diagram = ServeDiagram(scenario, "momp")
    for i in range(args.serves):
        diagram.run(episode_seed(3, i))
    momp_player.within_effort = within_effort
    same = all(within_effort(*c) == per_sample_loop(*c) for c in checked)
    print(f"{len(checked)} effort checks recorded over {args.serves} serves; same verdicts: {same}")
    for r in range(args.rounds):
        cpu = {}
        for name, check in (("per-sample loop", per_sample_loop), ("vectorised", within_effort)):
            c0 = time.process_time()
            for c in checked:
                check(*c)
            cpu[name] = 1e3 * (time.process_time() - c0) / len(checked)
        print(f"round {r}: " + ", ".join(f"{k} {v:.2f} ms" for k, v in cpu.items())
              + f" per check; ratio {cpu['per-sample loop'] / cpu['vectorised']:.2f}")


if __name__ == "__main__":
    main()
