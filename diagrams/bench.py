"""``tt-drake bench``: wall time per serve episode and real-time factor of the project's serve
diagram, against diagrams measured in the same run.

- The C++ reference has the same plant and contact model, and the arm under the same
  InverseDynamicsController, but follows a C++ ``TrajectorySource`` swing and has no Python
  system (no aerodynamics, joint stops, launcher or referee). It is integrated at the fixed
  :data:`REFERENCE_SIMULATOR` recipe (RK3, accuracy 1e-4, max step 2 ms) whatever the scenario's
  simulator settings, so that the ratio to it shows progress across changes of the scenario. It
  runs the same serves for the same simulated durations (those the project's episodes ended
  at); the launcher's serve sampling is timed separately.
- The C++-only physics diagram (:class:`PhysicsDiagram`): the serve diagram's physics (plant,
  contact, aerodynamics, the scenario's joint stops, controller behind the servo hold, the
  camera's 60 Hz events, the accuracy schedule) with C++ systems only, replaying the player's
  set-points, for the same durations. project / physics is what the Python systems cost;
  physics / reference what the project's physics adds to the reference's.
- For a player other than idle: the idle diagram on the same serves (the arm holds still, so
  the ball flies past and the episode ends sooner), and the **replay**: the same serve diagram
  (world, aerodynamics, launcher, referee, controller, servo holds) with the player and its
  vision systems replaced by Drake's C++ ``TrajectorySource`` replaying the set-points the
  player's episode gave the servo. It simulates the same physics, so replay / idle is what the
  returned ball costs the simulation itself (a longer episode, more contacts, a spinning ball)
  and project / replay is what the player's systems cost.
- Every diagram is timed on the same serve one after the other, serve by serve in one process
  (:func:`_alternate`): the per-serve CPU ratios compare times measured seconds apart, under
  the same load, and the bench reports their median and quartiles with the ratio of the totals.
  (Timed in blocks minutes apart, a ratio would move with the machine's load: docs/
  performance.md, "Measuring".)
- With ``workers`` > 1: the same serves in that many worker processes
  (:func:`tt_drake.diagrams.parallel.run_episodes`): the start-up (building the workers'
  diagrams), the steady wall time per serve, the speed-up over one process and the projected
  wall time of 10,000 serves.
- Last, untimed: the calls Drake makes into Python (:mod:`tt_drake.diagrams.python_calls`)
  while each diagram plays the first serve once more, per simulated second and per system,
  beside the integrator's steps and derivative evaluations per simulated second. The counter's
  profiler slows the episode it watches, so it runs after every timing.
"""

import copy
import os
import time

import numpy as np
from pydrake.systems.analysis import ApplySimulatorConfig, SimulatorConfig
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import TrajectorySource, ZeroOrderHold
from pydrake.trajectories import PiecewisePolynomial

from tt_drake.benchmarks import bench_momp_planning
from tt_drake.diagrams.episodes import ServeDiagram, episode_seed
from tt_drake.diagrams.parallel import run_episodes
from tt_drake.diagrams.players import ControllerPorts, check_player
from tt_drake.diagrams.python_calls import count_drake_calls
from tt_drake.diagrams.scenario import ControllerConfig, Scenario
from tt_drake.diagrams.station import add_station, arm_port
from tt_drake.serves import serve_sampler
from tt_drake.systems.joint_stops import JointStopsConfig
from tt_drake.systems.wam import add_servo_hold, hold_first_setpoint
from tt_drake.systems.world import (
    RECIPE_FLIGHT_ACCURACY,
    advance_in_segments,
    make_simulator,
    set_ball_state,
    simulator_and_schedule,
)
from tt_drake.wam_params import AWAITING

# The recipe the C++ reference diagram was defined with (docs/design.md, "Simulation recipe"):
# kept fixed.
REFERENCE_SIMULATOR = SimulatorConfig(integration_scheme="runge_kutta3", accuracy=1e-4,
                                      max_step_size=2e-3, use_error_control=True)
PROJECTED_SERVES = 10_000


