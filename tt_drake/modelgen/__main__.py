"""``python -m tt_drake.modelgen``: rewrite every generated file in ``models/``."""

from __future__ import annotations

import importlib
from importlib import resources
from pathlib import Path

# The tt_drake.models package: models/ in a checkout, tt_drake/models/ in an installed wheel.
MODELS_DIR = Path(str(resources.files("tt_drake.models")))


def generated_files() -> dict:
    """File name -> function returning its text, over every generator module."""
    files = {}
    for module in ("world", "wam"):
        try:
            mod = importlib.import_module(f"tt_drake.modelgen.{module}")
        except ModuleNotFoundError:
            continue
        files.update(getattr(mod, "GENERATED", {}))
    return files


def main() -> None:
    for name, make in generated_files().items():
        (MODELS_DIR / name).write_text(make())
        print(f"wrote {MODELS_DIR / name}")


if __name__ == "__main__":
    main()
