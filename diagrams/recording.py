"""Meshcat recordings saved as one self-contained HTML file.

Recording is observation only. The serve diagram has no visualizer: each episode is simulated
exactly as an unrecorded one (from t = 0, the same context reset, loggers only at the referee's
rate), and :class:`Recording` places it on its own timeline afterwards: it sets the logged
poses of the arm and the ball in a separate plant and publishes them into one
``MeshcatAnimation`` at ``offset + t``, episode after episode, each held still for
:data:`HOLD` seconds at its end.

Drake's Meshcat runs offline on localhost; ``StaticHtml()`` inlines three.js and the animation,
so the file opens in any browser with no network (docs/constants.md). After Drake writes the
page, :func:`finish_page` adds a legend (the serves' outcomes, landing points and what each
colour means) and a script that keeps the animation playing in a loop and highlights the serve
on screen. Each serve's drawings (paths, markers) are visible only during its segment.
"""

import html as html_lib
import logging
import math

import numpy as np
from pydrake.geometry import Cylinder, Meshcat, MeshcatParams, Rgba, Sphere
from pydrake.math import RigidTransform
from pydrake.systems.framework import DiagramBuilder

from tt_drake.diagrams.episodes import EpisodeResult
from tt_drake.diagrams.station import add_station, robots_of

# Colours (r, g, b, alpha); the legend names each one.
RETURN_COLOUR = (0.1, 0.8, 0.2, 1.0)
FAULT_COLOUR = (0.9, 0.1, 0.1, 1.0)
PATH_COLOUR = (1.0, 0.55, 0.1, 0.9)
ESTIMATE_COLOUR = (0.2, 0.6, 1.0, 0.9)
PREDICTION_COLOUR = (1.0, 0.0, 1.0, 0.9)
TARGET_COLOUR = (1.0, 0.85, 0.0, 0.75)
PRIMITIVE_COLOUR = (0.55, 0.25, 0.95, 0.9)
FALLBACK_COLOUR = (0.5, 0.5, 0.5, 0.6)

BALL_COLOUR = (1.0, 0.45, 0.0, 0.45)
BALL_MARKER_RADIUS = 0.045  # m

HOLD = 0.6  # s: each episode's last pose stays on screen this long before the next serve
TAIL = 0.5  # s: simulated after the decided landing (observation only), to show the bounce
LANDING_RADIUS = 0.05  # m: the landing marker's sphere (the ball's is 0.02)
PIN_HEIGHT = 0.45  # m: a pin above each landing point, visible from afar
TARGET_PIN_HEIGHT = 0.25  # m: the target's, shorter
TABLE_Z = 0.76  # m: the playing surface

# From behind the robot's forehand side, above it: the arm, the table and the ball's flight.
CAMERA_POSITION = (1.8, -2.95, 1.8)
CAMERA_TARGET = (0.05, -0.5, 0.7)


def make_meshcat():
    """A Meshcat server bound to localhost (the recording is saved with ``StaticHtml``).

    ``DRAKE_ALLOW_NETWORK`` is left alone: restricting it to ``meshcat`` makes every ``Parser``
    fail at construction in pydrake 1.51 (its package map registers the remote ``drake_models``),
    and our models reference no remote package. Nothing is served to a browser from it, so
    Drake's "Meshcat listening for connections" line (logged at info level as the server starts)
    is not shown: it would point at a server that stops with the command."""
    drake_log = logging.getLogger("drake")
    level = drake_log.level
    drake_log.setLevel(logging.WARNING)
    try:
        meshcat = Meshcat(MeshcatParams(host="localhost"))
    finally:
        drake_log.setLevel(level)
    meshcat.SetProperty("/Background", "visible", False)
    meshcat.SetCameraPose(list(CAMERA_POSITION), list(CAMERA_TARGET))
    return meshcat


