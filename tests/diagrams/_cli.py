"""Running the ``tt-drake`` command in the test's process, for the tests of its error lines."""

from tt_drake.diagrams.cli import main


def one_line_error(capsys, argv, code=2):
    """Run ``tt-drake argv`` in this process; the exit status and the single stderr line."""
    try:
        status = main(argv)
    except SystemExit as exit_:
        status = exit_.code
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert status == code, err
    assert len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]
