"""Aerodynamics: drag and Magnus force on the ball, which Drake does not model for free bodies.

    F = m ( -k |v| v + C_L (omega x v) )      (docs/constants.md; same law as tt_drake.ball_model)

Input ``ball_state``: the plant's state output for the ball's model instance,
(quaternion wxyz, p, omega, v), 13 floats. Output ``generalized_force``: the plant's full
generalized-force vector with the force in the ball's translational entries (a free body's
generalized force is the world-frame torque and force at its origin).

The output is evaluated at every integrator stage, so the law is a C++ ``SymbolicVectorSystem``
(no Python call per stage; docs/performance.md), wrapped in a small diagram that names its
ports.
"""


from dataclasses import dataclass

import numpy as np
from pydrake.symbolic import Expression, Variable, sqrt
from pydrake.systems.framework import Diagram, DiagramBuilder

from tt_drake.constants import BALL
from tt_drake.systems.symbolic_law import symbolic_law


@dataclass
class AerodynamicsConfig:
    drag_k: float = BALL.drag_k  # 1/m
    magnus_cl: float = BALL.magnus_cl
    enabled: bool = True


def aerodynamic_force_expressions(state: np.ndarray, num_velocities: int, force_start: int,
                                  config: AerodynamicsConfig, mass: float) -> np.ndarray:
    """The generalized force (``num_velocities`` expressions) of the ball state ``state`` (13
    variables): m (-k |v| v + C_L omega x v) at ``force_start``, zero elsewhere."""
    out = np.array([Expression(0.0)] * num_velocities, dtype=object)
    if not config.enabled:
        return out
    w, v = state[7:10], state[10:13]
    mk = mass * config.drag_k
    mc = mass * config.magnus_cl
    speed = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    magnus = (w[1] * v[2] - w[2] * v[1], w[2] * v[0] - w[0] * v[2], w[0] * v[1] - w[1] * v[0])
    for i in range(3):
        out[force_start + i] = -mk * speed * v[i] + mc * magnus[i]
    return out


def make_aerodynamics(num_velocities: int, ball_velocity_start: int,
                      config: AerodynamicsConfig | None = None,
                      mass: float = BALL.mass) -> Diagram:
    """The aerodynamics system: input ``ball_state`` (13), output ``generalized_force``
    (``num_velocities``); ``ball_velocity_start``: the ball's first entry in the plant's v."""
    config = config or AerodynamicsConfig()
    state = np.array([Variable(f"x{i}") for i in range(13)])
    # The force entries follow the ball's three torque entries.
    law = symbolic_law(state, aerodynamic_force_expressions(
        state, num_velocities, ball_velocity_start + 3, config, mass))
    builder = DiagramBuilder()
    law = builder.AddNamedSystem("drag_and_magnus", law)
    builder.ExportInput(law.get_input_port(), "ball_state")
    builder.ExportOutput(law.get_output_port(), "generalized_force")
    diagram = builder.Build()
    diagram.set_name("aerodynamics")
    return diagram


def add_aerodynamics(builder, world, config: AerodynamicsConfig | None = None,
                     name: str = "aerodynamics", connect: bool = True) -> Diagram:
    """Add the aerodynamics for ``world``'s ball and wire its input to the ball's state; with
    ``connect`` its output drives the plant's applied generalized force (without, the caller
    sums it with other generalized forces)."""
    plant = world.plant
    aero = make_aerodynamics(plant.num_velocities(),
                             world.ball_body.floating_velocities_start_in_v(), config)
    aero.set_name(name)
    builder.AddSystem(aero)
    builder.Connect(plant.get_state_output_port(world.ball), aero.get_input_port(0))
    if connect:
        builder.Connect(aero.get_output_port(0),
                        plant.get_applied_generalized_force_input_port())
    return aero
