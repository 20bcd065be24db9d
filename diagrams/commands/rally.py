"""``tt-drake rally``: two robots, one at each end of the table, keep a ball in play
(docs/rally.md)."""

import sys

from tt_drake.constants import MAX_EXCHANGES
from tt_drake.diagrams.commands.options import (
    add_artefacts_option,
    add_command,
    add_html_option,
    add_json_option,
    add_learned_options,
    add_quiet_option,
    add_scenario_options,
    add_seed_option,
    add_workers_option,
    check_learned,
    check_player_name,
    chosen_artefact_set,
    names_artefacts,
    one_of,
    positive_int,
    scenario_from_options,
    serve_count,
)
from tt_drake.diagrams.players import player_names, plays_learned_artefacts
from tt_drake.models import artefact_files, artefact_settings
from tt_drake.rally_aim import AIMS


def register(subparsers) -> None:
    p = add_command(subparsers, "rally", help="two robots, one at each end of the table, keep "
                                              "a ball in play (docs/rally.md)")
    p.add_argument("--players", nargs=2, metavar=("A", "B"), default=["analytical",
                                                                     "analytical"],
                   type=one_of("player", player_names()),
                   help=f"robot A's and robot B's players, each one of "
                        f"{', '.join(player_names())}")
    p.add_argument("--rallies", type=serve_count, default=10, help="number of rallies")
    add_seed_option(p)
    p.add_argument("--start", choices=("serve", "rally"), default="serve",
                   help="the first ball, to robot A: a launcher serve of the scenario's "
                        "distribution, or a real rally ball (rallies.json)")
    p.add_argument("--aim", choices=AIMS, default=None,
                   help="each stroke's aim: cooperative (one target, flat strokes) or "
                        "competitive (target, pace and spin drawn per stroke; "
                        "docs/rally.md); default: the scenario's rally.aim")
    p.add_argument("--max-exchanges", type=positive_int, default=None,
                   help=f"stop a rally after this many exchanges, at most {MAX_EXCHANGES} "
                        "(default: the scenario's, 50)")
    add_html_option(p)
    add_json_option(p, "write the summary and one record per rally")
    add_quiet_option(p)
    add_workers_option(p)
    add_scenario_options(p)
    add_learned_options(p, artefact_sets=False)
    add_artefacts_option(p, "with its moving goal",
                         ". The rally plays a set's primitive library and moving goal, with the "
                         "rally's hitting configuration and the physical-model hitting point "
                         "(docs/rally.md)")
    p.add_argument("--spinless-configuration", action="store_true",
                   help="learned players: the analytical hitting configuration for a "
                        "spinless ball (the serve's), instead of for the predicted spin at "
                        "the hit (docs/rally.md)")
    p.set_defaults(run=run)


def run(args) -> None:
    # The rally runner and the scenario's schema import pydrake: loaded when the command runs,
    # not for --help.
    from tt_drake.diagrams.rally import format_rally_summary, run_rallies
    from tt_drake.diagrams.scenario import sets_field

    players = tuple(args.players)
    for player in players:
        check_player_name(player)
    args.player = None  # the shipped artefacts are chosen by use_rally_artefacts
    scenario = scenario_from_options(args)
    if args.configuration is None and not sets_field(args.scenario, "learned.configuration"):
        # The shipped CrKR model learned the serve task's target; the rally aims elsewhere.
        scenario.learned.configuration = "analytical"
    # The other robot's returns spin: the learned players' racket follows the spinning contact
    # point unless told not to (docs/rally.md, "Spin-aware learned players").
    scenario.learned.spin_aware = not args.spinless_configuration
    if args.aim is not None:
        scenario.rally.aim = args.aim
    use_rally_artefacts(players, scenario, args.artefacts)
    for player in players:
        check_learned(player, scenario)
    data = run_rallies(scenario, players, args.rallies, args.seed, args.start, args.html,
                       args.json, progress=not args.quiet, workers=args.workers,
                       max_exchanges=args.max_exchanges)
    print(format_rally_summary(data))
    for path in (args.json, args.html):
        if path:
            print(f"wrote {path}")


def use_rally_artefacts(players: tuple, scenario, artefact_set: str | None = None) -> None:
    """Learned players given no artefact play the rally with a set's primitive library
    (``momp``) and moving goal, the set ``--artefacts`` names (by default the shipped ``paper``
    set) and, only with ``--configuration crkr``, its CrKR model; the hitting point comes from
    the physical model: the shipped GPRs and CrKR models learned launcher serves and the serve
    task's target, and fail on the other robot's returns (docs/rally.md). A set named with
    artefact files is refused (CliError, one line)."""
    learned = scenario.learned
    named = names_artefacts(learned, artefact_set)
    if not any(plays_learned_artefacts(p) for p in players) or named:
        return
    chosen, where = chosen_artefact_set(artefact_set)
    files = artefact_files(chosen)
    if "momp" in players:
        learned.library = files["library"]
    if learned.configuration == "crkr":
        learned.crkr = files["crkr"]
    learned.moving_goal = learned.moving_goal or artefact_settings(chosen).moving_goal
    spin = (", for the predicted spin" if learned.configuration == "analytical"
            and learned.spin_aware else "")
    print(f"tt-drake: the learned players use {where} (hitting configuration: "
          f"{learned.configuration}{spin}; moving goal: "
          f"{'on' if learned.moving_goal else 'off'}; hitting point: the physical model)",
          file=sys.stderr)
