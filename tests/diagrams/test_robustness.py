"""The robustness guards, one test each: bad numbers never give a wrong answer, bad input is one
line and exit status 2, outputs survive a full disk, caches survive damage, run folders are locked
(docs/robustness.md lists the risks and their guards)."""

import fcntl
import json
import resource
import signal
import subprocess
import sys

import numpy as np
import pytest

from tests.diagrams._cli import one_line_error
from tt_drake.diagrams.scenario import ScenarioError, load_scenario

# -- 1. scenario values are checked at the boundary ----------------------------------------------

INVALID_FIELDS = {
    "referee_rate: .inf\n": "referee_rate must be finite",
    "referee: {target_radius: -0.2}\n": "referee.target_radius must be > 0",
    "launcher: {spin_max: .nan}\n": "launcher.spin_max must be finite",
    "world: {simulator: {max_step_size: .inf}}\n": "world.simulator.max_step_size must be finite",
    "world: {simulator: {accuracy: .nan}}\n": "world.simulator.accuracy must be finite",
    "world: {simulator: {integration_scheme: bogus}}\n":
        "world.simulator.integration_scheme 'bogus' is not one of",
    "world: {plant: {contact_model: bogus}}\n": "world.plant.contact_model 'bogus' is not one of",
    "aerodynamics: {drag_k: .nan}\n": "aerodynamics.drag_k must be finite",
    "aerodynamics: {drag_k: -0.1}\n": "aerodynamics.drag_k must be >= 0",
    "world: {simulator: {max_step_size: -0.002}}\n": "world.simulator.max_step_size must be > 0",
    "controller: {kp: [900, 900, 900, .nan, 900, 900, 900]}\n": "controller.kp [3] must be finite",
    "controller: {kd: [60, 60, 60, 60, 60, 60, -1]}\n": "controller.kd [6] must be >= 0",
    "after_crossing: .inf\n": "after_crossing must be finite",
    "teacher: {ik_solver: ipopt}\n": "teacher.ik_solver 'ipopt' is not one of snopt, sqp",
}


@pytest.mark.parametrize("text, message", INVALID_FIELDS.items())
def test_invalid_scenario_values_are_refused_naming_the_field(tmp_path, text, message):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(ScenarioError, match=message.replace("[", r"\[").replace("]", r"\]")):
        load_scenario(str(path))


def test_every_invalid_field_is_named_in_one_line(tmp_path, capsys):
    path = tmp_path / "bad.yaml"
    path.write_text("referee_rate: .inf\nreferee: {target_radius: -0.2}\n")
    line = one_line_error(capsys, ["serve", "--scenario", str(path), "--serves", "1", "--quiet"])
    assert "referee_rate must be finite" in line and "referee.target_radius must be > 0" in line


def test_invalid_values_set_through_the_api_never_reach_drake():
    from tt_drake.diagrams.episodes import ServeDiagram

    scenario = load_scenario("default")
    scenario.referee_rate = float("inf")
    with pytest.raises(ScenarioError, match="referee_rate must be finite"):
        ServeDiagram(scenario, "idle")


def test_malformed_model_files_are_one_line(tmp_path, capsys):
    broken = tmp_path / "broken.urdf"
    broken.write_text("<robot name='wam'><link name='a'>")  # not well-formed XML
    wrong = tmp_path / "wrong.urdf"
    wrong.write_text("<robot name='x'><link name='a'/><joint name='j'/></robot>")  # no WAM
    for path, message in ((broken, "malformed model file"), (wrong, "cannot load model file")):
        scenario = tmp_path / f"{path.stem}.yaml"
        scenario.write_text(f"world: {{models: {{robot: {path}}}}}\n")
        line = one_line_error(capsys, ["serve", "--scenario", str(scenario), "--serves", "1",
                                       "--quiet"])
        assert message in line and path.name in line


# -- 2. option errors, seeds and serve counts ------------------------------------------------------

@pytest.mark.parametrize("argv, message", [
    (["serve", "--serves", "0"], "tt-drake serve: error: argument --serves: must be > 0"),
    (["serve", "--bogus"], "tt-drake: error: unrecognized arguments: --bogus"),
    (["collect"], "tt-drake collect: error: the following arguments are required: --out"),
    (["nosuch"], "tt-drake: error: argument command: invalid choice: 'nosuch'"),
    (["serve", "--seed", "-1"], "tt-drake serve: error: argument --seed: must be in [0, "),
    (["serve", "--serves", "1000000000"],
     "tt-drake serve: error: argument --serves: must be at most 100000"),
])
def test_option_errors_are_one_line_and_exit_2(capsys, argv, message):
    assert one_line_error(capsys, argv).startswith(message)


def test_negative_seed_writes_nothing(tmp_path, capsys):
    from tt_drake.diagrams.collect import collect
    from tt_drake.diagrams.episodes import SeedError

    out = tmp_path / "data"
    one_line_error(capsys, ["collect", "--seed", "-5", "--serves", "1", "--out", str(out),
                            "--quiet"])
    with pytest.raises(SeedError, match="seed must be a whole number in"):
        collect(load_scenario("default"), "idle", 1, -5, str(out))
    assert not out.exists()  # no manifest-only folder that would block the next run


