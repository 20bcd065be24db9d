"""``tt-drake train-predictor``: train the GPR hitting-point predictor."""

from tt_drake.diagrams.commands.options import (
    add_command,
    add_quiet_option,
    add_scenario_option,
    add_seed_option,
    add_serves_option,
)


def register(subparsers) -> None:
    p = add_command(subparsers, "train-predictor", help="train the GPR hitting-point predictor")
    add_serves_option(p, 1000, "training serves")
    add_seed_option(p, help="base seed of the serves")
    p.add_argument("--out", required=True, help="predictor file to write (.npz)")
    p.add_argument("--distribution", default=None,
                   help="serve distribution, or a comma-separated mix shared evenly (e.g. "
                        "default,spin,real-train); default: default")
    p.add_argument("--features", default="states", choices=("states", "states+spin"),
                   help="GPR inputs: the four observed states (the paper's), or those and "
                        "the estimated spin at the fourth")
    add_scenario_option(p, help="scenario whose camera the features are drawn with: a name "
                                "(models/<name>.yaml) or YAML path")
    add_quiet_option(p)
    p.set_defaults(run=run)


def run(args) -> None:
    # The predictor's ball-only world imports pydrake: loaded when the command runs, not for
    # --help.
    from tt_drake.diagrams.predictor import format_train, train_predictor
    from tt_drake.diagrams.scenario import load_scenario

    camera = load_scenario(args.scenario).camera
    print(format_train(train_predictor(args.serves, args.seed, args.out, camera=camera,
                                       progress=not args.quiet, distribution=args.distribution,
                                       feature_set=args.features)))