def _swing(duration: float) -> PiecewisePolynomial:
    """A smooth arm swing around the awaiting posture (cubic, zero end velocities)."""
    q0 = np.asarray(AWAITING, dtype=float)
    q1 = q0 + np.array([0.3, -0.2, 0.2, -0.3, 0.2, 0.2, 0.1])
    times = [0.0, 0.5 * duration, duration]
    knots = np.column_stack([q0, q1, q0])
    return PiecewisePolynomial.CubicWithContinuousSecondDerivatives(
        times, knots, np.zeros(7), np.zeros(7))


class ReferenceDiagram:
    def __init__(self, scenario: Scenario, duration: float):
        world_config = copy.copy(scenario.world)
        world_config.simulator = REFERENCE_SIMULATOR
        world_config.flight_accuracy = RECIPE_FLIGHT_ACCURACY  # one accuracy throughout
        world_config.joint_stops = JointStopsConfig(enabled=False)  # the plant's joints alone
        # The station's plant and the arm's controller at the scenario's gains (its model exact,
        # no joint faults), without launcher, aerodynamics or referee: no Python system.
        reference = copy.copy(scenario)
        c = scenario.controller
        reference.controller = ControllerConfig(kp=list(c.kp), ki=list(c.ki), kd=list(c.kd))
        builder = DiagramBuilder()
        station = add_station(builder, reference, robots=1, launcher=False, referee=False,
                              aerodynamics=False, world_config=world_config)
        self.world = station.world
        controller = ControllerPorts(station.GetInputPort(arm_port(0, "desired_state")),
                                     station.GetInputPort(arm_port(0, "desired_acceleration")))
        traj = _swing(duration)
        source = builder.AddNamedSystem("swing", TrajectorySource(traj, 1))
        builder.Connect(source.get_output_port(), controller.get_input_port_desired_state())
        accel = builder.AddNamedSystem("swing_acceleration",
                                       TrajectorySource(traj.derivative(2)))
        builder.Connect(accel.get_output_port(), controller.get_input_port_desired_acceleration())
        self.diagram = builder.Build()
        self.simulator = make_simulator(self.diagram, world_config, self.world.plant)
        self.context = self.simulator.get_mutable_context()
        plant_context = self.world.plant.GetMyMutableContextFromRoot(self.context)
        self.world.plant.SetPositions(plant_context, self.world.robot, np.asarray(AWAITING))
        self._initial = self.context.Clone()

    def run(self, launch_state, duration: float) -> float:
        """Simulate the serve from ``launch_state`` for ``duration``; returns the time reached."""
        self.context.SetTimeStateAndParametersFrom(self._initial)
        set_ball_state(self.world, self.world.plant.GetMyMutableContextFromRoot(self.context),
                       launch_state)
        self.simulator.Initialize()
        self.simulator.AdvanceTo(duration)
        return self.context.get_time()


class PhysicsDiagram:
    """The project's physics with C++ systems only: the serve diagram's plant, contact model,
    drag and Magnus (``aerodynamics``), the arm's controller behind the 500 Hz servo hold, fed
    by a C++ ``TrajectorySource`` of recorded set-points (as the replay), and the camera's
    60 Hz events as a C++ ``ZeroOrderHold`` sampling the ball's state; no launcher, referee,
    player or vision system. It runs at the scenario's simulator settings and accuracy
    schedule, advancing in the episodes' segments (:func:`advance_in_segments`, the schedule
    deciding between segments: the one piece of Python, called from Python), for the
    durations the project's episodes lasted. project / physics is then what every Python
    system of the serve diagram costs, and physics / reference what the project's physics
    adds to the reference's (aerodynamics, servo hold, camera events, the schedule)."""

    def __init__(self, scenario: Scenario, segment: float):
        builder = DiagramBuilder()
        station = add_station(builder, scenario, robots=1, launcher=False, referee=False)
        self.world = station.world
        controller = ControllerPorts(station.GetInputPort(arm_port(0, "desired_state")),
                                     station.GetInputPort(arm_port(0, "desired_acceleration")))
        _replay_player(builder, self.world, controller, scenario)
        camera = builder.AddNamedSystem("camera_events", ZeroOrderHold(
            1.0 / scenario.camera.rate, station.GetOutputPort("ball_state").size()))
        builder.Connect(station.GetOutputPort("ball_state"), camera.get_input_port())
        self.diagram = builder.Build()
        self.source = self.diagram.GetSubsystemByName("setpoint_replay")
        self.simulator, self._schedule = simulator_and_schedule(self.diagram, scenario.world,
                                                                self.world.plant)
        self._segment = segment
        self._config = scenario.world.simulator
        self.context = self.simulator.get_mutable_context()
        plant_context = self.world.plant.GetMyMutableContextFromRoot(self.context)
        self.world.plant.SetPositions(plant_context, self.world.robot, np.asarray(AWAITING))
        self._initial = self.context.Clone()

    def run(self, launch_state, trajectory: PiecewisePolynomial | None, duration: float
            ) -> float:
        """Simulate the serve from ``launch_state`` for ``duration`` with the set-points of
        ``trajectory`` (None: the arm holds its awaiting posture); returns the time reached."""
        self.context.SetTimeStateAndParametersFrom(self._initial)
        ApplySimulatorConfig(self._config, self.simulator)
        plant_context = self.world.plant.GetMyMutableContextFromRoot(self.context)
        set_ball_state(self.world, plant_context, launch_state)
        if trajectory is not None:
            self.source.UpdateTrajectory(trajectory)
            # The arm starts where the recorded player waited (its awaiting posture).
            start = trajectory.value(trajectory.start_time())[:7, 0]
            self.world.plant.SetPositions(plant_context, self.world.robot, start)
        # The servo holds the first set-point before its first tick, as in the episodes (what
        # the drive-aware correction reads at t = 0).
        hold_first_setpoint(self.diagram, self.context)
        self.simulator.Initialize()
        if self._schedule is None:
            self.simulator.AdvanceTo(duration)
        else:
            advance_in_segments(self.simulator, self._schedule, duration, self._segment)
        return self.context.get_time()


