"""``tt-drake collect``: record teacher demonstrations (resumable)."""

from tt_drake.diagrams.commands.options import (
    add_command,
    add_perception_option,
    add_player_option,
    add_quiet_option,
    add_scenario_options,
    add_seed_option,
    add_serves_option,
    add_workers_option,
    check_player_name,
    scenario_from_options,
)


def register(subparsers) -> None:
    p = add_command(subparsers, "collect", help="record teacher demonstrations (resumable)")
    add_player_option(p, "analytical")
    add_serves_option(p, 100)
    add_seed_option(p)
    p.add_argument("--out", required=True, help="dataset folder (created, or resumed)")
    add_workers_option(p, None, "parallel worker processes (default: all cores)")
    add_quiet_option(p)
    add_perception_option(p)
    add_scenario_options(p)
    p.set_defaults(run=run)


def run(args) -> None:
    # The collection's diagrams import pydrake: loaded when the command runs, not for --help.
    from tt_drake.diagrams.collect import collect
    from tt_drake.diagrams.inputs import check_inputs
    from tt_drake.diagrams.parallel import default_workers

    check_player_name(args.player)
    scenario = scenario_from_options(args)
    check_inputs(scenario)
    summary = collect(scenario, args.player, args.serves, args.seed, args.out,
                      args.workers or default_workers(), progress=not args.quiet)
    print(f"{summary['folder']}: {summary['serves']} serves ({summary['simulated']} simulated "
          f"now, {summary['kept']} kept from before), legal return "
          f"{summary['return_rate']:.1%}")
