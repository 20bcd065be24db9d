"""The ``tt-drake`` command.

    tt-drake serve  --player idle --serves N --seed S [--scenario default] [--distribution D]
                    [--spin-max W] [--perception camera|oracle] [--ceiling]
                    [--html out.html] [--json out.json]
    tt-drake serves --info [--distribution D]   (the real-ball pools' counts, docs/serves.md)
    tt-drake bench  [--serves N] [--json out.json]
    tt-drake collect --player analytical --serves N --seed S --out DIR [--workers W]
    tt-drake models  (rewrite the generated model files in models/)
    tt-drake train library|crkr --data DIR --out FILE [--primitives 300] [--samples 2500]
    tt-drake serve --player momp --library FILE [--crkr FILE] [--predictor FILE]
                   [--configuration crkr|analytical] ...
    tt-drake serve --player crkr --crkr FILE [--predictor FILE] ...   (CrKR + teacher's quintics)
    tt-drake reproduce --out DIR [--quick] [--workers N] [--executor local|ray]

Bad input (an unknown or malformed scenario field, a missing model or data file, an unknown
distribution or player, N <= 0, an unwritable output path) gives one line naming the problem on
stderr and exit status 2, with no traceback and no partial output file.
"""

import argparse
import sys

EXIT_BAD_INPUT = 2


class CliError(Exception):
    """A user error: printed as one line, exit status 2."""


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {value}")
    return value


def _add_scenario_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scenario", default="default",
                   help="scenario name (models/<name>.yaml) or YAML path (default: default)")
    p.add_argument("--distribution", default=None,
                   help="override the launcher's serve distribution: default, spin, real, "
                        "real-train, real-test, rally, rally-train, rally-test or fixed")
    p.add_argument("--spin-max", type=float, default=None,
                   help="override the launcher's spin per axis (rad/s; 0: the distribution's "
                        "default, 100 for spin)")


def _add_learned_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--library", default="", help="momp player: primitive library (train library)")
    p.add_argument("--crkr", default="", help="momp player: CrKR model (train crkr)")
    p.add_argument("--predictor", default="",
                   help="momp player: GPR predictor (train-predictor; default: physical model)")
    p.add_argument("--configuration", default="crkr",
                   help="momp player: hitting configuration from crkr (default) or analytical")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="tt-drake", description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)

    serve = sub.add_parser("serve", help="serve balls at a player and report what happened")
    serve.add_argument("--player", default="idle", help="which player returns the serves")
    serve.add_argument("--serves", type=_positive_int, default=10, help="number of serves")
    serve.add_argument("--seed", type=int, default=0, help="base seed of the run")
    serve.add_argument("--html", default=None, help="write a self-contained Meshcat recording")
    serve.add_argument("--json", default=None, help="write the summary and one record per serve")
    serve.add_argument("--quiet", action="store_true", help="no progress bar")
    serve.add_argument("--workers", type=_positive_int, default=1,
                       help="parallel worker processes (not with --html; default 1)")
    serve.add_argument("--perception", choices=("camera", "oracle"), default=None,
                       help="what the player sees: camera (+ EKF) or oracle (the true ball "
                            "state); default: the scenario's (camera)")
    serve.add_argument("--ceiling", action="store_true",
                       help="also play the same serves with the oracle analytical player and "
                            "report returnable_rate and return_rate_of_returnable")
    _add_scenario_options(serve)
    _add_learned_options(serve)

    bench = sub.add_parser("bench", help="time serve episodes against a C++ reference diagram")
    bench.add_argument("--serves", type=_positive_int, default=10)
    bench.add_argument("--seed", type=int, default=0)
    bench.add_argument("--player", default="idle")
    bench.add_argument("--json", default=None, help="write the measurements as JSON")
    _add_scenario_options(bench)
    _add_learned_options(bench)

    collect = sub.add_parser("collect", help="record teacher demonstrations (resumable)")
    collect.add_argument("--player", default="analytical")
    collect.add_argument("--serves", type=_positive_int, default=100)
    collect.add_argument("--seed", type=int, default=0)
    collect.add_argument("--out", required=True, help="dataset folder (created, or resumed)")
    collect.add_argument("--workers", type=_positive_int, default=None,
                         help="parallel worker processes (default: all cores)")
    collect.add_argument("--quiet", action="store_true", help="no progress bar")
    _add_scenario_options(collect)

    pools = sub.add_parser("serves", help="the serve distributions' real-ball pools")
    pools.add_argument("--info", action="store_true",
                       help="print how many balls each pool (and split) holds")
    _add_scenario_options(pools)

    sub.add_parser("models", help="rewrite the generated model files in models/")

    learn = sub.add_parser("train", help="train the learned player's library or CrKR model")
    learn.add_argument("artefact", choices=("library", "crkr"))
    learn.add_argument("--data", required=True, help="teacher dataset folder (tt-drake collect)")
    learn.add_argument("--out", required=True, help="artefact file to write (.npz)")
    learn.add_argument("--primitives", type=_positive_int, default=300,
                       help="library: at most this many hitting primitives (default 300)")
    learn.add_argument("--samples", type=_positive_int, default=2500,
                       help="crkr: at most this many teacher pairs (default 2500)")

    train = sub.add_parser("train-predictor", help="train the GPR hitting-point predictor")
    train.add_argument("--serves", type=_positive_int, default=1000)
    train.add_argument("--seed", type=int, default=0)
    train.add_argument("--out", required=True, help="predictor file to write (.npz)")
    train.add_argument("--quiet", action="store_true", help="no progress bar")
    evalp = sub.add_parser("eval-predictor", help="GPR vs physical model on held-out serves")
    evalp.add_argument("--model", required=True, help="predictor file from train-predictor")
    evalp.add_argument("--serves", type=_positive_int, default=3500)
    evalp.add_argument("--seed", type=int, default=1)
    evalp.add_argument("--json", default=None, help="write the metrics as JSON")
    evalp.add_argument("--quiet", action="store_true", help="no progress bar")

    rep = sub.add_parser("reproduce", help="the paper's experiments from nothing, with a report "
                                           "(resumable)")
    rep.add_argument("--out", required=True, help="run folder (created, or resumed)")
    rep.add_argument("--quick", action="store_true",
                     help="every stage on few serves (minutes; the CI run)")
    rep.add_argument("--workers", type=_positive_int, default=None,
                     help="parallel worker processes (default: all cores)")
    rep.add_argument("--executor", default="local",
                     help="where rollouts run: local (default) or ray")
    rep.add_argument("--quiet", action="store_true", help="no progress output")
    return parser


