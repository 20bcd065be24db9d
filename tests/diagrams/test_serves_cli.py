"""``tt-drake serves --info`` and the serve options (docs/serves.md): bad input is one line on
stderr, exit status 2 and no output file."""

import json

import pytest

from tt_drake.diagrams.cli import main
from tt_drake.serves import ServeSampler, load_real_states, split_of

KEYS = ("pos_x", "pos_y", "pos_z", "vel_x", "vel_y", "vel_z", "w_vel_x", "w_vel_y", "w_vel_z")


def _balls(path, n, ids=True):
    """The first n shipped serves, rewritten in the file's frame, with or without ids."""
    records = []
    for k, s in enumerate(load_real_states()[:n]):
        r = dict(zip(KEYS, map(float, s), strict=True))
        r["pos_z"] -= 0.76
        if ids:
            r["id"] = k
        records.append(r)
    path.write_text(json.dumps(records))
    return path


def _one_line_exit_2(capsys, argv, message):
    try:
        code = main(argv)
    except SystemExit as exit_:  # an option error: argparse exits (one line, status 2)
        code = exit_.code
    assert code == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and "Traceback" not in err


def test_bad_serve_input_is_one_line_exit_2_and_no_output(tmp_path, capsys, monkeypatch):
    out = tmp_path / "out.json"
    _one_line_exit_2(capsys, ["serve", "--distribution", "lob", "--json", str(out)],
                     "'lob' is not one of")
    _one_line_exit_2(capsys, ["serve", "--distribution", "spin", "--spin-max", "-1",
                              "--json", str(out)], "spin_max must be >= 0")
    monkeypatch.setenv("TT_DRAKE_SERVES", str(_balls(tmp_path / "noids.json", 5, ids=False)))
    _one_line_exit_2(capsys, ["serve", "--distribution", "real-test", "--json", str(out)],
                     "has no record ids, so it has no test split")
    _one_line_exit_2(capsys, ["serves", "--info", "--distribution", "real-train"],
                     "has no record ids, so it has no train split")
    _one_line_exit_2(capsys, ["serves"], "use --info")
    assert not out.exists()


def test_serves_info_prints_each_pool_count(tmp_path, capsys, monkeypatch):
    path = _balls(tmp_path / "balls.json", 30)
    monkeypatch.setenv("TT_DRAKE_SERVES", str(path))
    for name, split in (("real", None), ("real-test", "test")):
        assert main(["serves", "--info", "--distribution", name]) == 0
        line = capsys.readouterr().out.strip()
        in_split = sum(split is None or split_of(i) == split for i in range(30))
        pool = len(ServeSampler(name, real_path=path).pool())
        assert line.startswith(f"{name}: {pool} of {in_split} balls")
        assert f"(30 records in {path})" in line


@pytest.mark.parametrize("name", ["default", "spin", "fixed"])
def test_serves_info_names_the_launcher_distributions(capsys, name):
    assert main(["serves", "--info", "--distribution", name]) == 0
    assert capsys.readouterr().out.strip() == f"{name}: drawn by the launcher, no pool"
