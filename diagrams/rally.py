"""``tt-drake rally``: two robots keep one ball in play (docs/rally.md).

The rally diagram is the serve diagram's world with a second WAM at the other end of the table,
mirrored through the net (``WorldConfig.with_second_robot``, :mod:`tt_drake.rally_rules`), each
robot with its own controller and its own player: camera, estimator and player (any registered
in :mod:`tt_drake.diagrams.players`), built by the same player functions as ``serve``'s,
each inside its own sub-diagram (``player_A``, ``player_B``) whose input ``ball_state`` is the
ball seen from that robot's frame (B's through a C++ ``MatrixGain``, the mirror M = Rz(pi)) and
whose outputs ``desired_state``, ``desired_acceleration`` drive that robot's controller. So both
players run unchanged in their own frame; they play again after each stroke (``play_again``).
The :class:`tt_drake.systems.rally_referee.RallyReferee` alternates sides, counts exchanges and
ends the rally (and the simulation) at the first fault or at ``Scenario.rally.max_exchanges``.

A rally starts from a launcher ball to robot A: a serve of the scenario's distribution
(``--start serve``) or a real rally ball (``--start rally``: the ``rally`` distribution,
``rallies.json``). Rally i of a run uses ``episode_seed(seed, i)``: the launcher's draw, and each
camera's noise (``episode_seed`` of it and the side's index), so a rally replays exactly.
"""

from __future__ import annotations

import copy
import dataclasses
import html as html_lib
import math
import sys
import time
from dataclasses import dataclass, field

import numpy as np
from pydrake.geometry import Rgba, Sphere
from pydrake.math import RigidTransform
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import PassThrough, VectorLogSink
from tqdm import tqdm

from tt_drake.camera_model import MAX_CAMERA_FRAMES
from tt_drake.diagrams.episodes import PlayerError, check_run, episode_seed
from tt_drake.diagrams.parallel import run_episodes
from tt_drake.diagrams.players import (
    ControllerPorts,
    drive_controller,
    player_function,
    player_system,
    plays_learned_artefacts,
)
from tt_drake.diagrams.recording import (
    BALL_COLOUR,
    BALL_MARKER_RADIUS,
    FAULT_COLOUR,
    HOLD,
    PATH_COLOUR,
    RETURN_COLOUR,
    TABLE_Z,
    RecordingScene,
)
from tt_drake.diagrams.scenario import Scenario, validate
from tt_drake.diagrams.serve import scenario_dict
from tt_drake.diagrams.station import (
    add_station,
    arm_port,
    awaiting_posture,
    reset_episode,
    station_ports,
)
from tt_drake.outputs import check_writable, write_json_atomic, write_text_atomic
from tt_drake.provenance import run_provenance
from tt_drake.rally_rules import SIDES, Exchange, RallyFault, receiver_after, to_side
from tt_drake.rally_stats import outgoing_figures
from tt_drake.systems.wam import hold_first_setpoint
from tt_drake.systems.world import make_simulator

STARTS = ("serve", "rally")


@dataclass
class RallyResult:
    """One rally: its seed, the launcher's ball, the exchanges, the fault that ended it (None if
    capped), the simulated and wall durations; the logged poses when recorded."""

    seed: int
    launch_state: list[float]
    exchanges: list[Exchange]
    fault: RallyFault | None
    capped: bool
    duration: float
    wall_time: float
    poses: tuple | None = field(default=None, repr=False)

    @property
    def length(self) -> int:
        return len(self.exchanges)

    def as_dict(self) -> dict:
        return {"seed": self.seed, "launch_state": [round(float(c), 5) for c in self.launch_state],
                "exchanges": len(self.exchanges), "capped": self.capped,
                "fault": None if self.fault is None else self.fault.as_dict(),
                "duration": round(self.duration, 4), "wall_time": round(self.wall_time, 4),
                "strokes": [e.as_dict() for e in self.exchanges]}


class _PortWorld:
    """What a player function reads from ``World``: the state ports of the ball (the side's
    view) and of the side's own arm."""

    class _Plant:
        def __init__(self, ports: dict):
            self._ports = ports

        def get_state_output_port(self, instance):  # noqa: D102 (MultibodyPlant's name)
            return self._ports[instance]

    def __init__(self, ball_port, arm_port):
        self.ball, self.robot = "ball", "robot"
        self.plant = self._Plant({self.ball: ball_port, self.robot: arm_port})


