"""Inverse dynamics of a serial chain of revolute joints by the recursive Newton-Euler algorithm
(RNEA), compiled, for many samples at once.

The arm's effort checks (:func:`tt_drake.stages.within_effort`) ask for the torques

    tau = M(q) q_ddot + C(q, q_dot) q_dot - tau_g(q) + D q_dot + J_r q_ddot

(D the joints' viscous damping, J_r their actuators' reflected inertia) at every 50 Hz sample of
a plan: ~85 samples per plan, a plan per re-plan. The chain is described by arrays
(:class:`Chain`, filled from a Drake plant by ``tt_drake.systems.arm_dynamics``) and
:func:`inverse_dynamics` runs, per sample, with every body's spatial velocity ``(w, v)`` and
spatial acceleration ``(dw, dv)`` at its origin in its own frame (Featherstone's spatial
vectors; the base accelerates with -g, which puts gravity into every body's acceleration):

    outward, body b with parent p, X_pb = (R_pb, p_pb) the pose of b in p at q:
        w_b  = R_bp w_p + s_b q_dot_b,           s_b = (a_b, r_b x a_b)
        v_b  = R_bp (v_p + w_p x p_pb) + (r_b x a_b) q_dot_b
        dw_b = R_bp dw_p + a_b q_ddot_b + w_b x a_b q_dot_b
        dv_b = R_bp (dv_p + dw_p x p_pb) + (r_b x a_b) q_ddot_b
               + w_b x (r_b x a_b) q_dot_b + v_b x a_b q_dot_b
        n_b = I_b dw_b + m c_b x dv_b + w_b x (I_b w_b + m c_b x v_b) + v_b x (m (v_b + w_b x c_b))
        f_b = m (dv_b + dw_b x c_b) + w_b x (m (v_b + w_b x c_b))
    inward:  tau_b = a_b . n_b + (r_b x a_b) . f_b;
             n_p += R_pb n_b + p_pb x (R_pb f_b),   f_p += R_pb f_b

with a_b the joint's unit axis and r_b a point on it (both in b's frame; zero axis for a weld),
m, c_b, I_b the body's mass, centre of mass and rotational inertia about its origin. A weld
moves nothing and transmits the wrench. The result agrees with Drake's ``CalcInverseDynamics``
(with the plant's force elements as applied forces) to rounding: within 1e-9 N m on the arm's
states (``tests/systems/test_arm_dynamics.py``), which is what the effort check's verdict needs (its
budgets are fractions of tens of N m).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tt_drake.flight_kernel import compiled

#: inverse_dynamics' signature: samples Q, Qd, Qdd (K x n), the chain's arrays (see Chain), the
#: base's acceleration (3); returns tau (K x n).
SIGNATURE = ("float64[:, :](float64[:, :], float64[:, :], float64[:, :], int64[:], int64[:], "
             "float64[:, :, :], float64[:, :], float64[:, :], float64[:, :], float64[:], "
             "float64[:, :], float64[:, :, :], float64[:], float64[:], float64[:])")


@dataclass(frozen=True)
class Chain:
    """A tree of rigid bodies in topological order (a body after its parent; the base's parent
    is -1) as arrays, one row per body:

    - ``parent`` (B,): index of the parent body, -1 for the body on the base;
    - ``joint`` (B,): the generalized coordinate its joint moves, -1 for a weld;
    - ``rotation`` (B, 3, 3), ``translation`` (B, 3): the body's pose in its parent at q = 0,
      R0 and p0; ``axis_parent`` (B, 3): the joint's unit axis a in the parent's frame (zero
      for a weld) and ``axis_point`` (B, 3): a point r on it, so that at q the pose is
      R = R_a(q) R0, p = R_a(q) (p0 - r) + r (a revolute joint turns b about an axis fixed in p);
    - ``mass`` (B,), ``com`` (B, 3), ``inertia`` (B, 3, 3): the body's mass, centre of mass
      and rotational inertia about its origin, in its frame;
    - ``damping``, ``reflected_inertia`` (n,): per generalized coordinate.
    """

    parent: np.ndarray
    joint: np.ndarray
    rotation: np.ndarray
    translation: np.ndarray
    axis_parent: np.ndarray
    axis_point: np.ndarray
    mass: np.ndarray
    com: np.ndarray
    inertia: np.ndarray
    damping: np.ndarray
    reflected_inertia: np.ndarray
    gravity: np.ndarray

    def torques(self, q, qd, qdd) -> np.ndarray:
        """tau (K, n) for samples (K, n) of q, q_dot, q_ddot (or one sample (n,) -> (n,))."""
        one = np.ndim(q) == 1
        Q, Qd, Qdd = (_samples(x) for x in (q, qd, qdd))
        tau = inverse_dynamics(Q, Qd, Qdd, self.parent, self.joint, self.rotation,
                               self.translation, self.axis_parent, self.axis_point, self.mass,
                               self.com, self.inertia, self.damping, self.reflected_inertia,
                               -self.gravity)
        return tau[0] if one else tau

    def mass_matrix(self, q) -> np.ndarray:
        """M(q) (n, n): at rest tau(q, 0, q_ddot) = M(q) q_ddot + tau(q, 0, 0) (gravity only, no
        Coriolis or damping), so column k is tau(q, 0, e_k) - tau(q, 0, 0); M is symmetric, and
        its rows are those columns."""
        q = np.asarray(q, dtype=float)
        n = len(q)
        rest = np.zeros((n + 1, n))
        tau = self.torques(np.tile(q, (n + 1, 1)), rest, np.vstack([np.eye(n), np.zeros(n)]))
        return tau[:n] - tau[n]


def _samples(x) -> np.ndarray:
    """``x`` as a C-contiguous float (K, n) array the kernel accepts: copied if it is read-only
    (a Drake log's data, a broadcast view), which the compiled signature does not take."""
    a = np.ascontiguousarray(np.atleast_2d(x), dtype=float)
    return a if a.flags.writeable else a.copy()


@compiled(SIGNATURE)
def inverse_dynamics(Q, Qd, Qdd, parent, joint, rotation, translation, axis_parent,
                     axis_point, mass, com, inertia, damping, reflected, base_acceleration):
    """The module docstring's recursion for each row of Q, Qd, Qdd. The joint of body b turns
    it about ``axis_parent[b]`` through ``axis_point[b]`` (parent's frame): its pose in the
    parent at q is R = R_a(q) R0, p = R_a(q) (p0 - r) + r; in b's frame the axis is
    a_b = R^T a and passes through r_b = R^T (r - p)."""
    K, n = Q.shape
    B = parent.shape[0]
    out = np.zeros((K, n))
    R = np.empty((B, 3, 3))
    p = np.empty((B, 3))
    ab = np.zeros((B, 3))
    rb = np.zeros((B, 3))
    w = np.empty((B, 3))
    v = np.empty((B, 3))
    dw = np.empty((B, 3))
    dv = np.empty((B, 3))
    nn = np.empty((B, 3))
    ff = np.empty((B, 3))
    Ra = np.empty((3, 3))
    L = np.empty(3)  # a body's angular momentum about its origin: I w + m c x v
    Ia = np.empty(3)  # I dw + m c x dv
    for k in range(K):
        # Poses and axes at q.
        for b in range(B):
            j = joint[b]
            if j < 0:
                for r in range(3):
                    p[b, r] = translation[b, r]
                    for c in range(3):
                        R[b, r, c] = rotation[b, r, c]
                continue
            ax, ay, az = axis_parent[b, 0], axis_parent[b, 1], axis_parent[b, 2]
            s, cq = math.sin(Q[k, j]), math.cos(Q[k, j])
            t = 1.0 - cq
            Ra[0, 0] = cq + ax * ax * t
            Ra[0, 1] = ax * ay * t - az * s
            Ra[0, 2] = ax * az * t + ay * s
            Ra[1, 0] = ay * ax * t + az * s
            Ra[1, 1] = cq + ay * ay * t
            Ra[1, 2] = ay * az * t - ax * s
            Ra[2, 0] = az * ax * t - ay * s
            Ra[2, 1] = az * ay * t + ax * s
            Ra[2, 2] = cq + az * az * t
            for r in range(3):
                acc = axis_point[b, r]
                for c in range(3):
                    acc += Ra[r, c] * (translation[b, c] - axis_point[b, c])
                    R[b, r, c] = (Ra[r, 0] * rotation[b, 0, c] + Ra[r, 1] * rotation[b, 1, c]
                                  + Ra[r, 2] * rotation[b, 2, c])
                p[b, r] = acc
            for c in range(3):  # a_b = R^T a, r_b = R^T (r - p)
                ab[b, c] = R[b, 0, c] * ax + R[b, 1, c] * ay + R[b, 2, c] * az
                rb[b, c] = (R[b, 0, c] * (axis_point[b, 0] - p[b, 0])
                            + R[b, 1, c] * (axis_point[b, 1] - p[b, 1])
                            + R[b, 2, c] * (axis_point[b, 2] - p[b, 2]))
        # Outward: velocities and accelerations.
        for b in range(B):
            pa = parent[b]
            if pa < 0:
                wp0, wp1, wp2 = 0.0, 0.0, 0.0
                vp0, vp1, vp2 = 0.0, 0.0, 0.0
                dwp0, dwp1, dwp2 = 0.0, 0.0, 0.0
                dvp0 = base_acceleration[0]
                dvp1 = base_acceleration[1]
                dvp2 = base_acceleration[2]
            else:
                wp0, wp1, wp2 = w[pa, 0], w[pa, 1], w[pa, 2]
                vp0, vp1, vp2 = v[pa, 0], v[pa, 1], v[pa, 2]
                dwp0, dwp1, dwp2 = dw[pa, 0], dw[pa, 1], dw[pa, 2]
                dvp0, dvp1, dvp2 = dv[pa, 0], dv[pa, 1], dv[pa, 2]
            x, y, z = p[b, 0], p[b, 1], p[b, 2]
            # v_p + w_p x p_pb and dv_p + dw_p x p_pb, in the parent's frame.
            u0 = vp0 + (wp1 * z - wp2 * y)
            u1 = vp1 + (wp2 * x - wp0 * z)
            u2 = vp2 + (wp0 * y - wp1 * x)
            e0 = dvp0 + (dwp1 * z - dwp2 * y)
            e1 = dvp1 + (dwp2 * x - dwp0 * z)
            e2 = dvp2 + (dwp0 * y - dwp1 * x)
            for c in range(3):  # R_bp = R^T
                w[b, c] = R[b, 0, c] * wp0 + R[b, 1, c] * wp1 + R[b, 2, c] * wp2
                v[b, c] = R[b, 0, c] * u0 + R[b, 1, c] * u1 + R[b, 2, c] * u2
                dw[b, c] = R[b, 0, c] * dwp0 + R[b, 1, c] * dwp1 + R[b, 2, c] * dwp2
                dv[b, c] = R[b, 0, c] * e0 + R[b, 1, c] * e1 + R[b, 2, c] * e2
            j = joint[b]
            if j >= 0:
                qd, qdd = Qd[k, j], Qdd[k, j]
                a0, a1, a2 = ab[b, 0], ab[b, 1], ab[b, 2]
                r0, r1, r2 = rb[b, 0], rb[b, 1], rb[b, 2]
                l0 = r1 * a2 - r2 * a1  # r_b x a_b
                l1 = r2 * a0 - r0 * a2
                l2 = r0 * a1 - r1 * a0
                w[b, 0] += a0 * qd
                w[b, 1] += a1 * qd
                w[b, 2] += a2 * qd
                v[b, 0] += l0 * qd
                v[b, 1] += l1 * qd
                v[b, 2] += l2 * qd
                w0, w1, w2 = w[b, 0], w[b, 1], w[b, 2]
                v0, v1, v2 = v[b, 0], v[b, 1], v[b, 2]
                # s q_ddot + (w, v) x_m s q_dot
                dw[b, 0] += a0 * qdd + (w1 * a2 - w2 * a1) * qd
                dw[b, 1] += a1 * qdd + (w2 * a0 - w0 * a2) * qd
                dw[b, 2] += a2 * qdd + (w0 * a1 - w1 * a0) * qd
                dv[b, 0] += l0 * qdd + ((w1 * l2 - w2 * l1) + (v1 * a2 - v2 * a1)) * qd
                dv[b, 1] += l1 * qdd + ((w2 * l0 - w0 * l2) + (v2 * a0 - v0 * a2)) * qd
                dv[b, 2] += l2 * qdd + ((w0 * l1 - w1 * l0) + (v0 * a1 - v1 * a0)) * qd
            # The body's wrench at its origin: f = I a + v x* I v.
            m = mass[b]
            c0, c1, c2 = com[b, 0], com[b, 1], com[b, 2]
            w0, w1, w2 = w[b, 0], w[b, 1], w[b, 2]
            v0, v1, v2 = v[b, 0], v[b, 1], v[b, 2]
            h0 = m * (v0 + (w1 * c2 - w2 * c1))  # linear momentum m (v + w x c)
            h1 = m * (v1 + (w2 * c0 - w0 * c2))
            h2 = m * (v2 + (w0 * c1 - w1 * c0))
            for r in range(3):
                L[r] = inertia[b, r, 0] * w0 + inertia[b, r, 1] * w1 + inertia[b, r, 2] * w2
                Ia[r] = (inertia[b, r, 0] * dw[b, 0] + inertia[b, r, 1] * dw[b, 1]
                         + inertia[b, r, 2] * dw[b, 2])
            L[0] += m * (c1 * v2 - c2 * v1)
            L[1] += m * (c2 * v0 - c0 * v2)
            L[2] += m * (c0 * v1 - c1 * v0)
            d0, d1, d2 = dv[b, 0], dv[b, 1], dv[b, 2]
            Ia[0] += m * (c1 * d2 - c2 * d1)
            Ia[1] += m * (c2 * d0 - c0 * d2)
            Ia[2] += m * (c0 * d1 - c1 * d0)
            g0, g1, g2 = dw[b, 0], dw[b, 1], dw[b, 2]
            nn[b, 0] = Ia[0] + (w1 * L[2] - w2 * L[1]) + (v1 * h2 - v2 * h1)
            nn[b, 1] = Ia[1] + (w2 * L[0] - w0 * L[2]) + (v2 * h0 - v0 * h2)
            nn[b, 2] = Ia[2] + (w0 * L[1] - w1 * L[0]) + (v0 * h1 - v1 * h0)
            ff[b, 0] = m * (d0 + (g1 * c2 - g2 * c1)) + (w1 * h2 - w2 * h1)
            ff[b, 1] = m * (d1 + (g2 * c0 - g0 * c2)) + (w2 * h0 - w0 * h2)
            ff[b, 2] = m * (d2 + (g0 * c1 - g1 * c0)) + (w0 * h1 - w1 * h0)
        # Inward: joint torques, and each wrench carried to the parent.
        for b in range(B - 1, -1, -1):
            j = joint[b]
            if j >= 0:
                a0, a1, a2 = ab[b, 0], ab[b, 1], ab[b, 2]
                r0, r1, r2 = rb[b, 0], rb[b, 1], rb[b, 2]
                out[k, j] = (a0 * nn[b, 0] + a1 * nn[b, 1] + a2 * nn[b, 2]
                             + (r1 * a2 - r2 * a1) * ff[b, 0] + (r2 * a0 - r0 * a2) * ff[b, 1]
                             + (r0 * a1 - r1 * a0) * ff[b, 2]
                             + damping[j] * Qd[k, j] + reflected[j] * Qdd[k, j])
            pa = parent[b]
            if pa < 0:
                continue
            x, y, z = p[b, 0], p[b, 1], p[b, 2]
            F0 = R[b, 0, 0] * ff[b, 0] + R[b, 0, 1] * ff[b, 1] + R[b, 0, 2] * ff[b, 2]
            F1 = R[b, 1, 0] * ff[b, 0] + R[b, 1, 1] * ff[b, 1] + R[b, 1, 2] * ff[b, 2]
            F2 = R[b, 2, 0] * ff[b, 0] + R[b, 2, 1] * ff[b, 1] + R[b, 2, 2] * ff[b, 2]
            ff[pa, 0] += F0
            ff[pa, 1] += F1
            ff[pa, 2] += F2
            nn[pa, 0] += (R[b, 0, 0] * nn[b, 0] + R[b, 0, 1] * nn[b, 1] + R[b, 0, 2] * nn[b, 2]
                          + (y * F2 - z * F1))
            nn[pa, 1] += (R[b, 1, 0] * nn[b, 0] + R[b, 1, 1] * nn[b, 1] + R[b, 1, 2] * nn[b, 2]
                          + (z * F0 - x * F2))
            nn[pa, 2] += (R[b, 2, 0] * nn[b, 0] + R[b, 2, 1] * nn[b, 1] + R[b, 2, 2] * nn[b, 2]
                          + (x * F1 - y * F0))
    return out
