"""``tt-drake reproduce``: the paper's experiments from nothing, with a report (resumable)."""

from tt_drake.diagrams.commands.options import (
    CliError,
    add_command,
    add_quiet_option,
    add_scenario_option,
    add_workers_option,
    one_of,
)

# The names these options accept (their registries import pydrake, too slow for --help; tests
# check these equal tt_drake.diagrams.reproduce.PROTOCOLS and STAGES and
# tt_drake.diagrams.parallel.EXECUTORS).
PROTOCOL_NAMES = ("paper", "hard", "hard-stiff")
REPRODUCE_STAGES = ("teacher", "predictor", "library", "crkr", "single", "gamma1",
                    "responsibility", "power", "final")
EXECUTOR_NAMES = ("local", "ray")


def register(subparsers) -> None:
    p = add_command(subparsers, "reproduce", help="the paper's experiments from nothing, with a "
                                                  "report (resumable)")
    p.add_argument("--out", required=True, help="run folder (created, or resumed)")
    p.add_argument("--quick", action="store_true",
                   help="every stage on few serves (minutes; the CI run)")
    add_workers_option(p, None, "parallel worker processes (default: all cores)")
    p.add_argument("--executor", default="local", type=one_of("executor", EXECUTOR_NAMES),
                   choices=EXECUTOR_NAMES, help="where rollouts run")
    p.add_argument("--protocol", default="paper", choices=PROTOCOL_NAMES,
                   help="paper: the paper's experiments on default serves; hard: learn from "
                        "spin and recorded serves, judged on unseen ones against the oracle "
                        "teacher's ceiling (docs/reproducing.md); hard-stiff: the same with "
                        "the stiffer hitting DMP of models/learned-hard/")
    p.add_argument("--sizes", default=None, choices=("full", "quick", "artefacts"),
                   help="the stages' serve counts, the protocol's: full (the default), quick "
                        "(= --quick), or "
                        "artefacts (the training stages' sizes that made "
                        "models/learned-hard/, with --protocol hard-stiff --until crkr)")
    p.add_argument("--until", default=None, choices=REPRODUCE_STAGES,
                   help="stop after this stage; from crkr on, export the artefacts trained so "
                        "far to DIR/artefacts/")
    add_scenario_option(p, help="scenario every stage plays: a name (models/<name>.yaml) or "
                                "YAML path (ideal_robot: the ideal drives and camera)")
    add_quiet_option(p, "no progress output")
    p.set_defaults(run=run)


def run(args) -> None:
    # The experiments import pydrake: loaded when the command runs, not for --help.
    from tt_drake.diagrams.reproduce import reproduce

    if args.quick and args.sizes not in (None, "quick"):
        raise CliError(f"--quick and --sizes {args.sizes} disagree; give one")
    quick = args.quick or args.sizes == "quick"
    report = reproduce(args.out, quick, args.workers, args.executor,
                       progress=not args.quiet, protocol=args.protocol,
                       sizes=args.sizes, until=args.until, scenario=args.scenario)
    for row in report["table"]:
        print(f"{row['experiment']}: paper {row['paper']}, ours {row['ours']}")
    print(f"wrote {args.out}/report.md and {args.out}/report.json")