def build_player_side(player, scenario: Scenario, side: int, opponent=None):
    """The sub-diagram of one side's player (a registered name or a player function): inputs
    ``ball_state`` (13, the side's frame) and ``arm_state`` (14: its arm's measured q, q_dot,
    which the learned player's hold reads), outputs ``desired_state`` (14) and
    ``desired_acceleration`` (7). Every system with a ``play_again`` attribute plays again after
    each stroke, and every planner (a ``planner`` attribute whose config has a target) aims at
    the rally's target; with the competitive aim every system with an ``aims`` attribute gets
    the scenario's, with the reach of ``opponent`` (the other side's player), unless its
    ``takes_aims`` is False. Returns (diagram,
    the systems that draw random numbers, the player system: the one with a ``stroke`` output,
    or None)."""
    add_player = player_function(player)
    sub = DiagramBuilder()
    ball = sub.AddNamedSystem("ball_state", PassThrough(13))
    sub.ExportInput(ball.get_input_port(), "ball_state")
    arm = sub.AddNamedSystem("arm_state", PassThrough(14))
    sub.ExportInput(arm.get_input_port(), "arm_state")
    desired = sub.AddNamedSystem("desired_state", PassThrough(14))
    accel = sub.AddNamedSystem("desired_acceleration", PassThrough(7))
    seeded = add_player(sub, _PortWorld(ball.get_output_port(), arm.get_output_port()),
                        ControllerPorts(desired.get_input_port(), accel.get_input_port()),
                        scenario)
    sub.ExportOutput(desired.get_output_port(), "desired_state")
    sub.ExportOutput(accel.get_output_port(), "desired_acceleration")
    system = player_system(sub)
    for found in sub.GetSystems():
        if hasattr(found, "play_again"):
            found.play_again = True  # read at their updates
    # The rally's aim replaces the single stroke's in every planner the player has (the
    # analytical player's; the learned player's with ``configuration: analytical``).
    for found in sub.GetSystems():
        planner = getattr(found, "planner", None)
        if planner is not None and hasattr(getattr(planner, "config", None), "target_x"):
            planner.config = dataclasses.replace(
                planner.config, target_x=scenario.rally.target_x,
                target_y=scenario.rally.target_y,
                flight_times=tuple(float(t) for t in scenario.rally.flight_times))
    # The competitive aim draws each stroke's aim (tt_drake.rally_aim) in every system that
    # takes per-stroke aims (an ``aims`` attribute: the analytical player), from the rally's
    # seed: such a system joins the seeded systems, after the others.
    if scenario.rally.aim == "competitive":
        for found in sub.GetSystems():
            if hasattr(found, "aims") and getattr(found, "takes_aims", True):
                found.aims = scenario.rally.competitive.against(
                    plays_learned_artefacts(opponent))
                seeded = [*seeded, found]
    diagram = sub.Build()
    diagram.set_name(f"player_{SIDES[side]}")
    return diagram, seeded, system


def rally_scenario(scenario: Scenario, start: str = "serve") -> Scenario:
    """The scenario as the rally plays it: two robots, the launcher's ``rally`` distribution for
    ``start`` = ``rally``, and camera noise drawn for the longest rally."""
    scenario = copy.deepcopy(scenario)
    if start not in STARTS:
        raise PlayerError(f"unknown rally start {start!r}; choose one of {', '.join(STARTS)}")
    scenario.world.with_second_robot = True
    if start == "rally":
        scenario.launcher.distribution = "rally"
    # The camera's first block of draws covers RALLY_CAMERA_BLOCK seconds whatever the cap (the
    # noise of frame k depends on the block size; later frames come from further blocks,
    # tt_drake.camera_model): a rally replays the same under another cap.
    frames = math.ceil(RALLY_CAMERA_BLOCK / scenario.camera.period) + 2
    scenario.camera.max_frames = max(scenario.camera.max_frames,
                                     min(frames, MAX_CAMERA_FRAMES))
    return scenario


#: Seconds of camera frames drawn in the rally camera's first block (50 exchanges take ~55 s).
RALLY_CAMERA_BLOCK = 300.0


def max_duration(scenario: Scenario) -> float:
    """The longest a rally is simulated (s): every exchange (and the start) at its timeout, each
    decided at most one referee tick after it: ``(max_exchanges + 1) (exchange_timeout +
    1 / referee_rate)``. A rally still in play then ends as capped."""
    return ((scenario.rally.max_exchanges + 1)
            * (scenario.rally.exchange_timeout + 1.0 / scenario.referee_rate))