def run_bench(scenario: Scenario, serves: int = 10, seed: int = 0, player: str = "idle",
              workers: int = 1) -> dict:
    """Time ``serves`` serve episodes of ``player`` against the C++ reference diagram (and, for
    a player other than idle, the set-point replay and the idle diagram) on the same serves.

    An untimed pass first plays every serve once to learn its duration (the reference runs each
    serve for as long as the project's episode of it lasted) and, for a player other than idle,
    the set-points its episodes gave the servo (the replay's). The timed pass then runs serve
    after serve on every diagram in turn (:func:`_alternate`), so that each per-serve ratio
    compares CPU times measured seconds apart, under the same load."""
    seeds = [episode_seed(seed, i) for i in range(serves)]
    sampler = serve_sampler(scenario.launcher)
    sampler.sample(seeds[0])  # untimed: the process's first compiled flight loads its code
    t0 = time.perf_counter()
    launch = [sampler.sample(s) for s in seeds]
    sampling = (time.perf_counter() - t0) / serves

    project = ServeDiagram(scenario, player)
    if player == "idle":
        durations = [project.run(s).duration for s in seeds]
        trajectories = None
    else:
        durations, trajectories = _record_setpoints(scenario, player, seeds)
    reference = ReferenceDiagram(scenario, max(durations))
    physics = PhysicsDiagram(scenario, 1.0 / scenario.referee_rate)
    runners = {"project": lambda i: project.run(seeds[i]).duration,
               "reference": lambda i: reference.run(launch[i].launch_state, durations[i]),
               "physics": lambda i: physics.run(
                   launch[i].launch_state, trajectories[i] if trajectories else None,
                   durations[i])}
    if player != "idle":
        idle = ServeDiagram(scenario, "idle")
        replay = ServeDiagram(scenario, _replay_player)
        source = replay.diagram.GetSubsystemByName("setpoint_replay")

        def run_replay(i: int) -> float:
            source.UpdateTrajectory(trajectories[i])
            return replay.run(seeds[i]).duration

        runners["replay"] = run_replay
        runners["idle"] = lambda i: idle.run(seeds[i]).duration
    timed = _alternate(runners, serves)
    p, ref = timed["project"], timed["reference"]
    project_wall, project_cpu = _mean(p["wall"]), _mean(p["cpu"])
    reference_wall, reference_cpu = _mean(ref["wall"]), _mean(ref["cpu"])
    mean_duration = float(np.mean(durations))
    result = {
        "serves": serves, "player": player, "mean_episode_sim_time": mean_duration,
        "timing": "alternated: serve by serve on every diagram in turn, one process",
        "project": {"wall_per_serve": project_wall, "cpu_per_serve": project_cpu,
                    "real_time_factor": mean_duration / project_wall},
        "reference": {"wall_per_serve": reference_wall, "cpu_per_serve": reference_cpu,
                      "real_time_factor": mean_duration / reference_wall},
        "serve_sampling_per_serve": sampling,
        "ratio_project_to_reference": project_wall / reference_wall,
        # The same ratio in this process's CPU time: steadier on a loaded machine.
        "cpu_ratio_project_to_reference": project_cpu / reference_cpu,
        "per_serve_cpu_ratio_to_reference": _spread(p["cpu"], ref["cpu"]),
        "physics": {"wall_per_serve": _mean(timed["physics"]["wall"]),
                    "cpu_per_serve": _mean(timed["physics"]["cpu"]),
                    # With it the physics holds the controller's drive-aware correction, a
                    # Python system (docs/faults.md).
                    "drive_aware": bool(scenario.controller.drive_aware)},
        # What the serve diagram's Python systems cost over the same physics in C++ only, and
        # what the project's physics costs over the reference's.
        "cpu_ratio_project_to_physics": project_cpu / _mean(timed["physics"]["cpu"]),
        "per_serve_cpu_ratio_to_physics": _spread(p["cpu"], timed["physics"]["cpu"]),
        "cpu_ratio_physics_to_reference": _mean(timed["physics"]["cpu"]) / reference_cpu,
        # Serves whose timed episode lasted as long as the reference was run for it (all of
        # them: the untimed pass and the timed one simulate the same numbers).
        "durations_equal": int(sum(a == b for a, b in zip(p["duration"], durations,
                                                          strict=True))),
        "reference_simulator": {"integration_scheme": REFERENCE_SIMULATOR.integration_scheme,
                                "accuracy": REFERENCE_SIMULATOR.accuracy,
                                "max_step_size": REFERENCE_SIMULATOR.max_step_size},
        "simulator": {"integration_scheme": scenario.world.simulator.integration_scheme,
                      "accuracy": scenario.world.simulator.accuracy,
                      "flight_accuracy": scenario.world.flight_accuracy,
                      "max_step_size": scenario.world.simulator.max_step_size},
    }
    if player != "idle":
        # The same serves at the idle diagram. A returned ball flies on to the far court, so per
        # serve the player's episodes also simulate longer.
        idle_wall = _mean(timed["idle"]["wall"])
        idle_sim = _mean(timed["idle"]["duration"])
        result["idle"] = {"wall_per_serve": idle_wall, "mean_episode_sim_time": idle_sim,
                          "real_time_factor": idle_sim / idle_wall}
        result["ratio_to_idle_per_serve"] = project_wall / idle_wall
        result["ratio_to_idle_per_simulated_second"] = (
            (project_wall / mean_duration) / (idle_wall / idle_sim))
        r = timed["replay"]
        replay_wall, replay_cpu = _mean(r["wall"]), _mean(r["cpu"])
        result["replay"] = {"wall_per_serve": replay_wall, "cpu_per_serve": replay_cpu,
                            "mean_episode_sim_time": _mean(r["duration"])}
        result["ratio_to_replay_per_serve"] = project_wall / replay_wall
        result["cpu_ratio_to_replay_per_serve"] = project_cpu / replay_cpu
        result["per_serve_cpu_ratio_to_replay"] = _spread(p["cpu"], r["cpu"])
        result["replay_to_idle_per_serve"] = replay_wall / idle_wall
    if workers > 1:
        result["parallel"] = _time_parallel(scenario, player, seeds, workers, project_wall,
                                            project_cpu)
    result["momp_planning"] = bench_momp_planning()
    # Untimed, after every timing: the counter's profiler slows the episodes it watches.
    result["drake_python_calls"] = {
        "project": count_drake_calls(lambda: project.run(seeds[0]).duration,
                                     project.simulator.get_integrator),
        "reference": count_drake_calls(
            lambda: reference.run(launch[0].launch_state, durations[0]),
            reference.simulator.get_integrator),
        "physics": count_drake_calls(
            lambda: runners["physics"](0), physics.simulator.get_integrator)}
    if player != "idle":
        result["drake_python_calls"]["replay"] = count_drake_calls(
            lambda: run_replay(0), replay.simulator.get_integrator)
    return result


