"""Model files (URDF, SDF, scenario YAML) and the learned player's shipped artefacts
(``learned/``, ``learned-hard/``), read through ``importlib.resources`` so that they are found in
a checkout and in an installed wheel alike."""

import json
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

from tt_drake.errors import BadInputError

#: The learned player's artefacts shipped in each set's folder (made by ``tt-drake reproduce``).
SHIPPED_ARTEFACTS = {"library": "library.npz", "crkr": "crkr.npz", "predictor": "predictor.npz"}


@dataclass(frozen=True)
class ArtefactSet:
    """A set of learned-player artefacts: its folder (a shipped set's, in this package; or a
    path) and the player settings it was trained and measured with
    (``LearnedPlayerConfig.moving_goal`` and ``configuration``, the latter unless the command
    line names one)."""

    folder: str
    moving_goal: bool = False
    configuration: str = "crkr"


#: The provenance file of an exported set: the command that made it and, under ``player``, the
#: settings it plays with (``configuration``, ``moving_goal``).
PROVENANCE = "provenance.json"


class ArtefactSetError(ValueError, BadInputError):
    """A folder that is not an exported artefact set."""


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


def artefact_settings(artefact_set: "str | ArtefactSet") -> ArtefactSet:
    """The settings of an artefact set: a shipped set's name, or an :class:`ArtefactSet`."""
    return artefact_set if isinstance(artefact_set, ArtefactSet) else ARTEFACT_SETS[artefact_set]


def artefact_files(artefact_set: "str | ArtefactSet") -> dict[str, str]:
    """The paths of a set's ``library``, ``crkr`` and ``predictor`` artefacts, by kind (a
    shipped set's name, or an :class:`ArtefactSet` whose folder is a path)."""
    if isinstance(artefact_set, ArtefactSet):
        return {kind: str(Path(artefact_set.folder) / name)
                for kind, name in SHIPPED_ARTEFACTS.items()}
    return {kind: str(shipped_artefact(kind, artefact_set)) for kind in SHIPPED_ARTEFACTS}


def use_artefact_set(learned, artefact_set: "str | ArtefactSet" = "paper",
                     configuration_given: bool = False) -> None:
    """Point a scenario's ``learned`` settings (``LearnedPlayerConfig``) at an artefact set (a
    shipped set's name, or an :class:`ArtefactSet` whose folder is a path, such as a
    ``tt-drake reproduce`` run's export): its three artefacts, its moving goal (kept on if
    already on) and, unless the caller chose one, its hitting configuration."""
    chosen = artefact_settings(artefact_set)
    files = artefact_files(artefact_set)
    learned.library, learned.crkr, learned.predictor = (files[kind] for kind in SHIPPED_ARTEFACTS)
    learned.moving_goal = learned.moving_goal or chosen.moving_goal
    if not configuration_given:
        learned.configuration = chosen.configuration


def exported_artefact_set(folder) -> ArtefactSet:
    """The artefact set a ``tt-drake reproduce`` run exported to ``folder`` (``DIR/artefacts``:
    the three artefacts and a provenance naming the player settings its protocol plays with),
    as :func:`use_artefact_set` takes it. Raises :class:`ArtefactSetError` if a file is missing
    or the provenance does not name the settings."""
    path = Path(folder)
    missing = [name for name in (*SHIPPED_ARTEFACTS.values(), PROVENANCE)
               if not (path / name).is_file()]
    if missing:
        raise ArtefactSetError(f"{folder} is not an exported artefact set (no "
                               f"{', '.join(missing)}; tt-drake reproduce writes one to "
                               f"DIR/artefacts)")
    try:
        player = json.loads((path / PROVENANCE).read_text())["player"]
        configuration, moving_goal = player["configuration"], player["moving_goal"]
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise ArtefactSetError(f"{path / PROVENANCE} names no player settings (player: "
                               f"configuration, moving_goal): {error!r}") from None
    if configuration not in ("crkr", "analytical") or not isinstance(moving_goal, bool):
        raise ArtefactSetError(f"{path / PROVENANCE}: unknown player settings {player!r}")
    return ArtefactSet(str(path.resolve()), moving_goal=moving_goal, configuration=configuration)
