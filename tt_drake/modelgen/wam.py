"""URDF text of the Barrett WAM 7-DoF with a table-tennis racket, from :mod:`tt_drake.wam_params`.

``python -m tt_drake.modelgen.wam`` rewrites ``models/wam7_racket.urdf`` (``python -m
tt_drake.modelgen`` rewrites every generated model); a test checks the committed file is current.

Frames. The root link ``wam_base`` has its origin on the base plate with ``z`` pointing toward the
shoulder (DH frame 0 is ``BASE_TO_SHOULDER`` along ``+z``, same axes). URDF joint axes must pass
through the child link's origin, which the DH frames 3 and 4 do not (a = +-0.045 m), so link
``wam_link{i}``'s frame is DH frame ``i-1`` turned by ``q_i`` about ``z_{i-1}`` (joint ``i`` is
about its ``z``), and DH frame ``i`` sits at the constant offset ``Tz(d_i) Tx(a_i) Rx(alpha_i)``
in it.
Inertials and geometry below are written in DH frame ``i`` and mapped through that offset.
``racket`` is welded at DH frame 7 (the flange, same axes) and ``racket_center`` at the blade
centre, 0.30 m along ``z_7``, with the racket normal as its ``y`` axis.

Collision geometry only on the forearm (link 4), the wrist (links 5, 6) and the racket blade,
each with explicit Drake point-contact properties (docs/constants.md); a
``drake:collision_filter_group`` keeps the robot from colliding with itself.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from tt_drake import wam_params as wp
from tt_drake.constants import CONTACT, ContactSurface

FILE_NAME = "wam7_racket.urdf"
# The tt_drake.models package: models/ in a checkout, tt_drake/models/ in an installed wheel.
MODELS_DIR = Path(str(resources.files("tt_drake.models")))

WHITE = (0.92, 0.92, 0.92, 1.0)
GREY = (0.45, 0.45, 0.47, 1.0)
RED = (0.80, 0.05, 0.05, 1.0)
BLACK = (0.05, 0.05, 0.05, 1.0)


def _num(v: float, digits: int | None = None) -> str:
    """``v`` as text: exact (shortest round-trip repr) by default, else ``digits`` significant."""
    v = float(v)
    if abs(v) < 1e-15:
        return "0"
    return repr(v) if digits is None else f"{v:.{digits}g}"


def _nums(values, digits: int | None = None) -> str:
    return " ".join(_num(v, digits) for v in values)


# Inertial values and shape sizes/positions are printed to 12 significant digits (far finer than
# they are known); joint and frame offsets and all angles are printed exactly, so the model's
# kinematics is the DH chain to 1e-15.
_INERTIA_DIGITS = 12
_SHAPE_DIGITS = 12


def _rot_x(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _pose(xyz=(0.0, 0.0, 0.0), rotation=None) -> np.ndarray:
    x = np.eye(4)
    x[:3, 3] = xyz
    if rotation is not None:
        x[:3, :3] = rotation
    return x


def _rpy(rotation: np.ndarray) -> tuple[float, float, float]:
    """URDF roll-pitch-yaw (R = Rz(yaw) Ry(pitch) Rx(roll)) of a rotation matrix."""
    pitch = math.asin(max(-1.0, min(1.0, -rotation[2, 0])))
    roll = math.atan2(rotation[2, 1], rotation[2, 2])
    yaw = math.atan2(rotation[1, 0], rotation[0, 0])
    return roll, pitch, yaw


def _origin(pose: np.ndarray, digits: int | None = None) -> str:
    """``<origin>`` of a pose; angles always exact, positions to ``digits`` if given."""
    xyz, rpy = _nums(pose[:3, 3], digits), _nums(_rpy(pose[:3, :3]))
    return f'<origin xyz="{xyz}" rpy="{rpy}"/>'


def dh_offset(i: int) -> np.ndarray:
    """X_{L_i F_i}: DH frame i in link i's URDF frame, Tz(d_i) Tx(a_i) Rx(alpha_i) (i = 1..7)."""
    row = wp.DH_TABLE[i - 1]
    return _pose((row.a, 0.0, row.d), _rot_x(row.alpha))


# Turns a cylinder/capsule (axis z in its own frame) so its axis lies along y: Rx(-pi/2).
ALONG_Y = _rot_x(-math.pi / 2)


@dataclass(frozen=True)
class Shape:
    """A primitive posed in a link's DH frame.

    ``kind``: sphere, cylinder or capsule (axis z); ``size``: (radius,) or (radius, length).
    """

    name: str
    kind: str
    size: tuple
    pose: np.ndarray
    rgba: tuple | None = None  # visual colour; None: collision only
    surface: ContactSurface | None = None  # contact properties; None: visual only


def _geometry(shape: Shape) -> str:
    size = [_num(v, _SHAPE_DIGITS) for v in shape.size]
    if shape.kind == "sphere":
        return f'<sphere radius="{size[0]}"/>'
    return f'<{shape.kind} radius="{size[0]}" length="{size[1]}"/>'


