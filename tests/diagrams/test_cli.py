"""The tt-drake command: bad input is one line and exit status 2; a run writes JSON and HTML."""

import base64
import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
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


def _subparsers():
    import argparse

    from tt_drake.diagrams.cli import build_parser

    parser = build_parser()
    (sub,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return parser, sub.choices


def test_option_names_are_the_registries_names():
    from tt_drake.diagrams.commands.options import CONFIGURATION_NAMES
    from tt_drake.diagrams.commands.reproduce import EXECUTOR_NAMES
    from tt_drake.diagrams.parallel import EXECUTORS
    from tt_drake.diagrams.players import player_names
    from tt_drake.systems.hitting_configuration import SOURCES

    parser, commands = _subparsers()
    (player,) = [a for a in commands["serve"]._actions if a.dest == "player"]
    assert tuple(player.choices) == player_names()[:4] == ("idle", "analytical", "momp", "crkr")
    assert CONFIGURATION_NAMES == tuple(SOURCES)
    assert EXECUTOR_NAMES == tuple(EXECUTORS)


def test_every_help_lists_the_choices_and_the_defaults():
    _, commands = _subparsers()
    assert set(commands) >= {"serve", "bench", "collect", "train", "train-predictor",
                             "eval-predictor", "reproduce", "models"}
    for name, parser in commands.items():
        text = " ".join(parser.format_help().split())
        for action in parser._actions:
            if action.dest == "help":
                continue
            if action.choices:
                assert "{" + ",".join(action.choices) + "}" in text, (name, action.dest)
            default = action.default
            if default is not None and default is not False and default != "":
                assert f"(default: {default})" in text, (name, action.dest)
    serve = " ".join(commands["serve"].format_help().split())
    assert "--player {idle,analytical,momp,crkr}" in serve
    assert "(default: idle, which never swings)" in serve
    from tt_drake.serves import DISTRIBUTIONS

    assert "--distribution {" + ",".join(DISTRIBUTIONS) + "}" in serve
    assert {"default", "spin", "real-test", "rally-train", "fixed"} <= set(DISTRIBUTIONS)


def test_every_help_names_only_options_its_command_has():
    """A help text that sends the user to an option must be talking about one they can give
    (the rally's --configuration help once pointed at a --artefacts it does not have)."""
    _, commands = _subparsers()
    for name, parser in commands.items():
        own = {s for action in parser._actions for s in action.option_strings}
        named = set(re.findall(r"(?<![\w-])--[a-z][a-z-]*[a-z]", parser.format_help()))
        assert named <= own, (name, sorted(named - own))


def test_version_is_the_installed_distributions(capsys):
    from importlib.metadata import version

    with pytest.raises(SystemExit) as exit_:
        main(["--version"])
    assert exit_.value.code == 0
    assert capsys.readouterr().out.strip() == f"tt-drake {version('tt-drake')}"


def test_the_parser_imports_no_drake():
    """--help and option errors answer at once: building every command's options loads no
    pydrake (the commands load their builders when they run)."""
    code = ("import sys\nfrom tt_drake.diagrams.cli import build_parser\nbuild_parser()\n"
            "print(sorted(k for k in sys.modules if k.split('.')[0] == 'pydrake'))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == "[]", f"building the parser imported {out}"


def test_every_user_error_is_bad_input():
    """The command reports bad input as one line by its base class; each module's error for
    the user's input derives from it."""
    from tt_drake.diagrams.collect import DatasetError
    from tt_drake.diagrams.commands.options import CliError
    from tt_drake.diagrams.episodes import PlayerError, SeedError
    from tt_drake.diagrams.parallel import ExecutorError
    from tt_drake.diagrams.predictor import PredictorError
    from tt_drake.diagrams.reproduce import ReproduceError
    from tt_drake.diagrams.scenario import ScenarioError
    from tt_drake.diagrams.serve import CeilingFileError
    from tt_drake.diagrams.train import TrainError
    from tt_drake.errors import BadInputError
    from tt_drake.hitting_point import PredictorFileError
    from tt_drake.learned_player import LearnedArtefactError
    from tt_drake.outputs import OutputError
    from tt_drake.serves import ServeError
    from tt_drake.systems.world import ModelFileError

    for error in (CliError, ScenarioError, ServeError, PlayerError, ModelFileError, OutputError,
                  PredictorError, PredictorFileError, DatasetError, TrainError,
                  LearnedArtefactError, ReproduceError, ExecutorError, SeedError,
                  CeilingFileError):
        assert issubclass(error, BadInputError), error


def test_learned_players_default_to_the_shipped_artefacts(capsys):
    from tt_drake.diagrams.cli import build_parser
    from tt_drake.diagrams.commands.options import scenario_from_options
    from tt_drake.models import shipped_artefact

    parser = build_parser()
    for player in ("momp", "crkr"):
        scenario = scenario_from_options(parser.parse_args(["serve", "--player", player]))
        learned = scenario.learned
        assert (learned.library, learned.crkr, learned.predictor) == tuple(
            str(shipped_artefact(k)) for k in ("library", "crkr", "predictor"))
        assert all(shipped_artefact(k).is_file() for k in ("library", "crkr", "predictor"))
        assert f"the {player} player uses the shipped artefacts" in capsys.readouterr().err
    # A file named on the command line: only that one, as before (no --predictor: physical).
    learned = scenario_from_options(
        parser.parse_args(["serve", "--player", "momp", "--library", "mine.npz"])).learned
    assert (learned.library, learned.crkr, learned.predictor) == ("mine.npz", "", "")
    # Other players load no artefact.
    learned = scenario_from_options(parser.parse_args(["serve", "--player", "analytical"])).learned
    assert (learned.library, learned.crkr, learned.predictor) == ("", "", "")
    learned = scenario_from_options(parser.parse_args(["bench", "--player", "crkr"])).learned
    assert learned.crkr == str(shipped_artefact("crkr"))


def _legend_covers(record: dict, legend: dict, where: str = "") -> None:
    for key, value in record.items():
        assert key in legend, f"{where}{key} has no entry in the fields legend"
        entry = legend[key]
        if isinstance(value, dict):
            _legend_covers(value, entry, f"{where}{key}.")
        elif "components" in entry and value is not None:
            assert len(value) == len(entry["components"]) == len(entry["units"]), where + key


def test_serve_json_has_provenance_the_full_scenario_and_a_fields_legend(tmp_path, capsys):
    from tt_drake.diagrams.episodes import EpisodeResult, stroke_summary
    from tt_drake.diagrams.scenario import load_scenario
    from tt_drake.learned_player import MoMPStroke
    from tt_drake.provenance import package_version
    from tt_drake.referee_rules import Outcome

    path = tmp_path / "idle.json"
    assert main(["serve", "--serves", "1", "--seed", "3", "--quiet", "--json", str(path)]) == 0
    out, err = capsys.readouterr()
    assert "idle player, 1 default serves" in out
    assert "no --player given, so this was the idle player" in err
    assert "never swings" in err
    data = json.loads(path.read_text())
    assert data["tt_drake_version"] == package_version()
    repo = Path(__file__).resolve().parents[2]
    head = subprocess.run(["git", "-C", str(repo), "rev-parse", "HEAD"], capture_output=True,
                          text=True).stdout.strip()
    if (repo / ".git").exists() and head:
        assert data["git_commit"] in (head, f"{head}-dirty")
    else:  # a copy of the checkout without its repository
        assert data["git_commit"] is None
    scenario = load_scenario("default")
    assert data["scenario"]["name"] == "default"
    assert data["scenario"]["referee"]["target_y"] == scenario.referee.target_y
    assert data["scenario"]["controller"]["kp"] == scenario.controller.kp
    assert data["scenario"]["world"]["simulator"]["max_step_size"] == 0.002
    legend = data["fields"]
    _legend_covers(data["summary"], legend["summary"])
    _legend_covers(data["episodes"][0], legend["episodes"])
    assert legend["episodes"]["launch_state"]["units"][6:] == ["rad/s"] * 3
    # A learned player's record (stroke) and a landing: every field named too.
    stroke = stroke_summary(MoMPStroke(np.zeros(6), 0.5, np.zeros(7), np.zeros(7),
                                       np.array([3, 4]), np.array([0.25, 0.75]), held=True,
                                       spinless=True,
                                       configuration=(np.ones(7), np.ones(7))))
    assert stroke["held"] and stroke["spinless"] and stroke["teacher_stroke"]
    record = EpisodeResult(1, [0.0] * 9, [0.0] * 7, 1.0, Outcome(
        "returned", True, True, True, (), (0.1, 0.7), 0.1, 0.4, 0.9), 0.1, stroke=stroke,
        arm={"joint_limit_excess": 0.0, "max_joint_speed": 1.0, "saturated_fraction": 0.0,
             "saturated_samples_per_joint": [0] * 7}).as_dict()
    _legend_covers(record, legend["episodes"])

    # Given --player, no hint.
    assert main(["serve", "--player", "idle", "--serves", "1", "--quiet"]) == 0
    assert "no --player given" not in capsys.readouterr().err


def test_reproduce_checks_its_input_files_before_the_first_stage(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("TT_DRAKE_SERVES", str(tmp_path / "nowhere" / "serves.json"))
    out = tmp_path / "run"
    assert main(["reproduce", "--quick", "--workers", "1", "--quiet", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "file not found" in err[0] and "serves.json" in err[0]
    assert not out.exists()  # no stage ran, no run folder was made
