"""``tt-drake serves``: the serve distributions' real-ball pools (docs/serves.md)."""

from tt_drake.diagrams.commands.options import (
    CliError,
    add_command,
    add_scenario_options,
    scenario_from_options,
)
from tt_drake.serves import DISTRIBUTIONS, POOLS, pool_counts


def register(subparsers) -> None:
    p = add_command(subparsers, "serves", help="the serve distributions' real-ball pools")
    p.add_argument("--info", action="store_true",
                   help="print how many balls each pool (and split) holds")
    add_scenario_options(p)
    p.set_defaults(run=run)


def run(args) -> None:
    if not args.info:
        raise CliError("nothing asked: use --info")
    scenario = scenario_from_options(args)
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