def proximity(surface: ContactSurface, indent: str) -> str:
    """Drake ``<drake:proximity_properties>`` for point contact with Hunt-Crossley dissipation
    (URDF form: each property in a ``value`` attribute)."""
    tags = (("point_contact_stiffness", surface.stiffness),
            ("hunt_crossley_dissipation", surface.dissipation),
            ("mu_dynamic", surface.friction), ("mu_static", surface.friction))
    body = "".join(f'{indent}  <drake:{tag} value="{_num(value)}"/>\n' for tag, value in tags)
    return f"{indent}<drake:proximity_properties>\n{body}{indent}</drake:proximity_properties>\n"


def _shape_xml(shape: Shape, to_link: np.ndarray) -> str:
    origin = _origin(to_link @ shape.pose, _SHAPE_DIGITS)
    out = ""
    if shape.rgba is not None:
        out += (f'    <visual name="{shape.name}_visual">\n      {origin}\n'
                f"      <geometry>{_geometry(shape)}</geometry>\n"
                f'      <material><color rgba="{_nums(shape.rgba)}"/></material>\n    </visual>\n')
    if shape.surface is not None:
        out += (f'    <collision name="{shape.name}">\n      {origin}\n'
                f"      <geometry>{_geometry(shape)}</geometry>\n"
                f"{proximity(shape.surface, '      ')}    </collision>\n")
    return out


def _inertial_xml(mass: float, com, inertia: np.ndarray, to_link: np.ndarray) -> str:
    """``<inertial>`` in link coordinates for a CoM and a CoM inertia given in another frame."""
    rotation = to_link[:3, :3]
    com_link = to_link[:3, :3] @ np.asarray(com, dtype=float) + to_link[:3, 3]
    i = rotation @ inertia @ rotation.T
    d = _INERTIA_DIGITS
    entries = " ".join(f'{name}="{_num(i[r, c], d)}"' for name, r, c in (
        ("ixx", 0, 0), ("ixy", 0, 1), ("ixz", 0, 2), ("iyy", 1, 1), ("iyz", 1, 2), ("izz", 2, 2)))
    return (f'    <inertial>\n      <origin xyz="{_nums(com_link, d)}" rpy="0 0 0"/>\n'
            f'      <mass value="{_num(mass, d)}"/>\n      <inertia {entries}/>\n'
            f"    </inertial>\n")


def _link_shapes(i: int) -> list[Shape]:
    """Primitives of link i (1..7) in DH frame i (see wam_params for the frame conventions)."""
    robot = CONTACT.surface("robot")
    if i == 1:  # shoulder housing around joint 1, between the base column and the shoulder
        return [Shape("shoulder_housing", "cylinder", (0.10, 0.16),
                      _pose((0.0, 0.12, 0.0), ALONG_Y), WHITE)]
    if i == 2:  # shoulder pitch, centred where joints 1 and 2 meet
        return [Shape("shoulder", "sphere", (0.09,), _pose(), GREY)]
    if i == 3:  # upper arm: frame 3 is at the elbow; the arm runs back along +y_3 at x = -0.045
        return [Shape("upper_arm", "cylinder", (0.045, 0.42), _pose((-0.045, 0.29, 0.0), ALONG_Y),
                      WHITE),
                Shape("elbow_housing", "cylinder", (0.05, 0.11), _pose(), GREY)]
    if i == 4:  # forearm along z_4 to the wrist at z_4 = 0.3
        return [Shape("elbow_cap", "sphere", (0.05,), _pose(), GREY),
                Shape("forearm", "capsule", (0.042, 0.19), _pose((0.0, 0.0, 0.145)), WHITE,
                      robot)]
    if i == 5:  # wrist centre (joints 5-7 axes meet at the frame-5 origin)
        return [Shape("wrist", "sphere", (0.045,), _pose(), GREY, robot)]
    if i == 6:  # wrist pitch body toward the flange, along z_6
        return [Shape("hand", "cylinder", (0.035, 0.05), _pose((0.0, 0.0, 0.025)), WHITE, robot)]
    # Link 7: the flange disc just behind the tool frame.
    return [Shape("flange", "cylinder", (0.035, 0.01), _pose((0.0, 0.0, -0.005)), GREY)]


def _racket_shapes() -> list[Shape]:
    r = wp.RACKET
    blade_pose = _pose((0.0, 0.0, r.center_offset), ALONG_Y)
    return [Shape("racket_handle", "cylinder", (r.handle_radius, r.handle_length),
                  _pose((0.0, 0.0, 0.5 * r.handle_length)), BLACK),
            Shape(wp.RACKET_BLADE_GEOMETRY, "cylinder", (r.blade_radius, r.blade_thickness),
                  blade_pose, RED, CONTACT.surface("racket"))]


