"""The CLI's check of the learned player's artefacts is the load the diagram uses: once per
process."""

import shutil
from pathlib import Path

from tt_drake.diagrams.episodes import load_learned_player
from tt_drake.diagrams.scenario import load_scenario

LEARNED = Path(__file__).resolve().parents[2] / "models" / "learned"


def _scenario(library: Path):
    scenario = load_scenario()
    scenario.learned.library = str(library)
    scenario.learned.configuration = "analytical"  # the library alone: no CrKR fit needed
    return scenario


def test_a_kept_load_is_taken_once_by_the_next_load(tmp_path):
    library = tmp_path / "library.npz"
    shutil.copy(LEARNED / "library.npz", library)
    scenario = _scenario(library)
    checked = load_learned_player(scenario, keep=True)
    assert load_learned_player(scenario, keep=True)["library"] is checked["library"]
    built = load_learned_player(scenario)
    assert built["library"] is checked["library"]  # the diagram takes the checked artefacts
    again = load_learned_player(scenario)  # a second diagram gets its own
    assert again["library"] is not checked["library"]
    assert (again["library"].weights == checked["library"].weights).all()


def test_a_rewritten_file_is_loaded_again(tmp_path):
    library = tmp_path / "library.npz"
    shutil.copy(LEARNED / "library.npz", library)
    scenario = _scenario(library)
    checked = load_learned_player(scenario, keep=True)
    library.write_bytes(library.read_bytes() + b"\0")  # another size: another file
    other = load_learned_player(scenario)
    assert other["library"] is not checked["library"]