def _mean(values: list[float]) -> float:
    return float(np.mean(values))


def _spread(numerators: list[float], denominators: list[float]) -> dict:
    """Median, quartiles and extremes of the per-serve ratios ``numerators[i] / denominators[i]``
    (each pair timed seconds apart, :func:`_alternate`)."""
    ratios = np.asarray(numerators) / np.asarray(denominators)
    q1, median, q3 = np.percentile(ratios, [25, 50, 75])
    return {"median": float(median), "q1": float(q1), "q3": float(q3),
            "min": float(ratios.min()), "max": float(ratios.max())}


def _alternate(runners: dict, serves: int) -> dict:
    """Time every runner (name -> ``run(i)`` that plays serve ``i`` and returns its simulated
    duration) on serves 0 .. ``serves`` - 1, serve by serve: each runner once as a warm-up on
    serve 0 (untimed), then for each serve every runner in turn, the order rotating by one from
    serve to serve so that none always runs right after the same other one.

    Returns per runner the wall and CPU (``time.process_time``) times and the durations of its
    episodes, in the order of the serves, and under ``"calls"`` the (runner, serve) sequence of
    the timed calls."""
    names = list(runners)
    for name in names:
        runners[name](0)  # warm caches (first Python calls, scalar conversions)
    out = {name: {"wall": [], "cpu": [], "duration": []} for name in names}
    calls = []
    for i in range(serves):
        k = i % len(names)
        for name in names[k:] + names[:k]:
            t0, c0 = time.perf_counter(), time.process_time()
            duration = runners[name](i)
            cpu = time.process_time() - c0
            out[name]["wall"].append(time.perf_counter() - t0)
            out[name]["cpu"].append(cpu)
            out[name]["duration"].append(duration)
            calls.append((name, i))
    out["calls"] = calls
    return out