def test_collect_streams_its_seeds(tmp_path, monkeypatch):
    """The first episode starts before the seeds of the later serves are computed."""
    import tt_drake.diagrams.collect as collect_module

    computed = []
    real_seed = collect_module.episode_seed

    def counting_seed(base, index):
        computed.append(index)
        return real_seed(base, index)

    class FirstEpisode(Exception):
        pass

    def first_episode(scenario, player, seeds, *args, **kwargs):
        next(iter(seeds))
        raise FirstEpisode(len(computed))

    monkeypatch.setattr(collect_module, "episode_seed", counting_seed)
    monkeypatch.setattr(collect_module, "run_episodes", first_episode)
    with pytest.raises(FirstEpisode) as info:
        collect_module.collect(load_scenario("default"), "idle", 50_000, 0, str(tmp_path / "d"),
                               progress=False)
    assert info.value.args[0] == 1


# -- 2. outputs: a full disk is one line, and leaves no partial or temporary file ----------------

def _refuse_writes(limit=4096):
    """In the child: the kernel refuses to grow any file beyond ``limit`` bytes (EFBIG, as a
    full disk refuses with ENOSPC); SIGXFSZ is ignored so the write fails instead of killing."""
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, resource.RLIM_INFINITY))


def _cli_on_full_disk(*args, limit=4096):
    return subprocess.run([sys.executable, "-m", "tt_drake.diagrams.cli", *args],
                          capture_output=True, text=True, timeout=600,
                          preexec_fn=lambda: _refuse_writes(limit))


def _left(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())


@pytest.mark.parametrize("args", [["serve", "--quiet", "--json"], ["serve", "--quiet", "--html"],
                                  ["bench", "--json"]])
def test_full_disk_on_json_and_html_output_is_one_line(tmp_path, args):
    out = tmp_path / "out.file"
    result = _cli_on_full_disk(*args, str(out), "--serves", "2", limit=200)
    # (--html: Drake logs where its Meshcat server listens; that line is no error)
    lines = [line for line in result.stderr.strip().splitlines()
             if not line.startswith("INFO:drake:Meshcat listening")]
    assert result.returncode == 2, result.stderr
    assert len(lines) == 1 and f"cannot write {out}" in lines[0], result.stderr
    assert _left(tmp_path) == []  # neither the output nor a temporary file


def test_full_disk_in_collect_and_train_library_is_one_line(tmp_path):
    from tt_drake.diagrams.collect import collect

    data = tmp_path / "data"
    result = _cli_on_full_disk("collect", "--serves", "1", "--out", str(data), "--workers", "1",
                               "--quiet", limit=20_000)
    assert result.returncode == 2, result.stderr
    assert len(result.stderr.strip().splitlines()) == 1 and "cannot write" in result.stderr
    assert _left(data) == ["manifest.json"]  # the chunk was not written, nor a temporary file

    teacher = tmp_path / "teacher"
    collect(load_scenario(), "analytical", 3, 11, str(teacher), progress=False, chunk_size=3)
    library = tmp_path / "library.npz"
    result = _cli_on_full_disk("train", "library", "--data", str(teacher), "--out", str(library),
                               limit=1000)
    assert result.returncode == 2, result.stderr
    assert len(result.stderr.strip().splitlines()) == 1 and "cannot write" in result.stderr
    assert not library.exists() and not list(tmp_path.glob(".library.npz*"))


def test_full_disk_in_train_predictor_leaves_no_temp_file(tmp_path):
    out = tmp_path / "p.npz"
    result = _cli_on_full_disk("train-predictor", "--serves", "2", "--out", str(out), "--quiet",
                               limit=2000)
    assert result.returncode == 2, result.stderr
    assert len(result.stderr.strip().splitlines()) == 1 and "cannot write" in result.stderr
    assert _left(tmp_path) == []  # no chunk, no *.tmp.npz, no predictor


def test_atomic_file_turns_enospc_into_one_output_error(tmp_path, monkeypatch):
    import tt_drake.outputs as outputs

    def full(fd):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(outputs.os, "fsync", full)
    with pytest.raises(outputs.OutputError, match="cannot write .*a.json: No space left"):
        outputs.write_json_atomic(tmp_path / "a.json", {"x": 1})
    assert _left(tmp_path) == []


# -- 2. damaged cache chunks are detected, reported and recomputed --------------------------------

