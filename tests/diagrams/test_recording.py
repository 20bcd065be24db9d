"""The Meshcat recording is observation only, lays the serves end to end, and explains itself."""

import json
from pathlib import Path

import numpy as np
import pytest

from tt_drake.diagrams import serve as serve_module
from tt_drake.diagrams.episodes import ServeDiagram, episode_seed
from tt_drake.diagrams.recording import HOLD, TABLE_Z, TAIL, Recording, finish_page
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.diagrams.serve import _report, run_serves, serve_episodes

LEARNED = Path(__file__).resolve().parents[2] / "models" / "learned"


def _scenario():
    scenario = load_scenario("default")
    scenario.learned.library = str(LEARNED / "library.npz")
    scenario.learned.crkr = str(LEARNED / "crkr.npz")
    scenario.learned.predictor = str(LEARNED / "predictor.npz")
    return scenario


def _spy_results(monkeypatch) -> list:
    """Capture the EpisodeResults (full precision) of each run_serves call."""
    runs = []

    def spy(*args, **kwargs):
        results = serve_episodes(*args, **kwargs)
        runs.append(results)
        return results

    monkeypatch.setattr(serve_module, "serve_episodes", spy)
    return runs


@pytest.mark.parametrize("player", ["idle", "analytical", "momp", "crkr"])
def test_recording_does_not_change_the_serves(player, tmp_path, monkeypatch):
    """The same command with and without --html: the same episodes, serve by serve (each
    recorded episode is simulated from t = 0 with the same context reset as any other)."""
    runs = _spy_results(monkeypatch)
    scenario = _scenario()
    plain_json, rec_json, page = (tmp_path / "plain.json", tmp_path / "rec.json",
                                  tmp_path / "rec.html")
    run_serves(scenario, player, 3, 5, json_path=str(plain_json), progress=False)
    data = run_serves(scenario, player, 3, 5, html=str(page), json_path=str(rec_json),
                      progress=False)
    plain, recorded = runs
    for a, b in zip(plain, recorded, strict=True):
        assert a.seed == b.seed and a.duration == b.duration
        assert a.outcome.outcome == b.outcome.outcome and a.outcome.faults == b.outcome.faults
        assert a.outcome.reward == b.outcome.reward and a.outcome.hit_time == b.outcome.hit_time
        assert (a.outcome.landing is None) == (b.outcome.landing is None)
        if a.outcome.landing is not None:
            assert np.allclose(a.outcome.landing, b.outcome.landing, rtol=0.0, atol=1e-9)
    without_times = [
        [{k: v for k, v in e.items() if k != "wall_time"} for e in json.loads(p.read_text())
         ["episodes"]] for p in (plain_json, rec_json)]
    assert without_times[0] == without_times[1]
    if player in ("analytical", "momp"):  # the players that return these serves
        assert data["summary"]["return_rate"] > 0
    # The page carries a legend with one row per serve, its outcome and landing point.
    html = page.read_text()
    assert html.index('id="tt-legend"') < html.rindex("</body>")
    for i, episode in enumerate(data["episodes"]):
        assert f"<td>{i + 1}</td>" in html and episode["outcome"] in html
        if episode["landing"] is not None:
            x, y = episode["landing"]
            assert f"({x:+.2f}, {y:+.2f})" in html
    assert "animator.play()" in html


class _SpyAnimation:
    """Forwards to Drake's MeshcatAnimation and keeps what the recording put in it."""

    def __init__(self, animation):
        self.animation, self.properties, self.transforms = animation, [], []

    def frame(self, t):
        return self.animation.frame(t)

    def frames_per_second(self):
        return self.animation.frames_per_second()

    def SetProperty(self, frame, path, prop, value):  # noqa: N802 (Drake's name)
        self.properties.append((frame, path, prop, value))
        self.animation.SetProperty(frame, path, prop, value)

    def SetTransform(self, frame, path, pose):  # noqa: N802
        self.transforms.append((frame, path, pose.translation().copy()))
        self.animation.SetTransform(frame, path, pose)