class RallyDiagram:
    """The rally diagram of a (rally) scenario and two players, built once, run per rally."""

    def __init__(self, scenario: Scenario, players: tuple[str, str] = ("analytical",
                                                                      "analytical"),
                 log: bool = False):
        validate(scenario)
        c = scenario.controller
        if any(c.joint_coulomb) or any(c.joint_viscous) or any(c.torque_noise):
            raise PlayerError("the rally does not model joint friction or torque noise; use a "
                              "scenario without them")
        if not scenario.world.with_second_robot or not scenario.world.with_robot:
            raise PlayerError("a rally scenario has two robots (use rally_scenario)")
        self.scenario, self.players = scenario, tuple(players)
        builder = DiagramBuilder()
        parts = station = self.station = add_station(builder, scenario, robots=2)
        self.world, self.launcher, self.referee = parts.world, parts.launcher, parts.referee
        self.seeded = [self.launcher]
        self.sides, self.player_systems = [], []
        for k, name in enumerate(self.players):
            world, controller = station_ports(station, k)
            side, seeded, system = build_player_side(name, scenario, k,
                                                     opponent=self.players[1 - k])
            builder.AddSystem(side)
            drive_controller(builder, world, controller, side)
            self.seeded += seeded
            self.sides.append(side)
            self.player_systems.append(system)
        self.loggers = []
        if log:  # at the referee's rate: no event time the unlogged diagram lacks
            period = 1.0 / scenario.referee_rate
            for name, port, size in (("ball", "ball_state", 13),
                                     ("arm_A", arm_port(0, "state"), 14),
                                     ("arm_B", arm_port(1, "state"), 14)):
                logger = builder.AddNamedSystem(f"{name}_logger", VectorLogSink(size, period))
                builder.Connect(station.GetOutputPort(port), logger.get_input_port())
                self.loggers.append(logger)
        self.diagram = builder.Build()
        self.diagram.set_name("rally_diagram")
        self.simulator = make_simulator(self.diagram, scenario.world, self.world.plant)
        self.context = self.simulator.get_mutable_context()
        self._set_awaiting_posture()
        self._initial = self.context.Clone()

    def _set_awaiting_posture(self) -> None:
        """Each side's servo hold holding its player's first set-point, and each arm at rest
        where its player asks (its awaiting posture)."""
        for side in self.sides:
            hold_first_setpoint(side, self.context)
        awaiting_posture(self.world, self.context, self.station)

    def run(self, seed: int, gamma=None) -> RallyResult:
        """Simulate one rally from ``seed`` (``gamma``: accepted for the parallel runner's
        interface; must be None)."""
        if gamma is not None:
            raise PlayerError("responsibilities gamma are not used by the rally")
        wall = time.perf_counter()
        serve = reset_episode(self.simulator, self._initial, self.scenario.world.simulator,
                              self.seeded, self.world, seed)
        for logger in self.loggers:
            logger.FindMutableLog(self.context).Clear()
        self.simulator.Initialize()
        self.simulator.AdvanceTo(max_duration(self.scenario))  # the referee ends it earlier
        record = self.referee.record(self.referee.GetMyContextFromRoot(self.context))
        t = self.context.get_time()
        # At the time limit a rally still in play ended on no one's fault: capped.
        capped = record.capped or not record.over
        poses = None
        if self.loggers:
            logs = [logger.FindLog(self.context) for logger in self.loggers]
            n = min(log.num_samples() for log in logs)
            poses = (logs[0].sample_times()[:n].copy(),
                     *(log.data()[:, :n].T.copy() for log in logs))
        return RallyResult(seed, list(serve.launch_state), list(record.exchanges), record.fault,
                           capped, t, time.perf_counter() - wall, poses)


def _percentiles(values) -> dict | None:
    values = [v for v in values if v is not None and math.isfinite(v)]
    if not values:
        return None
    p = np.percentile(values, [5, 25, 50, 75, 95])
    return {"n": len(values), **{f"p{q}": round(float(x), 3)
                                 for q, x in zip((5, 25, 50, 75, 95), p, strict=True)}}


