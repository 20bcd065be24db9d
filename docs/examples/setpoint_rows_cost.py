"""Set-points served from a player's state against its Python ``setpoint`` output
(docs/performance.md, "Measured and not used").

    OPENBLAS_NUM_THREADS=1 python docs/examples/setpoint_rows_cost.py [--seconds 20] [--rounds 3]

Two diagrams with the serve diagram's clocks and no plant: a player with an unrestricted update
every planning tick (4 ms) and a 21-value set-point sampled by a zero-order hold every servo tick
(2 ms), its held value integrated by a C++ ``Integrator`` so that the simulator takes steps.

- ``python``: the hold samples the player's ``setpoint`` output, a row of a table, at each servo
  tick (a Python call per tick: the serve diagram's wiring);
- ``state``: the player's update writes the rows of both servo ticks of its planning tick into a
  discrete-state group (42 values) served by a state output port, and C++ picks the row per
  servo tick: a ``Demultiplexer``, a ``PortSwitch`` and, as its selector, a one-step
  ``DiscreteTimeDelay`` of an ``InputPortIndex`` fed back on itself, which alternates between
  the two rows at the servo's rate (no Python between planning ticks).

An unrestricted update at a tick comes before the discrete updates of that tick, so the hold
at the planning tick 2k already sees the rows written there: row 2k is the first, row 2k + 1 the
second. Both diagrams hold the same values to the bit (checked); the script prints the CPU time
per servo tick of each, the two alternated round by round, and their ratio.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder, EventStatus, InputPortIndex, LeafSystem
from pydrake.systems.primitives import (
    Demultiplexer,
    DiscreteTimeDelay,
    Integrator,
    PortSwitch,
    ZeroOrderHold,
)

SERVO_PERIOD = 0.002
#: The set-points: a fixed random table, row k held from servo tick k.
TABLE = np.random.default_rng(0).normal(size=(1000, 21))


def row(k: int) -> np.ndarray:
    return TABLE[k % TABLE.shape[0]]


class RowsPlayer(LeafSystem):
    """``setpoint`` (Python output: row k at servo tick k) and ``rows`` (state output: the rows
    of the servo ticks 2k and 2k + 1, written by the update at planning tick 2k)."""

    def __init__(self, write_rows: bool):
        super().__init__()
        self._write_rows = write_rows
        self._rows = self.DeclareDiscreteState(42)
        self.DeclareStateOutputPort("rows", self._rows)
        self.DeclareVectorOutputPort("setpoint", 21, self._calc_setpoint)
        self.DeclarePeriodicUnrestrictedUpdateEvent(2 * SERVO_PERIOD, 0.0, self._update)

    def _update(self, context, state):
        if self._write_rows:
            k = round(context.get_time() / SERVO_PERIOD)
            state.get_mutable_discrete_state(self._rows).set_value(
                np.concatenate((row(k), row(k + 1))))
        return EventStatus.Succeeded()

    def _calc_setpoint(self, context, output):
        output.get_mutable_value()[:] = row(round(context.get_time() / SERVO_PERIOD))


def build(mode: str):
    """The ``mode`` ("python" or "state") diagram, its integrator and (state) the selector."""
    builder = DiagramBuilder()
    player = builder.AddSystem(RowsPlayer(write_rows=mode == "state"))
    hold = builder.AddSystem(ZeroOrderHold(SERVO_PERIOD, 21))
    integrator = builder.AddSystem(Integrator(21))
    builder.Connect(hold.get_output_port(), integrator.get_input_port())
    selector = None
    if mode == "python":
        builder.Connect(player.GetOutputPort("setpoint"), hold.get_input_port())
    else:
        split = builder.AddSystem(Demultiplexer([21, 21]))
        builder.Connect(player.GetOutputPort("rows"), split.get_input_port())
        switch = builder.AddSystem(PortSwitch(21))
        first, second = switch.DeclareInputPort("first"), switch.DeclareInputPort("second")
        builder.Connect(split.get_output_port(0), first)
        builder.Connect(split.get_output_port(1), second)
        selector = builder.AddSystem(DiscreteTimeDelay(
            SERVO_PERIOD, 1, AbstractValue.Make(InputPortIndex(first.get_index()))))
        builder.Connect(selector.get_output_port(), selector.get_input_port())
        builder.Connect(selector.get_output_port(), switch.get_port_selector_input_port())
        builder.Connect(switch.get_output_port(), hold.get_input_port())
        selector = (selector, first.get_index(), second.get_index())
    return builder.Build(), integrator, selector


def run(mode: str, seconds: float) -> tuple[float, np.ndarray]:
    """CPU seconds of ``seconds`` simulated, and the integrator's final state."""
    diagram, integrator, selector = build(mode)
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    if selector is not None:
        # The delay's two slots, in the order that makes ticks 0, 2, 4, ... take the first row
        # (the held values below are compared with the Python output's).
        delay, first, second = selector
        delay_context = delay.GetMyMutableContextFromRoot(context)
        delay_context.SetAbstractState(0, InputPortIndex(second))
        delay_context.SetAbstractState(1, InputPortIndex(first))
    simulator.Initialize()
    c0 = time.process_time()
    simulator.AdvanceTo(seconds)
    cpu = time.process_time() - c0
    state = integrator.GetMyContextFromRoot(context).get_continuous_state_vector()
    return cpu, state.CopyToVector()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=float, default=20.0, help="simulated per run")
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()
    cpu = {"python": [], "state": []}
    ends = {}
    for r in range(args.rounds):
        for mode in (("python", "state") if r % 2 == 0 else ("state", "python")):
            c, x = run(mode, args.seconds)
            cpu[mode].append(c)
            ends.setdefault(mode, x)
    same = bool(np.array_equal(ends["python"], ends["state"]))
    ticks = args.seconds / SERVO_PERIOD
    py, st = (1e6 * sum(cpu[m]) / (len(cpu[m]) * ticks) for m in ("python", "state"))
    print(f"{args.seconds:g} s simulated, {args.rounds} rounds: python output {py:.2f}, "
          f"state rows + C++ selection {st:.2f} CPU us per servo tick (state / python "
          f"{st / py:.3f}); the held set-points integrate to the same state: {same}")


if __name__ == "__main__":
    main()