def test_serves_play_one_after_the_other():
    """Each serve has its own segment of the timeline, after the previous one; its drawings are
    visible only then; the ball's marker starts at the launch point, and the landing marker
    appears when the ball is at the landing point."""
    scenario = _scenario()
    diagram = ServeDiagram(scenario, "analytical", log_ball=True)
    recording = Recording(scenario)
    spy = recording.animation = _SpyAnimation(recording.animation)
    results = serve_episodes(diagram, [episode_seed(2, i) for i in range(2)], recording)
    assert recording.segments[0][0] == 0.0
    assert recording.segments[1][0] == recording.segments[0][1]
    for i, (result, (start, end)) in enumerate(zip(results, recording.segments, strict=True)):
        # The episode (to a frame), at most its extension (observation only), and the hold.
        frame = 1.0 / spy.frames_per_second()
        assert result.duration + HOLD - frame <= end - start <= result.duration + TAIL + HOLD
        path = f"/episodes/{i:04d}"
        visible = sorted((f, v) for f, p, prop, v in spy.properties
                         if p == path and prop == "visible")
        expected = [(spy.frame(start), True), (spy.frame(end), False)]
        assert visible == ([(0, False)] if i else []) + expected
        marker = [(f, p) for f, name, p in spy.transforms if name == "/ball_marker"
                  and spy.frame(start) <= f < spy.frame(end)]
        assert marker and marker[0][0] == spy.frame(start)
        assert np.allclose(marker[0][1], result.launch_state[:3], atol=1e-12)
        assert result.outcome.landing is not None  # the teacher returns these serves
        (landed,) = [f for f, p, prop, v in spy.properties if p == f"{path}/landing" and v]
        # It appears when the ball is at the landing point (the ball's centre a radius above
        # the table): at the frame nearest to it, or the next.
        after_hit = [(f, p) for f, p in marker if f >= spy.frame(start + result.outcome.hit_time)]
        gaps = [np.linalg.norm(p - [*result.outcome.landing, TABLE_Z + 0.02]) for _, p in after_hit]
        nearest = after_hit[int(np.argmin(gaps))][0]
        assert min(gaps) < 0.05 and landed - nearest in (0, 1)
    # Every ball-marker keyframe lies inside some serve's segment (nothing from t = 0 overlaid).
    last = spy.frame(recording.segments[-1][1])
    assert all(f < last for f, name, _ in spy.transforms if name == "/ball_marker")
    # three.js loops each object's clip on its own duration: every animated path ends at the
    # recording's last frame, so serve 1's drawings do not come back during serve 2.
    page = recording.html(_report(scenario, "analytical", 2, results))
    assert "tt-legend" in page
    ends = {}
    for f, name, *_ in spy.properties + spy.transforms:
        ends[name] = max(ends.get(name, 0), f)
    assert set(ends) >= {"/ball_marker", "/episodes/0000", "/episodes/0001/predicted_hit"}
    assert set(ends.values()) == {last}


def test_an_episode_is_the_same_alone_or_after_others():
    """Every episode starts from the same reset, the integrator's too: replaying serve i alone
    gives serve i of a run."""
    scenario = _scenario()
    seeds = [episode_seed(7, i) for i in range(2)]
    diagram = ServeDiagram(scenario, "analytical")
    diagram.run(seeds[0])
    in_run = diagram.run(seeds[1])
    alone = ServeDiagram(scenario, "analytical").run(seeds[1])
    assert in_run.outcome.landing == alone.outcome.landing
    assert in_run.duration == alone.duration


def _data(outcomes):
    episodes = [{"outcome": o, "landing": None if o == "missed" else [0.1 * i, 0.6],
                 "target_distance": None if o == "missed" else 0.1, "on_target": o == "returned",
                 "faults": ["net"] if o == "fault" else [], "reward": 0.5}
                for i, o in enumerate(outcomes)]
    return {"player": "analytical<b>", "distribution": "default", "seed": 4,
            "summary": {"serves": len(outcomes), "return_rate": 1 / 3, "target_rate": 1 / 3,
                        "mean_reward": 0.5},
            "episodes": episodes}


def test_the_legend_is_added_before_the_end_of_the_page():
    page = "<html><body><div id='meshcat-pane'></div></body></html>"
    out = finish_page(page, _data(["returned", "fault", "missed"]),
                      [(0.0, 2.0), (2.0, 4.5), (4.5, 6.0)], 0.2)
    assert out.startswith("<html><body><div id='meshcat-pane'></div>")
    assert out.endswith("</body></html>")
    assert out.count('<tr data-start="') == 3 and 'data-start="2.000" data-end="4.500"' in out
    assert "returned (on target)" in out and "fault: net" in out and "missed" in out
    assert "(+0.10, +0.60)" in out and "within 0.20 m" in out
    assert "analytical&lt;b&gt;" in out and "analytical<b>" not in out  # escaped
    with pytest.raises(ValueError, match="</body>"):
        finish_page("<html></html>", _data(["missed"]), [(0.0, 1.0)], 0.2)
