"""``tt-drake bench``: time serve episodes against a C++ reference diagram."""

from tt_drake.diagrams.commands.options import (
    add_command,
    add_json_option,
    add_learned_options,
    add_player_option,
    add_scenario_options,
    add_seed_option,
    add_serves_option,
    add_workers_option,
    check_learned,
    check_player_name,
    scenario_from_options,
)
from tt_drake.outputs import check_writable, write_json_atomic
from tt_drake.provenance import run_provenance


def register(subparsers) -> None:
    p = add_command(subparsers, "bench", help="time serve episodes against a C++ reference "
                                              "diagram")
    add_serves_option(p, 10)
    add_seed_option(p)
    add_player_option(p, "idle")
    add_json_option(p, "write the measurements as JSON")
    add_workers_option(p, help="also time the serves on this many worker processes and "
                               "project 10,000 serves (default 1: not)")
    add_scenario_options(p)
    add_learned_options(p)
    p.set_defaults(run=run)


def run(args) -> None:
    # The benchmark's diagrams import pydrake: loaded when the command runs, not for --help.
    from tt_drake.diagrams.bench import format_bench, run_bench
    from tt_drake.diagrams.serve import scenario_dict

    check_player_name(args.player)
    scenario = scenario_from_options(args)
    check_learned(args.player, scenario)
    if args.json:
        check_writable(args.json)
    result = run_bench(scenario, args.serves, args.seed, args.player, args.workers)
    print(format_bench(result))
    if args.json:
        write_json_atomic(args.json, {**run_provenance(), "scenario": scenario_dict(scenario),
                                      **result})
        print(f"wrote {args.json}")