class RecordingScene:
    """A world of its own (the scenario's) drawn by a ``MeshcatVisualizer`` that records: logged
    poses set on its plant context become the animation's frames. The recording starts playing
    when the page opens and loops until it is closed (the legend's script restarts it if a
    browser paused it)."""

    def __init__(self, world_config):
        self.meshcat = make_meshcat()
        # Only the plant (and scene graph) of the station, drawn by the visualizer.
        builder = DiagramBuilder()
        station = add_station(builder, None, robots_of(world_config), self.meshcat,
                              launcher=False, referee=False, aerodynamics=False,
                              controllers=False, world_config=world_config)
        self.world, self.visualizer = station.world, station.visualizer
        self.diagram = builder.Build()
        self.context = self.diagram.CreateDefaultContext()
        self.plant_context = self.world.plant.GetMyMutableContextFromRoot(self.context)
        self.visualizer_context = self.visualizer.GetMyContextFromRoot(self.context)
        self.animation = self.visualizer.StartRecording(set_transforms_while_recording=False)
        self.animation.set_repetitions(1_000_000)
        self.animation.set_autoplay(True)


def _episode_path(index: int) -> str:
    return f"/episodes/{index:04d}"


class Recording(RecordingScene):
    """One Meshcat animation of several episodes laid end to end.

    Builds its own plant (the scenario's world) with a ``MeshcatVisualizer``; :meth:`add` writes
    one episode's logged poses into the animation at the current offset, with its drawings;
    :meth:`html` makes the page."""

    def __init__(self, scenario, library=None):
        self.scenario = scenario
        self.library = library
        super().__init__(scenario.world)
        mark_target(self.meshcat, scenario.referee.target_x, scenario.referee.target_y,
                    scenario.referee.target_radius)

        # The ball (40 mm) is a few pixels wide at the default camera: a halo follows it.
        self.meshcat.SetObject("/ball_marker", Sphere(BALL_MARKER_RADIUS), Rgba(*BALL_COLOUR))
        self.offset = 0.0
        self.segments = []  # (start, end) on the recording's timeline, one per episode
        # The last keyframe of every animated path: three.js loops each object's clip on its
        # own duration, so each gets a keyframe at the recording's end (:meth:`_close`).
        self._last_properties, self._last_transforms = {}, {}
        self._last_pose = None

    def frame(self, t: float) -> int:
        return self.animation.frame(t)

    def _set_property(self, frame: int, path: str, prop: str, value: bool) -> None:
        self.animation.SetProperty(frame, path, prop, value)
        last = self._last_properties.get((path, prop))
        if last is None or frame >= last[0]:
            self._last_properties[(path, prop)] = (frame, value)

    def _publish(self, t: float, ball, arm) -> None:
        self._last_pose = (ball, arm)
        self.animation.SetTransform(self.frame(t), "/ball_marker", RigidTransform(ball[4:7]))
        plant = self.world.plant
        plant.SetPositions(self.plant_context, self.world.ball, ball)
        if arm is not None and self.world.robot is not None:
            plant.SetPositions(self.plant_context, self.world.robot, arm)
        self.context.SetTime(t)
        self.visualizer.ForcedPublish(self.visualizer_context)

    def add(self, index: int, result: EpisodeResult, poses: tuple, beliefs: dict | None = None,
            stroke: dict | None = None) -> None:
        """Episode ``index``: its logged ``poses`` (times, ball, arm from
        ``ServeDiagram.poses``) from the current offset on, one keyframe per animation frame
        (the logged sample nearest to it), then its drawings, shown only during its segment:
        from the offset to the end of the log plus :data:`HOLD`, in whole frames."""
        times, ball, arm = poses
        fps = self.animation.frames_per_second()
        start = self.offset
        first, last = self.frame(start), self.frame(start + times[-1])
        for f in range(first, last + 1):
            t = f / fps - start
            k = int(np.clip(np.searchsorted(times, t), 1, len(times) - 1))
            k = k - 1 if t - times[k - 1] < times[k] - t else k
            self._publish(f / fps, ball[k], None if arm is None else arm[k])
        stop = last + round(HOLD * fps)  # the next serve's first frame
        # Hold the last pose: three.js interpolates between keyframes, so the ball would glide
        # to the next serve's launch point.
        self._publish((stop - 1) / fps, ball[-1], None if arm is None else arm[-1])
        path = _episode_path(index)
        draw_episode(self.meshcat, path, result, ball[:, 4:7] if len(times) > 1 else None)
        draw_stroke(self.meshcat, path, stroke, self.library)
        last_prediction = draw_beliefs(self.meshcat, self.animation, path, beliefs or {}, start)
        if last_prediction is not None:
            self._last_transforms[last_prediction[0]] = last_prediction[1]
        if result.outcome.landing is not None:
            # The landing marker appears at the first frame after the ball landed.
            landed = math.ceil((start + _landing_time(times, ball, result)) * fps)
            self._set_property(0, f"{path}/landing", "visible", False)
            self._set_property(landed, f"{path}/landing", "visible", True)
        if first > 0:
            self._set_property(0, path, "visible", False)
        self._set_property(first, path, "visible", True)
        self._set_property(stop, path, "visible", False)
        self.segments.append((start, stop / fps))
        self.offset = stop / fps

    def _close(self) -> None:
        """Give every animated path a keyframe at the recording's last frame, holding its last
        value: all clips then last as long and loop together."""
        end = self.frame(self.offset)
        if self._last_pose is not None:
            self._publish(end / self.animation.frames_per_second(), *self._last_pose)
        for (path, prop), (_, value) in self._last_properties.items():
            self.animation.SetProperty(end, path, prop, value)
        for path, point in self._last_transforms.items():
            self.animation.SetTransform(end, path, RigidTransform(point))

    def html(self, data: dict) -> str:
        """The page: Drake's static HTML of the recording plus the legend (:func:`finish_page`)."""
        self._close()
        self.visualizer.StopRecording()
        self.visualizer.PublishRecording()
        return finish_page(self.meshcat.StaticHtml(), data, self.segments,
                           self.scenario.referee.target_radius)


