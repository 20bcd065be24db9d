"""The arm's inverse dynamics as a compiled chain (:class:`tt_drake.rnea.Chain`), read off a
Drake plant of revolute and weld joints (the control plant of ``systems/wam.py``).

:func:`chain_of` reads, for every body but the world in topological order, its joint's pose at
q = 0, axis and point on the axis in the parent's frame, the body's mass, centre of mass and
rotational inertia about its origin (the plant's default parameters, as a default context has
them), the joints' damping and the actuators' reflected inertia, and the plant's gravity.
"""

from __future__ import annotations

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import BodyIndex, JointActuatorIndex, JointIndex

from tt_drake.rnea import Chain


def chain_of(plant: MultibodyPlant) -> Chain:
    """The plant's bodies as a :class:`Chain`. Raises ValueError for a joint other than revolute
    or weld, or a body that is not the child of exactly one joint."""
    world = plant.world_body().index()
    inboard = {}
    for i in range(plant.num_joints()):
        joint = plant.get_joint(JointIndex(i))
        if joint.type_name() not in ("revolute", "weld"):
            raise ValueError(f"joint {joint.name()!r} is {joint.type_name()}: the chain "
                             "holds revolute and weld joints only")
        inboard[joint.child_body().index()] = joint
    order, parent_of, frontier = [], {}, [world]
    while frontier:  # breadth first from the world: a body after its parent
        body = frontier.pop(0)
        for child, joint in inboard.items():
            if joint.parent_body().index() == body:
                order.append(child)
                parent_of[child] = body
                frontier.append(child)
    if len(order) != plant.num_bodies() - 1:
        raise ValueError("every body but the world must hang from the world by one joint")
    position = {body: k for k, body in enumerate(order)}
    n = plant.num_velocities()
    damping, reflected = np.zeros(n), np.zeros(n)
    for i in range(plant.num_actuators()):
        actuator = plant.get_joint_actuator(JointActuatorIndex(i))
        reflected[actuator.joint().velocity_start()] = actuator.default_reflected_inertia()
    rows = {name: [] for name in ("parent", "joint", "rotation", "translation", "axis_parent",
                                  "axis_point", "mass", "com", "inertia")}
    for body_index in order:
        joint = inboard[body_index]
        X_PF = joint.frame_on_parent().GetFixedPoseInBodyFrame()
        X_MB = joint.frame_on_child().GetFixedPoseInBodyFrame().inverse()
        if joint.type_name() == "weld":
            X_PB = X_PF.multiply(joint.X_FM()).multiply(X_MB)
            axis, coordinate = np.zeros(3), -1
        else:
            X_PB = X_PF.multiply(X_MB)  # at q = 0
            axis = X_PF.rotation().matrix() @ np.asarray(joint.revolute_axis(), dtype=float)
            coordinate = joint.velocity_start()
            damping[coordinate] = joint.default_damping()
        body = plant.get_body(BodyIndex(int(body_index)))
        inertia = body.default_spatial_inertia()
        rows["parent"].append(position.get(parent_of[body_index], -1))
        rows["joint"].append(coordinate)
        rows["rotation"].append(X_PB.rotation().matrix())
        rows["translation"].append(X_PB.translation())
        rows["axis_parent"].append(axis)
        rows["axis_point"].append(X_PF.translation())
        rows["mass"].append(inertia.get_mass())
        rows["com"].append(inertia.get_com())
        rows["inertia"].append(inertia.CalcRotationalInertia().CopyToFullMatrix3())
    arrays = {name: np.ascontiguousarray(values, dtype=float) for name, values in rows.items()}
    for name in ("parent", "joint"):
        arrays[name] = np.asarray(rows[name], dtype=np.int64)
    return Chain(**arrays, damping=damping, reflected_inertia=reflected,
                 gravity=np.asarray(plant.gravity_field().gravity_vector(), dtype=float))