def summarize_rallies(results: list[RallyResult]) -> dict:
    """Mean and median rally length (exchanges; a capped rally counts as the cap), how many
    reached the cap, the faults by kind, and per player: its exchange success rate (legal
    returns over the balls it had to return, the rally's first ball from the launcher
    included; a ``robot_table`` fault while the other player received is among the faults,
    not among its balls) and the same over the balls the other robot sent, and the
    percentiles of the incoming ball's speed (m/s) and spin |omega| (rad/s) at its strokes and
    faults, and the figures of the balls it sent (``outgoing``:
    :func:`tt_drake.rally_stats.outgoing_figures`, speed at the net, topspin share, landing
    spread)."""
    lengths = [r.length for r in results]
    faults: dict[str, int] = {}
    for r in results:
        if r.fault is not None:
            key = f"{SIDES[r.fault.player]}:{r.fault.kind}"
            faults[key] = faults.get(key, 0) + 1
    summary = {"rallies": len(results),
               "mean_length": round(float(np.mean(lengths)), 3) if lengths else 0.0,
               "median_length": float(np.median(lengths)) if lengths else 0.0,
               "capped": sum(r.capped for r in results), "faults": dict(sorted(faults.items()))}
    players = {}
    for k, side in enumerate(SIDES):
        returns = [e for r in results for e in r.exchanges if e.player == k]
        # A fault ends one of k's balls only if k was receiving (a robot that touches the
        # table while the other has the ball loses the point, but had no ball to return).
        lost = [r for r in results if r.fault is not None and r.fault.player == k
                and receiver_after(r.exchanges) == k]
        fails = [r.fault for r in lost]
        firsts = sum(1 for r in results for i, e in enumerate(r.exchanges)
                     if e.player == k and i == 0)
        first_fails = sum(1 for r in lost if not r.exchanges)
        attempts = len(returns) + len(fails)
        robot_attempts = attempts - firsts - first_fails
        speeds = [e.incoming_speed for e in returns] + [f.incoming_speed for f in fails]
        spins = ([float(np.linalg.norm(e.incoming_spin)) for e in returns]
                 + [float(np.linalg.norm(f.incoming_spin)) for f in fails
                    if f.incoming_spin is not None])
        players[side] = {
            "returns": len(returns), "balls": attempts,
            "success_rate": len(returns) / attempts if attempts else None,
            "robot_balls": robot_attempts,
            "success_rate_on_robot_balls": (len(returns) - firsts) / robot_attempts
            if robot_attempts else None,
            "incoming_speed": _percentiles(speeds), "incoming_spin": _percentiles(spins),
            "outgoing": outgoing_figures([e.outgoing for e in returns
                                          if e.outgoing is not None])}
    summary["players"] = players
    return summary


def run_rallies(scenario: Scenario, players: tuple[str, str], rallies: int, seed: int,
                start: str = "serve", html: str | None = None, json_path: str | None = None,
                progress: bool = True, workers: int = 1, max_exchanges: int | None = None) -> dict:
    """Run ``rallies`` rallies; rally i uses ``episode_seed(seed, i)``. Returns the JSON dict.
    With ``workers`` > 1 (and no ``html``) they run in that many processes
    (:func:`tt_drake.diagrams.parallel.run_episodes`)."""
    check_run(seed, rallies)
    for path in (html, json_path):
        if path:
            check_writable(path)
    scenario = copy.deepcopy(scenario)
    if max_exchanges is not None:
        scenario.rally.max_exchanges = max_exchanges
        validate(scenario, "--max-exchanges")
    scenario.launcher.run_seed = seed
    scenario = rally_scenario(scenario, start)
    seeds = [episode_seed(seed, i) for i in range(rallies)]
    label = f"rallies ({players[0]} vs {players[1]})"
    bar = tqdm(total=rallies, desc=label, unit="rally", file=sys.stderr, disable=not progress)
    results, recording = [], None
    if html or workers <= 1:
        diagram = RallyDiagram(scenario, players, log=bool(html))
        if html:
            recording = RallyRecording(scenario)
        runs = (diagram.run(s) for s in seeds)
    else:
        runs = run_episodes(scenario, tuple(players), seeds, workers, make_diagram=RallyDiagram)
    for i, result in enumerate(runs):
        results.append(result)
        if recording is not None:
            recording.add(i, result)
        bar.update()
        bar.set_postfix(median=float(np.median([r.length for r in results])))
    bar.close()
    data = {**run_provenance(), "scenario": scenario_dict(scenario), "players": list(players),
            "seed": seed, "start": start, "distribution": scenario.launcher.distribution,
            "summary": summarize_rallies(results), "rallies": [r.as_dict() for r in results]}
    if recording is not None:
        write_text_atomic(html, recording.html(data))
    if json_path:
        write_json_atomic(json_path, data)
    return data