def test_damaged_predictor_cache_chunk_is_recomputed(tmp_path, capsys):
    from tt_drake.diagrams.predictor import _chunk_path, generate_samples

    clean = generate_samples(2, 3, tmp_path / "a", workers=1, progress=False)
    chunk = _chunk_path(tmp_path / "a", 3, 0)
    chunk.write_bytes(chunk.read_bytes()[:300])  # a truncated zip: BadZipFile
    again = generate_samples(2, 3, tmp_path / "a", workers=1, progress=False)
    assert "damaged cache chunk" in capsys.readouterr().err
    np.testing.assert_array_equal(again["seed"], clean["seed"])
    for key in clean:  # the same serves, simulated again (to the integrator's 1e-9 m)
        np.testing.assert_allclose(again[key], clean[key], rtol=0, atol=1e-9)
    third = generate_samples(2, 3, tmp_path / "a", workers=1, progress=False)  # cached again
    assert "damaged" not in capsys.readouterr().err
    np.testing.assert_array_equal(third["crossing"], again["crossing"])


# -- 2. a run folder is locked ---------------------------------------------------------------------

def _hold_lock(folder):
    """Another holder of ``folder``'s lock (flock locks belong to an open file description, so
    this is what another process's run looks like to this one)."""
    folder.mkdir(parents=True, exist_ok=True)
    file = open(folder / ".lock", "a")  # noqa: SIM115
    fcntl.flock(file.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    return file


def test_second_run_into_a_locked_folder_is_refused(tmp_path, capsys):
    from tt_drake.diagrams.collect import DatasetError, prepare_folder
    from tt_drake.diagrams.reproduce import ReproduceError, Run, quick_config

    manifest = {"format": "x", "seed": 1}
    prepare_folder(tmp_path / "d", manifest).release()
    other = _hold_lock(tmp_path / "d")
    with pytest.raises(DatasetError, match="in use by another"):
        prepare_folder(tmp_path / "d", manifest)
    line = one_line_error(capsys, ["collect", "--serves", "1", "--out", str(tmp_path / "d"),
                                   "--quiet"])
    assert "in use by another" in line
    other.close()
    prepare_folder(tmp_path / "d", manifest).release()  # free again once the other run ends

    other = _hold_lock(tmp_path / "r")
    with pytest.raises(ReproduceError, match="in use by another run"):
        Run(tmp_path / "r", quick_config(), True, 1, progress=False)
    other.close()
    Run(tmp_path / "r", quick_config(), True, 1, progress=False)


def test_concurrent_cli_run_is_refused(tmp_path):
    """Two processes run the same collect into one folder: the first has claimed it (and waits
    here, so the timing is fixed), the second is refused while the first runs."""
    from tt_drake.diagrams.collect import CHUNK_SIZE, _manifest

    folder = tmp_path / "d"
    manifest = _manifest(load_scenario(), "analytical", 1, 0, CHUNK_SIZE)
    first = subprocess.Popen(
        [sys.executable, "-c", "import json, sys; from tt_drake.diagrams.collect import "
         "prepare_folder; claim = prepare_folder(sys.argv[1], json.loads(sys.argv[2])); "
         "print('claimed', flush=True); sys.stdin.read()", str(folder), json.dumps(manifest)],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert first.stdout.readline().strip() == "claimed"
        second = subprocess.run([sys.executable, "-m", "tt_drake.diagrams.cli", "collect",
                                 "--serves", "1", "--out", str(folder), "--quiet"],
                                capture_output=True, text=True, timeout=300)
    finally:
        first.communicate("", timeout=60)
    assert second.returncode == 2, second.stderr
    assert "in use by another" in second.stderr
    assert len(second.stderr.strip().splitlines()) == 1
    assert _left(folder) == ["manifest.json"]  # the second wrote nothing; the first released


def test_predictor_cache_folder_is_locked(tmp_path):
    from tt_drake.diagrams.predictor import PredictorError, generate_samples

    other = _hold_lock(tmp_path / "c")
    with pytest.raises(PredictorError, match="in use"):
        generate_samples(2, 3, tmp_path / "c", workers=1, progress=False)
    other.close()


# -- a serve that never crosses the hitting plane is an outcome, not a crash -----------------------

def test_serve_that_never_crosses_the_hitting_plane_is_an_outcome():
    from tt_drake.diagrams.episodes import ServeDiagram
    from tt_drake.serves import LAUNCHER_Y, LAUNCHER_Z, Serve

    scenario = load_scenario("default")
    scenario.launcher.distribution = "fixed"
    diagram = ServeDiagram(scenario, "idle")
    away = np.array([0.0, LAUNCHER_Y, LAUNCHER_Z, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0])  # away from us
    diagram.launcher.sampler.sample = lambda seed: Serve(away, None)
    result = diagram.run(0)
    assert not result.outcome.hit and not result.outcome.returned
    assert all(c is None for c in result.as_dict()["predicted_crossing"])
    json.dumps(result.as_dict(), allow_nan=False)
    # The ball fell to the floor behind the launcher: the episode ended there (z = 0 from
    # z0 = LAUNCHER_Z with vz0 = 1 m/s takes sqrt-law time, under a second).
    t_floor = (1.0 + np.sqrt(1.0 + 2 * 9.81 * LAUNCHER_Z)) / 9.81
    assert result.duration == pytest.approx(t_floor, abs=0.05)