def _landing_time(times, ball, result: EpisodeResult) -> float:
    """When the logged ball came closest to its landing point (after the hit)."""
    x, y = result.outcome.landing
    after = times >= (result.outcome.hit_time or 0.0)
    if not np.any(after):
        return float(times[-1])
    p = ball[after, 4:7]
    k = int(np.argmin(np.linalg.norm(p - [x, y, TABLE_Z], axis=1)))
    return float(times[after][k])


def draw_beliefs(meshcat, animation, path: str, beliefs: dict, offset: float = 0.0):
    """What the robot believed: the estimated ball path (blue line) and the predicted hitting
    point (magenta sphere), moved in the recording each time the prediction changed. Returns the
    sphere's path and last position (None without predictions)."""
    estimated = beliefs.get("estimated_path")
    if estimated is not None and len(estimated) > 1:
        meshcat.SetLine(f"{path}/estimated_path", np.asarray(estimated).T, 3.0,
                        Rgba(*ESTIMATE_COLOUR))
    times, points = beliefs.get("prediction_times"), beliefs.get("predictions")
    if times is None or len(times) == 0:
        return None
    name = f"{path}/predicted_hit"
    meshcat.SetObject(name, Sphere(0.04), Rgba(*PREDICTION_COLOUR))
    previous = None
    for t, p in zip(times, points, strict=True):
        if previous is None or np.linalg.norm(p - previous) > 1e-4:
            animation.SetTransform(animation.frame(offset + t), name, RigidTransform(p))
            previous = p
    return name, previous


def draw_episode(meshcat, path: str, result: EpisodeResult, ball_path=None) -> None:
    """The ball's path (default: the result's) as a line and the landing point as a sphere on a
    pin (green: legal return, red: fault)."""
    ball_path = result.ball_path if ball_path is None else ball_path
    if ball_path is not None and len(ball_path) > 1:
        meshcat.SetLine(f"{path}/ball_path", np.asarray(ball_path).T, 3.0, Rgba(*PATH_COLOUR))
    if result.outcome.landing is not None:
        colour = Rgba(*(RETURN_COLOUR if result.outcome.returned else FAULT_COLOUR))
        x, y = result.outcome.landing
        meshcat.SetObject(f"{path}/landing/ball", Sphere(LANDING_RADIUS), colour)
        meshcat.SetTransform(f"{path}/landing/ball", RigidTransform([x, y, TABLE_Z]))
        meshcat.SetObject(f"{path}/landing/pin", Cylinder(0.012, PIN_HEIGHT), colour)
        meshcat.SetTransform(f"{path}/landing/pin",
                             RigidTransform([x, y, TABLE_Z + 0.5 * PIN_HEIGHT]))
        meshcat.SetObject(f"{path}/landing/head", Sphere(0.04), colour)
        meshcat.SetTransform(f"{path}/landing/head", RigidTransform([x, y, TABLE_Z + PIN_HEIGHT]))


