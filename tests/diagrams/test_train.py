"""tt-drake train library|crkr on a tiny teacher dataset, the artefacts' checks, and the momp
player end to end through the CLI."""

import json

import numpy as np
import pytest

from tt_drake.constants import PLANES
from tt_drake.diagrams.cli import main
from tt_drake.diagrams.collect import collect
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.learned_player import (
    LearnedArtefactError,
    load_configuration_model,
    load_player_library,
)
from tt_drake.responsibility import ResponsibilityParams
from tt_drake.stages import AWAITING, FOLLOW_THROUGH, PREPARATION


@pytest.fixture(scope="module")
def artefacts(tmp_path_factory):
    root = tmp_path_factory.mktemp("learned")
    data = root / "teacher"
    collect(load_scenario(), "analytical", 6, 11, str(data), progress=False, chunk_size=3)
    library, crkr = root / "library.npz", root / "crkr.npz"
    assert main(["train", "library", "--data", str(data), "--out", str(library)]) == 0
    assert main(["train", "crkr", "--data", str(data), "--out", str(crkr)]) == 0
    return data, library, crkr


def test_library_holds_one_primitive_per_successful_stroke(artefacts):
    from tt_drake.diagrams.collect import load_dataset

    data, library_path, _ = artefacts
    dataset = load_dataset(data)
    library, stages, meta = load_player_library(library_path, "default", PLANES.hitting_y)
    assert library.n_primitives == int(dataset["returned"].sum())
    assert library.stimuli.shape[1] == 6 and library.bandwidths[1] == 1.0  # y: the plane
    assert set(stages) == {PREPARATION, FOLLOW_THROUGH, AWAITING}
    assert meta["scenario"] == "default" and meta["dataset_serves"] == 6


def test_crkr_reproduces_its_training_configurations(artefacts):
    from tt_drake.diagrams.collect import load_dataset

    data, _, crkr_path = artefacts
    dataset = load_dataset(data)
    model, meta = load_configuration_model(crkr_path, "default", PLANES.hitting_y)
    ok = np.flatnonzero(dataset["returned"] > 0.5)
    q, qd, var = model.predict(dataset["stimulus"][ok[0], :6])
    assert q.shape == (7,) and qd.shape == (7,) and var > 0
    # lambda C = 0.01 c regularises lightly: near the samples the mean is close to them
    np.testing.assert_allclose(q, dataset["q_hit"][ok[0]], atol=0.2)
    assert meta["outputs"].startswith("theta_hit")


