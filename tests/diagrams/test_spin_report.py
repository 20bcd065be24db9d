"""spin_report's bad input: one line on stderr, exit status 2, no output file."""

from tt_drake.diagrams.spin_report import main


def test_bad_input_is_one_line_and_exit_2(tmp_path, capsys):
    out = tmp_path / "report.json"
    for argv in (["--serves", "0"], ["--serves", "2", "--distribution", "nowhere"],
                 ["--serves", "2", "--scenario", str(tmp_path / "missing.yaml")]):
        assert main([*argv, "--json", str(out)]) == 2
        err = capsys.readouterr().err
        assert err.startswith("error: ") and err.count("\n") == 1
        assert not out.exists()