def _replay_player(builder: DiagramBuilder, world, controller, scenario: Scenario) -> list:
    """Recorded set-points (q, q_dot, q_ddot) from a C++ ``TrajectorySource`` through the servo
    holds; the trajectory is set per episode (:func:`run_bench`)."""
    rest = np.r_[AWAITING, np.zeros(14)]
    source = builder.AddNamedSystem("setpoint_replay", TrajectorySource(
        PiecewisePolynomial.FirstOrderHold([0.0, 1.0], np.column_stack([rest, rest]))))
    add_servo_hold(builder, source.get_output_port(), controller)
    return []


def _record_setpoints(scenario: Scenario, player: str, seeds: list[int]
                      ) -> tuple[list[float], list[PiecewisePolynomial]]:
    """Play ``player``'s episodes of ``seeds`` (untimed) with the servo's set-points logged: their
    durations and the set-points as trajectories for the replay."""
    recorder = ServeDiagram(scenario, player, log_setpoints=True)
    durations, trajectories = [], []
    for s in seeds:
        durations.append(recorder.run(s).duration)
        ticks, setpoints = recorder.setpoints()
        trajectories.append(PiecewisePolynomial.FirstOrderHold(ticks, setpoints.T))
    return durations, trajectories


def _machine_jiffies() -> tuple[int, int] | None:
    """(busy, steal) clock ticks of all CPUs so far (Linux ``/proc/stat``), None elsewhere."""
    try:
        with open("/proc/stat") as f:
            fields = [int(v) for v in f.readline().split()[1:]]
    except (OSError, ValueError):
        return None
    user, nice, system, _idle, _iowait, irq, softirq, steal = (fields + [0] * 8)[:8]
    return user + nice + system + irq + softirq, steal


