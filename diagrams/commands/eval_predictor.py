"""``tt-drake eval-predictor``: the GPR predictor against the physical model on held-out
serves."""

from tt_drake.diagrams.commands.options import (
    add_command,
    add_json_option,
    add_quiet_option,
    add_seed_option,
    add_serves_option,
)


def register(subparsers) -> None:
    p = add_command(subparsers, "eval-predictor", help="GPR vs physical model on held-out "
                                                       "serves")
    p.add_argument("--model", required=True, help="predictor file from train-predictor")
    add_serves_option(p, 3500, "held-out serves")
    add_seed_option(p, 1, "base seed of the serves")
    add_json_option(p, "write the metrics as JSON")
    p.add_argument("--distribution", default=None,
                   help="held-out serve distribution (or a comma-separated mix); default: "
                        "default")
    add_quiet_option(p)
    p.set_defaults(run=run)


def run(args) -> None:
    # The predictor's ball-only world imports pydrake: loaded when the command runs, not for
    # --help.
    from tt_drake.diagrams.predictor import eval_predictor, format_eval

    print(format_eval(eval_predictor(args.model, args.serves, args.seed, args.json,
                                     progress=not args.quiet, distribution=args.distribution)))
    if args.json:
        print(f"wrote {args.json}")
