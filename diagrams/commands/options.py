"""What the ``tt-drake`` commands share: the parser classes, the option types, the option groups
several commands take (each defined once here) and the scenario those options describe.

Building the parser imports no pydrake (``--help`` and option errors are instant): the names an
option accepts come from light registries or from the tuples below, and the scenario is loaded
only when a command runs.
"""

import argparse
import sys
from collections.abc import Callable
from pathlib import Path

from tt_drake.constants import MAX_SEED, MAX_SERVES
from tt_drake.diagrams.players import (
    check_player,
    player_names,
    plays_learned_artefacts,
    registered_player,
)
from tt_drake.errors import BadInputError
from tt_drake.models import exported_artefact_set, shipped_artefact, use_artefact_set
from tt_drake.serves import DISTRIBUTIONS, serve_sampler

EXIT_BAD_INPUT = 2

# The names these options accept (their registries import pydrake, too slow for --help; tests
# check these equal tt_drake.systems.hitting_configuration.SOURCES and tt_drake.models.
# ARTEFACT_SETS). The players' registry imports no pydrake: --player offers every player
# registered when the parser is built.
CONFIGURATION_NAMES = ("crkr", "analytical")
ARTEFACT_SET_NAMES = ("paper", "hard")


class CliError(BadInputError):
    """A user error found by a command itself: printed as one line, exit status 2."""


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Shows every option's default, except the empty ones (no file, off, none)."""

    def _get_help_string(self, action):
        if action.default is None or action.default is False or action.default == "" \
                or action.required:
            return action.help
        return super()._get_help_string(action)


class OneLineParser(argparse.ArgumentParser):
    """argparse whose option errors are what the README promises: one line on stderr,
    ``tt-drake <command>: error: ...``, and exit status 2 (no usage block)."""

    def error(self, message: str):
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {' '.join(message.split())}\n")


def add_command(subparsers, name: str, **kwargs) -> argparse.ArgumentParser:
    """The subparser of command ``name``, with the commands' help formatter."""
    return subparsers.add_parser(name, formatter_class=HelpFormatter, **kwargs)


# -- option types ----------------------------------------------------------------------------