def _time_parallel(scenario: Scenario, player: str, seeds: list[int], workers: int,
                   serial_wall: float, serial_cpu: float | None = None) -> dict:
    """The serves of ``seeds`` on ``workers`` processes as ``tt-drake serve --workers`` runs them
    (a learned player's artefacts loaded once, before the workers fork). ``start_up``: until the
    first result (the workers build their diagrams); ``wall_per_serve``: the steady rate after
    it; the projection adds the two for :data:`PROJECTED_SERVES` serves.

    Where a speed-up below ``workers`` comes from (each a factor; ``speedup`` is ``workers`` times
    ``serial_wall / serial_cpu`` divided by their product, up to the start-up's share):

    - ``cpu_inflation``: the workers' CPU per episode over the single process's (contention for
      the memory system, or a slower core when both are busy);
    - ``core_share``: the workers' wall time per episode over their CPU time (> 1: a worker did
      not have a core to itself, e.g. other processes ran);
    - ``between_episodes``: ``workers`` x the steady wall time per serve over the workers' mean
      episode wall time (time outside episodes: inter-process transfer, the last serves' tail);
    - ``other_load``: CPUs' worth of busy time (Linux ``/proc/stat``) spent by everything else
      during the run (the parent process included), and ``steal``: CPUs' worth taken by the
      hypervisor."""
    check_player(player, scenario)  # a learned player's artefacts, kept for the workers
    jiffies0 = _machine_jiffies()
    t0 = time.perf_counter()
    first = None
    episodes = []
    for result in run_episodes(scenario, player, seeds, workers):
        first = time.perf_counter() if first is None else first
        episodes.append(result)
    end = time.perf_counter()
    jiffies1 = _machine_jiffies()
    start_up = first - t0
    per_serve = (end - first) / max(1, len(seeds) - 1)
    out = {"workers": workers, "serves": len(seeds), "total_wall": end - t0,
           "start_up": start_up, "wall_per_serve": per_serve,
           "speedup": serial_wall / per_serve,
           "projected_wall_10000": start_up + PROJECTED_SERVES * per_serve}
    # Each worker's first episode (the first ``workers`` tasks) includes its warm-up.
    steady = episodes[workers:] or episodes
    episode_wall = float(np.mean([e.wall_time for e in steady]))
    episode_cpu = float(np.mean([e.cpu_time for e in steady]))
    out.update(episode_wall=episode_wall, episode_cpu=episode_cpu,
               core_share=episode_wall / episode_cpu if episode_cpu > 0 else float("nan"),
               between_episodes=workers * per_serve / episode_wall)
    if serial_cpu:
        out["cpu_inflation"] = episode_cpu / serial_cpu
    if jiffies0 is not None and jiffies1 is not None:
        hz = os.sysconf("SC_CLK_TCK")
        busy = (jiffies1[0] - jiffies0[0]) / hz
        ours = sum(e.cpu_time for e in episodes)
        out["other_load"] = max(0.0, busy - ours) / (end - t0)
        out["steal"] = (jiffies1[1] - jiffies0[1]) / hz / (end - t0)
    return out


def _project_accuracy(simulator: dict) -> str:
    """The project's accuracy; with a flight accuracy (ContactAccuracy) both."""
    flight = simulator.get("flight_accuracy", 0.0)
    if flight > 0.0:
        return f"{simulator['accuracy']:g} near contacts, {flight:g} in flight"
    return f"{simulator['accuracy']:g}"


def _format_spread(s: dict) -> str:
    return (f"median {s['median']:.2f}, quartiles {s['q1']:.2f}-{s['q3']:.2f}, "
            f"range {s['min']:.2f}-{s['max']:.2f}")


