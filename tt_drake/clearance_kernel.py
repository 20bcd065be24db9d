"""A lower bound on the gap between the WAM's collision geometries and the table top, from the
joint angles alone, compiled (numba, cached as :mod:`tt_drake.flight_kernel`'s kernels are): while
it is positive no arm geometry can touch the table, and the referee need not ask the plant for its
contacts (:class:`tt_drake.systems.table_clearance.TableClearance`).

Anchors. The DH chain (:func:`tt_drake.ik_kernel.chain`) gives, for each joint ``i``, a point
``o_i`` on its axis, and the blade centre ``p``. A point on joint ``i``'s axis is carried rigidly
by both links the joint connects, and ``p`` by the racket, so each collision geometry ``g`` has an
anchor ``a_g`` among them whose distance to the geometry's centre ``c_g`` no joint angle changes.
With ``r_g`` the radius of a sphere about ``c_g`` that holds the shape, the geometry lies inside
the ball

    B_g(q) = { x : |x - a_g(q)| <= rho_g },    rho_g = |c_g - a_g| + r_g.

The table top is a set of boxes ``T_j`` (centre ``t_j``, rotation ``R_j``, half-extents ``h_j``,
world frame); a point's distance to a box is ``|max(|R_jᵀ (x - t_j)| - h_j, 0)|`` (elementwise
max). So

    gap(q) = min over g, j of ( d(a_g(q), T_j) - rho_g )

is at most the distance between the arm's geometries and the table top while they are apart, and
at most zero when one overlaps it (a point x in both has d(a_g, T_j) <= |x - a_g| <= rho_g): a
positive gap means that no pair of them overlaps, which the plant's point contact needs to report
a contact.
"""

from __future__ import annotations

import math

import numpy as np

from tt_drake.flight_kernel import compiled
from tt_drake.ik_kernel import chain

#: The anchor index of the blade centre (0..6 are the joints' axis points o_i).
BLADE_CENTRE = 7

GAP_SIGNATURE = ("float64(float64[::1], float64[::1], float64[::1], float64[::1], "
                 "float64[:, ::1], float64, int64[::1], float64[::1], float64[:, :, ::1], "
                 "float64[:, ::1], float64[:, ::1])")


@compiled(GAP_SIGNATURE)
def table_gap(q, dh_a, dh_alpha, dh_d, x_w0, center, anchor, radius, box_rotation, box_centre,
              box_half):
    """gap(q) of the module docstring: the DH chain at ``q`` (``dh_*``, the shoulder pose
    ``x_w0`` and the blade centre's offset ``center``, as :func:`tt_drake.ik_kernel.chain` takes
    them), geometry ``g``'s anchor index ``anchor[g]`` (0..6: o_i, 7: the blade centre) and bound
    ``radius[g]`` (rho_g), and the table's boxes (``box_rotation[j]`` R_j, ``box_centre[j]`` t_j,
    ``box_half[j]`` h_j). Infinite with no geometry or no box."""
    o = np.empty((7, 3))
    z = np.empty((7, 3))
    p, _ = chain(q, dh_a, dh_alpha, dh_d, x_w0, center, o, z)
    gap = math.inf
    for g in range(anchor.shape[0]):
        k = anchor[g]
        if k == BLADE_CENTRE:
            ax, ay, az = p[0], p[1], p[2]
        else:
            ax, ay, az = o[k, 0], o[k, 1], o[k, 2]
        for j in range(box_centre.shape[0]):
            dx = ax - box_centre[j, 0]
            dy = ay - box_centre[j, 1]
            dz = az - box_centre[j, 2]
            outside = 0.0
            for c in range(3):
                u = box_rotation[j, 0, c] * dx + box_rotation[j, 1, c] * dy \
                    + box_rotation[j, 2, c] * dz
                e = abs(u) - box_half[j, c]
                if e > 0.0:
                    outside += e * e
            d = math.sqrt(outside) - radius[g]
            if d < gap:
                gap = d
    return gap
