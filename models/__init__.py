"""Model files (URDF, SDF, scenario YAML) and the learned player's shipped artefacts
(``learned/``), read through ``importlib.resources`` so that they are found in a checkout and in
an installed wheel alike."""

from importlib import resources
from pathlib import Path

#: The learned player's artefacts shipped in ``learned/`` (made by ``tt-drake reproduce``).
SHIPPED_ARTEFACTS = {"library": "library.npz", "crkr": "crkr.npz", "predictor": "predictor.npz"}


def shipped_artefact(kind: str) -> Path:
    """Path of the shipped ``library``, ``crkr`` or ``predictor`` artefact."""
    return Path(str(resources.files(__name__).joinpath("learned", SHIPPED_ARTEFACTS[kind])))
