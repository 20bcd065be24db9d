"""``tt-drake models``: rewrite the generated model files in models/."""

from tt_drake.diagrams.commands.options import add_command
from tt_drake.modelgen.__main__ import main as write_models


def register(subparsers) -> None:
    p = add_command(subparsers, "models", help="rewrite the generated model files in models/")
    p.set_defaults(run=run)


def run(_args) -> None:
    write_models()
