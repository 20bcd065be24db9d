"""`tt-drake train-predictor` / `eval-predictor`: a tiny run end to end and the user errors."""

import json

import pytest

from tt_drake.diagrams.cli import main


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    d = tmp_path_factory.mktemp("pred")
    out = d / "p.npz"
    assert main(["train-predictor", "--serves", "40", "--seed", "3", "--out", str(out),
                 "--quiet"]) == 0
    return d, out


def test_train_then_eval_writes_json_and_prints_the_table(trained, capsys):
    d, out = trained
    js = d / "e.json"
    assert main(["eval-predictor", "--model", str(out), "--serves", "20", "--seed", "4",
                 "--json", str(js), "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "GPR MSE" in text and "phys MSE" in text and "exact" in text
    data = json.loads(js.read_text())
    assert [r["output"] for r in data["gpr"]] == ["p_x", "p_y", "p_z", "v_x", "v_y", "v_z",
                                                  "t_hit"]
    assert data["gpr"][1]["exact"] and data["query_time"]["median_ms"] < 5.0


def test_corrupt_model_is_one_line_exit_2(trained, capsys):
    d, out = trained
    bad = d / "bad.npz"
    raw = bytearray(out.read_bytes())
    raw[len(raw) // 3] ^= 0xFF
    bad.write_bytes(bytes(raw))
    assert main(["eval-predictor", "--model", str(bad), "--serves", "5", "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("tt-drake eval-predictor: error:") and "\n" not in err


def test_same_seed_and_unwritable_output_are_refused(trained, tmp_path, capsys):
    _, out = trained
    assert main(["eval-predictor", "--model", str(out), "--serves", "5", "--seed", "3",
                 "--quiet"]) == 2
    assert "training seed" in capsys.readouterr().err
    assert main(["train-predictor", "--serves", "5", "--out", str(tmp_path / "no" / "p.npz"),
                 "--quiet"]) == 2
    assert not (tmp_path / "no").exists()
