"""The tt-drake command: bad input is one line and exit status 2; a run writes JSON and HTML."""

import base64
import json
import re
import subprocess
import sys

import pytest

from tt_drake.diagrams.cli import main


def run_cli(*args):
    """Run the real console entry point in a subprocess (exit status and streams as users see)."""
    return subprocess.run([sys.executable, "-m", "tt_drake.diagrams.cli", *args],
                          capture_output=True, text=True, timeout=300)


def write(path, text):
    path.write_text(text)
    return str(path)


@pytest.mark.parametrize("args, message", [
    (["serve", "--player", "nobody"], "unknown player 'nobody'"),
    (["serve", "--serves", "0"], "must be > 0"),
    (["serve", "--serves", "-3"], "must be > 0"),
    (["serve", "--distribution", "lob"], "'lob' is not one of"),
    (["serve", "--scenario", "no/such/scenario.yaml"], "scenario file not found"),
    (["bench", "--player", "nobody"], "unknown player"),
])
def test_bad_arguments_exit_2_with_one_line(args, message):
    result = run_cli(*args)
    assert result.returncode == 2
    assert message in result.stderr
    assert "Traceback" not in result.stderr


def test_bad_scenario_files_exit_2(tmp_path):
    cases = {
        "launcherr: {distribution: default}\n": "unknown to the schema",
        "launcher: {spin_max: fast}\n": "could not convert",
        "world: {models: {ball: missing_ball.sdf}}\n": "model file not found: missing_ball.sdf",
        "referee_rate: -1\n": "referee_rate must be > 0",
        "launcher: [1, 2\n": "invalid scenario",
    }
    for i, (text, message) in enumerate(cases.items()):
        scenario = write(tmp_path / f"s{i}.yaml", text)
        out = tmp_path / f"out{i}.json"
        result = run_cli("serve", "--scenario", scenario, "--serves", "1", "--json", str(out))
        assert result.returncode == 2, text
        assert message in result.stderr, (text, result.stderr)
        assert "Traceback" not in result.stderr
        assert not out.exists()


def test_unwritable_outputs_exit_2_and_leave_nothing(tmp_path):
    result = run_cli("serve", "--serves", "1", "--json", str(tmp_path / "missing" / "o.json"))
    assert result.returncode == 2 and "does not exist" in result.stderr
    result = run_cli("serve", "--serves", "1", "--html", str(tmp_path))
    assert result.returncode == 2 and "is a directory" in result.stderr
    assert list(tmp_path.iterdir()) == []


def test_serve_writes_summary_json_and_a_self_contained_recording(tmp_path, capsys):
    json_path, html_path = tmp_path / "serves.json", tmp_path / "serves.html"
    code = main(["serve", "--player", "idle", "--serves", "2", "--seed", "3", "--quiet",
                 "--json", str(json_path), "--html", str(html_path)])
    assert code == 0
    assert "idle player, 2 default serves" in capsys.readouterr().out
    data = json.loads(json_path.read_text())
    assert set(data["summary"]) >= {"serves", "hit_rate", "return_rate", "target_rate"}
    assert data["summary"]["serves"] == 2 and len(data["episodes"]) == 2
    # The idle robot holds its posture away from the ball's path: every serve is missed.
    assert [e["outcome"] for e in data["episodes"]] == ["missed", "missed"]
    html = html_path.read_text()
    assert not re.search(r"<script[^>]+src=", html)  # three.js is inlined, nothing to fetch
    assert "package://" not in html and "file://" not in html
    # Meshcat embeds its commands as base64 data URLs (msgpack): the recording and the drawn paths.
    commands = b"".join(base64.b64decode(chunk)
                        for chunk in re.findall(r'data:[^;"]*;base64,([A-Za-z0-9+/=]+)', html))
    assert b"set_animation" in commands
    assert b"/episodes/0000/ball_path" in commands and b"/episodes/0001/ball_path" in commands
    assert not list(tmp_path.glob(".*.tmp"))  # no temporary file left behind


def test_same_seed_replays_the_same_episodes(tmp_path):
    outs = []
    for k in range(2):
        path = tmp_path / f"r{k}.json"
        assert main(["serve", "--serves", "2", "--seed", "11", "--quiet", "--json",
                     str(path)]) == 0
        outs.append([{k: v for k, v in e.items() if k != "wall_time"}
                     for e in json.loads(path.read_text())["episodes"]])
    assert outs[0] == outs[1]
