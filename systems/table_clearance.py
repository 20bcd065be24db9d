"""Whether a WAM can touch the table top, from its joint angles alone: the bound of
:mod:`tt_drake.clearance_kernel`, built from and checked against a plant.

The referees look for a robot's touch of the table in the plant's contact results (a geometry
query at every sample); :meth:`TableClearance.may_touch` tells them when no arm geometry can be
within :data:`MARGIN` of the table top, so that the query can be skipped without changing what
they see (docs/performance.md, "The serve diagram's Python").
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.geometry import Box, Capsule, Cylinder, Ellipsoid, Sphere

from tt_drake import ik_kernel
from tt_drake.clearance_kernel import BLADE_CENTRE, table_gap
from tt_drake.systems.wam import RACKET_CENTER_FRAME, shoulder_pose
from tt_drake.wam_params import NUM_JOINTS

#: The gap (m) below which the referee asks the plant for its contacts: far above the bound's
#: rounding (~1e-15 m), so that a positive gap is never a contact.
MARGIN = 1e-3
#: How far (m) the chain's blade centre and the plant's may differ at a sampled configuration,
#: and how much an anchor's distance to a geometry may vary over them, for the bound to be built.
MODEL_TOLERANCE = 1e-9
#: Sampled configurations (uniform in [-pi, pi] per joint, fixed seed) the bound is checked on.
SAMPLES = 32


def bounding_radius(shape) -> float | None:
    """The radius of a sphere about the shape's frame origin that holds the shape (the shapes
    are centred there): a sphere's radius; a cylinder's sqrt(r^2 + (L/2)^2); a capsule's
    r + L/2; a box's half-diagonal; an ellipsoid's largest semi-axis. None for other shapes."""
    if isinstance(shape, Sphere):
        return shape.radius()
    if isinstance(shape, Cylinder):
        return math.hypot(shape.radius(), 0.5 * shape.length())
    if isinstance(shape, Capsule):
        return shape.radius() + 0.5 * shape.length()
    if isinstance(shape, Box):
        return 0.5 * math.sqrt(shape.width() ** 2 + shape.depth() ** 2 + shape.height() ** 2)
    if isinstance(shape, Ellipsoid):
        return max(shape.a(), shape.b(), shape.c())
    return None


class TableClearance:
    """``gap(q)`` (m): a lower bound on the distance between the robot's collision geometries and
    the table top at joint angles ``q`` (:func:`tt_drake.clearance_kernel.table_gap`);
    ``may_touch(q)``: gap(q) <= :data:`MARGIN`. Built by :meth:`of`."""

    def __init__(self, x_w0, anchor, radius, box_rotation, box_centre, box_half):
        self._args = (np.ascontiguousarray(x_w0, dtype=float),
                      float(ik_kernel.CENTER_OFFSET),
                      np.ascontiguousarray(anchor, dtype=np.int64),
                      np.ascontiguousarray(radius, dtype=float),
                      np.ascontiguousarray(box_rotation, dtype=float).reshape(-1, 3, 3),
                      np.ascontiguousarray(box_centre, dtype=float).reshape(-1, 3),
                      np.ascontiguousarray(box_half, dtype=float).reshape(-1, 3))

    def gap(self, q) -> float:
        x_w0, center, anchor, radius, rotation, centre, half = self._args
        return table_gap(np.ascontiguousarray(q, dtype=float), ik_kernel.DH_A, ik_kernel.DH_ALPHA,
                         ik_kernel.DH_D, x_w0, center, anchor, radius, rotation, centre, half)

    def may_touch(self, q) -> bool:
        return self.gap(q) <= MARGIN

    @classmethod
    def of(cls, plant, robot, table_geometry_ids, inspector,
           samples: int = SAMPLES) -> TableClearance | None:
        """The bound for ``robot`` (a model instance of the finalised ``plant``, the WAM) and the
        table top's collision geometries ``table_geometry_ids`` (SceneGraph's ``inspector``
        describes them), or None where it cannot be trusted: the robot has not 7 positions, its
        blade centre is not the DH chain's (mounted where its base frame is) within
        :data:`MODEL_TOLERANCE` at ``samples`` configurations, one of its collision shapes has no
        :func:`bounding_radius`, no anchor keeps its distance to a geometry's centre over the
        samples, or a table geometry is not a box."""
        if plant.num_positions(robot) != NUM_JOINTS or not table_geometry_ids:
            return None
        context = plant.CreateDefaultContext()
        x_w0 = np.ascontiguousarray(shoulder_pose(plant, robot, context))
        geometries = []  # (body, X_BG's translation, bounding radius)
        for index in plant.GetBodyIndices(robot):
            body = plant.get_body(index)
            for g in plant.GetCollisionGeometriesForBody(body):
                r = bounding_radius(inspector.GetShape(g))
                if r is None:
                    return None
                geometries.append((body, inspector.GetPoseInFrame(g).translation(), r))
        boxes = []
        for g in table_geometry_ids:
            shape = inspector.GetShape(g)
            if not isinstance(shape, Box):
                return None
            body = plant.GetBodyFromFrameId(inspector.GetFrameId(g))
            pose = plant.EvalBodyPoseInWorld(context, body) @ inspector.GetPoseInFrame(g)
            boxes.append((pose.rotation().matrix(), pose.translation(),
                          0.5 * np.array([shape.width(), shape.depth(), shape.height()])))
        centre_frame = plant.GetFrameByName(RACKET_CENTER_FRAME, robot)
        qs = np.random.default_rng(0).uniform(-math.pi, math.pi, (samples, NUM_JOINTS))
        distances = np.empty((samples, len(geometries), BLADE_CENTRE + 1))
        o, z = np.empty((NUM_JOINTS, 3)), np.empty((NUM_JOINTS, 3))
        for s, q in enumerate(qs):
            plant.SetPositions(context, robot, q)
            p, _ = ik_kernel.chain(q, ik_kernel.DH_A, ik_kernel.DH_ALPHA, ik_kernel.DH_D, x_w0,
                                   ik_kernel.CENTER_OFFSET, o, z)
            if np.abs(centre_frame.CalcPoseInWorld(context).translation() - p).max() \
                    > MODEL_TOLERANCE:
                return None
            anchors = np.vstack([o, p])
            for k, (body, offset, _) in enumerate(geometries):
                c = plant.EvalBodyPoseInWorld(context, body) @ offset
                distances[s, k] = np.linalg.norm(anchors - c, axis=1)
        spread = distances.max(axis=0) - distances.min(axis=0)
        anchor, radius = [], []
        for k, (_, _, r) in enumerate(geometries):
            rigid = np.flatnonzero(spread[k] <= MODEL_TOLERANCE)
            if rigid.size == 0:
                return None
            best = rigid[np.argmin(distances[:, k, rigid].max(axis=0))]
            anchor.append(best)
            radius.append(distances[:, k, best].max() + MODEL_TOLERANCE + r)
        return cls(x_w0, anchor, radius, [b[0] for b in boxes], [b[1] for b in boxes],
                   [b[2] for b in boxes])
