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


def test_bad_distributions_and_features_are_one_line_exit_2(tmp_path, capsys, monkeypatch):
    out = tmp_path / "p.npz"
    js = tmp_path / "e.json"
    for argv, message in (
            (["train-predictor", "--distribution", "default,lob"], "unknown serve distribution"),
            (["train-predictor", "--distribution", "spin,spin"], "listed twice"),
            (["eval-predictor", "--model", "unused.npz", "--distribution", "lob"],
             "unknown serve distribution")):
        assert main([*argv, "--serves", "5", "--out" if argv[0] == "train-predictor"
                     else "--json", str(out if argv[0] == "train-predictor" else js),
                     "--quiet"]) == 2
        err = capsys.readouterr().err
        assert message in err and err.count("\n") == 1
    with pytest.raises(SystemExit) as exit_:  # argparse's choices: one line, status 2
        main(["train-predictor", "--features", "spin", "--out", str(out)])
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and err.count("\n") == 1 and "invalid choice" in err
    # A split asked of a ball file without record ids.
    noids = tmp_path / "noids.json"
    noids.write_text(json.dumps([{"pos_x": 0.0, "pos_y": 1.0, "pos_z": 0.1, "vel_x": 0.0,
                                  "vel_y": -4.0, "vel_z": 1.0, "w_vel_x": 0.0, "w_vel_y": 0.0,
                                  "w_vel_z": 0.0}]))
    monkeypatch.setenv("TT_DRAKE_SERVES", str(noids))
    assert main(["train-predictor", "--distribution", "default,real-train", "--serves", "5",
                 "--out", str(out), "--quiet"]) == 2
    assert "no train split" in capsys.readouterr().err
    assert not out.exists() and not js.exists()


def test_eval_on_another_distribution_names_it(trained, capsys):
    d, out = trained
    js = d / "spin.json"
    assert main(["eval-predictor", "--model", str(out), "--serves", "12", "--seed", "5",
                 "--distribution", "spin", "--json", str(js), "--quiet"]) == 0
    assert "12 spin (eval seed 5" in capsys.readouterr().out
    data = json.loads(js.read_text())
    assert data["distribution"] == "spin" and data["train_distribution"] == "default"
    assert data["feature_set"] == "states"


def test_a_mix_is_shared_evenly_in_its_order():
    from tt_drake.diagrams.predictor import parse_distributions, share

    names = parse_distributions("default, spin,real-train")
    assert names == ["default", "spin", "real-train"]
    assert share(900, names) == [300, 300, 300] and share(11, names) == [4, 4, 3]
    assert share(2, names) == [1, 1, 0] and parse_distributions(None) == ["default"]


def test_a_distributions_serves_are_its_own(tmp_path):
    """The samples of a mix: each distribution's share drawn from that distribution (the
    spin launcher's serves spin, the default ones do not), labelled with its index."""
    import numpy as np

    from tt_drake.diagrams.predictor import generate_mix

    samples = generate_mix(4, 7, ["default", "spin"], None, workers=1, progress=False)
    assert samples["distribution"].tolist() == [0, 0, 1, 1]
    spin = np.abs(samples["launch"][:, 6:9]).max(axis=1)
    assert np.all(spin[:2] == 0.0) and np.all(spin[2:] > 0.0) and np.all(spin[2:] <= 100.0)
