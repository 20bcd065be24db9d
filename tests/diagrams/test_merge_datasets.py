"""The hard protocol's teacher datasets merged into one: every per-sample owner array
(``trajectory_serve`` and ``recorded_serve``) follows its serves to their new indices."""

import json

import numpy as np

from tt_drake.artefacts import save_artefact
from tt_drake.diagrams.collect import KIND, MANIFEST, PER_SERVE, TRAJECTORY_COLUMNS, load_dataset
from tt_drake.diagrams.reproduce import _merge_datasets


def _dataset(folder, serves: int, rows_per_serve: int, tag: float):
    folder.mkdir(parents=True)
    arrays = {"index": np.arange(serves), "seed": np.arange(serves, dtype=np.uint64)}
    for key in PER_SERVE:
        arrays[key] = np.full((serves, 3), tag)
    arrays["returned"] = np.ones(serves)
    for name in ("trajectory", "recorded"):
        owner = np.repeat(np.arange(serves), rows_per_serve)
        rows = np.zeros((len(owner), len(TRAJECTORY_COLUMNS)))
        rows[:, 0] = np.tile(np.arange(rows_per_serve) * 0.002, serves)  # t, per serve
        rows[:, 2] = tag + owner  # q1 tells which serve of which dataset a row is
        arrays[name], arrays[f"{name}_serve"] = rows, owner
    save_artefact(folder / "chunk_00000.npz", KIND, arrays, {"chunk": 0})
    (folder / MANIFEST).write_text(json.dumps({"format": KIND, "player": "analytical",
                                               "scenario": "default", "distribution": str(tag),
                                               "seed": 1, "serves": serves,
                                               "chunk_size": serves}))


def test_merged_owners_follow_their_serves(tmp_path):
    _dataset(tmp_path / "a", 3, 4, 100.0)
    _dataset(tmp_path / "b", 2, 5, 200.0)
    _merge_datasets([tmp_path / "a", tmp_path / "b"], tmp_path / "merged")
    data = load_dataset(tmp_path / "merged")
    assert list(data["index"]) == [0, 1, 2, 3, 4]
    for name in ("trajectory", "recorded"):
        owner = data[f"{name}_serve"]
        for i in range(5):
            rows = data[name][owner == i]
            tag, local = (100.0, i) if i < 3 else (200.0, i - 3)
            assert len(rows) == (4 if i < 3 else 5)
            assert np.all(rows[:, 2] == tag + local)  # this serve's rows, none of another's
            assert np.all(np.diff(rows[:, 0]) > 0)  # one stroke's clock, increasing
