"""The floor: what the serve diagram's Python systems cost with nothing to do
(docs/performance.md, "The Python floor, and what is left").

    OPENBLAS_NUM_THREADS=1 python docs/examples/python_floor.py [--serves 20] [--seed 3]
        [--scenario S]

Plays the momp player's serves once (untimed) to record the set-points its episodes gave the
servo and their durations, then times, serve by serve in one process (the order rotating, as
``tt-drake bench`` does), these diagrams on the same serves:

- ``reference``: the C++ reference diagram of ``tt-drake bench`` (no Python system);
- ``replay``: the serve diagram with the player and its vision replaced by a C++
  ``TrajectorySource`` of the recorded set-points (Python left: the referee at 250 Hz, the
  launcher, the accuracy decided per referee tick);
- ``floor-player``: the replay with a Python stub of the player instead of the C++ source: an
  unrestricted update with an abstract state at the planning rate (plus its forced update), the
  same input ports, and a ``setpoint`` output the servo hold samples at 500 Hz, whose body copies
  the recorded set-point of the tick (a table row);
- ``floor``: the same with Python stubs of the vision chain too: the camera (discrete update at
  60 Hz reading the ball), the estimator and the hitting-point predictor (discrete updates at the
  planning rate that read their inputs, write their state when a new frame or estimate arrives
  and return ``DidNothing`` otherwise, as the real ones do) and the hitting configuration
  (outputs computed from its inputs), wired port for port as the learned player's diagram;
- ``floor-60hz``: the same with the estimator and predictor stubs ticking at the camera's
  60 Hz instead of the planning rate (what the vision chain's ticks without a frame cost);
- ``floor-merged``: the player and its vision as one Python system: a discrete update at the
  camera's 60 Hz reading the ball and the arm, and the ``setpoint`` output as above (the
  fewest Python events a camera-driven player can have with Python set-points);
- ``momp``: the real momp diagram (the shipped artefacts).

The stubs' bodies do no arithmetic beyond copying a few numbers, so floor - replay is what the
framework charges for these systems' events and ports at these rates, and momp - floor what the
player's and vision's own computation costs. Prints each diagram's CPU ms per serve, its ratio to
the reference (of the totals, and the median and quartiles per serve) and the number of Python
calls per serve (a separate profiled pass of 2 serves each, not timed).
"""

from __future__ import annotations

import argparse
import cProfile
import math
import pstats
import time

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import EventStatus, LeafSystem

from tt_drake.diagrams.bench import ReferenceDiagram, _alternate, _record_setpoints, _replay_player
from tt_drake.diagrams.commands.options import add_scenario_option
from tt_drake.diagrams.episodes import ServeDiagram, connect_hitting_chain, episode_seed
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.models import use_artefact_set
from tt_drake.serves import serve_sampler
from tt_drake.systems.immutable import Immutable
from tt_drake.systems.wam import add_servo_hold
from tt_drake.wam_params import AWAITING, PLANNING_RATE, SERVO_PERIOD

_NOTHING = EventStatus.DidNothing()


class _StubState(Immutable):
    __slots__ = ("seen",)

    def __init__(self, seen=None):
        self.seen = seen


class StubCamera(LeafSystem):
    """60 Hz discrete update reading the ball; ``measurement`` (x, y, z, t, seen) from the
    state, as BallCamera."""

    def __init__(self, period: float):
        super().__init__()
        self._ball = self.DeclareVectorInputPort("ball_state", 13)
        self._xd = self.DeclareDiscreteState(np.array([math.nan] * 3 + [math.nan, 0.0]))
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)
        self.DeclareVectorOutputPort("measurement", 5, self._calc,
                                     prerequisites_of_calc={self.xd_ticket()})

    def _update(self, context, discrete_state):
        s = self._ball.Eval(context)
        discrete_state.set_value(self._xd, np.array([s[4], s[5], s[6], context.get_time(), 1.0]))

    def _calc(self, context, output):
        output.SetFromVector(context.get_discrete_state(self._xd).get_value())