def mark_target(meshcat, x: float, y: float, radius: float) -> None:
    """The landing target: a yellow disc of the on-target radius with a pin at its centre."""
    colour = Rgba(*TARGET_COLOUR)
    meshcat.SetObject("/target/disc", Cylinder(radius, 0.004), colour)
    meshcat.SetTransform("/target/disc", RigidTransform([x, y, TABLE_Z + 0.003]))
    height = TARGET_PIN_HEIGHT
    meshcat.SetObject("/target/pin", Cylinder(0.008, height), colour)
    meshcat.SetTransform("/target/pin", RigidTransform([x, y, TABLE_Z + 0.5 * height]))
    meshcat.SetObject("/target/head", Sphere(0.03), colour)
    meshcat.SetTransform("/target/head", RigidTransform([x, y, TABLE_Z + height]))


def draw_stroke(meshcat, path: str, stroke: dict | None, library) -> None:
    """Which hitting primitives carried the learned player's stroke: each one's demonstrated
    hitting point x_i (its stimulus' position, on the hitting plane) as a sphere whose volume is
    its mixture weight nu_i (Eq. 6), the five heaviest; grey if the primitives' plan left the
    joint limits and the teacher's quintics moved the arm instead."""
    if not stroke or library is None or not stroke["primitives"]:
        return
    colour = FALLBACK_COLOUR if stroke["fallback"] else PRIMITIVE_COLOUR
    order = np.argsort(stroke["mixture"])[::-1][:5]
    for rank, k in enumerate(order):
        i, nu = stroke["primitives"][k], stroke["mixture"][k]
        name = f"{path}/primitives/{rank}_primitive_{i}"
        meshcat.SetObject(name, Sphere(0.04 * float(nu) ** (1.0 / 3.0)), Rgba(*colour))
        meshcat.SetTransform(name, RigidTransform(library.stimuli[i, :3]))


def _css(colour) -> str:
    r, g, b, _ = colour
    return f"rgb({round(255 * r)},{round(255 * g)},{round(255 * b)})"


def legend_html(data: dict, segments: list, target_radius: float) -> str:
    """The legend: the run, one row per serve (segment on the timeline, outcome, landing point,
    distance to the target, reward) and what each colour means."""
    esc = html_lib.escape
    s = data["summary"]
    rows = []
    for i, (episode, (start, end)) in enumerate(zip(data["episodes"], segments, strict=True)):
        landing = episode.get("landing")
        where = "–" if landing is None else f"({landing[0]:+.2f}, {landing[1]:+.2f})"
        d = episode.get("target_distance")
        outcome = episode["outcome"] + (" (on target)" if episode.get("on_target") else "")
        if episode.get("faults"):
            outcome += ": " + ", ".join(episode["faults"])
        colour = (_css(RETURN_COLOUR) if episode["outcome"] == "returned"
                  else _css(FAULT_COLOUR) if episode["outcome"] == "fault" else "#888")
        rows.append(
            f'<tr data-start="{start:.3f}" data-end="{end:.3f}"><td>{i + 1}</td>'
            f"<td>{start:.1f}–{end:.1f}</td>"
            f'<td><span style="color:{colour}">&#9679;</span> {esc(outcome)}</td>'
            f"<td>{where}</td><td>{'–' if d is None else f'{d:.2f}'}</td>"
            f"<td>{episode.get('reward', 0.0):.2f}</td></tr>")
    key = [
        (BALL_COLOUR, "dot", "the ball (with a halo, to see it from afar)"),
        (PATH_COLOUR, "line", "ball's path (simulated)"),
        (ESTIMATE_COLOUR, "line", "ball's path as the robot estimated it (camera, EKF)"),
        (PREDICTION_COLOUR, "dot", "predicted hitting point (moves as the prediction improves)"),
        (TARGET_COLOUR, "dot", f"target (disc and pin): on target within {target_radius:.2f} m"),
        (RETURN_COLOUR, "dot", "landing point (sphere and pin) of a legal return"),
        (FAULT_COLOUR, "dot", "landing point of a fault"),
    ]
    if any(e.get("stroke") for e in data["episodes"]):
        key.append((PRIMITIVE_COLOUR, "dot", "hitting points of the 5 heaviest primitives "
                    "(size: weight; grey: fallback)"))
    items = "".join(
        f'<li><span class="tt-{kind}" style="background:{_css(c)}"></span>{esc(text)}</li>'
        for c, kind, text in key)
    title = (f"{esc(data['player'])} player, {s['serves']} {esc(data['distribution'])} serves "
             f"(seed {data['seed']})")
    rates = (f"legal returns {s['return_rate']:.0%}, on target {s['target_rate']:.0%}, "
             f"mean reward {s['mean_reward']:.2f}")
    return f"""
<div id="tt-legend">
  <div class="tt-title" title="click to fold or unfold the legend">{title} &#9662;</div>
  <div>{rates}</div>
  <div id="tt-clock">t = 0.0 s</div>
  <table><tr><th>serve</th><th>t (s)</th><th>outcome</th><th>landing x, y (m)</th>
  <th>to target (m)</th><th>reward</th></tr>{''.join(rows)}</table>
  <ul>{items}</ul>
  <div class="tt-hint">The serves play one after the other, in a loop. Pause and scrub: Open
  Controls &rarr; Animations &rarr; default (play, pause, time). Drag to turn the view, scroll to
  zoom. Click the title to fold this legend.</div>
</div>"""


