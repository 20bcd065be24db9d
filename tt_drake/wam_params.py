"""Barrett WAM 7-DoF with a table-tennis racket: kinematic, inertial and actuation parameters.

Pure Python/numpy (no pydrake): the URDF generator (:mod:`tt_drake.modelgen.wam`), the Drake
helpers (:mod:`tt_drake.systems.wam`) and any planner read the robot from here.

Conventions
-----------
* Kinematics: standard (Spong) Denavit-Hartenberg. DH frame ``i`` (i = 1..7) is reached from frame
  ``i-1`` by ``Rz(q_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``; joint ``i`` turns about ``z_{i-1}``. Frame 0
  is the *shoulder* frame: origin where the axes of joints 1 and 2 meet, ``z_0`` along joint 1,
  pointing from the base plate toward the shoulder (the base plate is ``BASE_TO_SHOULDER`` below
  the shoulder along ``-z_0``). ``x_0`` is the robot's front: positive ``q_2`` and positive ``q_4``
  move the hand toward ``+x_0``. Frame 7 is the tool flange (Barrett's end-effector frame).
* Racket (docs/constants.md, "The MPI lab's setup"): the blade centre is ``RACKET.center_offset`` =
  0.30 m along ``z_7``; the racket normal is ``y_7`` (the blade disc is rotated -90 deg about
  ``x_7``). The *racket-centre frame* ``C`` is frame 7 translated to the blade centre, same axes:
  ``y_C`` is the racket normal, ``z_C`` runs from the handle through the blade (in the blade plane).
* World placement (the ceiling mount): :func:`shoulder_pose_in_world`, built from
  :data:`tt_drake.constants.MOUNT` and :data:`BASE_ROTATION`.

Inertial parameters: Barrett's inertial specification AC-02 as listed in docs/constants.md, "Barrett
WAM". They were checked against the DH frames (see ``LinkInertia`` and tests/systems/test_wam.py):
each centre of mass is given in its link's DH frame ``i`` (link 3's CoM at y = 0.21 m lies on the
upper arm, which runs from the elbow at the frame-3 origin back to the shoulder along ``+y_3``); the
listed inertias are taken about the DH frame *origin*, not the CoM, and the three off-diagonal
numbers are *products* of inertia ``P_xy = +integral(x y dm)``, i.e. the tensor entries are ``-P``.
Only that reading gives a physically valid inertia about the CoM for every link (with the opposite
sign the tensors of links 3 and 6 about their CoM are not positive definite), and it reproduces
Barrett's at-the-CoM values (e.g. link 1: I_xx = 0.29486 - m (c_y^2 + c_z^2) = 0.13488 kg m^2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tt_drake.constants import MOUNT

NUM_JOINTS = 7
BASE_TO_SHOULDER = MOUNT.base_to_shoulder  # m; Barrett WAM manual


@dataclass(frozen=True)
class DHRow:
    """One row of the Spong DH table: link length a (m), twist alpha (rad), offset d (m)."""

    a: float
    alpha: float
    d: float


# Barrett WAM user manual, 7-DoF (docs/constants.md, "Barrett WAM"). Joint angle offsets are all
# zero.
DH_TABLE: tuple[DHRow, ...] = (
    DHRow(0.0, -math.pi / 2, 0.0),
    DHRow(0.0, math.pi / 2, 0.0),
    DHRow(0.045, -math.pi / 2, 0.55),
    DHRow(-0.045, math.pi / 2, 0.0),
    DHRow(0.0, -math.pi / 2, 0.3),
    DHRow(0.0, math.pi / 2, 0.0),
    DHRow(0.0, 0.0, 0.06),
)

JOINT_NAMES: tuple[str, ...] = tuple(f"wam_joint{i}" for i in range(1, NUM_JOINTS + 1))
LINK_NAMES: tuple[str, ...] = tuple(f"wam_link{i}" for i in range(1, NUM_JOINTS + 1))
BASE_LINK = "wam_base"
RACKET_LINK = "racket"
RACKET_CENTER_FRAME = "racket_center"
RACKET_BLADE_GEOMETRY = "racket_blade"

# Joint position limits (rad) of the MPI table-tennis WAM (docs/constants.md): the manual's limits
# except J5 -4.8..1.3 and J7 +-2.2 (racket mount).
JOINT_LOWER: tuple[float, ...] = (-2.6, -2.0, -2.8, -0.9, -4.8, -1.6, -2.2)
JOINT_UPPER: tuple[float, ...] = (2.6, 2.0, 2.8, 3.1, 1.3, 1.6, 2.2)
# Joint speed bound of the lab's trajectory optimisers (docs/constants.md), rad/s.
VELOCITY_LIMIT: tuple[float, ...] = (10.0,) * NUM_JOINTS
# Torque limits of the lab's code (docs/constants.md), N m. Adequate for holding the arm and
# racket: the gravity torques at AWAITING are (0, 13.3, -4.0, 5.0, -0.38, -0.26, 0.0001) N m, at
# most 17 % of a limit (tests/systems/test_wam.py checks < 50 %). The wrist limits (3, 4, 1 N m)
# are what a fast stroke can saturate: the racket alone has ~0.02 kg m^2 about the wrist.
EFFORT_LIMIT: tuple[float, ...] = (75.0, 125.0, 39.0, 30.0, 3.0, 4.0, 1.0)
# The drives (docs/constants.md, "Drives"): Barrett's motor data per joint (torque constant
# k_t, N m/A; winding resistance R, ohm; no-load speed at the design voltage, motor rad/s) and
# the joint's transmission ratio N (Barrett WAM manual, arm and wrist transmission ratios; J2/J3
# and J5/J6 are cable differentials, taken here as one motor per joint through the joint's
# ratio). The motors' design voltage is 48 V; the WAM's supply takes 24-90 V DC.
MOTOR_TORQUE_CONSTANT: tuple[float, ...] = (0.457, 0.457, 0.457, 0.457, 0.236, 0.236, 0.067)
MOTOR_RESISTANCE: tuple[float, ...] = (3.473, 3.473, 3.473, 3.473, 6.213, 6.213, 5.205)
MOTOR_NO_LOAD_SPEED: tuple[float, ...] = (100.218, 100.218, 100.218, 100.218, 192.309, 192.309,
                                          569.022)
TRANSMISSION_RATIO: tuple[float, ...] = (42.0, 28.25, 28.25, 18.0, 9.48, 9.48, 14.93)
DESIGN_VOLTAGE = 48.0  # V
SUPPLY_VOLTAGE_RANGE = (24.0, 90.0)  # V
# The lab's joint acceleration bound (docs/constants.md), rad/s^2; for planners.
ACCELERATION_LIMIT: tuple[float, ...] = (200.0,) * NUM_JOINTS

# The robot's servo clock (docs/constants.md: the lab's servo rate, 500 Hz): the controller's
# set-point is held for one tick (tt_drake.systems.wam.add_servo_hold). The vision systems
# downstream of the 60 Hz camera and the players look for new data every other tick (PLANNING_RATE):
# a new frame is acted on within 4 ms per stage, with half the Python calls of every tick (measured:
# 5-10 % of a learned player's episode), and the two clocks' event times coincide exactly in
# floating point (the planning period is exactly twice the servo's), so the integrator takes no
# extra steps.
SERVO_RATE = 500.0  # Hz
SERVO_PERIOD = 1.0 / SERVO_RATE  # s
PLANNING_RATE = 0.5 * SERVO_RATE  # Hz


@dataclass(frozen=True)
class LinkInertia:
    """Barrett AC-02 inertial data of one link, exactly as listed (docs/constants.md, "Barrett
    WAM").

    ``com``: centre of mass (m) in the link's DH frame. ``origin_inertia``: (I_xx, P_xy, P_xz, I_yy,
    P_yz, I_zz) in kg m^2 about the DH frame's origin, axes of the DH frame, with products of
    inertia P_xy = +integral(x y dm) (module docstring explains how this reading was checked).
    """

    mass: float
    com: tuple[float, float, float]
    origin_inertia: tuple[float, float, float, float, float, float]

    def inertia_about_origin(self) -> np.ndarray:
        """3x3 rotational inertia tensor about the frame origin (tensor entries, I_xy = -P_xy)."""
        ixx, pxy, pxz, iyy, pyz, izz = self.origin_inertia
        return np.array([[ixx, -pxy, -pxz], [-pxy, iyy, -pyz], [-pxz, -pyz, izz]])

    def inertia_about_com(self) -> np.ndarray:
        """3x3 rotational inertia tensor about the CoM, axes of the DH frame (parallel axes)."""
        c = np.asarray(self.com, dtype=float)
        shift = self.mass * (float(c @ c) * np.eye(3) - np.outer(c, c))
        return self.inertia_about_origin() - shift


# Links 1..7, each in its DH frame i.
LINK_INERTIA: tuple[LinkInertia, ...] = (
    LinkInertia(10.768, (-0.0044342, 0.12189, -0.00066489),
                (0.29486, -0.0079502, -0.00009311, 0.11350, -0.00018711, 0.25065)),
    LinkInertia(3.8749, (-0.0023698, 0.031056, 0.015421),
                (0.026068, -0.00001346, -0.00011701, 0.014722, 0.00003659, 0.019348)),
    LinkInertia(1.8023, (-0.038259, 0.20751, 0.00003309),
                (0.13672, -0.016804, 0.0000051, 0.0058835, -0.0000053, 0.13951)),
    LinkInertia(2.4007, (0.0049851, -0.00022942, 0.13272),
                (0.057193, 0.00001467, 0.00008193, 0.057165, -0.00009417, 0.0030044)),
    LinkInertia(0.12376, (0.00008921, 0.0051122, 0.0043582),
                (0.00005587, 0.00000026, 0.0, 0.00007817, -0.00000083, 0.00006594)),
    LinkInertia(0.41797, (0.00012262, -0.017032, 0.024683),
                (0.00093106, 0.00000148, -0.00000201, 0.00049833, -0.00022162, 0.00057483)),
    LinkInertia(0.068648, (-0.00007974, 0.00016313, -0.0032355),
                (0.00003845, -0.00000019, 0.00000002, 0.00003878, -0.00000004, 0.00007408)),
)

# The base. Its AC-02 numbers are in a frame at the shoulder whose axes are (y_0, z_0, x_0): its
# CoM lies 0.27 m below the shoulder (toward the plate) and 0.14 m behind it. The base is welded
# to the ceiling, so its inertia never enters the dynamics; it is kept for the mass budget.
BASE_INERTIA = LinkInertia(9.9706, (-0.02018, -0.26605, -0.14072),
                           (1.01233, 0.05992, 0.05389, 0.38443, 0.37489, 0.82739))
# Columns: the base-data frame's axes expressed in DH frame 0.
BASE_DATA_ROTATION: tuple[tuple[float, ...], ...] = ((0.0, 0.0, 1.0),
                                                     (1.0, 0.0, 0.0),
                                                     (0.0, 1.0, 0.0))

ARM_MASS = sum(link.mass for link in LINK_INERTIA)  # links 1..7, 19.4566 kg


@dataclass(frozen=True)
class Racket:
    """The racket on the flange (frame 7); a choice documented here, not a Barrett part.

    Blade: a disc of ``blade_radius`` (the MPI code's 0.076 m) and ``blade_thickness`` (10 mm
    collision disc, thick enough against tunnelling, docs/constants.md), centred
    ``center_offset`` along ``z_7`` with its normal along ``y_7``. Handle (with the mount
    adapter): a cylinder along ``z_7`` from the flange to the blade's edge. Masses: a blade with
    two rubbers ~0.12 kg, handle and adapter ~0.05 kg; 0.17 kg in all, a typical racket.
    """

    blade_radius: float = 0.076
    blade_thickness: float = 0.010
    center_offset: float = 0.30
    blade_mass: float = 0.12
    handle_mass: float = 0.05
    handle_radius: float = 0.015

    @property
    def handle_length(self) -> float:
        return self.center_offset - self.blade_radius

    @property
    def mass(self) -> float:
        return self.blade_mass + self.handle_mass

    def com(self) -> np.ndarray:
        """Centre of mass in frame 7 (m)."""
        z = (self.blade_mass * self.center_offset
             + self.handle_mass * 0.5 * self.handle_length) / self.mass
        return np.array([0.0, 0.0, z])

    def inertia_about_com(self) -> np.ndarray:
        """3x3 inertia tensor about the racket's CoM, axes of frame 7 (blade normal = y_7)."""
        r, t, mb = self.blade_radius, self.blade_thickness, self.blade_mass
        # Solid disc, axis y: I_yy = m r^2/2, in-plane axes m r^2/4 + m t^2/12.
        blade = np.diag([mb * r**2 / 4 + mb * t**2 / 12, mb * r**2 / 2,
                         mb * r**2 / 4 + mb * t**2 / 12])
        rh, lh, mh = self.handle_radius, self.handle_length, self.handle_mass
        handle = np.diag([mh * (3 * rh**2 + lh**2) / 12, mh * (3 * rh**2 + lh**2) / 12,
                          mh * rh**2 / 2])
        c = self.com()[2]
        parts = ((blade, mb, self.center_offset), (handle, mh, 0.5 * lh))
        total = np.zeros((3, 3))
        for inertia, m, z in parts:
            dz = z - c
            total += inertia + m * dz**2 * np.diag([1.0, 1.0, 0.0])
        return total