def whole_number(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None


def positive_int(text: str) -> int:
    value = whole_number(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {value}")
    return value


def one_of(what: str, names: tuple[str, ...]) -> Callable[[str], str]:
    """An argparse ``type`` accepting one of ``names``; the error names the value and the
    choices (also given as ``choices=``, so that ``--help`` lists them)."""
    def check(text: str) -> str:
        if text not in names:
            raise argparse.ArgumentTypeError(f"unknown {what} {text!r}; choose one of "
                                             f"{', '.join(names)}")
        return text
    check.__name__ = what
    return check


def artefact_set_or_folder(text: str) -> str:
    """An argparse ``type`` for ``--artefacts``: a shipped set's name or an existing folder
    (checked as an exported set when the scenario is made)."""
    if text not in ARTEFACT_SET_NAMES and not Path(text).is_dir():
        raise argparse.ArgumentTypeError(f"{text!r} is neither an artefact set "
                                         f"({', '.join(ARTEFACT_SET_NAMES)}) nor a folder")
    return text


def bounded_float(low: float, high: float | None) -> Callable[[str], float]:
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


def serve_count(text: str) -> int:
    """--serves: 1 .. MAX_SERVES (a run keeps every serve's result for its summary)."""
    value = positive_int(text)
    if value > MAX_SERVES:
        raise argparse.ArgumentTypeError(f"must be at most {MAX_SERVES}, got {value}")
    return value


def seed(text: str) -> int:
    """--seed: a whole number in [0, MAX_SEED]."""
    value = whole_number(text)
    if not 0 <= value <= MAX_SEED:
        raise argparse.ArgumentTypeError(f"must be in [0, {MAX_SEED}], got {value}")
    return value


def distribution(text: str) -> str:
    if text not in DISTRIBUTIONS:
        raise argparse.ArgumentTypeError(f"serve distribution {text!r} is not one of "
                                         f"{', '.join(DISTRIBUTIONS)}")
    return text


# -- the options several commands take -------------------------------------------------------

def add_serves_option(p: argparse.ArgumentParser, default: int,
                      help: str = "number of serves") -> None:
    p.add_argument("--serves", type=serve_count, default=default, help=help)


def add_seed_option(p: argparse.ArgumentParser, default: int = 0,
                    help: str = "base seed of the run") -> None:
    p.add_argument("--seed", type=seed, default=default, help=help)


def add_workers_option(p: argparse.ArgumentParser, default: int | None = 1,
                       help: str = "parallel worker processes (not with --html)") -> None:
    p.add_argument("--workers", type=positive_int, default=default, help=help)


def add_html_option(p: argparse.ArgumentParser) -> None:
    p.add_argument("--html", default=None, help="write a self-contained Meshcat recording")


def add_json_option(p: argparse.ArgumentParser, help: str) -> None:
    p.add_argument("--json", default=None, help=help)


def add_quiet_option(p: argparse.ArgumentParser, help: str = "no progress bar") -> None:
    p.add_argument("--quiet", action="store_true", help=help)


def add_scenario_option(p: argparse.ArgumentParser,
                        help: str = "scenario name (models/<name>.yaml) or YAML path") -> None:
    """``--scenario``: the scenario a command or script plays (:func:`load_scenario`'s name or
    path; ``ideal_robot`` for the ideal drives and camera), ``default`` unless given."""
    p.add_argument("--scenario", default="default", help=help)


def add_scenario_options(p: argparse.ArgumentParser) -> None:
    add_scenario_option(p)
    p.add_argument("--distribution", default=None, type=distribution, choices=DISTRIBUTIONS,
                   help="override the launcher's serve distribution (default: the scenario's)")
    p.add_argument("--spin-max", type=float, default=None,
                   help="override the launcher's spin per axis (rad/s; 0: the distribution's "
                        "default, 100 for spin; default: the scenario's)")


def add_learned_options(p: argparse.ArgumentParser, artefact_sets: bool = True) -> None:
    p.add_argument("--library", default="",
                   help="momp player: primitive library (tt-drake train library). With none of "
                        "--library, --crkr, --predictor (and none in the scenario) the learned "
                        "players use the artefacts shipped in tt_drake/models/learned/")
    p.add_argument("--crkr", default="", help="learned players: CrKR model (tt-drake train crkr)")
    p.add_argument("--predictor", default="",
                   help="learned players: GPR predictor (tt-drake train-predictor); not given "
                        "with --library or --crkr: the physical model")
    p.add_argument("--configuration", default=None,
                   type=one_of("hitting configuration", CONFIGURATION_NAMES),
                   choices=CONFIGURATION_NAMES,
                   help="learned players: hitting configuration from the CrKR model or the "
                        "analytical IK" + (" (default: the scenario's, crkr; with --artefacts, "
                                           "the set's; the crkr player: always crkr)"
                                           if artefact_sets else
                                           " (default: the scenario's if it names one, else "
                                           "analytical: the rally aims elsewhere than the "
                                           "serve task the shipped CrKR model learned)"))
    if artefact_sets:
        add_artefacts_option(p, "played with its protocol's settings")


def add_artefacts_option(p: argparse.ArgumentParser, exported: str, more: str = "") -> None:
    """``--artefacts``: a shipped set's name or an exported set's folder; ``exported`` says how
    this command plays an exported set, ``more`` what else it says."""
    p.add_argument("--artefacts", default=None, type=artefact_set_or_folder,
                   metavar="{" + ",".join(ARTEFACT_SET_NAMES) + "} or DIR",
                   help="learned players: the artefact set to play with when no file is named "
                        "(paper: tt_drake/models/learned/, the default; hard: "
                        "tt_drake/models/learned-hard/, trained on spin, real and rally serves, "
                        "played with the hitting DMP's moving goal; DIR: a set tt-drake "
                        f"reproduce exported to DIR/artefacts, {exported}){more}")


def add_perception_option(p: argparse.ArgumentParser) -> None:
    p.add_argument("--perception", choices=("camera", "oracle"), default=None,
                   help="what the player sees: camera (+ EKF) or oracle (the true ball "
                        "state); default: the scenario's (camera)")


def add_player_option(p: argparse.ArgumentParser, default: str | None) -> None:
    names = player_names()
    p.add_argument("--player", default=default, type=one_of("player", names),
                   choices=names,
                   help="which player returns the serves" + ("" if default else
                                                             " (default: idle, which never "
                                                             "swings)"))


# -- the scenario the options describe -------------------------------------------------------

def scenario_from_options(args):
    """The scenario ``--scenario`` names, with the other scenario, learned-player and
    perception options of ``args`` applied (those a command has)."""
    # The scenario's schema imports pydrake: loaded when a command runs, not for --help.
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
        use_shipped_artefacts(args.player, scenario, getattr(args, "artefacts", None), chosen)
    if args.distribution is not None:
        scenario.launcher.distribution = args.distribution
        validate(scenario, "--distribution")
    if args.spin_max is not None:
        scenario.launcher.spin_max = args.spin_max
        validate(scenario, "--spin-max")
    if getattr(args, "perception", None) is not None:
        scenario.perception = args.perception
    check_serves(scenario)
    return scenario


def use_shipped_artefacts(player: str | None, scenario, artefact_set: str | None = None,
                          configuration_given: bool = False) -> None:
    """A learned player given no artefact (none on the command line, none in the scenario)
    plays with a shipped set: ``artefact_set`` (``--artefacts``), by default ``paper``, the
    ones in tt_drake/models/learned/ (what ``make demo`` shows), with the set's moving goal and,
    unless ``--configuration`` or the scenario chose one, the set's hitting configuration (the
    ``crkr`` player's is always its CrKR model). A set is the whole player: naming files too is
    refused (CliError, one line)."""
    learned = scenario.learned
    named = names_artefacts(learned, artefact_set)
    if not plays_learned_artefacts(player) or named:
        return
    chosen, where = chosen_artefact_set(artefact_set)
    use_artefact_set(learned, chosen, configuration_given or player == "crkr")
    print(f"tt-drake: the {player} player uses {where} (hitting configuration: "
          f"{learned.configuration}, moving goal: {'on' if learned.moving_goal else 'off'})",
          file=sys.stderr)


def names_artefacts(learned, artefact_set: str | None) -> bool:
    """Whether the scenario's ``learned`` settings (or the command line) name artefact files;
    CliError (one line) if a set is named as well: a set is the whole player."""
    named = bool(learned.library or learned.crkr or learned.predictor)
    if artefact_set is not None and named:
        raise CliError("--artefacts picks a shipped set of library, CrKR and predictor; "
                       "name either it or artefact files, not both")
    return named


def chosen_artefact_set(artefact_set: str | None):
    """(the set ``--artefacts`` names, by default ``paper``: a shipped set's name or the
    :class:`tt_drake.models.ArtefactSet` exported to a folder; where it is, for the notice)."""
    chosen = artefact_set or "paper"
    if chosen in ARTEFACT_SET_NAMES:
        return chosen, f"the shipped artefacts in {shipped_artefact('library', chosen).parent}"
    return exported_artefact_set(chosen), f"the exported artefacts in {chosen}"


def check_serves(scenario) -> None:
    """Fail with one line before any simulation if the launcher's data file is unusable (a
    split asked of a file without ids, a malformed file)."""
    serve_sampler(scenario.launcher).check()


def check_player_name(name: str) -> None:
    registered_player(name)  # PlayerError naming the choices


def check_learned(player: str, scenario) -> None:
    """Fail with one line before any simulation if the player cannot play the scenario (a
    learned player's artefacts are unusable; they are kept for the diagram built next)."""
    check_player(player, scenario)
