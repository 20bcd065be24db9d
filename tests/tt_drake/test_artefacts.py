"""Persistence: .npz + JSON metadata, no pickle, clear errors."""

from __future__ import annotations

import json
import zipfile

import numpy as np
import pytest

from tt_drake.artefacts import ArtefactError, load_artefact, save_artefact
from tt_drake.crkr import CrKR
from tt_drake.dmp import HittingDMP
from tt_drake.momp import MotorPrimitiveLibrary
from tt_drake.responsibility import ResponsibilityParams


def _library():
    dmp = HittingDMP(n_basis=12, alpha_z=2.5)
    rng = np.random.default_rng(0)
    lib = MotorPrimitiveLibrary(
        dmp, rng.normal(size=(4, 7, 12)), rng.uniform(0.1, 1, (4, 7)), rng.normal(size=(4, 6)),
        rng.uniform(0.2, 1, 6), responsibility=ResponsibilityParams(kappa=2.0, zeta=0.5),
        min_weight=1e-5,
    )
    lib.update_responsibilities(lib.stimuli[0], 0.3, prune=False)
    return lib


def test_generic_round_trip_is_exact(tmp_path):
    arrays = {"a": np.arange(6.0).reshape(2, 3), "b": np.array([1, 2], dtype=np.int32),
              "c": np.array(np.pi)}
    path = save_artefact(tmp_path / "x.npz", "thing", arrays, {"note": "hi", "k": [1, 2]})
    out, meta = load_artefact(path, "thing")
    assert meta == {"note": "hi", "k": [1, 2]}
    for k, v in arrays.items():
        assert out[k].dtype == v.dtype and np.array_equal(out[k], v)
    assert [p.name for p in tmp_path.iterdir()] == ["x.npz"]  # no temporary left behind


def test_library_round_trip_is_exact(tmp_path):
    lib = _library()
    lib.save(tmp_path / "lib.npz")
    again = MotorPrimitiveLibrary.load(tmp_path / "lib.npz")
    assert again.dmp == lib.dmp and again.responsibility == lib.responsibility
    assert again.min_weight == lib.min_weight
    for name in ("weights", "amplitude", "stimuli", "bandwidths", "gamma", "s", "n"):
        assert np.array_equal(getattr(again, name), getattr(lib, name))
    x, task = lib.stimuli[1], (np.zeros(7), np.ones(7), np.ones(7), 0.5)
    assert np.array_equal(again.plan(x, *task).q, lib.plan(x, *task).q)


def test_crkr_round_trip_is_exact(tmp_path):
    rng = np.random.default_rng(1)
    x, y, c = rng.normal(size=(20, 3)), rng.normal(size=(20, 2)), rng.uniform(0.1, 1, 20)
    model = CrKR([0.5, 1.0, 2.0], 0.3).fit(x[:12], y[:12], c[:12]).add(x[12:], y[12:], c[12:])
    model.save(tmp_path / "m.npz")
    again = CrKR.load(tmp_path / "m.npz")
    xq = rng.normal(size=(5, 3))
    for a, b in zip(model.predict(xq), again.predict(xq), strict=True):
        assert np.array_equal(a, b)


def test_corrupted_file_fails_with_clear_message(tmp_path):
    path = tmp_path / "lib.npz"
    _library().save(path)
    data = bytearray(path.read_bytes())
    data[len(data) // 3] ^= 0xFF  # flip bits inside the compressed payload
    path.write_bytes(bytes(data))
    with pytest.raises(ArtefactError, match="lib.npz"):
        MotorPrimitiveLibrary.load(path)


def test_truncated_file_fails(tmp_path):
    path = tmp_path / "lib.npz"
    _library().save(path)
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    with pytest.raises(ArtefactError, match="corrupt or truncated"):
        MotorPrimitiveLibrary.load(path)


def test_missing_not_an_artefact_and_pickle(tmp_path):
    with pytest.raises(ArtefactError, match="no such"):
        load_artefact(tmp_path / "nope.npz", "thing")
    np.save(tmp_path / "bare.npy", np.zeros(3))
    with pytest.raises(ArtefactError, match="bare .npy"):
        load_artefact(tmp_path / "bare.npy", "thing")
    np.savez(tmp_path / "plain.npz", a=np.zeros(3))
    with pytest.raises(ArtefactError, match="no __meta__"):
        load_artefact(tmp_path / "plain.npz", "thing")
    np.save(tmp_path / "obj.npy", np.array([{"a": 1}], dtype=object), allow_pickle=True)
    with pytest.raises(ArtefactError):
        load_artefact(tmp_path / "obj.npy", "thing")
    (tmp_path / "text.npz").write_text("hello")
    with pytest.raises(ArtefactError):
        load_artefact(tmp_path / "text.npz", "thing")
    with pytest.raises(ValueError):
        save_artefact(tmp_path / "o.npz", "thing", {"a": np.array([None])})


def test_wrong_kind_and_version(tmp_path):
    path = save_artefact(tmp_path / "x.npz", "crkr-model", {"a": np.zeros(2)})
    with pytest.raises(ArtefactError, match="expected 'momp-library'"):
        MotorPrimitiveLibrary.load(path)
    # rewrite the metadata with a future version
    with zipfile.ZipFile(path) as zf:
        meta = json.loads(np.load(path)["__meta__"].tobytes())
        members = {n: zf.read(n) for n in zf.namelist()}
    meta["format_version"] = 99
    np.savez(tmp_path / "future.npz", a=np.zeros(2),
             __meta__=np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8))
    assert members
    with pytest.raises(ArtefactError, match="format version 99"):
        load_artefact(tmp_path / "future.npz", "crkr-model")


def test_array_swapped_behind_the_metadata_is_detected(tmp_path):
    path = save_artefact(tmp_path / "x.npz", "thing", {"a": np.arange(3.0)})
    meta = np.load(path)["__meta__"]
    np.savez(tmp_path / "edited.npz", a=np.arange(3.0) + 1, __meta__=meta)
    with pytest.raises(ArtefactError, match="checksum"):
        load_artefact(tmp_path / "edited.npz", "thing")
    np.savez(tmp_path / "short.npz", __meta__=meta)
    with pytest.raises(ArtefactError, match="missing arrays"):
        load_artefact(tmp_path / "short.npz", "thing")