RACKET = Racket()

# Ready (awaiting) posture, rad. The racket centre is in front of the robot over its forehand at
# (0.302, -2.000, 1.096) m in the world, 0.66 m behind the table edge and 0.34 m above the table's
# height, with the racket normal (-0.14, 0.99, 0.01), 8 deg from +y (facing the table); the blade
# tip leans up and out to the forehand. Chosen by minimising sum(((q - mid) / half_range)^4) with
# the racket centre at (0.30, -2.00, 1.10) and the normal within 8 deg of +y, then rounded: every
# joint stays within 54 % of its half-range from mid-range, leaving room to swing. The upper arm
# hangs nearly straight down with the elbow 0.18 m to the backhand side (x = -0.18) and the
# forearm reaching forward; asking for the elbow on the forehand side instead pushes J6 to 84 % of
# its range.
AWAITING: tuple[float, ...] = (-0.80, 0.57, 1.50, 1.65, -2.89, -0.79, -1.06)

# Orientation of DH frame 0 (and of the base link) in the world when hanging from the ceiling:
# a rotation of pi about the horizontal axis (1, 1, 0)/sqrt(2), i.e. Rz(pi/2) Rx(pi). It maps
# x_0 (the robot's front) to +y (toward the table), y_0 to +x (the forehand side) and z_0 (joint 1)
# to -z (hanging). Rows are world axes, columns the frame-0 axes.
BASE_ROTATION: tuple[tuple[float, ...], ...] = ((0.0, 1.0, 0.0),
                                                (1.0, 0.0, 0.0),
                                                (0.0, 0.0, -1.0))


