"""The WAM's drives: the torque a voltage-limited DC motor can give a joint at a joint speed.

A joint ``j`` is driven by a brushless DC motor through a transmission of ratio ``N``
(:data:`tt_drake.wam_params.TRANSMISSION_RATIO`). With the motor's torque constant ``k``, winding
resistance ``R``, back-EMF constant ``k_e`` and the drive's voltage ``u`` (|u| <= V, the supply),
the motor turns at ``N q̇`` and its current is ``i = (u - k_e N q̇) / R`` (the winding's
inductance, 0.4-1.2 ms of L/R, is neglected against a stroke's 0.1-0.5 s). The joint torque
``tau = N k i`` is therefore bounded by the supply,

    -a - b q̇  <=  tau  <=  a - b q̇,        a = N k V / R,   b = N² k k_e / R,

and by the current limit, ``|tau| <= E`` (the actuator's effort limit,
:data:`tt_drake.wam_params.EFFORT_LIMIT`, which the plant applies). ``a`` is the stall torque,
``a / b = V / (k_e N)`` the joint's no-load speed: a joint driven in its direction of motion
loses torque linearly with speed and has none left at ``a / b``; braking (tau against q̇) has
more. ``k_e`` is Barrett's design voltage over its listed no-load speed
(:data:`tt_drake.wam_params.MOTOR_NO_LOAD_SPEED`), so the line meets Barrett's no-load speed at
48 V (with the listed ``k`` for ``k_e`` it would lie 5 % (J1-J6) and 26 % (J7) faster: the
listed speeds include the motors' own losses).

:func:`torque_bounds` is the envelope; :class:`DriveEnvelope` the numbers of one supply
voltage. The simulation applies the envelope with C++ primitives
(:func:`tt_drake.systems.wam.add_drive_limits`); the planners' effort checks use
:meth:`DriveEnvelope.bounds` with their torque fraction (:class:`EffortBudget`).
"""

from dataclasses import dataclass

import numpy as np

from tt_drake import wam_params as wp
from tt_drake.stages import JointLimits

#: The share of the drives' supply (and of each joint's no-load speed) the players' plans may
#: ask for at each joint speed: a plan asking somewhat more than the supply gives is followed
#: with a short lag, and returns more balls than one refused. Chosen on the teacher's
#: validation serves (docs/analytical_player.md, "Drives"); the learned player's plans use it
#: too (docs/learned_player.md, "On the stock robot: the drives' supply").
SUPPLY_FRACTION = 1.5


@dataclass(frozen=True)
class DriveEnvelope:
    """The drives of the seven joints at supply voltage ``voltage`` (V).

    ``stall`` (N m): ``a = N k V / R`` per joint; ``back_emf`` (N m s/rad): ``b = N² k k_e /
    R``, with ``k_e`` = design voltage / listed no-load speed."""

    voltage: float

    def __post_init__(self):
        if not (np.isfinite(self.voltage) and self.voltage > 0.0):
            raise ValueError(f"a drive's supply voltage must be a finite number > 0 V, got "
                             f"{self.voltage!r}")

    @property
    def stall(self) -> np.ndarray:
        n, k, _, r = _motor_arrays()
        return n * k * self.voltage / r

    @property
    def back_emf(self) -> np.ndarray:
        n, k, k_e, r = _motor_arrays()
        return n * n * k * k_e / r

    @property
    def no_load_speed(self) -> np.ndarray:
        """``a / b = V / (k_e N)`` (rad/s): the joint speed at which the drive has no torque."""
        n, _, k_e, _ = _motor_arrays()
        return self.voltage / (k_e * n)

    def bounds(self, qdot, fraction: float = 1.0,
               supply_fraction: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) joint torques (N m) the drives give at joint speeds ``qdot`` within
        ``fraction`` of the effort limits and ``supply_fraction`` (default ``fraction``) of
        the supply: :func:`torque_bounds` with ``E -> fraction E`` and ``a -> supply_fraction
        a`` (a plan that asks for at most ``fraction`` of both leaves the rest for tracking)."""
        if supply_fraction is None:
            supply_fraction = fraction
        return torque_bounds(qdot, supply_fraction * self.stall, self.back_emf,
                             fraction * np.asarray(wp.EFFORT_LIMIT, dtype=float))


def _motor_arrays() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(N, k, k_e, R) per joint."""
    back_emf_constant = wp.DESIGN_VOLTAGE / np.asarray(wp.MOTOR_NO_LOAD_SPEED, dtype=float)
    return (np.asarray(wp.TRANSMISSION_RATIO, dtype=float),
            np.asarray(wp.MOTOR_TORQUE_CONSTANT, dtype=float), back_emf_constant,
            np.asarray(wp.MOTOR_RESISTANCE, dtype=float))


def torque_bounds(qdot, stall, back_emf, effort) -> tuple[np.ndarray, np.ndarray]:
    """The joint torques (N m) the drives can apply at joint speeds ``qdot``, elementwise:
    ``clip(-a - b q̇, -E, E)`` to ``clip(a - b q̇, -E, E)``, the range of a command clamped to
    the supply's bounds and then to the current limit (as the simulation applies it). Beyond
    the no-load speed the drive can only brake: both bounds have the sign against the motion,
    and past ``(a + E) / b`` the back EMF alone drives the current limit's braking torque."""
    qdot = np.asarray(qdot, dtype=float)
    stall, back_emf = np.asarray(stall, dtype=float), np.asarray(back_emf, dtype=float)
    effort = np.asarray(effort, dtype=float)
    emf = back_emf * qdot
    return np.clip(-stall - emf, -effort, effort), np.clip(stall - emf, -effort, effort)


@dataclass(frozen=True)
class EffortBudget:
    """What a plan may ask of the actuators: ``fraction`` of the effort limits, and with
    ``drive`` ``supply_fraction`` (default ``fraction``) of its supply
    (:meth:`DriveEnvelope.bounds`). ``bounds(q_dot)`` is what
    :func:`tt_drake.stages.within_effort` checks each sample against; elementwise, so one call
    gives the bounds of many samples' speeds (K, 7) at once."""

    fraction: float
    drive: DriveEnvelope | None = None
    supply_fraction: float | None = None

    def bounds(self, qdot) -> tuple[np.ndarray, np.ndarray]:
        if self.drive is not None:
            return self.drive.bounds(qdot, self.fraction, self.supply_fraction)
        limit = self.fraction * np.asarray(wp.EFFORT_LIMIT, dtype=float)
        return -limit, limit


def drive_envelope(voltage: float) -> DriveEnvelope | None:
    """The envelope at ``voltage`` V; None for 0 (ideal drives: the effort limits only)."""
    return None if voltage == 0.0 else DriveEnvelope(float(voltage))


def joint_limits(drive: DriveEnvelope | None = None, supply_fraction: float = 1.0) -> JointLimits:
    """The arm's joint limits for a planner's plans (the teacher's and the learned player's):
    the position, acceleration and lab's speed limits, and with ``drive`` no joint faster than
    ``supply_fraction`` of its drive's no-load speed (the speed at which that share of the
    supply is all back EMF)."""
    velocity = np.asarray(wp.VELOCITY_LIMIT, dtype=float)
    if drive is not None:
        velocity = np.minimum(velocity, supply_fraction * drive.no_load_speed)
    return JointLimits(np.asarray(wp.JOINT_LOWER, dtype=float),
                       np.asarray(wp.JOINT_UPPER, dtype=float), velocity,
                       np.asarray(wp.ACCELERATION_LIMIT, dtype=float))
