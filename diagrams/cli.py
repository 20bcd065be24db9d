"""The ``tt-drake`` command.

    tt-drake serve  --player idle --serves N --seed S [--scenario default] [--distribution D]
                    [--spin-max W] [--perception camera|oracle] [--ceiling]
                    [--html out.html] [--json out.json]
    tt-drake serves --info [--distribution D]   (the real-ball pools' counts, docs/serves.md)
    tt-drake bench  [--serves N] [--json out.json]
    tt-drake collect --player analytical --serves N --seed S --out DIR [--workers W]
                     [--perception camera|oracle]
    tt-drake models  (rewrite the generated model files in models/)
    tt-drake train library|crkr --data DIR --out FILE [--primitives 300] [--samples 2500]
                                [--stimulus paper|spin] [--demonstrations planned|recorded]
                                [--alpha-y 35] [--hitting-borrow 0.5] [--stage-borrow 0.5]
                                [--kappa 1] [--zeta 0.25] [--threshold 0.1]
    tt-drake serve --player momp [--library FILE --crkr FILE --predictor FILE]
                   [--configuration crkr|analytical] ...   (no FILE: the shipped artefacts)
    tt-drake serve --player momp --artefacts hard ...  (the hard protocol's shipped artefacts)
    tt-drake serve --player crkr [--crkr FILE --predictor FILE] ...  (CrKR + teacher's quintics)
    tt-drake reproduce --out DIR [--quick] [--workers N] [--executor local|ray]
                       [--protocol paper|hard|hard-stiff] [--sizes full|quick|artefacts]
                       [--until STAGE]
    tt-drake rally --players A B --rallies N --seed S [--start serve|rally] [--max-exchanges 50]
                   [--aim cooperative|competitive] [--html out.html] [--json out.json]
                   [--workers W]   (docs/rally.md)
    tt-drake --version

Bad input (an unknown or malformed scenario field, a missing model or data file, an unknown
distribution or player, N <= 0, an unwritable output path) gives one line naming the problem on
stderr and exit status 2, with no traceback and no partial output file.
"""

import argparse
import sys
from collections.abc import Callable

from tt_drake.constants import MAX_EXCHANGES
from tt_drake.diagrams.players import (
    check_player,
    player_names,
    plays_learned_artefacts,
    registered_player,
)
from tt_drake.rally_aim import AIMS

EXIT_BAD_INPUT = 2


class CliError(Exception):
    """A user error: printed as one line, exit status 2."""


# The names each option accepts (their registries import pydrake, too slow for --help; tests
# check these equal tt_drake.systems.hitting_configuration.SOURCES and
# tt_drake.diagrams.parallel.EXECUTORS). The players' registry imports no pydrake: --player
# offers every player registered when the parser is built.
CONFIGURATION_NAMES = ("crkr", "analytical")
ARTEFACT_SET_NAMES = ("paper", "hard")  # tt_drake.models.ARTEFACT_SETS
PROTOCOL_NAMES = ("paper", "hard", "hard-stiff")  # tt_drake.diagrams.reproduce.PROTOCOLS
REPRODUCE_STAGES = ("teacher", "predictor", "library", "crkr", "single", "gamma1",
                    "responsibility", "power", "final")  # tt_drake.diagrams.reproduce.STAGES
EXECUTOR_NAMES = ("local", "ray")


class _HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Shows every option's default, except the empty ones (no file, off, none)."""

    def _get_help_string(self, action):
        if action.default is None or action.default is False or action.default == "" \
                or action.required:
            return action.help
        return super()._get_help_string(action)


def _version() -> str:
    from tt_drake.provenance import package_version

    return f"tt-drake {package_version()}"


class OneLineParser(argparse.ArgumentParser):
    """argparse whose option errors are what the README promises: one line on stderr,
    ``tt-drake <command>: error: ...``, and exit status 2 (no usage block)."""

    def error(self, message: str):
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {' '.join(message.split())}\n")