def format_bench(r: dict) -> str:
    lines = [
        f"serve episodes: {r['serves']} ({r['player']} player), mean simulated time "
        f"{r['mean_episode_sim_time']:.2f} s",
        f"  project diagram    {1e3 * r['project']['wall_per_serve']:8.1f} ms/serve   "
        f"{r['project']['real_time_factor']:5.1f}x real time   "
        f"{1e3 * r['project']['cpu_per_serve']:8.1f} CPU ms/serve",
        f"  C++ reference      {1e3 * r['reference']['wall_per_serve']:8.1f} ms/serve   "
        f"{r['reference']['real_time_factor']:5.1f}x real time   "
        f"{1e3 * r['reference']['cpu_per_serve']:8.1f} CPU ms/serve",
        f"  ratio project/reference: {r['ratio_project_to_reference']:.2f} (reference at "
        f"accuracy {r['reference_simulator']['accuracy']:g}, project at "
        f"{_project_accuracy(r['simulator'])}); in CPU time "
        f"{r['cpu_ratio_project_to_reference']:.2f}",
        f"  per serve (CPU, alternated): {_format_spread(r['per_serve_cpu_ratio_to_reference'])}",
        f"  C++-only physics   {1e3 * r['physics']['wall_per_serve']:8.1f} ms/serve   "
        + ("(the project's physics and drive-aware correction)  "
           if r["physics"].get("drive_aware") else
           "(the project's physics, no Python system)      ")
        + f"{1e3 * r['physics']['cpu_per_serve']:8.1f} CPU ms/serve",
        f"  in CPU time: project/physics {r['cpu_ratio_project_to_physics']:.2f} (the Python "
        f"systems; per serve {_format_spread(r['per_serve_cpu_ratio_to_physics'])}), "
        f"physics/reference {r['cpu_ratio_physics_to_reference']:.2f}",
        f"  serve sampling (included in project): "
        f"{1e3 * r['serve_sampling_per_serve']:.1f} ms/serve",
    ]
    if "idle" in r:
        lines.append(f"  idle diagram       {1e3 * r['idle']['wall_per_serve']:8.1f} ms/serve   "
                     f"{r['idle']['real_time_factor']:5.1f}x real time (mean simulated "
                     f"{r['idle']['mean_episode_sim_time']:.2f} s)")
        lines.append(f"  ratio {r['player']}/idle: {r['ratio_to_idle_per_serve']:.2f} per serve, "
                     f"{r['ratio_to_idle_per_simulated_second']:.2f} per simulated second")
    if "replay" in r:
        lines.append(f"  set-point replay   {1e3 * r['replay']['wall_per_serve']:8.1f} ms/serve   "
                     f"(the same physics, no player systems; mean simulated "
                     f"{r['replay']['mean_episode_sim_time']:.2f} s)")
        lines.append(f"  ratio {r['player']}/replay: {r['ratio_to_replay_per_serve']:.2f} per "
                     f"serve, {r['cpu_ratio_to_replay_per_serve']:.2f} in CPU time (the "
                     f"player's systems); replay/idle: "
                     f"{r['replay_to_idle_per_serve']:.2f} (the returned ball's physics)")
        lines.append(f"  per serve (CPU, alternated): "
                     f"{_format_spread(r['per_serve_cpu_ratio_to_replay'])}")
    if "parallel" in r:
        p = r["parallel"]
        lines.append(f"  {p['workers']} workers: {1e3 * p['wall_per_serve']:.1f} ms/serve steady "
                     f"({p['speedup']:.2f}x one process) over {p['serves']} serves, start-up "
                     f"{p['start_up']:.1f} s; projected {PROJECTED_SERVES:,} serves: "
                     f"{p['projected_wall_10000'] / 60:.1f} min")
        if "episode_cpu" in p:
            parts = [f"episode {1e3 * p['episode_wall']:.1f} ms wall, "
                     f"{1e3 * p['episode_cpu']:.1f} CPU ms in a worker"]
            if "cpu_inflation" in p:
                parts.append(f"CPU per episode {p['cpu_inflation']:.2f}x one process's")
            parts.append(f"wall/CPU {p['core_share']:.2f}")
            parts.append(f"between episodes {p['between_episodes']:.2f}")
            if "other_load" in p:
                parts.append(f"other load {p['other_load']:.2f} CPUs, steal {p['steal']:.2f}")
            lines.append("    where the speed-up goes: " + "; ".join(parts))
    if "momp_planning" in r:
        lines.append(f"  MoMP planning: {r['momp_planning']}")
    if "drake_python_calls" in r:
        lines += _format_calls(r["drake_python_calls"])
    return "\n".join(lines)


def _format_calls(calls: dict) -> list[str]:
    """The Drake->Python calls of the project diagram per system, and the other diagrams'
    totals, per simulated second."""
    p = calls["project"]
    lines = [f"  Drake->Python calls per simulated second (serve 0 once more, untimed): project "
             f"{p['per_second']:,.0f}"
             + "".join(f", {name} {c['per_second']:,.0f}" for name, c in calls.items()
                       if name != "project")
             + f"; the project's integrator: {p['steps_per_second']:,.0f} steps, "
               f"{p['derivative_evaluations_per_second']:,.0f} derivative evaluations"]
    for system, rate in p["systems"].items():
        parts = ", ".join(f"{callback.split('.', 1)[-1]} {n:,.0f}"
                          for callback, n in p["callbacks"][system].items())
        lines.append(f"    {system:32s} {rate:7,.0f}   ({parts})")
    return lines
