"""docs/examples/station.py and docs/examples/custom_player.py run from a clean folder, as a user
runs them, and play what the station and the registry promise."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

from tests.data.make_recorded_outcomes import load_recorded

EXAMPLES = Path(__file__).resolve().parents[2] / "docs" / "examples"


def _run(name: str, cwd: Path, *args: str) -> list[str]:
    done = subprocess.run([sys.executable, str(EXAMPLES / name), *args], cwd=cwd,
                          capture_output=True, text=True, timeout=300, check=True)
    return done.stdout.splitlines()


def test_the_station_example_plays_the_recorded_serve_and_writes_its_recording(tmp_path):
    lines = _run("station.py", tmp_path)
    # Serve 0 of seed 1 at the analytical player: the recorded serve, returned to the same
    # landing (the visualizer's publish times cut the integrator's steps: within 1e-5 m).
    recorded = load_recorded()["serves"]["analytical/default"][0]
    found = re.fullmatch(r"returned: landing \(([-\d.e]+), ([-\d.e]+)\), hit at ([\d.]+) s",
                         lines[0])
    assert found, lines
    assert [float(found[1]), float(found[2])] == pytest.approx(recorded["landing"], abs=1e-5)
    assert float(found[3]) == recorded["hit_time"]
    page = tmp_path / "out" / "station.html"
    assert lines[1] == "wrote out/station.html"
    html = page.read_text(encoding="utf-8")
    assert html.lstrip().lower().startswith("<!doctype html") or "<html" in html[:200].lower()
    assert "animation" in html.lower()


def test_the_custom_player_example_plays_a_serve_a_rally_and_a_gym_episode(tmp_path):
    # The player never swings: it misses the serve; in the rally A (the analytical player)
    # returns the serve and B, the custom player, misses it; the Gym episode is a miss (0).
    assert _run("custom_player.py", tmp_path) == [
        "serve: missed", "rally: [0] missed by 1", "gym: missed reward 0.0"]
