"""A force law the integrator evaluates at every stage, as a C++ ``SymbolicVectorSystem``.

The aerodynamics, the joint stops and the joint friction are memoryless laws y = f(u); written
as symbolic expressions they are evaluated in C++, with no Python call per integrator stage
(docs/performance.md, "What runs when").
"""

from pydrake.symbolic import Expression, Variable
from pydrake.systems.primitives import SymbolicVectorSystem


def symbolic_law(inputs, outputs) -> SymbolicVectorSystem:
    """The system y = ``outputs`` (expressions) of the input variables ``inputs``.

    Drake (1.51) computes every subsystem's time derivatives, and a SymbolicVectorSystem
    without state fails there: the system gets one constant continuous state (derivative zero,
    so it adds nothing to the integrator's error estimate)."""
    return SymbolicVectorSystem(state=[Variable("unused")], dynamics=[Expression(0.0)],
                                input=inputs, output=outputs)
