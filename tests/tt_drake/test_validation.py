"""Every artefact array is checked at load (declared size before reading, finite values, shapes
and signs), so a damaged or edited file fails with one line instead of a wrong answer
(docs/robustness.md)."""

import io
import json
import zipfile
from importlib import resources

import numpy as np
import pytest

from tt_drake.artefacts import ArtefactError, load_artefact, save_artefact
from tt_drake.hitting_point import ARTEFACT_KIND, HittingPointGPR, PredictorFileError
from tt_drake.learned_player import (
    LIBRARY_FILE_KIND,
    LearnedArtefactError,
    load_player_library,
)

SHIPPED = str(resources.files("tt_drake.models").joinpath("learned"))


def _edited(src, dst, kind, name, edit):
    """A copy of the shipped artefact ``src`` with array ``name`` edited, re-saved with valid
    checksums: what a buggy trainer (not a damaged disk) would write."""
    arrays, meta = load_artefact(src, kind)
    arrays[name] = arrays[name].copy()
    edit(arrays[name])
    save_artefact(dst, kind, arrays, meta)
    return dst


@pytest.mark.parametrize("name, value", [("x_scale", np.inf), ("alpha", np.nan),
                                         ("length_scales", 0.0), ("y_scale", -1.0)])
def test_predictor_with_bad_numbers_is_refused(tmp_path, name, value):
    def edit(a):
        a.flat[3] = value

    path = _edited(f"{SHIPPED}/predictor.npz", tmp_path / "p.npz", ARTEFACT_KIND, name, edit)
    with pytest.raises(PredictorFileError, match=name):
        HittingPointGPR.load(path)


def test_library_with_nan_is_refused(tmp_path):
    def edit(a):
        a[0, 0, 0] = np.nan

    path = _edited(f"{SHIPPED}/library.npz", tmp_path / "l.npz", LIBRARY_FILE_KIND, "weights",
                   edit)
    with pytest.raises(LearnedArtefactError, match="'weights' holds NaN or infinite values"):
        load_player_library(path)


def test_nan_library_is_one_line_in_the_cli(tmp_path, capsys):
    from tt_drake.diagrams.cli import main

    def edit(a):
        a[5] = np.nan

    path = _edited(f"{SHIPPED}/library.npz", tmp_path / "l.npz", LIBRARY_FILE_KIND, "stimuli",
                   edit)
    status = main(["serve", "--player", "momp", "--library", str(path), "--crkr",
                   f"{SHIPPED}/crkr.npz", "--serves", "1", "--quiet"])
    err = capsys.readouterr().err
    assert status == 2 and len(err.strip().splitlines()) == 1
    assert "'stimuli' holds NaN" in err


def _npy_header(shape, dtype="<f8") -> bytes:
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": dtype, "fortran_order": False,
                                               "shape": shape})
    return buf.getvalue()


def test_small_file_claiming_a_huge_array_is_refused_before_reading(tmp_path):
    """A 400-byte .npz whose header claims 10^12 floats (8 TB) must not be allocated."""
    path = tmp_path / "huge.npz"
    doc = {"format": "tt-drake-artefact", "format_version": 1, "kind": "thing",
           "arrays": {"a": {"dtype": "<f8", "shape": [10**12], "sha256": "0"}}, "meta": {}}
    meta = np.frombuffer(json.dumps(doc).encode(), dtype=np.uint8)
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("a.npy", _npy_header((10**12,)))
        buf = io.BytesIO()
        np.lib.format.write_array(buf, meta)
        zf.writestr("__meta__.npy", buf.getvalue())
    assert path.stat().st_size < 1000
    with pytest.raises(ArtefactError, match=r"declares \[1000000000000\] <f8"):
        load_artefact(path, "thing")


def test_non_finite_arrays_are_refused_unless_allowed(tmp_path):
    path = save_artefact(tmp_path / "x.npz", "thing", {"a": [1.0, np.inf], "b": [np.nan, 2.0]})
    with pytest.raises(ArtefactError, match="'a' holds NaN or infinite values"):
        load_artefact(path, "thing", allow_nonfinite=("b",))
    arrays, _ = load_artefact(path, "thing", allow_nonfinite=("a", "b"))
    assert np.isinf(arrays["a"][1]) and np.isnan(arrays["b"][0])
