"""``tt-drake serve``: serve balls at a player and report what happened."""

import sys

from tt_drake.diagrams.commands.options import (
    add_command,
    add_html_option,
    add_json_option,
    add_learned_options,
    add_perception_option,
    add_player_option,
    add_quiet_option,
    add_scenario_options,
    add_seed_option,
    add_serves_option,
    add_workers_option,
    check_learned,
    check_player_name,
    scenario_from_options,
)


def register(subparsers) -> None:
    p = add_command(subparsers, "serve", help="serve balls at a player and report what happened")
    add_player_option(p, None)
    add_serves_option(p, 10)
    add_seed_option(p)
    add_html_option(p)
    add_json_option(p, "write the summary and one record per serve")
    add_quiet_option(p)
    add_workers_option(p)
    add_perception_option(p)
    p.add_argument("--ceiling", action="store_true",
                   help="also play the same serves with the oracle strategies (the "
                        "returnable bound, docs/rules.md) and report returnable_rate, "
                        "return_rate_of_returnable and returns_outside_ceiling")
    p.add_argument("--ceiling-from", default=None, metavar="JSON",
                   help="as --ceiling, with the returnable serves of this earlier --ceiling "
                        "--json run of the same serves (no oracle runs)")
    add_scenario_options(p)
    add_learned_options(p)
    p.set_defaults(run=run)


def run(args) -> None:
    # The serve runner imports pydrake: loaded when the command runs, not for --help.
    from tt_drake.diagrams.serve import format_summary, run_serves

    chosen = args.player is not None
    player = args.player = args.player or "idle"
    check_player_name(player)
    scenario = scenario_from_options(args)
    check_learned(player, scenario)
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
