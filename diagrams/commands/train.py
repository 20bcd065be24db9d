"""``tt-drake train``: train the learned player's library or CrKR model."""

from tt_drake.diagrams.commands.options import add_command, bounded_float, one_of, positive_int
from tt_drake.dmp import HittingDMP
from tt_drake.responsibility import ResponsibilityParams
from tt_drake.stimulus import STIMULI


def register(subparsers) -> None:
    p = add_command(subparsers, "train", help="train the learned player's library or CrKR "
                                              "model")
    p.add_argument("artefact", choices=("library", "crkr"), help="what to train")
    p.add_argument("--data", required=True, help="teacher dataset folder (tt-drake collect)")
    p.add_argument("--out", required=True, help="artefact file to write (.npz)")
    p.add_argument("--primitives", type=positive_int, default=300,
                   help="library: at most this many hitting primitives")
    p.add_argument("--samples", type=positive_int, default=2500,
                   help="crkr: at most this many teacher pairs")
    p.add_argument("--stimulus", type=one_of("stimulus", ("paper", "spin")),
                   choices=("paper", "spin"), default="paper",
                   help="the gating network's / CrKR's stimulus: paper = (p_hit, v_hit), "
                        "spin = with the predicted spin at impact (default: paper)")
    p.add_argument("--demonstrations", type=one_of("demonstrations", ("planned", "recorded")),
                   choices=("planned", "recorded"), default="planned",
                   help="library: imitate the teacher's executed plan or the arm's recorded "
                        "joint state (default: planned)")
    p.add_argument("--alpha-y", type=bounded_float(0.0, None), default=35.0,
                   help="library: the DMP gain alpha_y (Eq. 4; default 35)")
    for name in ("hitting", "stage"):
        p.add_argument(f"--{name}-borrow", type=bounded_float(0.0, 1.0), default=0.5,
                       help=f"library: {name} DMP joints whose amplitude is below this "
                            f"fraction of the largest take its shape (0: none; default 0.5)")
    responsibility = ResponsibilityParams()  # the defaults are the paper profile's
    p.add_argument("--kappa", type=bounded_float(0.0, None), default=responsibility.kappa,
                   help="library: responsibility learning's rate kappa (Eq. 10)")
    p.add_argument("--zeta", type=bounded_float(0.0, 100.0), default=responsibility.zeta,
                   help="library: responsibility learning's zeta (Eq. 10)")
    p.add_argument("--threshold", type=bounded_float(0.0, 0.99),
                   default=responsibility.threshold,
                   help="library: the responsibility below which a primitive is pruned "
                        "(Algorithm 3)")
    p.set_defaults(run=run)


def run(args) -> None:
    # Training reads datasets through modules that import pydrake: loaded when the command
    # runs, not for --help.
    from tt_drake.diagrams.train import format_train, train_crkr, train_library

    stimulus = STIMULI[args.stimulus]
    if args.artefact == "library":
        summary = train_library(args.data, args.out, args.primitives,
                                HittingDMP(alpha_y=args.alpha_y), args.demonstrations, stimulus,
                                args.hitting_borrow, args.stage_borrow,
                                ResponsibilityParams(args.kappa, args.zeta, args.threshold))
    else:
        summary = train_crkr(args.data, args.out, args.samples, stimulus)
    print(format_train(summary))
