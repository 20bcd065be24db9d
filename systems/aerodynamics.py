"""Aerodynamics: drag and Magnus force on the ball, which Drake does not model for free bodies.

    F = m ( -k |v| v + C_L (omega x v) )      (facts.md section 1; same law as tt_drake.ball_model)

Input ``ball_state``: the plant's state output for the ball's model instance,
(quaternion wxyz, p, omega, v), 13 floats. Output ``generalized_force``: the plant's full
generalized-force vector with the force in the ball's translational entries (a free body's
generalized force is the world-frame torque and force at its origin). The output is evaluated at
every integrator stage, so it uses plain-float arithmetic and allocates nothing (DESIGN.md).
"""


import math
from dataclasses import dataclass

from pydrake.systems.framework import BasicVector, LeafSystem

from tt_drake.constants import BALL


@dataclass
class AerodynamicsConfig:
    drag_k: float = BALL.drag_k  # 1/m
    magnus_cl: float = BALL.magnus_cl
    enabled: bool = True


class Aerodynamics(LeafSystem):
    def __init__(self, num_velocities: int, ball_velocity_start: int,
                 config: AerodynamicsConfig | None = None, mass: float = BALL.mass):
        super().__init__()
        self.config = config or AerodynamicsConfig()
        self._mk = mass * self.config.drag_k
        self._mc = mass * self.config.magnus_cl
        self._f0 = ball_velocity_start + 3  # force entries follow the torque entries
        self._enabled = self.config.enabled
        self._ball_state = self.DeclareVectorInputPort("ball_state", 13)
        self.DeclareVectorOutputPort("generalized_force", BasicVector(num_velocities),
                                     self._calc_force)

    def _calc_force(self, context, output):
        out = output.get_mutable_value()
        out[:] = 0.0  # a fresh BasicVector holds NaN
        if not self._enabled:
            return
        s = self._ball_state.Eval(context)
        wx, wy, wz, vx, vy, vz = float(s[7]), float(s[8]), float(s[9]), float(s[10]), \
            float(s[11]), float(s[12])
        kd = self._mk * math.sqrt(vx * vx + vy * vy + vz * vz)
        c = self._mc
        i = self._f0
        out[i] = -kd * vx + c * (wy * vz - wz * vy)
        out[i + 1] = -kd * vy + c * (wz * vx - wx * vz)
        out[i + 2] = -kd * vz + c * (wx * vy - wy * vx)


def add_aerodynamics(builder, world, config: AerodynamicsConfig | None = None,
                     name: str = "aerodynamics") -> Aerodynamics:
    """Add :class:`Aerodynamics` for ``world``'s ball and wire it: ball state in, the plant's
    applied generalized force out."""
    plant = world.plant
    aero = builder.AddNamedSystem(name, Aerodynamics(
        plant.num_velocities(), world.ball_body.floating_velocities_start_in_v(), config))
    builder.Connect(plant.get_state_output_port(world.ball), aero.get_input_port(0))
    builder.Connect(aero.get_output_port(0), plant.get_applied_generalized_force_input_port())
    return aero