class _SlicedState(LeafSystem):
    """A stub whose discrete state is a vector and whose outputs are named slices of it, each
    recomputed only when the state changes."""

    def _declare_slices(self, slices) -> None:
        deps = {self.xd_ticket()}
        for name, lo, hi in slices:
            self.DeclareVectorOutputPort(name, hi - lo, self._slice(lo, hi),
                                         prerequisites_of_calc=deps)

    def _slice(self, lo, hi):
        def calc(context, output):
            output.SetFromVector(context.get_discrete_state(self._xd).get_value()[lo:hi])
        return calc


class StubEstimator(_SlicedState):
    """Discrete update every ``period`` (the planning rate's, as BallFlightEstimator): a new
    frame is copied into the state, else DidNothing; outputs ``state`` (6), ``spin`` (3),
    ``status`` (2: tracking, time), as BallFlightEstimator."""

    def __init__(self, period: float):
        super().__init__()
        self._u = self.DeclareVectorInputPort("measurement", 5)
        self._xd = self.DeclareDiscreteState(np.zeros(11))
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)
        self._declare_slices((("state", 0, 6), ("spin", 6, 9), ("status", 9, 11)))

    def _update(self, context, discrete_state):
        u = self._u.Eval(context)
        x = context.get_discrete_state(self._xd).get_value()
        t = float(u[3])
        if math.isnan(t) or not t > x[10]:
            return _NOTHING
        new = x.copy()
        new[0:3] = u[0:3]
        new[9], new[10] = 1.0, t
        discrete_state.set_value(self._xd, new)


class StubPredictor(_SlicedState):
    """Discrete update every ``period`` (the planning rate's, as HittingPointPredictor): a new
    estimate is copied into the state, else DidNothing; outputs ``p_hit``, ``v_hit``, ``t_hit``,
    ``valid``, ``final``, ``spin_hit`` as HittingPointPredictor (never valid: the stub player
    does not plan)."""

    def __init__(self, period: float):
        super().__init__()
        self._state = self.DeclareVectorInputPort("state", 6)
        self._spin = self.DeclareVectorInputPort("spin", 3)
        self._status = self.DeclareVectorInputPort("status", 2)
        self._xd = self.DeclareDiscreteState(np.zeros(14))
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)
        self._declare_slices((("p_hit", 0, 3), ("v_hit", 3, 6), ("t_hit", 6, 7), ("valid", 7, 8),
                              ("final", 8, 9), ("spin_hit", 9, 12)))

    def _update(self, context, discrete_state):
        status = self._status.Eval(context)
        x = context.get_discrete_state(self._xd).get_value()
        t = float(status[1])
        if status[0] < 0.5 or not t > x[13]:
            return _NOTHING
        new = x.copy()
        new[0:6] = self._state.Eval(context)
        new[9:12] = self._spin.Eval(context)
        new[13] = t
        discrete_state.set_value(self._xd, new)


class StubConfiguration(LeafSystem):
    """``theta_hit``, ``theta_dot_hit``, ``valid`` computed from the inputs (all invalid)."""

    def __init__(self):
        super().__init__()
        self._valid = self.DeclareVectorInputPort("valid", 1)
        for name, size in (("p_hit", 3), ("v_hit", 3), ("t_hit", 1), ("spin_hit", 3)):
            self.DeclareVectorInputPort(name, size)
        deps = {self.all_input_ports_ticket()}
        for name, size in (("theta_hit", 7), ("theta_dot_hit", 7), ("valid", 1)):
            self.DeclareVectorOutputPort(name, size, self._calc, prerequisites_of_calc=deps)

    def _calc(self, context, output):
        self._valid.Eval(context)
        output.SetFromVector(np.zeros(output.size()))