def _scenario(args):
    from tt_drake.diagrams.scenario import load_scenario, validate

    scenario = load_scenario(args.scenario)
    if getattr(args, "library", None) is not None:
        learned = scenario.learned
        learned.library = args.library or learned.library
        learned.crkr = args.crkr or learned.crkr
        learned.predictor = args.predictor or learned.predictor
        learned.configuration = args.configuration
    if args.distribution is not None:
        scenario.launcher.distribution = args.distribution
        validate(scenario, "--distribution")
    if args.spin_max is not None:
        scenario.launcher.spin_max = args.spin_max
        validate(scenario, "--spin-max")
    if getattr(args, "perception", None) is not None:
        scenario.perception = args.perception
    _check_serves(scenario)
    return scenario


def _check_serves(scenario) -> None:
    """Fail with one line before any simulation if the launcher's data file is unusable (a
    split asked of a file without ids, a malformed file)."""
    from tt_drake.serves import ServeSampler

    c = scenario.launcher
    ServeSampler(c.distribution, c.spin_max, c.real_serves or None,
                 rally_path=c.rallies or None).check()


def _check_player(name: str) -> None:
    from tt_drake.diagrams.episodes import PLAYERS, PlayerError

    if name not in PLAYERS:
        raise PlayerError(f"unknown player {name!r}; choose one of {', '.join(PLAYERS)}")


def _check_learned(player: str, scenario) -> None:
    """Fail with one line before any simulation if a learned player's artefacts are unusable."""
    from tt_drake.diagrams.episodes import LEARNED_PLAYERS, load_learned_player

    if player in LEARNED_PLAYERS:
        load_learned_player(scenario, primitives=player == "momp")


def _serve(args) -> None:
    from tt_drake.diagrams.serve import format_summary, run_serves

    _check_player(args.player)
    scenario = _scenario(args)
    _check_learned(args.player, scenario)
    data = run_serves(scenario, args.player, args.serves, args.seed, args.html, args.json,
                      progress=not args.quiet, workers=args.workers, ceiling=args.ceiling)
    print(format_summary(data))
    for path in (args.json, args.html):
        if path:
            print(f"wrote {path}")


