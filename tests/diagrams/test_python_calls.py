"""The count of Drake's calls into Python (tt-drake bench): a diagram of known Python systems
gives the counts its events and its integrator imply."""

import numpy as np
import pytest
from pydrake.common.value import AbstractValue
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder, LeafSystem
from pydrake.systems.primitives import VectorLogSink

from tt_drake.diagrams.python_calls import COPY_LABEL, count_drake_calls
from tt_drake.systems.immutable import Immutable

TICK_RATE = 100.0  # Hz: the discrete update's
COPY_RATE = 50.0  # Hz: the unrestricted update's
DURATION = 1.0
MAX_STEP = 2e-3  # s: the integrator steps at ~500 per second, the tick at 100


class Ticker(LeafSystem):
    """A periodic discrete update at TICK_RATE that calls a Python helper and a builtin that
    calls back into Python (neither is Drake's call)."""

    def __init__(self):
        super().__init__()
        self._xd = self.DeclareDiscreteState(1)
        self.DeclarePeriodicDiscreteUpdateEvent(1.0 / TICK_RATE, 0.0, self._update)

    def _helper(self, x):
        return x + 1.0

    def _update(self, context, discrete_state):
        x = context.get_discrete_state(self._xd).get_value()[0]
        discrete_state.set_value(self._xd, [self._helper(x) + sum(k for k in range(2))])


class Clock(LeafSystem):
    """An output that depends on time: a per-step logger evaluates it once per step."""

    def __init__(self):
        super().__init__()
        self.DeclareVectorOutputPort("t", 1, self._calc)

    def _calc(self, context, output):
        output.SetAtIndex(0, context.get_time())


class Decay(LeafSystem):
    """x' = -x, in Python: the integrator calls it at each of its derivative evaluations."""

    def __init__(self):
        super().__init__()
        self.DeclareContinuousState(1)

    def DoCalcTimeDerivatives(self, context, derivatives):  # noqa: N802 (Drake's name)
        x = context.get_continuous_state_vector().GetAtIndex(0)
        derivatives.get_mutable_vector().SetAtIndex(0, -x)


class Token(Immutable):
    __slots__ = ("n",)

    def __init__(self, n=0):
        self.n = n


class Counter(LeafSystem):
    """An abstract state replaced by an unrestricted update at COPY_RATE."""

    def __init__(self):
        super().__init__()
        self._index = self.DeclareAbstractState(AbstractValue.Make(Token()))
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / COPY_RATE, 0.0, self._update)

    def _update(self, context, state):
        n = context.get_abstract_state(self._index).get_value().n
        state.get_mutable_abstract_state(self._index).set_value(Token(n + 1))


def _simulator():
    builder = DiagramBuilder()
    builder.AddSystem(Ticker())
    clock = builder.AddSystem(Clock())
    log = builder.AddSystem(VectorLogSink(1))  # publishes at every step (and at Initialize)
    builder.Connect(clock.get_output_port(), log.get_input_port())
    builder.AddSystem(Decay())
    builder.AddSystem(Counter())
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.get_mutable_integrator().set_maximum_step_size(MAX_STEP)
    simulator.get_mutable_context().SetContinuousState([1.0])
    return simulator


def test_counts_match_the_event_rates_and_the_integrators_steps():
    simulator = _simulator()

    def run():
        simulator.Initialize()
        simulator.AdvanceTo(DURATION)
        return simulator.get_context().get_time()

    calls = count_drake_calls(run, simulator.get_integrator)
    assert calls["simulated"] == DURATION
    per_step = calls["steps_per_second"]
    per_stage = calls["derivative_evaluations_per_second"]
    assert per_stage > per_step > 2 * TICK_RATE  # the three rates can be told apart
    systems, callbacks = calls["systems"], calls["callbacks"]
    # Ticks at 0, 10 ms, ..., 990 ms: the one at t = 1 s belongs to the next AdvanceTo.
    assert callbacks["Ticker"] == {"Ticker._update": pytest.approx(TICK_RATE)}
    # One evaluation per step plus the initial publish.
    assert callbacks["Clock"]["Clock._calc"] == pytest.approx(per_step + 1.0)
    assert callbacks["Decay"]["Decay.DoCalcTimeDerivatives"] == pytest.approx(per_stage)
    assert callbacks["Counter"] == {"Counter._update": pytest.approx(COPY_RATE)}
    # Drake deep-copies the abstract state at every unrestricted update (at least once).
    copies = systems[COPY_LABEL + "test_python_calls.Token"]
    assert copies >= COPY_RATE and copies == pytest.approx(round(copies / COPY_RATE) * COPY_RATE)
    assert calls["total"] == pytest.approx(sum(systems.values()) * DURATION)
    assert calls["per_second"] == pytest.approx(calls["total"] / DURATION)
    assert list(systems.values()) == sorted(systems.values(), reverse=True)


def test_python_called_from_python_or_numpy_is_not_counted():
    # Python's own calls (a comprehension, Token()) and numpy's (np.sum calls numpy's Python).
    calls = count_drake_calls(lambda: (np.sum([Token().n for _ in range(3)]), 0.5)[1])
    assert calls["total"] == 0 and calls["systems"] == {} and calls["per_second"] == 0.0
