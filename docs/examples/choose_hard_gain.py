"""Choose the hard profile's hitting-DMP gain alpha_y on validation serves.

    OPENBLAS_NUM_THREADS=1 python docs/examples/choose_hard_gain.py RUN OUT [--workers 2]
        [--scenario S]

RUN is a hard run's folder with its ``teacher``, ``predictor`` and ``crkr`` stages
(``tt-drake reproduce --protocol hard --out RUN --until crkr``); OUT receives one library per
candidate gain and one JSON of figures per gain and serve set, so an interrupted run resumes.

The rule: the hard profile exists so that learning has something to select, so the primitives'
weights must decide part of the impact. Its gain is the stiffest alpha_y below the stiff
profile's 15 whose gamma = 1 mixture returns (strokes the primitives carried) at least
:data:`GAP` fewer of the ``real-train`` validation serves than alpha_y 15's; the candidates are
tried from the stiffest. Each candidate's library has 300 primitives imitated from the run's
teacher data with the hard profile's other settings (``HARD_PROFILE``); it plays with the run's
GPR and CrKR, the teacher's IK as the hitting configuration and the moving goal, as the hard
protocol's player does, on validation serves no stage of the protocol uses.
"""

import argparse
import json
import types
from pathlib import Path

from tt_drake.diagrams.commands.options import add_scenario_option
from tt_drake.diagrams.parallel import run_episodes
from tt_drake.diagrams.protocols import rates
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.diagrams.train import HARD_PROFILE, library_options, train_library
from tt_drake.seeds import episode_seed

STIFF = 15
CANDIDATES = (12, 11, 10)  # from the stiffest
GAP = 0.10  # legal returns carried by the primitives, on the real-train validation serves
PRIMITIVES = 300
#: (distribution, serves, seed): validation serves no stage of the hard protocol uses.
VALIDATION = (("spin", 100, 5002), ("real-train", 150, 5001))


def library(run: Path, out: Path, alpha_y: int) -> Path:
    path = out / f"library_{alpha_y}.npz"
    if not path.exists():
        settings = types.SimpleNamespace(**{**HARD_PROFILE, "alpha_y": float(alpha_y)})
        train_library(run / "teacher" / "data", path, PRIMITIVES, **library_options(settings))
    return path


def figures(run: Path, out: Path, alpha_y: int, distribution: str, serves: int, seed: int,
            workers: int, scenario: str = "default") -> dict:
    """The gamma = 1 hard player's rates (``tt_drake.diagrams.protocols.rates``) with the
    library of ``alpha_y`` on ``serves`` serves of ``distribution`` (pools dealt by ``seed``) in
    ``scenario`` (a name in models/ or a YAML path)."""
    path = out / f"a{alpha_y}_{distribution}.json"
    if path.exists():
        return json.loads(path.read_text())
    scenario = load_scenario(scenario)
    learned = scenario.learned
    learned.library = str(library(run, out, alpha_y))
    learned.crkr = str(run / "crkr" / "crkr_1.npz")
    learned.predictor = str(run / "predictor" / "predictor.npz")
    learned.configuration, learned.moving_goal = "analytical", True
    scenario.launcher.distribution, scenario.launcher.run_seed = distribution, seed
    seeds = [episode_seed(seed, i) for i in range(serves)]
    result = rates([r.as_dict() for r in run_episodes(scenario, "momp", seeds, workers)])
    path.write_text(json.dumps(result))
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("run", type=Path)
    parser.add_argument("out", type=Path)
    parser.add_argument("--workers", type=int, default=2)
    add_scenario_option(parser)
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    carried = {}
    print("| alpha_y | set | legal returns (carried) | on target | mean reward | fallbacks |")
    print("|---|---|---|---|---|---|")
    for alpha_y in (STIFF, *CANDIDATES):
        for distribution, serves, seed in VALIDATION:
            r = figures(args.run, args.out, alpha_y, distribution, serves, seed, args.workers,
                        args.scenario)
            carried[alpha_y, distribution] = r["momp_return_rate"]
            print(f"| {alpha_y} | {distribution} ({serves}, seed {seed}) | "
                  f"{r['momp_return_rate']:.1%} | {r['momp_target_rate']:.1%} | "
                  f"{r['mean_reward']:.3f} | {r['fallback_strokes']} |", flush=True)
    reference = carried[STIFF, "real-train"]
    choice = next((a for a in CANDIDATES if carried[a, "real-train"] <= reference - GAP), None)
    print(f"alpha_y: {choice}" if choice is not None else
          f"no candidate leaves {GAP:.0%} of the real-train serves to learning")


if __name__ == "__main__":
    main()