LEGEND_STYLE = """
<style>
  #tt-legend { position: fixed; right: 10px; bottom: 10px; max-width: 440px; padding: 6px 8px;
    background: rgba(255,255,255,0.88); border: 1px solid #999; border-radius: 4px;
    font: 11px/1.3 sans-serif; color: #111; z-index: 10; }
  #tt-legend .tt-title { font-weight: bold; font-size: 13px; }
  #tt-legend table { border-collapse: collapse; margin: 4px 0; }
  #tt-legend th, #tt-legend td { padding: 1px 5px; text-align: left; white-space: nowrap; }
  #tt-legend tr.tt-now { background: #ffe97a; font-weight: bold; }
  #tt-legend ul { list-style: none; margin: 4px 0; padding: 0; }
  #tt-legend li { margin: 1px 0; }
  #tt-legend .tt-line { display: inline-block; width: 18px; height: 3px; margin: 0 6px 3px 0; }
  #tt-legend .tt-dot { display: inline-block; width: 10px; height: 10px; border-radius: 50%;
    margin: 0 10px -1px 4px; }
  #tt-legend .tt-hint { color: #444; font-size: 11px; }
  #tt-legend .tt-title { cursor: pointer; }
  #tt-legend.tt-folded table, #tt-legend.tt-folded ul, #tt-legend.tt-folded .tt-hint {
    display: none; }
  @media (max-width: 1100px) { #tt-legend { font-size: 10px; max-width: 380px; }
    #tt-legend .tt-hint { font-size: 10px; } }
</style>"""

# Starts the animation if the page loaded it paused, and shows the time and the current serve.
LEGEND_SCRIPT = """
<script>
  (function () {
    var rows = document.querySelectorAll("#tt-legend tr[data-start]");
    var clock = document.getElementById("tt-clock");
    var legend = document.getElementById("tt-legend");
    legend.querySelector(".tt-title").onclick = function () {
      legend.classList.toggle("tt-folded");
    };
    var started = false;
    function update() {
      requestAnimationFrame(update);  // with the viewer's own frames
      var animator = viewer.animator;
      if (!animator || animator.actions.length === 0) { return; }
      if (!started) { started = true; if (!animator.playing) { animator.play(); } }
      var t = animator.time;
      clock.textContent = "t = " + t.toFixed(2) + " s of " + animator.duration.toFixed(1) + " s";
      rows.forEach(function (row) {
        var now = t >= parseFloat(row.dataset.start) && t < parseFloat(row.dataset.end);
        row.classList.toggle("tt-now", now);
      });
    }
    requestAnimationFrame(update);
  })();
</script>"""


def finish_page(page: str, data: dict, segments: list, target_radius: float) -> str:
    """Drake's static page with the legend, its style and its script added before ``</body>``."""
    cut = page.rfind("</body>")
    if cut < 0:
        raise ValueError("Meshcat's page has no </body>")
    extra = LEGEND_STYLE + legend_html(data, segments, target_radius) + LEGEND_SCRIPT
    return page[:cut] + extra + "\n" + page[cut:]
