"""The hitting-point, t_hit and spin errors of the predictions a player's stroke is planned on,
per serve (what is measured: :mod:`tt_drake.diagrams.spin_report`):

    python -m tt_drake.diagrams.commands.spin_report --serves N --seed S [--scenario Y]
        [--distribution D] [--player analytical|momp] [--ceiling] [--workers W] [--json FILE]

Bad input gives one line on stderr and exit status 2.
"""

from __future__ import annotations

import argparse
import json
import sys

from tt_drake.diagrams.ball_world import BallOnlyWorld
from tt_drake.diagrams.commands.options import add_scenario_option
from tt_drake.diagrams.episodes import ServeDiagram, episode_seed
from tt_drake.diagrams.scenario import load_scenario, validate
from tt_drake.diagrams.serve import returnable_serves
from tt_drake.diagrams.spin_report import (
    PLAYER_CHOICES,
    format_summary,
    logged_player,
    momp_report,
    serve_report,
    summarise,
)
from tt_drake.models import shipped_artefact
from tt_drake.outputs import check_writable, write_json_atomic
from tt_drake.serves import ServeError, serve_sampler


def read_returnable(path: str | None, seed: int, distribution: str,
                     serves: int) -> list[int] | None:
    """The returnable serves' indices saved by an earlier ``--ceiling`` run of the same serves;
    ValueError (one line) if the file is not such a run."""
    if path is None:
        return None
    try:
        with open(path, encoding="utf-8") as f:
            data = json.load(f)
        indices = data["returnable_indices"]
        same = (data["seed"], data["distribution"], data["serves_run"]) == (seed, distribution,
                                                                            serves)
    except (OSError, ValueError, KeyError, TypeError) as err:
        raise ValueError(f"--returnable-from {path}: not a spin_report --ceiling result "
                         f"({err})") from None
    if not isinstance(indices, list) or not same:
        raise ValueError(f"--returnable-from {path}: another run (seed, distribution, serves "
                         f"differ) or not a --ceiling run")
    return [int(i) for i in indices]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m tt_drake.diagrams.commands.spin_report")
    p.add_argument("--serves", type=int, required=True)
    p.add_argument("--seed", type=int, default=0)
    add_scenario_option(p)
    p.add_argument("--distribution", default=None)
    p.add_argument("--player", default="analytical")
    p.add_argument("--ceiling", action="store_true",
                   help="report only the serves the oracle teacher returns")
    p.add_argument("--returnable-from", default=None,
                   help="take the returnable serves from this earlier --ceiling run's JSON "
                        "(same seed, distribution and --serves) instead of running the oracle")
    p.add_argument("--workers", type=int, default=1, help="processes for the oracle's run")
    p.add_argument("--json", default=None)
    args = p.parse_args(argv)
    try:
        if args.serves <= 0:
            raise ValueError(f"--serves must be positive, got {args.serves}")
        if args.workers <= 0:
            raise ValueError(f"--workers must be positive, got {args.workers}")
        if args.player not in PLAYER_CHOICES:
            raise ValueError(f"--player must be one of {', '.join(PLAYER_CHOICES)}, got "
                             f"{args.player!r}")
        scenario = load_scenario(args.scenario)
        if args.distribution is not None:
            scenario.launcher.distribution = args.distribution
            validate(scenario, "--distribution")
        scenario.launcher.run_seed = args.seed  # the serves of ``tt-drake serve --seed S``
        serve_sampler(scenario.launcher).check()  # a split of a file without ids
        if args.player == "momp" and not scenario.learned.library:
            learned = scenario.learned
            learned.library, learned.crkr, learned.predictor = (
                str(shipped_artefact(kind)) for kind in ("library", "crkr", "predictor"))
        returnable = read_returnable(args.returnable_from, args.seed,
                                      scenario.launcher.distribution, args.serves)
        if args.json:
            check_writable(args.json)
        diagram = ServeDiagram(scenario, logged_player(args.player), log_ball=True,
                               end_when_decided=True)
    except (ValueError, OSError, ServeError) as err:
        print(f"error: {' '.join(str(err).split())}", file=sys.stderr)
        return 2
    indices = list(range(args.serves))
    if args.ceiling and returnable is None:
        by = returnable_serves(scenario, args.serves, args.seed, progress=True,
                               workers=args.workers)
        returnable = [i for i, r in enumerate(by) if r is not None]
    if returnable is not None:
        indices = returnable
    ball_world = BallOnlyWorld(log_period=1.0 / 600.0)
    report = serve_report if args.player == "analytical" else momp_report
    rows = []
    for i in indices:
        rows.append({"index": i, **report(diagram, ball_world, episode_seed(args.seed, i))})
    summary = summarise(rows)
    if returnable is not None:
        summary["returnable_serves"] = len(indices)
        summary["run_serves"] = args.serves
    print(format_summary(summary))
    if args.json:
        write_json_atomic(args.json, {"scenario": scenario.name, "seed": args.seed,
                                      "distribution": scenario.launcher.distribution,
                                      "player": args.player, "serves_run": args.serves,
                                      "returnable_indices": returnable,
                                      "summary": summary, "serves": rows})
    return 0


if __name__ == "__main__":
    sys.exit(main())
