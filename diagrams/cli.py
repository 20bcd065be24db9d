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

Each command is a module of :mod:`tt_drake.diagrams.commands` that adds its own options and
runs them; this module builds the top parser from them and reports their errors.
"""

import argparse
import sys

from tt_drake.diagrams.commands import (
    bench,
    collect,
    eval_predictor,
    models,
    rally,
    reproduce,
    serve,
    serves,
    train,
    train_predictor,
)
from tt_drake.diagrams.commands.options import EXIT_BAD_INPUT, HelpFormatter, OneLineParser
from tt_drake.errors import BadInputError
from tt_drake.provenance import package_version

#: The commands in the order ``tt-drake --help`` lists them.
COMMANDS = (serve, rally, bench, collect, serves, models, train, train_predictor,
            eval_predictor, reproduce)


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(prog="tt-drake", description=__doc__.split("\n")[0],
                           formatter_class=HelpFormatter)
    parser.add_argument("--version", action="version",
                        version=f"tt-drake {package_version()}")
    subparsers = parser.add_subparsers(dest="command", required=True)
    for command in COMMANDS:
        command.register(subparsers)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        args.run(args)
    except BadInputError as err:
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
