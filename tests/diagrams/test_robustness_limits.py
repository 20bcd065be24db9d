"""No silent wrong result from limits, shadowing files or overridden settings: a rally at its time
limit, a fast camera, model files and scenario names in the working folder, a scenario's player
settings against the command line's defaults, artefact metadata, physical ranges, data files from
the environment, Drake's Meshcat log line. docs/robustness.md lists each defect with its test."""

import json
import subprocess
import sys
from importlib import resources

import numpy as np
import pytest

from tests.diagrams._cli import one_line_error
from tt_drake.artefacts import load_artefact, save_artefact
from tt_drake.camera_model import CameraConfig, CameraModel
from tt_drake.diagrams.cli import main
from tt_drake.diagrams.scenario import ScenarioError, load_scenario
from tt_drake.hitting_point import ARTEFACT_KIND, HittingPointGPR, PredictorFileError
from tt_drake.learned_player import LIBRARY_FILE_KIND, LearnedArtefactError, load_player_library

MODELS = resources.files("tt_drake.models")
SHIPPED = str(MODELS.joinpath("learned"))


def scenario_file(tmp_path, text: str, name: str = "s.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


# -- a rally at its time limit -----------------------------------------------------------------

def test_rally_time_limit_follows_max_exchanges():
    """Each exchange ends within its timeout (plus one referee tick), so a rally of n exchanges
    needs (n + 1) timeouts at most: the simulated time must allow that, whatever n."""
    from tt_drake.diagrams.rally import max_duration

    scenario = load_scenario()
    for n in (50, 300, 1000):
        scenario.rally.max_exchanges = n
        assert max_duration(scenario) >= (n + 1) * scenario.rally.exchange_timeout


def test_a_rally_still_in_play_at_the_time_limit_is_capped_not_a_fault(monkeypatch):
    from tt_drake.diagrams import rally
    from tt_drake.diagrams.rally import RallyDiagram, rally_scenario

    limit = 2.5  # s: A has returned the serve, B's ball is in the air
    monkeypatch.setattr(rally, "max_duration", lambda scenario: limit)
    result = RallyDiagram(rally_scenario(load_scenario()), ("analytical", "analytical")).run(11)
    assert result.duration == pytest.approx(limit)
    assert result.length >= 1 and result.exchanges[0].player == 0
    assert result.fault is None and result.capped
    assert result.as_dict()["fault"] is None


def test_max_exchanges_has_a_maximum(tmp_path, capsys):
    MAX_EXCHANGES = 1000  # noqa: N806 (the documented maximum, tt_drake.constants)

    with pytest.raises(ScenarioError, match=f"rally.max_exchanges must be <= {MAX_EXCHANGES}"):
        load_scenario(scenario_file(tmp_path, f"rally: {{max_exchanges: {MAX_EXCHANGES + 1}}}\n"))
    out = tmp_path / "rally.json"
    line = one_line_error(capsys, ["rally", "--rallies", "1", "--max-exchanges",
                                   str(MAX_EXCHANGES + 1), "--json", str(out), "--quiet"])
    assert "rally.max_exchanges must be <=" in line and not out.exists()


# -- a camera faster than max_frames covers ----------------------------------------------------

def test_a_fast_camera_measures_every_frame_of_the_episode():
    """2 kHz with the default 600 frames per block: 3 s of frames, every one measured (no
    dropouts configured), each the true position plus noise of the configured sigma."""
    config = CameraConfig(rate=2000.0, sigma=0.003)
    frames = 6000
    p = np.tile([0.1, -1.0, 1.0], (frames, 1))
    z = CameraModel(config).measure_sequence(7, p)
    assert not np.isnan(z).any()
    assert (z - p).std(axis=0) == pytest.approx([0.003] * 3, rel=0.05)
    # Frame k's draws depend on the seed and k only: the first block is the one drawn before.
    first = CameraModel(config).episode_draws(7)
    np.testing.assert_allclose(z[:600] - p[:600], first.noise, atol=1e-15)


def test_the_camera_system_delivers_frames_after_its_first_block():
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import ConstantVectorSource

    from tt_drake.systems.ball_camera import BallCamera

    builder = DiagramBuilder()
    state = np.zeros(13)
    state[0], state[4:7] = 1.0, (0.1, -1.0, 1.0)
    ball = builder.AddSystem(ConstantVectorSource(state))
    camera = builder.AddSystem(BallCamera(CameraConfig(rate=2000.0, max_frames=600)))
    builder.Connect(ball.get_output_port(), camera.get_input_port(0))
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = camera.GetMyContextFromRoot(simulator.get_mutable_context())
    for t in (0.25, 0.5, 1.0):  # frames 500, 1000, 2000
        simulator.AdvanceTo(t)
        x, y, z, _, valid = camera.GetOutputPort("measurement").Eval(context)
        assert valid == 1.0
        assert np.linalg.norm(np.array([x, y, z]) - state[4:7]) < 0.02


@pytest.mark.parametrize("text, message", [
    ("camera: {rate: 1.0e9}\n", "camera.rate must be in (0, 10000] Hz"),
    ("camera: {latency: 1.0e6}\n", "camera.latency must be in [0, 1] s"),
    ("camera: {max_frames: 1000000000}\n", "camera.max_frames must be a whole number in [1, "),
], ids=["rate", "latency", "max_frames"])
def test_camera_settings_have_physical_ranges(tmp_path, capsys, text, message):
    path = scenario_file(tmp_path, text)
    with pytest.raises(ScenarioError, match=message.replace("(", r"\(").replace("[", r"\[")):
        load_scenario(path)
    out = tmp_path / "serves.json"
    line = one_line_error(capsys, ["serve", "--scenario", path, "--serves", "1", "--json",
                                   str(out), "--quiet"])
    assert message in line and not out.exists()


# -- files in the working folder ---------------------------------------------------------------

def _heavy_ball(path):
    """The shipped ball with a 1 kg mass."""
    text = MODELS.joinpath("ball.sdf").read_text()
    start = text.index("<mass>") + len("<mass>")
    path.write_text(text[:start] + "1.0" + text[text.index("</mass>"):])


def _ball_mass(models) -> float:
    from pydrake.systems.framework import DiagramBuilder

    from tt_drake.systems.world import WorldConfig, add_world

    world = add_world(DiagramBuilder(), WorldConfig(models=models, with_robot=False))
    return world.ball_body.default_mass()


def test_a_model_file_in_the_working_folder_does_not_replace_the_shipped_one(tmp_path,
                                                                          monkeypatch):
    from tt_drake.systems.world import ModelFiles

    _heavy_ball(tmp_path / "ball.sdf")
    monkeypatch.chdir(tmp_path)
    assert _ball_mass(ModelFiles()) == pytest.approx(0.0027)
    # Named as a path, it is the file played, and the scenario records its absolute path.
    assert _ball_mass(ModelFiles(ball="./ball.sdf")) == pytest.approx(1.0)
    scenario = load_scenario(scenario_file(tmp_path, "world: {models: {ball: ./ball.sdf}}\n"))
    assert scenario.world.models.ball == str(tmp_path / "ball.sdf")
    assert load_scenario().world.models.ball == "ball.sdf"  # the package's


def test_a_file_named_like_a_scenario_in_the_working_folder_is_not_read(tmp_path, monkeypatch):
    (tmp_path / "default").write_text("referee_rate: 100.0\n")
    (tmp_path / "faulty_camera").write_text("camera: {dropout: 0.9}\n")
    monkeypatch.chdir(tmp_path)
    assert load_scenario("default").referee_rate == 250.0
    faulty = load_scenario("faulty_camera")
    assert faulty.referee_rate == 250.0 and faulty.camera.dropout < 0.9
    # A path names the file.
    assert load_scenario("./default").referee_rate == 100.0


# -- the scenario's player settings and the command line's defaults ---------------------------

def _serve_json(tmp_path, argv) -> dict:
    out = tmp_path / "serves.json"
    assert main(["serve", *argv, "--serves", "1", "--seed", "3", "--json", str(out),
                 "--quiet"]) == 0
    return json.loads(out.read_text())


def test_a_scenarios_hitting_configuration_is_kept_without_the_option(tmp_path):
    path = scenario_file(tmp_path, "learned: {configuration: analytical}\n")
    data = _serve_json(tmp_path, ["--player", "momp", "--scenario", path])
    assert data["scenario"]["learned"]["configuration"] == "analytical"


def test_the_crkr_player_plays_crkr_with_a_set_whose_configuration_is_another(tmp_path):
    data = _serve_json(tmp_path, ["--player", "crkr", "--artefacts", "hard"])
    learned = data["scenario"]["learned"]
    assert learned["configuration"] == "crkr"
    assert learned["crkr"].endswith("learned-hard/crkr.npz")


@pytest.mark.parametrize("argv", [
    ["--configuration", "analytical"],
    ["--scenario", "ANALYTICAL"],
], ids=["option", "scenario"])
def test_the_crkr_player_with_another_configuration_is_refused(tmp_path, capsys, argv):
    argv = [a if a != "ANALYTICAL" else
            scenario_file(tmp_path, "learned: {configuration: analytical}\n") for a in argv]
    out = tmp_path / "serves.json"
    line = one_line_error(capsys, ["serve", "--player", "crkr", *argv, "--serves", "1",
                                   "--json", str(out), "--quiet"])
    assert "the crkr player plays the CrKR hitting configuration" in line
    assert not out.exists()


# -- artefact metadata --------------------------------------------------------------------------

def _predictor_with_meta(tmp_path, edit):
    arrays, meta = load_artefact(f"{SHIPPED}/predictor.npz", ARTEFACT_KIND)
    edit(meta)
    return save_artefact(tmp_path / "p.npz", ARTEFACT_KIND, arrays, meta)


BAD_META = {
    "camera rate a string": (lambda m: m["camera"].update(rate="fast"), "camera"),
    "camera unknown key": (lambda m: m["camera"].update(zoom=2.0), "zoom"),
    "camera not a mapping": (lambda m: m.update(camera=[1, 2]), "camera"),
    "camera latency out of range": (lambda m: m["camera"].update(latency=1e6), "latency"),
    "estimator unknown key": (lambda m: m["estimator"].update(bogus=1.0), "bogus"),
    "estimator init_frames a string": (lambda m: m["estimator"].update(init_frames="3"),
                                       "init_frames"),
    "estimator meas_sigma negative": (lambda m: m["estimator"].update(meas_sigma=-1.0),
                                      "meas_sigma"),
    "estimator gate out of range": (lambda m: m["estimator"].update(gate_probability=1.5),
                                    "gate_probability"),
    "train_seed a string": (lambda m: m.update(train_seed="eleven"), "train_seed"),
}


@pytest.mark.parametrize("edit, name", BAD_META.values(), ids=BAD_META.keys())
def test_predictor_metadata_is_checked_at_load(tmp_path, edit, name):
    path = _predictor_with_meta(tmp_path, edit)
    with pytest.raises(PredictorFileError, match=name):
        HittingPointGPR.load(path)


@pytest.mark.parametrize("command", ["serve", "eval-predictor"])
def test_bad_predictor_metadata_is_one_line_in_the_cli(tmp_path, capsys, command):
    path = _predictor_with_meta(tmp_path, lambda m: m["estimator"].update(init_frames="3"))
    out = tmp_path / "out.json"
    argv = (["serve", "--player", "momp", "--library", f"{SHIPPED}/library.npz", "--crkr",
             f"{SHIPPED}/crkr.npz", "--predictor", str(path), "--serves", "1"]
            if command == "serve" else ["eval-predictor", "--model", str(path), "--serves", "1",
                                        "--seed", "5"])
    line = one_line_error(capsys, [*argv, "--json", str(out), "--quiet"])
    assert "init_frames" in line and not out.exists()


def test_a_library_of_absurd_magnitudes_is_refused(tmp_path):
    arrays, meta = load_artefact(f"{SHIPPED}/library.npz", LIBRARY_FILE_KIND)
    huge = {name: np.full_like(a, 1e300) if a.dtype.kind == "f" else a
            for name, a in arrays.items()}
    path = save_artefact(tmp_path / "l.npz", LIBRARY_FILE_KIND, huge, meta)
    with pytest.raises(LearnedArtefactError, match="outside its physical range"):
        load_player_library(path)


@pytest.mark.parametrize("key, value, message", [
    ("alpha_y", float("inf"), "must be finite"),
    ("eta_max", float("inf"), "must be finite"),
    ("min_steps", 10**9, "min_steps must be at most"),
])
def test_a_library_with_absurd_dmp_settings_is_refused(tmp_path, key, value, message):
    arrays, meta = load_artefact(f"{SHIPPED}/library.npz", LIBRARY_FILE_KIND)
    meta["dmp"][key] = value
    path = save_artefact(tmp_path / "l.npz", LIBRARY_FILE_KIND, arrays, meta)
    with pytest.raises(LearnedArtefactError, match=message):
        load_player_library(path)


# -- physical ranges of the controller's faults ------------------------------------------------

@pytest.mark.parametrize("text, message", [
    ("controller: {joint_viscous: [1.0e9, 0, 0, 0, 0, 0, 0]}\n",
     "controller.joint_viscous [0] must be <= 75"),
    ("controller: {joint_coulomb: [0, 0, 0, 0, 0, 0, 2.0]}\n",
     "controller.joint_coulomb [6] must be <= 1"),
    ("controller: {coulomb_velocity: 1.0e-300}\n", "controller.coulomb_velocity must be >= 0.01"),
    ("controller: {torque_noise: [0, 1.0e6, 0, 0, 0, 0, 0]}\n",
     "controller.torque_noise [1] must be <= 125"),
    ("rally: {exchange_timeout: 1.0e9}\n", "rally.exchange_timeout must be <= 60"),
], ids=["joint_viscous", "joint_coulomb", "coulomb_velocity", "torque_noise",
        "exchange_timeout"])
def test_absurd_physical_parameters_are_refused(tmp_path, text, message):
    with pytest.raises(ScenarioError, match=message.replace("[", r"\[").replace("]", r"\]")):
        load_scenario(scenario_file(tmp_path, text))


# -- data files named by the environment -------------------------------------------------------

def test_an_endless_ball_state_file_is_refused_by_its_size(monkeypatch, capsys):
    from tt_drake.serves import ServeError, load_real_states

    monkeypatch.setenv("TT_DRAKE_SERVES", "/dev/zero")
    with pytest.raises(ServeError, match=f"larger than {64 << 20} bytes"):
        load_real_states()
    line = one_line_error(capsys, ["serve", "--distribution", "real", "--serves", "1",
                                   "--quiet"])
    assert "/dev/zero is larger than" in line


# -- Drake's Meshcat log line ------------------------------------------------------------------

def test_the_recordings_meshcat_logs_nothing():
    """The recording's Meshcat serves no browser: nothing on stderr when it starts."""
    done = subprocess.run([sys.executable, "-c", "from tt_drake.diagrams.recording import "
                           "make_meshcat; make_meshcat()"], capture_output=True, text=True,
                          timeout=120, check=True)
    assert "Meshcat" not in done.stderr and done.stderr.strip() == "", done.stderr


def _rally_scenario(monkeypatch, argv):
    """The scenario ``tt-drake rally`` would play, without playing it."""
    import tt_drake.diagrams.rally as rally

    seen = {}

    def run_rallies(scenario, *args, **kwargs):
        seen["scenario"] = scenario
        return {}

    monkeypatch.setattr(rally, "run_rallies", run_rallies)
    monkeypatch.setattr(rally, "format_rally_summary", lambda data: "")
    assert main(["rally", "--players", "momp", "analytical", "--quiet", *argv]) == 0
    return seen["scenario"]


def test_the_rallys_configuration_default_does_not_override_a_scenarios(tmp_path, monkeypatch):
    crkr = scenario_file(tmp_path, "learned: {configuration: crkr}\n")
    assert _rally_scenario(monkeypatch, ["--scenario", crkr]).learned.configuration == "crkr"
    # A scenario that names none plays the rally's default; the option wins over both.
    assert _rally_scenario(monkeypatch, []).learned.configuration == "analytical"
    assert _rally_scenario(monkeypatch, ["--scenario", crkr, "--configuration",
                                         "analytical"]).learned.configuration == "analytical"


def test_a_python_built_scenarios_model_path_is_recorded_resolved(tmp_path, monkeypatch):
    from tt_drake.diagrams.serve import scenario_dict

    monkeypatch.chdir(tmp_path)
    (tmp_path / "ball.sdf").write_text(MODELS.joinpath("ball.sdf").read_text())
    scenario = load_scenario()
    scenario.world.models.ball = "./ball.sdf"
    assert scenario_dict(scenario)["world"]["models"]["ball"] == str(tmp_path / "ball.sdf")
    assert scenario.world.models.ball == "./ball.sdf"  # the caller's scenario is left as it was
