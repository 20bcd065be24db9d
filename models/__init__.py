"""Model files (URDF, SDF, scenario YAML) and the learned player's shipped artefacts
(``learned/``, ``learned-hard/``), read through ``importlib.resources`` so that they are found in
a checkout and in an installed wheel alike."""

from dataclasses import dataclass
from importlib import resources
from pathlib import Path

#: The learned player's artefacts shipped in each set's folder (made by ``tt-drake reproduce``).
SHIPPED_ARTEFACTS = {"library": "library.npz", "crkr": "crkr.npz", "predictor": "predictor.npz"}


@dataclass(frozen=True)
class ArtefactSet:
    """A shipped set of learned-player artefacts: its folder and the player settings it was
    trained and measured with (``LearnedPlayerConfig.moving_goal`` and ``configuration``, the
    latter unless the command line names one)."""

    folder: str
    moving_goal: bool = False
    configuration: str = "crkr"


#: ``paper``: the paper profile's run on default serves (``tt-drake reproduce``); ``hard``: the
#: hard protocol's training stages on spin, real and rally serves with the stiffer hitting DMP
#: (``--protocol hard-stiff``, models/learned-hard/README.md),
#: played with the hitting DMP's moving goal and the teacher's IK as the hitting configuration
#: (its CrKR, trained on 111 strokes, returned fewer real serves: docs/learned_player.md).
ARTEFACT_SETS = {"paper": ArtefactSet("learned"),
                 "hard": ArtefactSet("learned-hard", moving_goal=True,
                                     configuration="analytical")}


def shipped_artefact(kind: str, artefact_set: str = "paper") -> Path:
    """Path of the shipped ``library``, ``crkr`` or ``predictor`` artefact of a set."""
    folder = ARTEFACT_SETS[artefact_set].folder
    return Path(str(resources.files(__name__).joinpath(folder, SHIPPED_ARTEFACTS[kind])))


def use_artefact_set(learned, artefact_set: str = "paper", configuration_given: bool = False
                     ) -> None:
    """Point a scenario's ``learned`` settings (``LearnedPlayerConfig``) at a shipped set: its
    three artefacts, its moving goal (kept on if already on) and, unless the caller chose one,
    its hitting configuration."""
    chosen = ARTEFACT_SETS[artefact_set]
    learned.library, learned.crkr, learned.predictor = (
        str(shipped_artefact(kind, artefact_set)) for kind in SHIPPED_ARTEFACTS)
    learned.moving_goal = learned.moving_goal or chosen.moving_goal
    if not configuration_given:
        learned.configuration = chosen.configuration