def _whole_number(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None


def _positive_int(text: str) -> int:
    value = _whole_number(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {value}")
    return value


def _one_of(what: str, names: tuple[str, ...]) -> Callable[[str], str]:
    """An argparse ``type`` accepting one of ``names``; the error names the value and the
    choices (also given as ``choices=``, so that ``--help`` lists them)."""
    def check(text: str) -> str:
        if text not in names:
            raise argparse.ArgumentTypeError(f"unknown {what} {text!r}; choose one of "
                                             f"{', '.join(names)}")
        return text
    check.__name__ = what
    return check


def _bounded_float(low: float, high: float | None) -> Callable[[str], float]:
    """An argparse ``type``: a number above ``low`` (strictly when ``high`` is None, else in
    [low, high])."""
    def check(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
        if high is None and not (value > low and value < float("inf")):
            raise argparse.ArgumentTypeError(f"must be a finite number > {low:g}, got {text}")
        if high is not None and not low <= value <= high:
            raise argparse.ArgumentTypeError(f"must lie in [{low:g}, {high:g}], got {text}")
        return value
    check.__name__ = "number"
    return check


def _serve_count(text: str) -> int:
    """--serves: 1 .. MAX_SERVES (a run keeps every serve's result for its summary)."""
    from tt_drake.constants import MAX_SERVES

    value = _positive_int(text)
    if value > MAX_SERVES:
        raise argparse.ArgumentTypeError(f"must be at most {MAX_SERVES}, got {value}")
    return value


def _seed(text: str) -> int:
    """--seed: a whole number in [0, MAX_SEED]."""
    from tt_drake.constants import MAX_SEED

    value = _whole_number(text)
    if not 0 <= value <= MAX_SEED:
        raise argparse.ArgumentTypeError(f"must be in [0, {MAX_SEED}], got {value}")
    return value


def _distribution(text: str) -> str:
    from tt_drake.serves import DISTRIBUTIONS

    if text not in DISTRIBUTIONS:
        raise argparse.ArgumentTypeError(f"serve distribution {text!r} is not one of "
                                         f"{', '.join(DISTRIBUTIONS)}")
    return text


def _add_scenario_options(p: argparse.ArgumentParser) -> None:
    from tt_drake.serves import DISTRIBUTIONS

    p.add_argument("--scenario", default="default",
                   help="scenario name (models/<name>.yaml) or YAML path")
    p.add_argument("--distribution", default=None, type=_distribution, choices=DISTRIBUTIONS,
                   help="override the launcher's serve distribution (default: the scenario's)")
    p.add_argument("--spin-max", type=float, default=None,
                   help="override the launcher's spin per axis (rad/s; 0: the distribution's "
                        "default, 100 for spin; default: the scenario's)")


def _add_learned_options(p: argparse.ArgumentParser, artefact_sets: bool = True) -> None:
    p.add_argument("--library", default="",
                   help="momp player: primitive library (tt-drake train library). With none of "
                        "--library, --crkr, --predictor (and none in the scenario) the learned "
                        "players use the artefacts shipped in tt_drake/models/learned/")
    p.add_argument("--crkr", default="", help="learned players: CrKR model (tt-drake train crkr)")
    p.add_argument("--predictor", default="",
                   help="learned players: GPR predictor (tt-drake train-predictor); not given "
                        "with --library or --crkr: the physical model")
    p.add_argument("--configuration", default=None,
                   type=_one_of("hitting configuration", CONFIGURATION_NAMES),
                   choices=CONFIGURATION_NAMES,
                   help="learned players: hitting configuration from the CrKR model or the "
                        "analytical IK" + (" (default: the scenario's, crkr; with --artefacts, "
                                           "the set's; the crkr player: always crkr)"
                                           if artefact_sets else
                                           " (default: the scenario's if it names one, else "
                                           "analytical: the rally aims elsewhere than the "
                                           "serve task the shipped CrKR model learned)"))
    if not artefact_sets:
        return
    p.add_argument("--artefacts", default=None, type=_one_of("artefact set", ARTEFACT_SET_NAMES),
                   choices=ARTEFACT_SET_NAMES,
                   help="learned players: the shipped artefact set to play with when no file "
                        "is named (paper: tt_drake/models/learned/, the default; hard: "
                        "tt_drake/models/learned-hard/, trained on spin, real and rally serves, "
                        "played with the hitting DMP's moving goal)")


def _add_perception_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--perception", choices=("camera", "oracle"), default=None,
                        help="what the player sees: camera (+ EKF) or oracle (the true ball "
                             "state); default: the scenario's (camera)")


def _add_player_option(p: argparse.ArgumentParser, default: str | None) -> None:
    names = player_names()
    p.add_argument("--player", default=default, type=_one_of("player", names),
                   choices=names,
                   help="which player returns the serves" + ("" if default else
                                                             " (default: idle, which never "
                                                             "swings)"))


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(prog="tt-drake", description=__doc__.split("\n")[0],
                                     formatter_class=_HelpFormatter)
    parser.add_argument("--version", action="version", version=_version())
    sub = parser.add_subparsers(dest="command", required=True)

    def command(name: str, **kwargs) -> argparse.ArgumentParser:
        return sub.add_parser(name, formatter_class=_HelpFormatter, **kwargs)

    serve = command("serve", help="serve balls at a player and report what happened")
    _add_player_option(serve, None)
    serve.add_argument("--serves", type=_serve_count, default=10, help="number of serves")
    serve.add_argument("--seed", type=_seed, default=0, help="base seed of the run")
    serve.add_argument("--html", default=None, help="write a self-contained Meshcat recording")
    serve.add_argument("--json", default=None, help="write the summary and one record per serve")
    serve.add_argument("--quiet", action="store_true", help="no progress bar")
    serve.add_argument("--workers", type=_positive_int, default=1,
                       help="parallel worker processes (not with --html)")
    _add_perception_option(serve)
    serve.add_argument("--ceiling", action="store_true",
                       help="also play the same serves with the oracle strategies (the "
                            "returnable bound, docs/rules.md) and report returnable_rate, "
                            "return_rate_of_returnable and returns_outside_ceiling")
    serve.add_argument("--ceiling-from", default=None, metavar="JSON",
                       help="as --ceiling, with the returnable serves of this earlier --ceiling "
                            "--json run of the same serves (no oracle runs)")
    _add_scenario_options(serve)
    _add_learned_options(serve)

    rally = command("rally", help="two robots, one at each end of the table, keep a ball in "
                                  "play (docs/rally.md)")
    rally.add_argument("--players", nargs=2, metavar=("A", "B"), default=["analytical",
                                                                         "analytical"],
                       type=_one_of("player", player_names()),
                       help=f"robot A's and robot B's players, each one of "
                            f"{', '.join(player_names())}")
    rally.add_argument("--rallies", type=_serve_count, default=10, help="number of rallies")
    rally.add_argument("--seed", type=_seed, default=0, help="base seed of the run")
    rally.add_argument("--start", choices=("serve", "rally"), default="serve",
                       help="the first ball, to robot A: a launcher serve of the scenario's "
                            "distribution, or a real rally ball (rallies.json)")
    rally.add_argument("--aim", choices=AIMS, default=None,
                       help="each stroke's aim: cooperative (one target, flat strokes) or "
                            "competitive (target, pace and spin drawn per stroke; "
                            "docs/rally.md); default: the scenario's rally.aim")
    rally.add_argument("--max-exchanges", type=_positive_int, default=None,
                       help=f"stop a rally after this many exchanges, at most {MAX_EXCHANGES} "
                            "(default: the scenario's, 50)")
    rally.add_argument("--html", default=None, help="write a self-contained Meshcat recording")
    rally.add_argument("--json", default=None, help="write the summary and one record per rally")
    rally.add_argument("--quiet", action="store_true", help="no progress bar")
    rally.add_argument("--workers", type=_positive_int, default=1,
                       help="parallel worker processes (not with --html)")
    _add_scenario_options(rally)
    _add_learned_options(rally, artefact_sets=False)
    rally.add_argument("--spinless-configuration", action="store_true",
                       help="learned players: the analytical hitting configuration for a "
                            "spinless ball (the serve's), instead of for the predicted spin at "
                            "the hit (docs/rally.md)")

    bench = command("bench", help="time serve episodes against a C++ reference diagram")
    bench.add_argument("--serves", type=_serve_count, default=10, help="number of serves")
    bench.add_argument("--seed", type=_seed, default=0, help="base seed of the run")
    _add_player_option(bench, "idle")
    bench.add_argument("--json", default=None, help="write the measurements as JSON")
    bench.add_argument("--workers", type=_positive_int, default=1,
                       help="also time the serves on this many worker processes and project "
                            "10,000 serves (default 1: not)")
    _add_scenario_options(bench)
    _add_learned_options(bench)

    collect = command("collect", help="record teacher demonstrations (resumable)")
    _add_player_option(collect, "analytical")
    collect.add_argument("--serves", type=_serve_count, default=100, help="number of serves")
    collect.add_argument("--seed", type=_seed, default=0, help="base seed of the run")
    collect.add_argument("--out", required=True, help="dataset folder (created, or resumed)")
    collect.add_argument("--workers", type=_positive_int, default=None,
                         help="parallel worker processes (default: all cores)")
    collect.add_argument("--quiet", action="store_true", help="no progress bar")
    _add_perception_option(collect)
    _add_scenario_options(collect)

    pools = command("serves", help="the serve distributions' real-ball pools")
    pools.add_argument("--info", action="store_true",
                       help="print how many balls each pool (and split) holds")
    _add_scenario_options(pools)

    command("models", help="rewrite the generated model files in models/")

    learn = command("train", help="train the learned player's library or CrKR model")
    learn.add_argument("artefact", choices=("library", "crkr"), help="what to train")
    learn.add_argument("--data", required=True, help="teacher dataset folder (tt-drake collect)")
    learn.add_argument("--out", required=True, help="artefact file to write (.npz)")
    learn.add_argument("--primitives", type=_positive_int, default=300,
                       help="library: at most this many hitting primitives")
    learn.add_argument("--samples", type=_positive_int, default=2500,
                       help="crkr: at most this many teacher pairs")
    learn.add_argument("--stimulus", type=_one_of("stimulus", ("paper", "spin")),
                       choices=("paper", "spin"), default="paper",
                       help="the gating network's / CrKR's stimulus: paper = (p_hit, v_hit), "
                            "spin = with the predicted spin at impact (default: paper)")
    learn.add_argument("--demonstrations", type=_one_of("demonstrations", ("planned", "recorded")),
                       choices=("planned", "recorded"), default="planned",
                       help="library: imitate the teacher's executed plan or the arm's recorded "
                            "joint state (default: planned)")
    learn.add_argument("--alpha-y", type=_bounded_float(0.0, None), default=35.0,
                       help="library: the DMP gain alpha_y (Eq. 4; default 35)")
    for name in ("hitting", "stage"):
        learn.add_argument(f"--{name}-borrow", type=_bounded_float(0.0, 1.0), default=0.5,
                           help=f"library: {name} DMP joints whose amplitude is below this "
                                f"fraction of the largest take its shape (0: none; default 0.5)")
    from tt_drake.responsibility import ResponsibilityParams

    responsibility = ResponsibilityParams()  # the defaults are the paper profile's
    learn.add_argument("--kappa", type=_bounded_float(0.0, None),
                       default=responsibility.kappa,
                       help="library: responsibility learning's rate kappa (Eq. 10)")
    learn.add_argument("--zeta", type=_bounded_float(0.0, 100.0), default=responsibility.zeta,
                       help="library: responsibility learning's zeta (Eq. 10)")
    learn.add_argument("--threshold", type=_bounded_float(0.0, 0.99),
                       default=responsibility.threshold,
                       help="library: the responsibility below which a primitive is pruned "
                            "(Algorithm 3)")

    train = command("train-predictor", help="train the GPR hitting-point predictor")
    train.add_argument("--serves", type=_serve_count, default=1000, help="training serves")
    train.add_argument("--seed", type=_seed, default=0, help="base seed of the serves")
    train.add_argument("--out", required=True, help="predictor file to write (.npz)")
    train.add_argument("--distribution", default=None,
                       help="serve distribution, or a comma-separated mix shared evenly (e.g. "
                            "default,spin,real-train); default: default")
    train.add_argument("--features", default="states", choices=("states", "states+spin"),
                       help="GPR inputs: the four observed states (the paper's), or those and "
                            "the estimated spin at the fourth")
    train.add_argument("--quiet", action="store_true", help="no progress bar")
    evalp = command("eval-predictor", help="GPR vs physical model on held-out serves")
    evalp.add_argument("--model", required=True, help="predictor file from train-predictor")
    evalp.add_argument("--serves", type=_serve_count, default=3500, help="held-out serves")
    evalp.add_argument("--seed", type=_seed, default=1, help="base seed of the serves")
    evalp.add_argument("--json", default=None, help="write the metrics as JSON")
    evalp.add_argument("--distribution", default=None,
                       help="held-out serve distribution (or a comma-separated mix); default: "
                            "default")
    evalp.add_argument("--quiet", action="store_true", help="no progress bar")

    rep = command("reproduce", help="the paper's experiments from nothing, with a report "
                                     "(resumable)")
    rep.add_argument("--out", required=True, help="run folder (created, or resumed)")
    rep.add_argument("--quick", action="store_true",
                     help="every stage on few serves (minutes; the CI run)")
    rep.add_argument("--workers", type=_positive_int, default=None,
                     help="parallel worker processes (default: all cores)")
    rep.add_argument("--executor", default="local", type=_one_of("executor", EXECUTOR_NAMES),
                     choices=EXECUTOR_NAMES, help="where rollouts run")
    rep.add_argument("--protocol", default="paper", choices=PROTOCOL_NAMES,
                     help="paper: the paper's experiments on default serves; hard: learn from "
                          "spin and recorded serves, judged on unseen ones against the oracle "
                          "teacher's ceiling (docs/reproducing.md); hard-stiff: the same with "
                          "the stiffer hitting DMP of models/learned-hard/")
    rep.add_argument("--sizes", default=None, choices=("full", "quick", "artefacts"),
                     help="the stages' serve counts, the protocol's: full (the default), quick "
                          "(= --quick), or "
                          "artefacts (the training stages' sizes that made "
                          "models/learned-hard/, with --protocol hard-stiff --until crkr)")
    rep.add_argument("--until", default=None, choices=REPRODUCE_STAGES,
                     help="stop after this stage; from crkr on, export the artefacts trained so "
                          "far to DIR/artefacts/")
    rep.add_argument("--quiet", action="store_true", help="no progress output")
    return parser


def _scenario(args):
    from tt_drake.diagrams.scenario import LearnedPlayerConfig, load_scenario, validate

    scenario = load_scenario(args.scenario)
    if getattr(args, "library", None) is not None:
        # An option given replaces the scenario's setting; one not given leaves it.
        learned = scenario.learned
        learned.library = args.library or learned.library
        learned.crkr = args.crkr or learned.crkr
        learned.predictor = args.predictor or learned.predictor
        chosen = args.configuration is not None or (
            learned.configuration != LearnedPlayerConfig().configuration)
        if args.configuration is not None:
            learned.configuration = args.configuration
        if args.player == "crkr" and learned.configuration != "crkr":
            raise CliError(f"the crkr player plays the CrKR hitting configuration, not "
                           f"{learned.configuration!r} (set by --configuration or the "
                           f"scenario); for the teacher's IK use --player analytical or "
                           f"--player momp --configuration {learned.configuration}")
        _use_shipped_artefacts(args.player, scenario, getattr(args, "artefacts", None), chosen)
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


def _use_shipped_artefacts(player: str | None, scenario, artefact_set: str | None = None,
                          configuration_given: bool = False) -> None:
    """A learned player given no artefact (none on the command line, none in the scenario)
    plays with a shipped set: ``artefact_set`` (``--artefacts``), by default ``paper``, the
    ones in tt_drake/models/learned/ (what ``make demo`` shows), with the set's moving goal and,
    unless ``--configuration`` or the scenario chose one, the set's hitting configuration (the
    ``crkr`` player's is always its CrKR model). A set is the whole player: naming files too is
    refused (CliError, one line)."""
    from tt_drake.models import shipped_artefact, use_artefact_set

    learned = scenario.learned
    named = learned.library or learned.crkr or learned.predictor
    if artefact_set is not None and named:
        raise CliError("--artefacts picks a shipped set of library, CrKR and predictor; "
                         "name either it or artefact files, not both")
    if not plays_learned_artefacts(player) or named:
        return
    chosen = artefact_set or "paper"
    use_artefact_set(learned, chosen, configuration_given or player == "crkr")
    print(f"tt-drake: the {player} player uses the shipped artefacts in "
          f"{shipped_artefact('library', chosen).parent} (hitting configuration: "
          f"{learned.configuration})", file=sys.stderr)


def _check_serves(scenario) -> None:
    """Fail with one line before any simulation if the launcher's data file is unusable (a
    split asked of a file without ids, a malformed file)."""
    from tt_drake.serves import ServeSampler

    c = scenario.launcher
    ServeSampler(c.distribution, c.spin_max, c.real_serves or None,
                 rally_path=c.rallies or None).check()


def _check_player(name: str) -> None:
    registered_player(name)  # PlayerError naming the choices


def _check_learned(player: str, scenario) -> None:
    """Fail with one line before any simulation if the player cannot play the scenario (a
    learned player's artefacts are unusable; they are kept for the diagram built next)."""
    check_player(player, scenario)


def _serve(args) -> None:
    from tt_drake.diagrams.serve import format_summary, run_serves

    chosen = args.player is not None
    player = args.player = args.player or "idle"
    _check_player(player)
    scenario = _scenario(args)
    _check_learned(player, scenario)
    data = run_serves(scenario, player, args.serves, args.seed, args.html, args.json,
                      progress=not args.quiet, workers=args.workers, ceiling=args.ceiling,
                      ceiling_from=args.ceiling_from)
    print(format_summary(data))
    for path in (args.json, args.html):
        if path:
            print(f"wrote {path}")
    if not chosen:
        print("tt-drake serve: no --player given, so this was the idle player: it holds its "
              "posture and never swings (0 % returns is expected); try --player analytical or "
              "--player momp", file=sys.stderr)


def _rally(args) -> None:
    from tt_drake.diagrams.rally import format_rally_summary, run_rallies
    from tt_drake.diagrams.scenario import sets_field

    players = tuple(args.players)
    for player in players:
        _check_player(player)
    args.player = None  # the shipped artefacts are chosen by _use_rally_artefacts
    scenario = _scenario(args)
    if args.configuration is None and not sets_field(args.scenario, "learned.configuration"):
        # The shipped CrKR model learned the serve task's target; the rally aims elsewhere.
        scenario.learned.configuration = "analytical"
    # The other robot's returns spin: the learned players' racket follows the spinning contact
    # point unless told not to (docs/rally.md, "Spin-aware learned players").
    scenario.learned.spin_aware = not args.spinless_configuration
    if args.aim is not None:
        scenario.rally.aim = args.aim
    _use_rally_artefacts(players, scenario)
    for player in players:
        _check_learned(player, scenario)
    data = run_rallies(scenario, players, args.rallies, args.seed, args.start, args.html,
                       args.json, progress=not args.quiet, workers=args.workers,
                       max_exchanges=args.max_exchanges)
    print(format_rally_summary(data))
    for path in (args.json, args.html):
        if path:
            print(f"wrote {path}")


def _use_rally_artefacts(players: tuple, scenario) -> None:
    """Learned players given no artefact play the rally with the shipped primitive library
    (``momp``) and, only with ``--configuration crkr``, the shipped CrKR model; the hitting
    point comes from the physical model: the shipped GPR and CrKR learned launcher serves and
    the serve task's target, and fail on the other robot's returns (docs/rally.md)."""
    from tt_drake.models import shipped_artefact

    learned = scenario.learned
    if not any(plays_learned_artefacts(p) for p in players) or learned.library or learned.crkr \
            or learned.predictor:
        return
    if "momp" in players:
        learned.library = str(shipped_artefact("library"))
    if learned.configuration == "crkr":
        learned.crkr = str(shipped_artefact("crkr"))
    spin = (", for the predicted spin" if learned.configuration == "analytical"
            and learned.spin_aware else "")
    print(f"tt-drake: the learned players use the shipped artefacts in "
          f"{shipped_artefact('library').parent} (hitting configuration: "
          f"{learned.configuration}{spin}; hitting point: the physical model)", file=sys.stderr)


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
    from tt_drake.diagrams.serve import scenario_dict
    from tt_drake.outputs import check_writable, write_json_atomic
    from tt_drake.provenance import run_provenance

    _check_player(args.player)
    scenario = _scenario(args)
    _check_learned(args.player, scenario)
    if args.json:
        check_writable(args.json)
    result = run_bench(scenario, args.serves, args.seed, args.player, args.workers)
    print(format_bench(result))
    if args.json:
        write_json_atomic(args.json, {**run_provenance(), "scenario": scenario_dict(scenario),
                                      **result})
        print(f"wrote {args.json}")


def _collect(args) -> None:
    from tt_drake.diagrams.collect import collect
    from tt_drake.diagrams.inputs import check_inputs
    from tt_drake.diagrams.parallel import default_workers

    _check_player(args.player)
    scenario = _scenario(args)
    check_inputs(scenario)
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
                                       progress=not args.quiet, distribution=args.distribution,
                                       feature_set=args.features)))