def dh_transform(row: DHRow, theta: float) -> np.ndarray:
    """4x4 homogeneous transform from DH frame i-1 to frame i: Rz(theta) Tz(d) Tx(a) Rx(alpha)."""
    ct, st = math.cos(theta), math.sin(theta)
    ca, sa = math.cos(row.alpha), math.sin(row.alpha)
    return np.array([[ct, -st * ca, st * sa, row.a * ct],
                     [st, ct * ca, -ct * sa, row.a * st],
                     [0.0, sa, ca, row.d],
                     [0.0, 0.0, 0.0, 1.0]])


def dh_forward_kinematics(q) -> list[np.ndarray]:
    """Poses X_0i (4x4, DH frame i in the shoulder frame 0) for i = 0..7; element 0 is identity."""
    if len(q) != NUM_JOINTS:
        raise ValueError(f"expected {NUM_JOINTS} joint angles, got {len(q)}")
    frames = [np.eye(4)]
    for row, theta in zip(DH_TABLE, q, strict=True):
        frames.append(frames[-1] @ dh_transform(row, float(theta)))
    return frames


def shoulder_pose_in_world() -> np.ndarray:
    """X_W0: DH frame 0 in the world (4x4), hanging ``BASE_TO_SHOULDER`` below the mount plate."""
    x = np.eye(4)
    x[:3, :3] = np.array(BASE_ROTATION)
    x[:3, 3] = MOUNT.shoulder
    return x


def reach_bound() -> float:
    """An upper bound (m) on the distance from the shoulder (DH frame 0's origin) to any point
    of the racket's blade, whatever the joint angles: by the triangle inequality along the
    chain, sum_i sqrt(a_i^2 + d_i^2) over the DH rows, plus the blade centre's offset from the
    flange and the blade's radius (the stretched arm comes within centimetres of it)."""
    return (sum(math.hypot(row.a, row.d) for row in DH_TABLE) + RACKET.center_offset
            + RACKET.blade_radius)


def racket_center_in_world(q) -> np.ndarray:
    """X_WC: the racket-centre frame (4x4; y axis = racket normal) in the world at angles q."""
    offset = np.eye(4)
    offset[2, 3] = RACKET.center_offset
    return shoulder_pose_in_world() @ dh_forward_kinematics(q)[-1] @ offset
