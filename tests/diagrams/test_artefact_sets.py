"""The artefact sets (``--artefacts paper|hard|DIR``): which files and player settings a set
stands for, that the hard set loads (no pickle) with its recorded layouts, and bad input."""

import shutil

import numpy as np
import pytest

from tt_drake.diagrams.cli import build_parser, main
from tt_drake.diagrams.commands.options import ARTEFACT_SET_NAMES, scenario_from_options
from tt_drake.models import ARTEFACT_SETS, SHIPPED_ARTEFACTS, shipped_artefact


def test_the_cli_names_every_artefact_set():
    assert ARTEFACT_SET_NAMES == tuple(ARTEFACT_SETS)


def test_the_hard_set_is_its_files_and_the_moving_goal(capsys):
    parser = build_parser()
    learned = scenario_from_options(
        parser.parse_args(["serve", "--player", "momp", "--artefacts", "hard"])).learned
    assert (learned.library, learned.crkr, learned.predictor) == tuple(
        str(shipped_artefact(k, "hard")) for k in ("library", "crkr", "predictor"))
    assert learned.moving_goal and learned.configuration == "analytical"
    assert "learned-hard" in capsys.readouterr().err
    learned = scenario_from_options(parser.parse_args(
        ["serve", "--player", "momp", "--artefacts", "hard", "--configuration", "crkr"])).learned
    assert learned.moving_goal and learned.configuration == "crkr"  # the flag wins
    # Without the flag, or with --artefacts paper: the paper set, committed at the swing start.
    for extra in ([], ["--artefacts", "paper"]):
        learned = scenario_from_options(
            parser.parse_args(["serve", "--player", "momp", *extra])).learned
        assert learned.library == str(shipped_artefact("library"))
        assert not learned.moving_goal and learned.configuration == "crkr"


def test_the_hard_artefacts_load_with_their_recorded_layouts():
    from tt_drake.artefacts import load_artefact
    from tt_drake.hitting_point import HittingPointGPR
    from tt_drake.learned_player import load_configuration_model, load_player_library
    from tt_drake.stimulus import STIMULI

    for kind in SHIPPED_ARTEFACTS:
        path = shipped_artefact(kind, "hard")
        with np.load(path, allow_pickle=False) as data:  # no object arrays inside
            assert all(data[k].dtype != object for k in data.files)
        assert path.is_file()
        load_artefact(path, {"library": "momp-player-library",
                             "crkr": "crkr-hitting-configuration",
                             "predictor": "hitting-point-gpr"}[kind])
    library, _, meta = load_player_library(shipped_artefact("library", "hard"), "default")
    crkr, _ = load_configuration_model(shipped_artefact("crkr", "hard"), "default")
    gpr = HittingPointGPR.load(shipped_artefact("predictor", "hard"))
    spin = tuple(STIMULI["spin"])
    assert tuple(library.stimulus_layout) == spin and library.stimuli.shape[1] == 9
    assert tuple(crkr.stimulus) == spin
    assert gpr.feature_set == "states+spin"
    assert meta["dmp"]["alpha_y"] == 15.0