def _eval_predictor(args) -> None:
    from tt_drake.diagrams.predictor import eval_predictor, format_eval

    print(format_eval(eval_predictor(args.model, args.serves, args.seed, args.json,
                                     progress=not args.quiet, distribution=args.distribution)))
    if args.json:
        print(f"wrote {args.json}")


def _train(args) -> None:
    from tt_drake.diagrams.train import format_train, train_crkr, train_library
    from tt_drake.dmp import HittingDMP
    from tt_drake.responsibility import ResponsibilityParams
    from tt_drake.stimulus import STIMULI

    stimulus = STIMULI[args.stimulus]
    if args.artefact == "library":
        summary = train_library(args.data, args.out, args.primitives,
                                HittingDMP(alpha_y=args.alpha_y), args.demonstrations, stimulus,
                                args.hitting_borrow, args.stage_borrow,
                                ResponsibilityParams(args.kappa, args.zeta, args.threshold))
    else:
        summary = train_crkr(args.data, args.out, args.samples, stimulus)
    print(format_train(summary))


def _reproduce(args) -> None:
    from tt_drake.diagrams.reproduce import reproduce

    if args.quick and args.sizes not in (None, "quick"):
        raise CliError(f"--quick and --sizes {args.sizes} disagree; give one")
    quick = args.quick or args.sizes == "quick"
    report = reproduce(args.out, quick, args.workers, args.executor,
                       progress=not args.quiet, protocol=args.protocol,
                       sizes=args.sizes, until=args.until)
    for row in report["table"]:
        print(f"{row['experiment']}: paper {row['paper']}, ours {row['ours']}")
    print(f"wrote {args.out}/report.md and {args.out}/report.json")