class StubPlayer(LeafSystem):
    """The momp player's ports and events with a trivial body: an unrestricted update with an
    abstract state at the planning rate (and forced) that reads the prediction's validity and
    returns DidNothing; ``setpoint`` (21) copies the recorded set-point of the servo tick."""

    def __init__(self):
        super().__init__()
        self._valid = self.DeclareVectorInputPort("configuration_valid", 1)
        self._p = self.DeclareVectorInputPort("p_hit", 3)
        for name, size in (("v_hit", 3), ("t_hit", 1), ("theta_hit", 7), ("theta_dot_hit", 7),
                           ("spin_hit", 3), ("arm_state", 14)):
            self.DeclareVectorInputPort(name, size)
        self._index = self.DeclareAbstractState(AbstractValue.Make(_StubState()))
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / PLANNING_RATE, 0.0, self._update)
        self.DeclareForcedUnrestrictedUpdateEvent(self._update)
        self.DeclareVectorOutputPort("setpoint", 21, self._calc_setpoint)
        self.table = np.r_[AWAITING, np.zeros(14)][None, :]

    def _update(self, context, state):
        context.get_abstract_state(self._index).get_value()
        if self._valid.Eval(context)[0] < 0.5:
            return _NOTHING
        return _NOTHING

    def _calc_setpoint(self, context, output):
        k = min(round(context.get_time() / SERVO_PERIOD), self.table.shape[0] - 1)
        output.get_mutable_value()[:] = self.table[k]


class StubMerged(LeafSystem):
    """The player and its vision as one system: a discrete update at the camera's rate reading
    the ball and the arm (where one system would take the frame, filter it, predict and plan),
    and ``setpoint`` (21) copying the recorded set-point of the servo tick."""

    def __init__(self, period: float):
        super().__init__()
        self._ball = self.DeclareVectorInputPort("ball_state", 13)
        self._arm = self.DeclareVectorInputPort("arm_state", 14)
        self._xd = self.DeclareDiscreteState(np.zeros(5))
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)
        self.DeclareVectorOutputPort("setpoint", 21, self._calc_setpoint)
        self.table = np.r_[AWAITING, np.zeros(14)][None, :]

    def _update(self, context, discrete_state):
        s = self._ball.Eval(context)
        self._arm.Eval(context)
        discrete_state.set_value(self._xd, np.array([s[4], s[5], s[6], context.get_time(), 1.0]))

    def _calc_setpoint(self, context, output):
        k = min(round(context.get_time() / SERVO_PERIOD), self.table.shape[0] - 1)
        output.get_mutable_value()[:] = self.table[k]


def _merged_player(builder, world, controller, scenario) -> list:
    player = builder.AddNamedSystem("stub_player", StubMerged(scenario.camera.period))
    builder.Connect(world.plant.get_state_output_port(world.ball),
                    player.GetInputPort("ball_state"))
    builder.Connect(world.plant.get_state_output_port(world.robot),
                    player.GetInputPort("arm_state"))
    add_servo_hold(builder, player.GetOutputPort("setpoint"), controller)
    return []


def _floor_player(vision: bool, vision_at_frames: bool = False):
    """The stub player (and with ``vision`` the stub vision chain; ``vision_at_frames``: the
    estimator and predictor stubs tick at the camera's rate, aligned with its frames)."""
    def add(builder, world, controller, scenario) -> list:
        player = builder.AddNamedSystem("stub_player", StubPlayer())
        if vision:
            period = scenario.camera.period if vision_at_frames else 1.0 / PLANNING_RATE
            camera = builder.AddNamedSystem("stub_camera", StubCamera(scenario.camera.period))
            builder.Connect(world.plant.get_state_output_port(world.ball),
                            camera.get_input_port(0))
            estimator = builder.AddNamedSystem("stub_estimator", StubEstimator(period))
            builder.Connect(camera.GetOutputPort("measurement"), estimator.get_input_port(0))
            predictor = builder.AddNamedSystem("stub_predictor", StubPredictor(period))
            for name in ("state", "spin", "status"):
                builder.Connect(estimator.GetOutputPort(name), predictor.GetInputPort(name))
            configuration = builder.AddNamedSystem("stub_configuration", StubConfiguration())
            connect_hitting_chain(builder, predictor, configuration, player)
            builder.Connect(world.plant.get_state_output_port(world.robot),
                            player.GetInputPort("arm_state"))
        else:
            from pydrake.systems.primitives import ConstantVectorSource

            for name, size in (("configuration_valid", 1), ("p_hit", 3), ("v_hit", 3),
                               ("t_hit", 1), ("theta_hit", 7), ("theta_dot_hit", 7),
                               ("spin_hit", 3), ("arm_state", 14)):
                source = builder.AddSystem(ConstantVectorSource(np.zeros(size)))
                builder.Connect(source.get_output_port(), player.GetInputPort(name))
        add_servo_hold(builder, player.GetOutputPort("setpoint"), controller)
        return []
    return add


