"""Count the calls Drake makes into Python while a diagram runs: the price of the Python systems
that the simulation itself pays for, per simulated second and per system.

A Python LeafSystem costs the simulator a call from C++ into the interpreter whenever Drake
evaluates one of its callbacks: an output port's calc function, a discrete or unrestricted update
handler, a time-derivatives override, a simulator monitor, or a deep copy of a Python abstract
value (Drake clones the abstract state at every unrestricted update). Each such call costs the
framework several microseconds (argument wrapping, the interpreter's entry) before the callback
does any work of its own, so where the count runs at the integrator's step or sub-step rate
instead of an event rate is where the structure, not the arithmetic, sets the cost
(docs/performance.md).

:class:`DrakeCallCounter` counts them with ``sys.setprofile``: the profiler sees every Python
frame that starts and every C function that Python calls, so a Python frame that starts while the
innermost active call is a pydrake function (``Simulator.AdvanceTo``, ``InputPort.Eval``, ...)
was called by Drake. A Python function called by numpy or a builtin (``sum`` over a generator) is
not counted, and neither is Python called by Python. The profiler slows the run it watches
several times over, so the bench counts on a separate, untimed episode.

Calls are attributed to the class of the callback's ``self`` (a bound method, or a closure that
holds ``self``; else the first part of the function's qualified name) and, for Drake's deep
copies of abstract values, to the copied value's module and class
(``copy of referee._RefereeState``).
"""

from __future__ import annotations

import sys
from collections import Counter
from collections.abc import Callable

#: The label of Drake's deep copies of Python abstract values (``copy.deepcopy`` called by
#: ``Value<py::object>``'s clone), followed by the copied value's class.
COPY_LABEL = "copy of "


def _is_drake(function) -> bool:
    """Whether the C function the profiler reports is one of pydrake's bindings."""
    module = getattr(function, "__module__", None)
    return isinstance(module, str) and module.startswith("pydrake")


class DrakeCallCounter:
    """Context manager: while active, counts the Python frames that Drake's C++ starts.

    ``counts`` maps (label, callback) to the number of calls: ``label`` is the system's class
    (see the module's docstring), ``callback`` the Python function's qualified name."""

    def __init__(self):
        self.counts: Counter = Counter()
        self._stack: list[bool] = []  # per active frame: a pydrake C function?

    def _profile(self, frame, event, arg) -> None:
        stack = self._stack
        if event == "call":
            if stack and stack[-1]:
                self.counts[_label(frame)] += 1
            stack.append(False)
        elif event == "c_call":
            stack.append(_is_drake(arg))
        elif stack:  # return, c_return, c_exception (frames begun before the counter: none)
            stack.pop()

    def __enter__(self) -> DrakeCallCounter:
        self._stack.clear()
        sys.setprofile(self._profile)
        return self

    def __exit__(self, *exc) -> None:
        sys.setprofile(None)

    @property
    def total(self) -> int:
        return sum(self.counts.values())


def _label(frame) -> tuple[str, str]:
    code = frame.f_code
    if code.co_name == "deepcopy" and code.co_filename.endswith("copy.py"):
        cls = type(frame.f_locals.get("x"))
        return f"{COPY_LABEL}{cls.__module__.rsplit('.', 1)[-1]}.{cls.__name__}", "copy.deepcopy"
    owner = frame.f_locals.get("self") if "self" in code.co_varnames + code.co_freevars else None
    label = type(owner).__name__ if owner is not None else code.co_qualname.split(".")[0]
    return label, code.co_qualname


def count_drake_calls(run: Callable[[], float], integrator=None) -> dict:
    """Run ``run()`` (which simulates and returns the simulated duration, s) under a
    :class:`DrakeCallCounter`. ``integrator``: a callable returning the simulator's integrator
    after the run (its step counts are per run), or None.

    Returns ``simulated`` (s), ``total`` calls, ``per_second`` (calls per simulated second),
    ``systems``: label -> calls per simulated second, ``callbacks``: label -> callback ->
    calls per simulated second, the systems in decreasing order, and with ``integrator``
    ``steps_per_second`` and ``derivative_evaluations_per_second``: a callback near one of those
    rates runs at the integrator's step or stage rate."""
    with DrakeCallCounter() as counter:
        duration = float(run())
    per = 1.0 / duration if duration > 0 else 0.0
    systems: Counter = Counter()
    callbacks: dict[str, dict[str, float]] = {}
    for (label, callback), n in counter.counts.items():
        systems[label] += n
        callbacks.setdefault(label, {})[callback] = n * per
    out = {"simulated": duration, "total": counter.total, "per_second": counter.total * per,
           "systems": {label: n * per for label, n in systems.most_common()},
           "callbacks": {label: dict(sorted(callbacks[label].items(), key=lambda kv: -kv[1]))
                         for label, _ in systems.most_common()}}
    if integrator is not None:
        it = integrator()
        out["steps_per_second"] = it.get_num_steps_taken() * per
        out["derivative_evaluations_per_second"] = it.get_num_derivative_evaluations() * per
    return out