def test_artefacts_for_another_scenario_or_damaged_are_refused(artefacts, tmp_path, capsys):
    _, library, crkr = artefacts
    with pytest.raises(LearnedArtefactError, match="trained for scenario 'default'"):
        load_player_library(library, "other")
    with pytest.raises(LearnedArtefactError, match="hitting plane"):
        load_configuration_model(crkr, "default", PLANES.hitting_y + 0.1)
    bad = tmp_path / "bad.npz"
    bad.write_bytes(library.read_bytes()[:500])
    with pytest.raises(LearnedArtefactError, match="corrupt or truncated"):
        load_player_library(bad)
    with pytest.raises(LearnedArtefactError, match="expected 'momp-player-library'"):
        load_player_library(crkr)
    other = tmp_path / "other.yaml"
    other.write_text("name: other\n")
    assert main(["serve", "--player", "momp", "--library", str(library), "--crkr", str(crkr),
                 "--scenario", str(other), "--serves", "1", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "trained for scenario 'default', not 'other'" in err
    # Naming one artefact means naming them: no shipped library is mixed in.
    assert main(["serve", "--player", "momp", "--crkr", str(crkr), "--serves", "1",
                 "--quiet"]) == 2
    assert "needs --library" in capsys.readouterr().err
    assert main(["train", "crkr", "--data", str(tmp_path), "--out", str(tmp_path / "c.npz")]) == 2


def test_momp_player_serves_end_to_end(artefacts, tmp_path):
    _, library, crkr = artefacts
    out = tmp_path / "momp.json"
    assert main(["serve", "--player", "momp", "--library", str(library), "--crkr", str(crkr),
                 "--serves", "2", "--seed", "3", "--json", str(out), "--quiet"]) == 0
    data = json.loads(out.read_text())
    assert data["summary"]["serves"] == 2 and len(data["episodes"]) == 2


@pytest.mark.slow
def test_momp_player_trained_on_60_teacher_serves_returns_default_serves(tmp_path):
    """A small version of the acceptance run (docs/learned_player.md): at least the paper's 67 %
    legal returns for MoMP with gamma = 1 (physical-model predictor, no GPR file needed)."""
    from tt_drake.diagrams.serve import run_serves

    data = tmp_path / "teacher"
    collect(load_scenario(), "analytical", 60, 21, str(data), progress=False, workers=2)
    library, crkr = tmp_path / "library.npz", tmp_path / "crkr.npz"
    assert main(["train", "library", "--data", str(data), "--out", str(library)]) == 0
    assert main(["train", "crkr", "--data", str(data), "--out", str(crkr)]) == 0
    scenario = load_scenario()
    scenario.learned.library, scenario.learned.crkr = str(library), str(crkr)
    summary = run_serves(scenario, "momp", 40, seed=123, progress=False, workers=2)["summary"]
    assert summary["return_rate"] >= 0.67
    assert summary["robot_table_contacts"] == 0


def test_only_the_momp_player_acts_on_early_predictions(artefacts):
    """The momp player prepares from the first estimate of an approaching ball; the crkr player
    (the teacher's stages) plans once, on the predictor's final prediction."""
    from tt_drake.diagrams.episodes import ServeDiagram, episode_seed

    _, library, crkr = artefacts
    scenario = load_scenario()
    scenario.learned.library, scenario.learned.crkr = str(library), str(crkr)
    for player, early in (("momp", True), ("crkr", False)):
        diagram = ServeDiagram(scenario, player)
        predictor = diagram.diagram.GetSubsystemByName("hitting_point_predictor")
        assert (predictor.early is not None) == early
    result = diagram.run(episode_seed(4, 0))  # the crkr player
    final = predictor.GetOutputPort("p_hit").Eval(predictor.GetMyContextFromRoot(diagram.context))
    assert result.stroke["replans"] == 1
    np.testing.assert_allclose(result.stroke["stimulus"][:3], final, atol=1e-5)
    # It planned on the final prediction only: its hitting stage cannot have begun on an early
    # physical-model one (the count reproduce reports).
    assert result.stroke["early_prediction"] is False



def test_recorded_spin_library_and_crkr_from_the_cli(artefacts, tmp_path, capsys):
    """train library with the recorded demonstrations, a stimulus with spin, other DMP gains
    and no borrowing: all recorded in the artefact; the stimuli's spin is the teacher's."""
    from tt_drake.diagrams.collect import load_dataset
    from tt_drake.stimulus import SPIN_STIMULUS

    data, _, _ = artefacts
    dataset = load_dataset(data)
    out, crkr = tmp_path / "lib.npz", tmp_path / "crkr.npz"
    assert main(["train", "library", "--data", str(data), "--out", str(out), "--demonstrations",
                 "recorded", "--stimulus", "spin", "--alpha-y", "15", "--hitting-borrow", "0",
                 "--stage-borrow", "0.5", "--kappa", "4", "--zeta", "0.5"]) == 0
    library, _, meta = load_player_library(out, "default", PLANES.hitting_y)
    assert library.stimulus_layout == SPIN_STIMULUS and library.dmp.alpha_y == 15.0
    assert library.responsibility == ResponsibilityParams(kappa=4.0, zeta=0.5, threshold=0.1)
    assert meta["demonstrations"] == "recorded" and meta["borrowed_dofs"] == 0
    ok = np.flatnonzero(dataset["returned"] > 0.5)
    np.testing.assert_array_equal(library.stimuli[:, 6:], dataset["spin_hit"][ok])
    assert main(["train", "crkr", "--data", str(data), "--out", str(crkr), "--stimulus",
                 "spin"]) == 0
    model, meta = load_configuration_model(crkr, "default", PLANES.hitting_y)
    assert model.stimulus == SPIN_STIMULUS and meta["inputs"] == "p_hit, v_hit, spin_hit (9)"
    capsys.readouterr()
    for bad in (["--alpha-y", "0"], ["--hitting-borrow", "1.5"], ["--demonstrations", "x"],
                ["--kappa", "0"], ["--threshold", "1"]):
        with pytest.raises(SystemExit) as exit_:
            main(["train", "library", "--data", str(data), "--out", str(tmp_path / "x.npz"),
                  *bad])
        assert exit_.value.code == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "error" in err
    assert not (tmp_path / "x.npz").exists()


def test_a_dataset_without_recorded_states_is_refused_for_recorded_demonstrations(
        artefacts, tmp_path, capsys):
    from tt_drake.artefacts import load_artefact, save_artefact
    from tt_drake.diagrams.collect import KIND, PER_SERVE

    data, _, _ = artefacts
    old = tmp_path / "old"
    old.mkdir()
    for f in data.iterdir():  # as collected before the arm's state was recorded
        if f.suffix == ".npz":
            arrays, meta = load_artefact(f, KIND, allow_nonfinite=PER_SERVE)
            arrays = {k: v for k, v in arrays.items()
                      if k not in ("recorded", "recorded_serve", "spin_hit")}
            save_artefact(old / f.name, KIND, arrays, meta)
        else:
            (old / f.name).write_bytes(f.read_bytes())
    assert main(["train", "library", "--data", str(old), "--out", str(tmp_path / "a.npz")]) == 0
    for option in (["--demonstrations", "recorded"], ["--stimulus", "spin"]):
        assert main(["train", "library", "--data", str(old), "--out", str(tmp_path / "b.npz"),
                     *option]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "collect it again" in err


def test_reproduce_profiles_pass_their_library_settings():
    """A profile's config without the settings trains the paper's library (train_library's
    defaults); the hard profile's settings arrive as train_library's arguments."""
    from types import SimpleNamespace

    from tt_drake.diagrams.train import HARD_PROFILE, library_options, stimulus_of
    from tt_drake.stimulus import PAPER_STIMULUS, SPIN_STIMULUS

    assert library_options(SimpleNamespace(primitives=300)) == {"stimulus": PAPER_STIMULUS}
    hard = library_options(SimpleNamespace(**HARD_PROFILE))
    assert hard["stimulus"] == SPIN_STIMULUS and hard["dmp"].alpha_y == 11.0
    assert hard["demonstrations"] == "recorded" and hard["hitting_borrow"] == 0.0
    assert stimulus_of(SimpleNamespace(stimulus=["p_hit", "v_hit"])) == PAPER_STIMULUS


def test_a_profiles_responsibility_parameters_reach_the_library(artefacts, tmp_path):
    """kappa, zeta and the threshold of a profile's config become the library's responsibility
    parameters (the ones the responsibility and PoWER stages read); the others keep their
    defaults, and a config without them trains the default ones."""
    from types import SimpleNamespace

    from tt_drake.diagrams.train import library_options, train_library

    data, default_path, _ = artefacts
    options = library_options(SimpleNamespace(kappa=4, zeta=0.5))
    assert options["responsibility"] == ResponsibilityParams(kappa=4.0, zeta=0.5, threshold=0.1)
    out = tmp_path / "lib.npz"
    train_library(data, out, **options)
    library, _, _ = load_player_library(out, "default", PLANES.hitting_y)
    assert library.responsibility == ResponsibilityParams(kappa=4.0, zeta=0.5, threshold=0.1)
    assert library.responsibility.prune_below_reward == pytest.approx(1 - 0.5 * np.log(10) / 4)
    default, _, _ = load_player_library(default_path, "default", PLANES.hitting_y)
    assert default.responsibility == ResponsibilityParams()


def test_spin_stimulus_is_exercised_in_the_serve_diagram(artefacts, tmp_path):
    """A library and CrKR trained with the spin in their stimulus: in the serve diagram the
    MoMP player's stroke stimulus is (p_hit, v_hit, spin_hit) as the predictor published them."""
    from tt_drake.diagrams.episodes import ServeDiagram, episode_seed

    data, _, _ = artefacts
    library, crkr = tmp_path / "lib.npz", tmp_path / "crkr.npz"
    for artefact, out in (("library", library), ("crkr", crkr)):
        assert main(["train", artefact, "--data", str(data), "--out", str(out), "--stimulus",
                     "spin"]) == 0
    scenario = load_scenario()
    scenario.learned.library, scenario.learned.crkr = str(library), str(crkr)
    diagram = ServeDiagram(scenario, "momp")
    result = diagram.run(episode_seed(3, 4))  # a serve whose mixed stroke the effort check takes
    stroke = diagram.player.player_state(diagram.player.GetMyContextFromRoot(diagram.context)
                                         ).stroke
    np.testing.assert_allclose(result.stroke["stimulus"], stroke.stimulus, atol=1e-3)  # rounded
    stimulus = stroke.stimulus
    assert stimulus.shape == (9,) and not stroke.fallback
    # The spin part came from the predictor's spin_hit (unconnected, the player would have
    # refused to plan): a served ball spins after its bounce.
    assert 1.0 < np.linalg.norm(stimulus[6:]) < 1000.0
    # The stroke's mixture is the library's gating of that 9-D stimulus (Eq. 6).
    lib = diagram.library
    idx, nu = lib.active(stimulus)
    np.testing.assert_array_equal(stroke.primitives, idx)
    np.testing.assert_allclose(stroke.mixture, nu, atol=1e-12)
    # The CrKR configuration was asked with the same stimulus.
    model, _ = load_configuration_model(crkr)
    q_hit, _, _ = model.predict(stimulus, variance=False)
    np.testing.assert_allclose(stroke.q_hit, q_hit, atol=1e-12)


@pytest.mark.slow
def test_strokes_begun_on_an_early_prediction_are_flagged_only_when_the_player_acts_on_them():
    """With early predictions (the default) some fast serves' hitting stages begin before the
    GPR's final prediction; with ``early_prediction = false`` the player waits for it, and no
    stroke may be flagged."""
    from importlib.resources import files

    from tt_drake.diagrams.episodes import ServeDiagram, episode_seed

    models = files("tt_drake.models") / "learned"
    flagged = {}
    for early in (True, False):
        scenario = load_scenario()
        scenario.learned.library = str(models / "library.npz")
        scenario.learned.crkr = str(models / "crkr.npz")
        scenario.learned.predictor = str(models / "predictor.npz")
        scenario.learned.early_prediction = early
        diagram = ServeDiagram(scenario, "momp")
        flagged[early] = [diagram.run(episode_seed(40, i)).stroke["early_prediction"]
                          for i in range(6)]
    assert any(flagged[True]) and not any(flagged[False])