def _base_link() -> str:
    b = wp.BASE_INERTIA
    shoulder = _pose((0.0, 0.0, wp.BASE_TO_SHOULDER), np.array(wp.BASE_DATA_ROTATION))
    body = _inertial_xml(b.mass, b.com, b.inertia_about_com(), shoulder)
    shapes = [Shape("base_plate", "cylinder", (0.13, 0.03), _pose((0.0, 0.0, 0.015)), GREY),
              Shape("base_column", "cylinder", (0.09, 0.12), _pose((0.0, 0.0, 0.09)), WHITE)]
    body += "".join(_shape_xml(s, np.eye(4)) for s in shapes)
    return f'  <link name="{wp.BASE_LINK}">\n{body}  </link>\n'


def _arm_link(i: int) -> str:
    link = wp.LINK_INERTIA[i - 1]
    to_link = dh_offset(i)
    body = _inertial_xml(link.mass, link.com, link.inertia_about_com(), to_link)
    body += "".join(_shape_xml(s, to_link) for s in _link_shapes(i))
    return f'  <link name="{wp.LINK_NAMES[i - 1]}">\n{body}  </link>\n'


def _arm_joint(i: int) -> str:
    parent = wp.BASE_LINK if i == 1 else wp.LINK_NAMES[i - 2]
    origin = _pose((0.0, 0.0, wp.BASE_TO_SHOULDER)) if i == 1 else dh_offset(i - 1)
    name = wp.JOINT_NAMES[i - 1]
    k = i - 1
    return (f'  <joint name="{name}" type="revolute">\n'
            f'    <parent link="{parent}"/>\n    <child link="{wp.LINK_NAMES[k]}"/>\n'
            f"    {_origin(origin)}\n"
            f'    <axis xyz="0 0 1"/>\n'
            f'    <limit lower="{_num(wp.JOINT_LOWER[k])}" upper="{_num(wp.JOINT_UPPER[k])}" '
            f'velocity="{_num(wp.VELOCITY_LIMIT[k])}" effort="{_num(wp.EFFORT_LIMIT[k])}"/>\n'
            f"  </joint>\n")


def _transmission(i: int) -> str:
    name = wp.JOINT_NAMES[i - 1]
    return (f'  <transmission name="{name}_transmission">\n'
            f"    <type>transmission_interface/SimpleTransmission</type>\n"
            f'    <joint name="{name}"/>\n'
            f'    <actuator name="{name}_actuator"/>\n'
            f"  </transmission>\n")


def _racket() -> str:
    r = wp.RACKET
    body = _inertial_xml(r.mass, r.com(), r.inertia_about_com(), np.eye(4))
    body += "".join(_shape_xml(s, np.eye(4)) for s in _racket_shapes())
    flange = _pose((0.0, 0.0, wp.DH_TABLE[-1].d))
    center = _pose((0.0, 0.0, r.center_offset))
    return (f'  <link name="{wp.RACKET_LINK}">\n{body}  </link>\n'
            f'  <joint name="racket_mount" type="fixed">\n'
            f'    <parent link="{wp.LINK_NAMES[-1]}"/>\n    <child link="{wp.RACKET_LINK}"/>\n'
            f"    {_origin(flange)}\n  </joint>\n"
            f"  <!-- Blade centre; y is the racket normal. Massless, welded. -->\n"
            f'  <link name="{wp.RACKET_CENTER_FRAME}"/>\n'
            f'  <joint name="racket_center_weld" type="fixed">\n'
            f'    <parent link="{wp.RACKET_LINK}"/>\n'
            f'    <child link="{wp.RACKET_CENTER_FRAME}"/>\n'
            f"    {_origin(center)}\n  </joint>\n")


SELF_COLLISION_GROUP = "wam_self"


def _self_collision_filter() -> str:
    """A Drake collision filter group over every link that ignores itself: the robot's own
    geometries never collide with each other, whichever code loads the file."""
    links = (wp.BASE_LINK, *wp.LINK_NAMES, wp.RACKET_LINK, wp.RACKET_CENTER_FRAME)
    members = "".join(f'    <drake:member link="{name}"/>\n' for name in links)
    return (f'  <drake:collision_filter_group name="{SELF_COLLISION_GROUP}">\n{members}'
            f'    <drake:ignored_collision_filter_group name="{SELF_COLLISION_GROUP}"/>\n'
            f"  </drake:collision_filter_group>\n")


def wam_urdf() -> str:
    """The complete URDF text of the WAM with its racket (deterministic)."""
    parts = ['<?xml version="1.0"?>\n',
             "<!-- Generated by tt_drake.modelgen.wam from tt_drake/wam_params.py; do not edit.\n"
             "     Regenerate: python -m tt_drake.modelgen.wam -->\n",
             '<robot name="wam7_racket" xmlns:drake="http://drake.mit.edu">\n',
             _base_link()]
    for i in range(1, wp.NUM_JOINTS + 1):
        parts.append(_arm_link(i))
        parts.append(_arm_joint(i))
    parts.append(_racket())
    parts.extend(_transmission(i) for i in range(1, wp.NUM_JOINTS + 1))
    parts.append(_self_collision_filter())
    parts.append("</robot>\n")
    return "".join(parts)


GENERATED = {FILE_NAME: wam_urdf}


def main() -> None:
    path = MODELS_DIR / FILE_NAME
    path.write_text(wam_urdf())
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