def test_artefacts_flag_with_files_or_a_corrupt_set_is_one_line_exit_2(tmp_path, capsys,
                                                                       monkeypatch):
    assert main(["serve", "--player", "momp", "--artefacts", "hard", "--library",
                 "mine.npz"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--artefacts" in err[0]
    # A set whose library file is damaged: the loader's one line, before any serve.
    import tt_drake.models as models

    folder = tmp_path / "learned-hard"
    shutil.copytree(shipped_artefact("library", "hard").parent, folder)
    (folder / "library.npz").write_bytes(b"not an npz")
    monkeypatch.setattr(models, "shipped_artefact",
                        lambda kind, s="paper": folder / SHIPPED_ARTEFACTS[kind])
    out = tmp_path / "out.json"
    assert main(["serve", "--player", "momp", "--artefacts", "hard", "--serves", "1",
                 "--json", str(out), "--quiet"]) == 2
    err = [line for line in capsys.readouterr().err.strip().splitlines()
           if "uses the shipped artefacts" not in line]  # the usual notice, then the problem
    assert len(err) == 1 and "library" in err[0] and not out.exists()


@pytest.mark.parametrize("name", ["paper", "hard"])
def test_every_set_ships_three_artefacts_and_a_provenance(name):
    folder = shipped_artefact("library", name).parent
    assert {p.name for p in folder.iterdir()} >= {*SHIPPED_ARTEFACTS.values(), "provenance.json"}


def test_reproduce_until_crkr_runs_the_training_stages_and_exports_them(tmp_path, monkeypatch):
    """``--until crkr`` stops after the crkr stage and exports the library (gamma = 1), CrKR and
    predictor with a provenance that names the command (stage functions replaced by stubs that
    write their files: the stages themselves are tested elsewhere)."""
    import json

    from tt_drake.diagrams import reproduce as rp

    ran = []

    def stub(stage, files):
        def run_stage(run):
            ran.append(stage)
            for rel in files.values():
                (run.root / rel).parent.mkdir(parents=True, exist_ok=True)
                (run.root / rel).write_bytes(stage.encode())
            return dict(files)
        return run_stage

    stubs = {stage: stub(stage, {}) for stage in rp.STAGES}
    stubs["predictor"] = stub("predictor", {"model": "predictor/predictor.npz"})
    stubs["library"] = stub("library", {"library": "library/library.npz"})
    stubs["crkr"] = stub("crkr", {"best": "crkr/crkr_1.npz"})
    monkeypatch.setattr(rp, "STAGE_FUNCTIONS", stubs)
    monkeypatch.setattr(rp, "write_report", lambda run: {})  # the stubs' results are bare
    rp.reproduce(tmp_path / "run", workers=1, progress=False, config=rp.artefacts_config(),
                 protocol="hard", until="crkr")
    assert ran == ["teacher", "predictor", "library", "crkr"]
    art = tmp_path / "run" / "artefacts"
    assert {p.name for p in art.iterdir()} == {"library.npz", "crkr.npz", "predictor.npz",
                                                "provenance.json"}
    assert (art / "library.npz").read_bytes() == b"library"
    provenance = json.loads((art / "provenance.json").read_text())
    assert provenance["command"] == ("tt-drake reproduce --protocol hard --sizes artefacts "
                                     "--until crkr")
    # the settings the hard protocol's player plays it with: --artefacts DIR reads them
    assert provenance["player"] == {"configuration": "analytical", "moving_goal": True}
    with pytest.raises(rp.ReproduceError, match="unknown stage"):
        rp.reproduce(tmp_path / "other", workers=1, progress=False, until="rehearsal")


def test_the_shipped_hard_library_has_the_hard_stiff_protocols_settings():
    """models/learned-hard/ was made by the recipe ``--protocol hard-stiff --sizes artefacts
    --until crkr`` names (its README): the library's recorded DMP gains, responsibility
    parameters, demonstrations, borrowing and stimulus are those the protocol trains with, and
    the hard protocol's differ (a softer DMP, Eq. 10 able to prune)."""
    from tt_drake.diagrams import reproduce as rp
    from tt_drake.diagrams.train import library_options
    from tt_drake.learned_player import load_player_library

    _, _, meta = load_player_library(shipped_artefact("library", "hard"), "default")
    config = rp.SIZES["artefacts"]("hard-stiff")
    assert config == rp.artefacts_config() and meta["dataset_serves"] == config.teacher_serves
    for protocol, same in (("hard-stiff", True), ("hard", False)):
        options = library_options(rp.PROTOCOLS[protocol].library_settings(config))
        assert (options["dmp"].to_dict() == meta["dmp"]) == same
        responsibility = options.get("responsibility")
        assert (responsibility is None and meta["responsibility"] == {
            "kappa": 1.0, "zeta": 0.25, "threshold": 0.1}) == same
        assert options["demonstrations"] == meta["demonstrations"]
        assert options["hitting_borrow"] == meta["hitting_borrow"]
        assert list(options["stimulus"]) == meta["stimulus"]


def test_reproduce_sizes_and_stages_named_in_the_cli_are_the_modules():
    from tt_drake.diagrams import reproduce as rp
    from tt_drake.diagrams.commands.reproduce import PROTOCOL_NAMES, REPRODUCE_STAGES

    assert REPRODUCE_STAGES == rp.STAGES and PROTOCOL_NAMES == tuple(rp.PROTOCOLS)
    assert set(rp.SIZES) == {"full", "quick", "artefacts"}
    assert rp.SIZES["quick"]() == rp.quick_config()
    assert main(["reproduce", "--out", "x", "--quick", "--sizes", "artefacts"]) == 2


def _exported(tmp_path, player):
    """A folder laid out as ``tt-drake reproduce`` exports a set: the hard set's three files and
    a provenance naming ``player``."""
    import json

    folder = tmp_path / "artefacts"
    folder.mkdir()
    for kind, name in SHIPPED_ARTEFACTS.items():
        shutil.copyfile(shipped_artefact(kind, "hard"), folder / name)
    (folder / "provenance.json").write_text(json.dumps(
        {"command": "tt-drake reproduce --protocol hard", "protocol": "hard", "player": player}))
    return folder


def test_an_exported_set_plays_with_the_settings_its_provenance_names(tmp_path, capsys):
    parser = build_parser()
    folder = _exported(tmp_path, {"configuration": "analytical", "moving_goal": True})
    learned = scenario_from_options(parser.parse_args(
        ["serve", "--player", "momp", "--artefacts", str(folder)])).learned
    assert (learned.library, learned.crkr, learned.predictor) == tuple(
        str(folder.resolve() / name) for name in SHIPPED_ARTEFACTS.values())
    assert learned.moving_goal and learned.configuration == "analytical"
    assert f"exported artefacts in {folder}" in capsys.readouterr().err
    (tmp_path / "p").mkdir()
    paper = _exported(tmp_path / "p", {"configuration": "crkr", "moving_goal": False})
    learned = scenario_from_options(parser.parse_args(
        ["serve", "--player", "momp", "--artefacts", str(paper)])).learned
    assert not learned.moving_goal and learned.configuration == "crkr"


@pytest.mark.parametrize("damage", ["no-folder", "no-crkr", "no-player", "bad-player"])
def test_a_folder_that_is_no_exported_set_is_one_line_exit_2(tmp_path, capsys, damage):
    import json

    folder = _exported(tmp_path, {"configuration": "analytical", "moving_goal": True})
    if damage == "no-folder":
        folder = tmp_path / "nowhere"
    elif damage == "no-crkr":
        (folder / "crkr.npz").unlink()
    elif damage == "no-player":
        (folder / "provenance.json").write_text(json.dumps({"protocol": "hard"}))
    else:
        (folder / "provenance.json").write_text(json.dumps(
            {"player": {"configuration": "oracle", "moving_goal": True}}))
    out = tmp_path / "out.json"
    argv = ["serve", "--player", "momp", "--artefacts", str(folder), "--serves", "1", "--json",
            str(out), "--quiet"]
    if damage == "no-folder":  # an option error: argparse's exit
        with pytest.raises(SystemExit) as exit_:
            main(argv)
        assert exit_.value.code == 2
    else:
        assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and not out.exists()
    assert {"no-folder": "nor a folder", "no-crkr": "crkr.npz", "no-player": "player",
            "bad-player": "oracle"}[damage] in err[0]
