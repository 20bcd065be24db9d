"""Real ball states shipped inside the package.

``serves.json`` and ``rallies.json`` come unchanged from
google-deepmind/competitive_robot_table_tennis (CC-BY 4.0, Copyright 2025 Google LLC),
accompanying D'Ambrosio et al., "Achieving Human Level Competitive Robot Table Tennis",
ICRA 2025; see ``README.md`` in this folder.
"""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

#: The shipped files by name, and the environment variable that overrides each.
BALL_STATE_FILES = {"serves": ("serves.json", "TT_DRAKE_SERVES"),
                    "rallies": ("rallies.json", "TT_DRAKE_RALLIES")}


def ball_states_path(kind: str = "serves") -> Path:
    """Path of the ``serves`` or ``rallies`` file: the override's value when it is set, else the
    copy shipped in this package (read through ``importlib.resources``)."""
    try:
        filename, env = BALL_STATE_FILES[kind]
    except KeyError:
        raise ValueError(f"unknown ball-state file {kind!r}; choose one of "
                         f"{', '.join(BALL_STATE_FILES)}") from None
    override = os.environ.get(env)
    if override:
        return Path(override)
    return Path(str(resources.files(__name__).joinpath(filename)))