COMMANDS = {"reproduce": _reproduce, "serve": _serve, "bench": _bench, "collect": _collect,
            "models": _models, "serves": _serves, "rally": _rally,
            "train-predictor": _train_predictor, "eval-predictor": _eval_predictor,
            "train": _train}


def _user_errors() -> tuple[type[BaseException], ...]:
    from tt_drake.diagrams.collect import DatasetError
    from tt_drake.diagrams.episodes import PlayerError, SeedError
    from tt_drake.diagrams.parallel import ExecutorError
    from tt_drake.diagrams.predictor import PredictorError
    from tt_drake.diagrams.reproduce import ReproduceError
    from tt_drake.diagrams.scenario import ScenarioError
    from tt_drake.diagrams.serve import CeilingFileError
    from tt_drake.diagrams.train import TrainError
    from tt_drake.hitting_point import PredictorFileError
    from tt_drake.learned_player import LearnedArtefactError
    from tt_drake.outputs import OutputError
    from tt_drake.serves import ServeError
    from tt_drake.systems.world import ModelFileError

    return (CliError, ScenarioError, ServeError, PlayerError, ModelFileError, OutputError,
            PredictorError, PredictorFileError, DatasetError, TrainError, LearnedArtefactError,
            ReproduceError, ExecutorError, SeedError, CeilingFileError)


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        COMMANDS[args.command](args)
    except _user_errors() as err:
        print(f"tt-drake {args.command}: error: {' '.join(str(err).split())}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except OSError as err:  # the disk or the OS refused (full disk, permission): not a bug
        print(f"tt-drake {args.command}: error: {' '.join(str(err).split())}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print(f"tt-drake {args.command}: interrupted", file=sys.stderr)
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main())