def setpoint_table(trajectory) -> np.ndarray:
    """The recorded set-points (a first-order hold through the servo ticks) at every tick:
    (ticks, 21), row k for time k * SERVO_PERIOD."""
    ticks = np.arange(round(trajectory.end_time() / SERVO_PERIOD) + 1) * SERVO_PERIOD
    return np.column_stack([trajectory.value(t).ravel() for t in ticks]).T


def floor_diagram(scenario, vision: bool = True, vision_at_frames: bool = False) -> ServeDiagram:
    """The serve diagram with the stub player (and vision); set ``stub_player.table``."""
    return ServeDiagram(scenario, _floor_player(vision, vision_at_frames))


def merged_floor_diagram(scenario) -> ServeDiagram:
    return ServeDiagram(scenario, _merged_player)


def _calls_per_serve(run, serves: int) -> float:
    prof = cProfile.Profile()
    prof.enable()
    for i in range(serves):
        run(i)
    prof.disable()
    return pstats.Stats(prof).total_calls / serves


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--serves", type=int, default=20)
    ap.add_argument("--seed", type=int, default=3)
    add_scenario_option(ap)
    args = ap.parse_args()
    scenario = load_scenario(args.scenario)
    use_artefact_set(scenario.learned)  # the shipped paper set, as `tt-drake serve` plays it
    seeds = [episode_seed(args.seed, i) for i in range(args.serves)]
    durations, trajectories = _record_setpoints(scenario, "momp", seeds)
    tables = [setpoint_table(trajectory) for trajectory in trajectories]
    momp = ServeDiagram(scenario, "momp")
    reference = ReferenceDiagram(scenario, max(durations))
    replay = ServeDiagram(scenario, _replay_player)
    source = replay.diagram.GetSubsystemByName("setpoint_replay")
    floors = {name: floor_diagram(scenario, *how)
              for name, how in (("floor-player", (False,)), ("floor", (True,)),
                                ("floor-60hz", (True, True)))}
    floors["floor-merged"] = merged_floor_diagram(scenario)
    sampler = serve_sampler(scenario.launcher)
    launch = [sampler.sample(s).launch_state for s in seeds]

    def run_replay(i):
        source.UpdateTrajectory(trajectories[i])
        return replay.run(seeds[i]).duration

    def run_floor(name):
        diagram = floors[name]
        player = diagram.diagram.GetSubsystemByName("stub_player")

        def run(i):
            player.table = tables[i]
            return diagram.run(seeds[i]).duration
        return run

    runners = {"reference": lambda i: reference.run(launch[i], durations[i]),
               "replay": run_replay, "floor-player": run_floor("floor-player"),
               "floor": run_floor("floor"), "floor-60hz": run_floor("floor-60hz"),
               "floor-merged": run_floor("floor-merged"),
               "momp": lambda i: momp.run(seeds[i]).duration}
    c0 = time.process_time()
    timed = _alternate(runners, args.serves)
    print(f"{args.serves} serves (seed {args.seed}), each diagram in turn serve by serve "
          f"({time.process_time() - c0:.0f} CPU s); mean simulated {np.mean(durations):.2f} s")
    ref = np.asarray(timed["reference"]["cpu"])
    calls = {name: _calls_per_serve(run, 2) for name, run in runners.items()}
    print(f"{'diagram':14s} {'CPU ms/serve':>12s} {'/ reference':>11s} {'per serve: median':>18s}"
          f" {'quartiles':>11s} {'Python calls/serve':>19s} {'mean sim. s':>11s}")
    for name, t in timed.items():
        if name == "calls":
            continue
        cpu = np.asarray(t["cpu"])
        q1, med, q3 = np.percentile(cpu / ref, [25, 50, 75])
        print(f"{name:14s} {1e3 * cpu.mean():12.1f} {cpu.sum() / ref.sum():11.2f} {med:18.2f} "
              f"{q1:5.2f}-{q3:5.2f} {calls[name]:19.0f} {np.mean(t['duration']):11.3f}")


if __name__ == "__main__":
    main()
