"""The arm's mechanical joint stops, which Drake's continuous plant does not model.

A continuous MultibodyPlant (``time_step = 0``, the simulation recipe) ignores the joints'
position limits, so without stops a joint the controller drives past its limit keeps going (the
stock WAM's wrist, docs/analytical_player.md, "Drives"). Each stop is a one-sided
Hunt-Crossley spring on the joint (the same law as the plant's point contact)::

    d_j = q_j - upper_j > 0:   tau_j = -max(0, k_j d_j (1 + alpha v_j))
    d_j = lower_j - q_j > 0:   tau_j = +max(0, k_j d_j (1 - alpha v_j))
    otherwise                  tau_j = 0

so the torque is continuous where the stop is met, never pulls the joint back into it, and a
joint entering at speed v loses the share of its energy that ``alpha v`` sets. The stiffness of
joint j is k_j = I_j omega^2, with I_j the j-th diagonal entry of the arm's mass matrix at the
awaiting posture (``wam_params.AWAITING``): each stop rings at about ``omega`` for the joint's
own inertia, so a joint that meets it at speed v passes it by at most about v / omega, and a
drive pressing it at its effort limit e_j by e_j / k_j.

The torques go to the plant's applied generalized force (not the actuation input, whose values
the plant clamps to the effort limits). The law is a C++ ``SymbolicVectorSystem``, evaluated at
every integrator stage without a Python call.
"""

from dataclasses import dataclass

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import ModelInstanceIndex
from pydrake.symbolic import Expression, MakeVectorVariable, if_then_else
from pydrake.symbolic import abs as symbolic_abs
from pydrake.symbolic import max as symbolic_max
from pydrake.systems.primitives import SymbolicVectorSystem

from tt_drake import wam_params as wp
from tt_drake.systems.symbolic_law import symbolic_law

NUM_JOINTS = wp.NUM_JOINTS


@dataclass
class JointStopsConfig:
    """The stops at the arm's joint limits (the model file's). ``natural_frequency``: omega
    (rad/s) of each joint's stop for its own inertia at the awaiting posture; ``dissipation``:
    the Hunt-Crossley alpha (s/rad). ``enabled`` False leaves the joints without stops (the
    scenario's rules check the values: ``diagrams/scenario.py``)."""

    enabled: bool = True
    natural_frequency: float = 300.0  # rad/s
    dissipation: float = 1.0  # s/rad


def stop_stiffness(inertia, natural_frequency: float) -> np.ndarray:
    """k_j = I_j omega^2 (N m/rad) for the joints' inertias ``inertia`` (kg m^2)."""
    return np.asarray(inertia, dtype=float) * natural_frequency**2


def awaiting_inertia(plant: MultibodyPlant, instance: ModelInstanceIndex) -> np.ndarray:
    """The diagonal of ``instance``'s block of ``plant``'s mass matrix with the arm at the
    awaiting posture (the rest of the plant at its defaults)."""
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, instance, np.asarray(wp.AWAITING, dtype=float))
    mass = plant.CalcMassMatrix(context)
    start = plant.GetJointByName(wp.JOINT_NAMES[0], instance).velocity_start()
    return np.diag(mass)[start:start + NUM_JOINTS].copy()


def stop_torque(q, v, lower, upper, stiffness, dissipation: float):
    """The stops' torques (the module's law) as symbolic expressions of the positions ``q`` and
    velocities ``v`` (symbolic variables). Each joint's expression first asks whether the joint
    is outside its range, |q - mid| > half-range, one look-up of q: the integrator evaluates the
    law at every stage, nearly always inside the range, where this test is all it costs."""
    out = []
    for j in range(len(lower)):
        mid, half = 0.5 * (lower[j] + upper[j]), 0.5 * (upper[j] - lower[j])
        push_down = -symbolic_max(0.0, stiffness[j] * (q[j] - upper[j])
                                  * (1.0 + dissipation * v[j]))
        push_up = symbolic_max(0.0, stiffness[j] * (lower[j] - q[j])
                               * (1.0 - dissipation * v[j]))
        out.append(if_then_else(symbolic_abs(q[j] - mid) > half,
                                if_then_else(q[j] > mid, push_down, push_up), 0.0))
    return out


def make_joint_stops(plant: MultibodyPlant, instance: ModelInstanceIndex,
                     config: JointStopsConfig | None = None) -> SymbolicVectorSystem:
    """The stops of ``instance``'s joints: input the arm's state (q, v) (14), output ``plant``'s
    full generalized-force vector with the stops' torques at the arm's entries."""
    config = config or JointStopsConfig()
    joints = [plant.GetJointByName(name, instance) for name in wp.JOINT_NAMES]
    lower = [float(j.position_lower_limits()[0]) for j in joints]
    upper = [float(j.position_upper_limits()[0]) for j in joints]
    stiffness = stop_stiffness(awaiting_inertia(plant, instance), config.natural_frequency)
    x = MakeVectorVariable(2 * NUM_JOINTS, "x")
    torques = stop_torque(x[:NUM_JOINTS], x[NUM_JOINTS:], lower, upper, stiffness,
                          config.dissipation)
    out = np.array([Expression(0.0)] * plant.num_velocities(), dtype=object)
    for joint, tau in zip(joints, torques, strict=True):
        out[joint.velocity_start()] = tau
    return symbolic_law(x, out)