def _serves(args) -> None:
    from tt_drake.serves import DISTRIBUTIONS, POOLS, pool_counts

    if not args.info:
        raise CliError("nothing asked: use --info")
    scenario = _scenario(args)
    c = scenario.launcher
    names = ([args.distribution] if args.distribution is not None
             else [d for d in DISTRIBUTIONS if d.partition("-")[0] in POOLS])
    for name in names:
        n = pool_counts(name, c.real_serves or None, c.rallies or None)
        if n["pool"] is None:
            print(f"{name}: drawn by the launcher, no pool")
            continue
        split = "" if "-" not in name else f" in the {name.partition('-')[2]} split"
        print(f"{name}: {n['pool']} of {n['in_split']} balls{split} reach the robot's half "
              f"({n['records']} records in {n['file']})")


def _bench(args) -> None:
    from tt_drake.diagrams.bench import format_bench, run_bench
    from tt_drake.outputs import check_writable, write_json_atomic

    _check_player(args.player)
    scenario = _scenario(args)
    _check_learned(args.player, scenario)
    if args.json:
        check_writable(args.json)
    result = run_bench(scenario, args.serves, args.seed, args.player)
    print(format_bench(result))
    if args.json:
        write_json_atomic(args.json, result)
        print(f"wrote {args.json}")


def _collect(args) -> None:
    from tt_drake.diagrams.collect import collect
    from tt_drake.diagrams.parallel import default_workers

    _check_player(args.player)
    scenario = _scenario(args)
    summary = collect(scenario, args.player, args.serves, args.seed, args.out,
                      args.workers or default_workers(), progress=not args.quiet)
    print(f"{summary['folder']}: {summary['serves']} serves ({summary['simulated']} simulated "
          f"now, {summary['kept']} kept from before), legal return "
          f"{summary['return_rate']:.1%}")


def _models(_args) -> None:
    from tt_drake.modelgen.__main__ import main as write_models

    write_models()


def _train_predictor(args) -> None:
    from tt_drake.diagrams.predictor import format_train, train_predictor

    print(format_train(train_predictor(args.serves, args.seed, args.out,
                                       progress=not args.quiet)))


def _eval_predictor(args) -> None:
    from tt_drake.diagrams.predictor import eval_predictor, format_eval

    print(format_eval(eval_predictor(args.model, args.serves, args.seed, args.json,
                                     progress=not args.quiet)))
    if args.json:
        print(f"wrote {args.json}")


def _train(args) -> None:
    from tt_drake.diagrams.train import format_train, train_crkr, train_library

    if args.artefact == "library":
        summary = train_library(args.data, args.out, args.primitives)
    else:
        summary = train_crkr(args.data, args.out, args.samples)
    print(format_train(summary))


def _reproduce(args) -> None:
    from tt_drake.diagrams.reproduce import reproduce

    report = reproduce(args.out, args.quick, args.workers, args.executor,
                       progress=not args.quiet)
    for row in report["table"]:
        print(f"{row['experiment']}: paper {row['paper']}, ours {row['ours']}")
    print(f"wrote {args.out}/report.md and {args.out}/report.json")


COMMANDS = {"reproduce": _reproduce, "serve": _serve, "bench": _bench, "collect": _collect,
            "models": _models, "serves": _serves,
            "train-predictor": _train_predictor, "eval-predictor": _eval_predictor,
            "train": _train}


def _user_errors() -> tuple[type[BaseException], ...]:
    from tt_drake.diagrams.collect import DatasetError
    from tt_drake.diagrams.episodes import PlayerError
    from tt_drake.diagrams.parallel import ExecutorError
    from tt_drake.diagrams.predictor import PredictorError
    from tt_drake.diagrams.reproduce import ReproduceError
    from tt_drake.diagrams.scenario import ScenarioError
    from tt_drake.diagrams.train import TrainError
    from tt_drake.hitting_point import PredictorFileError
    from tt_drake.learned_player import LearnedArtefactError
    from tt_drake.outputs import OutputError
    from tt_drake.serves import ServeError
    from tt_drake.systems.world import ModelFileError

    return (CliError, ScenarioError, ServeError, PlayerError, ModelFileError, OutputError,
            PredictorError, PredictorFileError, DatasetError, TrainError, LearnedArtefactError,
            ReproduceError, ExecutorError)


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        COMMANDS[args.command](args)
    except _user_errors() as err:
        print(f"tt-drake {args.command}: error: {err}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print(f"tt-drake {args.command}: interrupted", file=sys.stderr)
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main())