def format_rally_summary(data: dict) -> str:
    s = data["summary"]
    a, b = data["players"]
    n = s["rallies"]
    line = (f"{a} (A) vs {b} (B), {n} rall{'y' if n == 1 else 'ies'} from a {data['start']} "
            f"ball (seed {data['seed']}): mean {s['mean_length']:.1f} exchanges, median "
            f"{s['median_length']:g}, {s['capped']} reached the cap")
    for side, p in s["players"].items():
        rate = "n/a" if p["success_rate"] is None else f"{p['success_rate']:.1%}"
        line += f"; {side} returned {p['returns']}/{p['balls']} ({rate})"
        out = p.get("outgoing")
        if out is not None:
            net = out["speed_at_net"]
            line += (f" [its returns: speed at the net {net['p10']:.1f}/{net['p50']:.1f}/"
                     f"{net['p90']:.1f} m/s, topspin {out['topspin_share']:.0%}, landing std "
                     f"{out['landing_std'][0]:.2f}/{out['landing_std'][1]:.2f} m]")
    return line


class RallyRecording(RecordingScene):
    """One Meshcat animation of whole rallies laid end to end (both arms and the ball, the ball's
    path and each landing), built as :class:`tt_drake.diagrams.recording.Recording` builds the
    serves'; saved with ``StaticHtml``."""

    def __init__(self, scenario: Scenario):
        super().__init__(scenario.world)
        self.meshcat.SetCameraPose([3.2, -0.6, 2.6], [0.0, 0.0, 0.76])
        self.meshcat.SetObject("/ball_marker", Sphere(BALL_MARKER_RADIUS), Rgba(*BALL_COLOUR))
        self.offset, self.segments = 0.0, []

    def _publish(self, t: float, ball, arm_a, arm_b) -> None:
        self.animation.SetTransform(self.animation.frame(t), "/ball_marker",
                                    RigidTransform(ball[4:7]))
        plant = self.world.plant
        plant.SetPositions(self.plant_context, self.world.ball, ball[:7])
        plant.SetPositions(self.plant_context, self.world.robot, arm_a[:7])
        plant.SetPositions(self.plant_context, self.world.robot_b, arm_b[:7])
        self.context.SetTime(t)
        self.visualizer.ForcedPublish(self.visualizer_context)

    def add(self, index: int, result: RallyResult) -> None:
        """Rally ``index`` from the current offset: one keyframe per animation frame, its ball
        path (orange line) and landings (green: a legal return's, red: where the fault ended it)
        shown only during its segment."""
        times, ball, arm_a, arm_b = result.poses
        fps = self.animation.frames_per_second()
        start = self.offset
        first, last = self.animation.frame(start), self.animation.frame(start + times[-1])
        for f in range(first, last + 1):
            k = min(int(np.searchsorted(times, f / fps - start)), len(times) - 1)
            self._publish(f / fps, ball[k], arm_a[k], arm_b[k])
        stop = last + round(HOLD * fps)
        self._publish((stop - 1) / fps, ball[-1], arm_a[-1], arm_b[-1])
        path = f"/rallies/{index:04d}"
        line = ball[:, 4:7].T
        self.meshcat.SetLine(f"{path}/ball_path", line, 2.0, Rgba(*PATH_COLOUR))
        for j, e in enumerate(result.exchanges):
            x, y, _ = to_side(e.player, e.landing[0], e.landing[1], 0.0)
            self.meshcat.SetObject(f"{path}/landing_{j:03d}", Sphere(0.03), Rgba(*RETURN_COLOUR))
            self.meshcat.SetTransform(f"{path}/landing_{j:03d}", RigidTransform([x, y, TABLE_Z]))
        end = ball[-1, 4:7]
        self.meshcat.SetObject(f"{path}/end", Sphere(0.04), Rgba(*FAULT_COLOUR))
        self.meshcat.SetTransform(f"{path}/end", RigidTransform(end))
        if first > 0:
            self.animation.SetProperty(0, path, "visible", False)
        self.animation.SetProperty(first, path, "visible", True)
        self.animation.SetProperty(stop, path, "visible", False)
        self.segments.append((start, stop / fps))
        self.offset = stop / fps

    def html(self, data: dict) -> str:
        self.visualizer.StopRecording()
        self.visualizer.PublishRecording()
        page = self.meshcat.StaticHtml()
        rows = "".join(
            f"<li>rally {i}: {r['exchanges']} exchanges"
            + (f", {r['fault']['player']} {html_lib.escape(r['fault']['kind'])}"
               if r["fault"] else ", capped") + "</li>"
            for i, r in enumerate(data["rallies"]))
        legend = ("<div style='position:fixed;top:8px;left:8px;background:#fffe;padding:6px;"
                  "font:13px sans-serif;max-height:90%;overflow:auto'>"
                  f"<b>{html_lib.escape(format_rally_summary(data))}</b><br>orange: the ball's "
                  "path; green: legal landings; red: where the rally ended<ol start=0>"
                  f"{rows}</ol></div>")
        cut = page.rfind("</body>")
        return page[:cut] + legend + page[cut:]
