"""The hitting-pose program of :class:`tt_drake.systems.hitting_ik.HittingIK`, solved by a compiled
sequential quadratic program (numba, cached on disk as :mod:`tt_drake.flight_kernel`'s kernels
are).

The program (docs/hitting_ik.md, "Position problem")::

    minimise    f(q) = (q - q_c)ᵀ W (q - q_c)                       W = diag(w)
    subject to  -b ≤ p_i(q) - p_hit,i ≤ b          (i = 1..3)        b = 1e-5 m
                nᵀ y(q) ≥ cos θ_0                                     θ_0 = 5e-4 rad
                q_lo ≤ q ≤ q_hi

with ``p(q)`` the blade centre and ``y(q)`` the racket normal of the WAM's DH chain
(:func:`tt_drake.wam_params.racket_center_in_world`): the same program Drake's
``InverseKinematics`` hands SNOPT, in the form ``c_k(q) ≥ 0`` of 21 constraints.

Kinematics. Joint ``i`` turns about the axis ``z_i`` through the point ``o_i`` (both in the
world, from the chain up to it), so::

    ∂p/∂q_i = z_i × (p - o_i),        ∂y/∂q_i = z_i × y,

and for ``i ≤ j`` (joint ``i`` turns ``z_j``, ``o_j``, ``p`` and ``y`` rigidly)::

    ∂²p/∂q_i∂q_j = (z_i × z_j) × (p - o_j) + z_j × (z_i × (p - o_j))
    ∂²y/∂q_i∂q_j = (z_i × z_j) × y + z_j × (z_i × y).

Iteration. From the start ``q``, with multipliers ``λ ≥ 0`` of the last step (zero at first),
each step solves the quadratic program of the Lagrangian ``L = f - λᵀ c``::

    minimise    ½ dᵀ H d + ∇f(q)ᵀ d        H = ∇²L(q, λ) = 2W - Σ_k λ_k ∇²c_k(q)
    subject to  c(q) + ∇c(q) d ≥ 0

by Goldfarb and Idnani's dual active-set method (:func:`dual_qp`), after raising every
eigenvalue of ``H`` below ``1e-3 max(2w)`` to it (``H`` must be positive definite there); its
multipliers are the next ``λ``. A step longer than 0.2 rad in any joint is scaled down to that.
The iteration has converged when a full step moves no joint by more than 1e-11 rad: ``q`` is
then a point of the program's first-order (KKT) conditions to rounding, where SNOPT stops at its
optimality tolerance (~1e-6), so the two answers from one start differ by SNOPT's slack
(docs/hitting_ik.md, "Solvers").
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from tt_drake import wam_params as wp
from tt_drake.flight_kernel import compiled

#: The DH chain and the blade centre's offset along z_7, as the kernels take them.
DH_A = np.array([row.a for row in wp.DH_TABLE])
DH_ALPHA = np.array([row.alpha for row in wp.DH_TABLE])
DH_D = np.array([row.d for row in wp.DH_TABLE])
SHOULDER_POSE = np.ascontiguousarray(wp.shoulder_pose_in_world())
CENTER_OFFSET = float(wp.RACKET.center_offset)
#: The most SQP steps a solve takes before it reports that it did not converge.
MAX_ITERATIONS = 60
#: A full step moving no joint further than this (rad) ends the iteration.
STEP_TOLERANCE = 1e-11
#: The longest step (rad, in any joint) taken at once.
MAX_STEP = 0.2
#: H's eigenvalues are kept at or above this share of the cost's largest curvature, 2 max w.
EIGENVALUE_FLOOR = 1e-3


@njit(inline="always")
def _cross(a0, a1, a2, b0, b1, b2):
    """a × b as three floats."""
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@njit
def chain(q, dh_a, dh_alpha, dh_d, x_w0, center, o, z):
    """The DH chain at ``q``: fills the joints' origins ``o`` and axes ``z`` (7 x 3, world)
    and returns the blade centre ``p`` and the racket normal ``y`` (world): X_W0 times
    Rz(q_i) Tz(d_i) Tx(a_i) Rx(alpha_i) over the joints, then ``center`` along z_7."""
    R = np.empty((3, 3))
    t = np.empty(3)
    for r in range(3):
        t[r] = x_w0[r, 3]
        for col in range(3):
            R[r, col] = x_w0[r, col]
    for i in range(7):
        for r in range(3):
            o[i, r] = t[r]
            z[i, r] = R[r, 2]
        ct, st = math.cos(q[i]), math.sin(q[i])
        ca, sa = math.cos(dh_alpha[i]), math.sin(dh_alpha[i])
        a, d = dh_a[i], dh_d[i]
        for r in range(3):
            r0, r1, r2 = R[r, 0], R[r, 1], R[r, 2]
            t[r] = t[r] + r0 * (a * ct) + r1 * (a * st) + r2 * d
            R[r, 0] = r0 * ct + r1 * st
            R[r, 1] = -r0 * (st * ca) + r1 * (ct * ca) + r2 * sa
            R[r, 2] = r0 * (st * sa) - r1 * (ct * sa) + r2 * ca
    p = np.empty(3)
    y = np.empty(3)
    for r in range(3):
        p[r] = t[r] + center * R[r, 2]
        y[r] = R[r, 1]
    return p, y


@njit
def jacobians(o, z, p, y, jp, jy):
    """Fills ∂p/∂q (``jp``) and ∂y/∂q (``jy``), 3 x 7: columns z_i × (p - o_i) and z_i × y."""
    for i in range(7):
        a0, a1, a2 = _cross(z[i, 0], z[i, 1], z[i, 2],
                            p[0] - o[i, 0], p[1] - o[i, 1], p[2] - o[i, 2])
        jp[0, i], jp[1, i], jp[2, i] = a0, a1, a2
        b0, b1, b2 = _cross(z[i, 0], z[i, 1], z[i, 2], y[0], y[1], y[2])
        jy[0, i], jy[1, i], jy[2, i] = b0, b1, b2


@njit
def curvature(o, z, p, y, m, n, la, out):
    """Fills ``out`` (7 x 7) with Σ_k m_k ∂²p_k/∂q² + la nᵀ ∂²y/∂q² (module docstring)."""
    for i in range(7):
        zi0, zi1, zi2 = z[i, 0], z[i, 1], z[i, 2]
        for j in range(i, 7):
            zj0, zj1, zj2 = z[j, 0], z[j, 1], z[j, 2]
            c0, c1, c2 = _cross(zi0, zi1, zi2, zj0, zj1, zj2)
            r0, r1, r2 = p[0] - o[j, 0], p[1] - o[j, 1], p[2] - o[j, 2]
            u0, u1, u2 = _cross(c0, c1, c2, r0, r1, r2)
            w0, w1, w2 = _cross(zi0, zi1, zi2, r0, r1, r2)
            v0, v1, v2 = _cross(zj0, zj1, zj2, w0, w1, w2)
            hp0, hp1, hp2 = u0 + v0, u1 + v1, u2 + v2
            u0, u1, u2 = _cross(c0, c1, c2, y[0], y[1], y[2])
            w0, w1, w2 = _cross(zi0, zi1, zi2, y[0], y[1], y[2])
            v0, v1, v2 = _cross(zj0, zj1, zj2, w0, w1, w2)
            hy0, hy1, hy2 = u0 + v0, u1 + v1, u2 + v2
            value = (m[0] * hp0 + m[1] * hp1 + m[2] * hp2
                     + la * (n[0] * hy0 + n[1] * hy1 + n[2] * hy2))
            out[i, j] = value
            out[j, i] = value


#: dual_qp's signature: G (n x n), a (n), C (m x n), b (m); returns (x, u, solved).
QP_SIGNATURE = ("Tuple((float64[::1], float64[::1], boolean))(float64[:, ::1], float64[::1], "
                "float64[:, ::1], float64[::1])")


@compiled(QP_SIGNATURE)
def dual_qp(G, a, C, b):
    """min ½ xᵀ G x + aᵀ x subject to C x ≥ b, G positive definite: Goldfarb and Idnani's dual
    active-set method. From the unconstrained minimum x = -G⁻¹ a, the most violated constraint
    ``p`` is added: with N the active rows, the primal direction is z = G⁻¹(n_p - Nᵀ r) with
    r = (N G⁻¹ Nᵀ)⁻¹ N G⁻¹ n_p, the full step t_1 = -(n_pᵀ x - b_p) / (zᵀ n_p) and the partial
    step t_2 the least u_j / r_j over r_j > 0 (an active multiplier reaching zero, whose
    constraint is dropped); x += t z, u_A -= t r, u_p += t for t = min(t_1, t_2), until no
    constraint is violated by more than 1e-13. Returns (x, u, solved): u the multipliers
    (G x + a = Cᵀ u, u ≥ 0, u_k (C x - b)_k = 0); solved False when the constraints are
    infeasible, the active rows turn out dependent or the method cycles."""
    n = G.shape[0]
    m = C.shape[0]
    g_inv = np.linalg.inv(G)
    x = -(g_inv @ a)
    u = np.zeros(m)
    active = np.zeros(m, dtype=np.bool_)
    for _ in range(4 * m + 10):
        worst, p = -1e-13, -1
        for k in range(m):
            if not active[k]:
                s = C[k] @ x - b[k]
                if s < worst:
                    worst, p = s, k
        if p < 0:
            return x, u, True
        n_p = np.ascontiguousarray(C[p])
        gn = g_inv @ n_p
        u_p = 0.0
        added = False
        for _ in range(m + 2):
            idx = np.nonzero(active)[0]
            if idx.size > 0:
                N = np.empty((idx.size, n))
                for r in range(idx.size):
                    N[r] = C[idx[r]]
                try:
                    r_dual = np.linalg.solve(N @ g_inv @ N.T, N @ gn)
                except Exception:  # dependent active rows (a singular arm): no answer here
                    return x, u, False
                z = gn - g_inv @ (N.T @ r_dual)
            else:
                r_dual = np.zeros(0)
                z = gn
            zn = z @ n_p
            full = math.inf if zn <= 1e-12 * (n_p @ gn) else -(n_p @ x - b[p]) / zn
            partial, drop = math.inf, -1
            for r in range(idx.size):
                if r_dual[r] > 0.0 and u[idx[r]] / r_dual[r] < partial:
                    partial, drop = u[idx[r]] / r_dual[r], idx[r]
            if full == math.inf and partial == math.inf:
                return x, u, False  # infeasible
            t = min(full, partial)
            if full < math.inf:
                x = x + t * z
            for r in range(idx.size):
                u[idx[r]] -= t * r_dual[r]
            u_p += t
            if full <= partial:
                active[p] = True
                u[p] = u_p
                added = True
                break
            active[drop] = False
            u[drop] = 0.0
        if not added:
            return x, u, False
    return x, u, False


#: sqp's signature: start, hitting point, unit normal, q_c, w, lower and upper bounds, the
#: position bound b, cos θ_0, the DH chain (a, alpha, d), X_W0, the blade centre's offset and the
#: most iterations; returns (q, multipliers (21), converged, iterations).
SQP_SIGNATURE = ("Tuple((float64[::1], float64[::1], boolean, int64))(" + ", ".join(
    ["float64[::1]"] * 7 + ["float64", "float64"] + ["float64[::1]"] * 3
    + ["float64[:, ::1]", "float64", "int64"]) + ")")


@compiled(SQP_SIGNATURE)
def sqp(q0, p_hit, n, qc, w, lower, upper, box, cos_min, dh_a, dh_alpha, dh_d, x_w0, center,
        max_iterations):
    """The program of the module docstring from ``q0`` by SQP steps (module docstring): the
    constraints c = (p - p_hit + b, b - (p - p_hit), nᵀy - cos θ_0, q - q_lo, q_hi - q).
    Returns (q, λ, converged, iterations)."""
    q = q0.copy()
    lam = np.zeros(21)
    C = np.zeros((21, 7))
    c = np.zeros(21)
    o = np.empty((7, 3))
    z = np.empty((7, 3))
    jp = np.empty((3, 7))
    jy = np.empty((3, 7))
    second = np.empty((7, 7))
    for j in range(7):
        C[7 + j, j] = 1.0
        C[14 + j, j] = -1.0
    cost_hessian = np.diag(2.0 * w)  # ∇²f = 2W
    floor = EIGENVALUE_FLOOR * 2.0 * np.max(w)
    for it in range(max_iterations):
        p, y = chain(q, dh_a, dh_alpha, dh_d, x_w0, center, o, z)
        jacobians(o, z, p, y, jp, jy)
        grad = 2.0 * w * (q - qc)
        for i in range(3):
            r = p[i] - p_hit[i]
            c[i] = r + box
            c[3 + i] = box - r
            C[i] = jp[i]
            C[3 + i] = -jp[i]
        c[6] = n @ y - cos_min
        C[6] = n @ jy
        for j in range(7):
            c[7 + j] = q[j] - lower[j]
            c[14 + j] = upper[j] - q[j]
        # H = 2W - Σ λ_k ∇²c_k: the position rows' curvature enters with λ_lo - λ_hi.
        curvature(o, z, p, y, lam[0:3] - lam[3:6], n, lam[6], second)
        H = cost_hessian - second
        values, vectors = np.linalg.eigh(H)
        if values[0] < floor:
            for k in range(7):
                values[k] = max(values[k], floor)
            H = (vectors * values) @ vectors.T
        d, lam_next, solved = dual_qp(np.ascontiguousarray(H), grad, C, -c)
        if not solved:
            return q, lam, False, it
        step = np.max(np.abs(d))
        q = q + (d if step <= MAX_STEP else (MAX_STEP / step) * d)
        lam = lam_next
        if step < STEP_TOLERANCE:
            return q, lam, True, it + 1
    return q, lam, False, max_iterations


def solve_hitting_pose(q0, p_hit, normal, comfort, weights, lower, upper, position_bound: float,
                       angle_bound: float, max_iterations: int = MAX_ITERATIONS):
    """:func:`sqp` on the WAM's chain from ``q0`` for the blade centre within
    ``position_bound`` (m, per axis) of ``p_hit`` and the normal within ``angle_bound`` (rad) of
    the unit ``normal``, nearest ``comfort`` in the weights ``weights``, inside
    [``lower``, ``upper``]. Returns (q, multipliers, converged, iterations)."""
    q0, p_hit, normal, comfort, weights, lower, upper = (
        np.ascontiguousarray(v, dtype=float).reshape(-1)
        for v in (q0, p_hit, normal, comfort, weights, lower, upper))
    return sqp(q0, p_hit, normal, comfort, weights, lower, upper, float(position_bound),
               math.cos(angle_bound), DH_A, DH_ALPHA, DH_D, SHOULDER_POSE, CENTER_OFFSET,
               int(max_iterations))
