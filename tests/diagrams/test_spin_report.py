"""spin_report's bad input: one line on stderr, exit status 2, no output file."""

from tt_drake.diagrams.commands.spin_report import main


def test_bad_input_is_one_line_and_exit_2(tmp_path, capsys):
    out = tmp_path / "report.json"
    for argv in (["--serves", "0"], ["--serves", "2", "--distribution", "nowhere"],
                 ["--serves", "2", "--player", "crkr"], ["--serves", "2", "--workers", "0"],
                 ["--serves", "2", "--scenario", str(tmp_path / "missing.yaml")]):
        assert main([*argv, "--json", str(out)]) == 2
        err = capsys.readouterr().err
        assert err.startswith("error: ") and err.count("\n") == 1
        assert not out.exists()


def _parabola_flight():
    """A ball flying in a vacuum: y falls linearly, z is a parabola (exact for cubic Hermite
    interpolation), sampled at 600 Hz; spin grows linearly so its sample is checkable."""
    import numpy as np

    from tt_drake.diagrams.spin_report import TrueFlight

    t = np.arange(0, 1.2, 1 / 600)
    g, y0, vy, z0, vz = 9.81, 1.0, -3.0, 1.0, 1.5
    flight = TrueFlight.__new__(TrueFlight)
    flight.t = t
    flight.p = np.c_[0.1 * t, y0 + vy * t, z0 + vz * t - 0.5 * g * t**2]
    flight.v = np.c_[np.full_like(t, 0.1), np.full_like(t, vy), vz - g * t]
    flight.w = np.c_[t, 0 * t, 0 * t]
    return flight, (g, y0, vy, z0, vz)


def test_truth_is_taken_on_the_surface_the_prediction_lies_on():
    import numpy as np
    import pytest

    from tt_drake.constants import PLANES

    flight, (g, y0, vy, z0, vz) = _parabola_flight()
    # On the plane: where y crosses the hitting plane.
    tc = (PLANES.hitting_y - y0) / vy
    c = flight.crossing([0.0, PLANES.hitting_y, 0.0], 0.0)
    assert c[9] == pytest.approx(tc, abs=1e-9)
    assert c[2] == pytest.approx(z0 + vz * tc - 0.5 * g * tc**2, abs=1e-9)
    # Off the plane (a band point at z = 0.65): where the ball falls through that height, not
    # where it rises through it; the spin is the sample at or before that time.
    level = 0.65
    tz = (vz + np.sqrt(vz**2 + 2 * g * (z0 - level))) / g
    c = flight.crossing([0.0, -1.5, level], tz + 0.01)
    assert c[9] == pytest.approx(tz, abs=1e-9)
    assert c[2] == pytest.approx(level, abs=1e-12)
    assert c[1] == pytest.approx(y0 + vy * tz, abs=1e-9)
    assert c[5] == pytest.approx(vz - g * tz, abs=1e-6) and c[5] < 0
    assert tz - 1 / 600 < c[6] <= tz
    # A height the ball never falls through: no truth.
    assert flight.crossing([0.0, -1.5, 5.0], 0.3) is None


def test_returnable_from_must_be_the_same_run(tmp_path, capsys):
    import json

    earlier = tmp_path / "ceiling.json"
    earlier.write_text(json.dumps({"seed": 13, "distribution": "real-test", "serves_run": 10,
                                   "returnable_indices": [1, 4]}))
    out = tmp_path / "report.json"
    for argv in (["--seed", "14", "--distribution", "real-test"],
                 ["--seed", "13", "--distribution", "spin"],
                 ["--seed", "13", "--distribution", "real-test", "--serves", "11"]):
        if "--serves" not in argv:
            argv = [*argv, "--serves", "10"]
        assert main([*argv, "--returnable-from", str(earlier), "--json", str(out)]) == 2
        err = capsys.readouterr().err
        assert err.startswith("error: --returnable-from") and err.count("\n") == 1
        assert not out.exists()
    earlier.write_text("{not json")
    assert main(["--serves", "10", "--returnable-from", str(earlier)]) == 2
    assert "not a spin_report --ceiling result" in capsys.readouterr().err


def test_a_log_of_two_episodes_is_refused():
    """The last sample at or before t, and a log whose times go back (not cleared between
    episodes) is an error rather than a sample from another episode."""
    import numpy as np
    import pytest

    from tt_drake.diagrams.spin_report import _at

    times = np.array([0.0, 0.1, 0.2])
    values = np.array([[1.0], [2.0], [3.0]])
    assert _at(times, values, 0.15)[0] == 2.0 and _at(times, values, 0.2)[0] == 3.0
    with pytest.raises(RuntimeError, match="more than one episode"):
        _at(np.r_[times, times], np.r_[values, values], 0.15)


def test_a_split_of_a_file_without_ids_is_one_line(tmp_path, capsys, monkeypatch):
    import json

    noids = tmp_path / "noids.json"
    noids.write_text(json.dumps([{"pos_x": 0.0, "pos_y": 1.0, "pos_z": 0.1, "vel_x": 0.0,
                                  "vel_y": -4.0, "vel_z": 1.0, "w_vel_x": 0.0, "w_vel_y": 0.0,
                                  "w_vel_z": 0.0}]))
    monkeypatch.setenv("TT_DRAKE_SERVES", str(noids))
    out = tmp_path / "report.json"
    assert main(["--serves", "2", "--distribution", "real-test", "--json", str(out)]) == 2
    err = capsys.readouterr().err
    assert "no test split" in err and err.count("\n") == 1 and not out.exists()
