"""tt-drake collect: chunked teacher demonstrations, resumable, refusing to mix runs."""

import numpy as np
import pytest

from tt_drake.diagrams.collect import DatasetError, collect, load_dataset
from tt_drake.diagrams.episodes import episode_seed
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.stages import HITTING, STAGES


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    folder = tmp_path_factory.mktemp("demos") / "run"
    summary = collect(load_scenario(), "analytical", 3, 5, str(folder), progress=False,
                      chunk_size=2)
    return folder, summary


def test_dataset_holds_every_serve_with_its_stroke(dataset):
    folder, summary = dataset
    assert summary["simulated"] == 3 and sorted(p.name for p in folder.iterdir()) == [
        "chunk_00000.npz", "chunk_00001.npz", "manifest.json"]
    data = load_dataset(folder)
    np.testing.assert_array_equal(data["index"], [0, 1, 2])
    assert [int(s) for s in data["seed"]] == [episode_seed(5, i) for i in range(3)]
    hit = data["hit"].astype(bool)
    assert hit.any()
    # The teacher's stimulus is its prediction of the true crossing: centimetres and ms apart.
    err = np.abs(data["stimulus"][hit] - data["true_hit"][hit])
    assert np.all(err[:, :3] < 0.03) and np.all(err[:, 6] < 0.02)
    # The hitting stage's samples end at the hitting configuration.
    for i in np.flatnonzero(hit):
        rows = data["trajectory"][(data["trajectory_serve"] == i)
                                  & (data["trajectory"][:, 1] == STAGES.index(HITTING))]
        np.testing.assert_allclose(rows[-1, 2:9], data["q_hit"][i], atol=1e-9)
        np.testing.assert_allclose(rows[-1, 9:16], data["qd_hit"][i], atol=1e-9)
        assert np.allclose(np.diff(rows[:, 0]), 1 / 500)  # 500 Hz


def test_an_interrupted_run_resumes_from_its_chunks(dataset):
    folder, _ = dataset
    first = (folder / "chunk_00000.npz").read_bytes()
    (folder / "chunk_00001.npz").unlink()  # as if interrupted before the last chunk
    summary = collect(load_scenario(), "analytical", 3, 5, str(folder), progress=False,
                      chunk_size=2)
    assert summary["simulated"] == 1 and summary["kept"] == 2
    assert (folder / "chunk_00000.npz").read_bytes() == first  # kept, not redone


def test_another_run_or_a_damaged_chunk_is_refused(dataset, tmp_path):
    folder, _ = dataset
    with pytest.raises(DatasetError, match="another run's dataset"):
        collect(load_scenario(), "analytical", 3, 6, str(folder), progress=False, chunk_size=2)
    (tmp_path / "stray.txt").write_text("x")
    with pytest.raises(DatasetError, match="not empty"):
        collect(load_scenario(), "analytical", 1, 0, str(tmp_path), progress=False)
    copy = tmp_path / "copy"
    copy.mkdir()
    for f in folder.iterdir():
        (copy / f.name).write_bytes(f.read_bytes())
    (copy / "chunk_00001.npz").write_bytes(b"\x00" * 100)
    with pytest.raises(DatasetError, match="incomplete or damaged"):
        load_dataset(copy)


def test_an_oracle_teacher_demonstrates_on_the_true_hitting_state(tmp_path):
    """With the oracle's perception (the paper protocol's teacher) the stimulus the teacher
    planned for is the ball's true state at the hitting plane to a millimetre and mm/s (through
    the camera it is centimetres off, above); the dataset names its perception, and the same
    run through the camera is another run's dataset."""
    scenario = load_scenario()
    scenario.perception = "oracle"
    folder = tmp_path / "oracle"
    collect(scenario, "analytical", 2, 5, str(folder), progress=False)
    data = load_dataset(folder)
    assert data["manifest"]["perception"] == "oracle"
    hit = data["hit"].astype(bool)
    assert hit.all()
    err = np.abs(data["stimulus"][hit] - data["true_hit"][hit])
    assert np.all(err[:, :3] < 1e-3) and np.all(err[:, 3:6] < 5e-3)
    with pytest.raises(DatasetError, match="another run's dataset"):
        collect(load_scenario(), "analytical", 2, 5, str(folder), progress=False)
