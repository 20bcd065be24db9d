"""The compiled SQP of the hitting pose (tt_drake/ik_kernel.py): its chain against Drake's plant,
its second derivatives against differences of its Jacobians, its quadratic programs and its
answers against the program's optimality (KKT) conditions, and against SNOPT's answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tt_drake import ik_kernel as k
from tt_drake import wam_params as wp
from tt_drake.systems.hitting_ik import HITTING_COMFORT, JOINT_HALF_RANGE, HittingIK

COMFORT = np.array(HITTING_COMFORT)
WEIGHTS = 1.0 / JOINT_HALF_RANGE**2
BOX, ANGLE = 1e-5, 5e-4


@pytest.fixture(scope="module")
def ik():
    return HittingIK()


def _chain(q):
    o, z = np.empty((7, 3)), np.empty((7, 3))
    p, y = k.chain(np.asarray(q, float), k.DH_A, k.DH_ALPHA, k.DH_D, k.SHOULDER_POSE,
                   k.CENTER_OFFSET, o, z)
    jp, jy = np.empty((3, 7)), np.empty((3, 7))
    k.jacobians(o, z, p, y, jp, jy)
    return o, z, p, y, jp, jy


def _requests(count, seed=1):
    """Racket poses the arm reaches: the blade centre and normal of postures within 0.3 rad of
    the comfort posture."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        q = COMFORT + rng.uniform(-0.3, 0.3, 7)
        _, _, p, y, _, _ = _chain(q)
        out.append((p.copy(), y.copy()))
    return out


def test_the_chain_and_its_jacobians_are_the_plants(ik):
    rng = np.random.default_rng(0)
    for _ in range(20):
        q = rng.uniform(wp.JOINT_LOWER, wp.JOINT_UPPER)
        _, _, p, y, jp, jy = _chain(q)
        pose = ik.racket_pose(q)
        assert np.abs(p - pose.translation()).max() < 1e-12
        assert np.abs(y - pose.rotation().matrix()[:, 1]).max() < 1e-12
        J = ik.jacobian(q)  # [omega; v] rows
        assert np.abs(jp - J[3:]).max() < 1e-12
        # dy/dq_i = omega_i x y
        assert np.abs(jy - np.cross(J[:3].T, y).T).max() < 1e-12


def test_the_second_derivatives_are_the_jacobians_derivatives():
    rng = np.random.default_rng(1)
    eps = 1e-6
    for _ in range(5):
        q = rng.uniform(-1.0, 1.0, 7)
        m, n, la = rng.normal(size=3), rng.normal(size=3), 0.7
        o, z, p, y, _, _ = _chain(q)
        H = np.empty((7, 7))
        k.curvature(o, z, p, y, m, n, la, H)
        for i in range(7):
            dq = np.zeros(7)
            dq[i] = eps
            _, _, _, _, jp_plus, jy_plus = _chain(q + dq)
            _, _, _, _, jp_minus, jy_minus = _chain(q - dq)
            row = (m @ (jp_plus - jp_minus) + la * n @ (jy_plus - jy_minus)) / (2 * eps)
            assert np.abs(H[i] - row).max() < 1e-7 * max(1.0, np.abs(H).max())
        assert np.array_equal(H, H.T)


def test_the_quadratic_programs_meet_their_optimality_conditions():
    rng = np.random.default_rng(2)
    solved = 0
    for _ in range(100):
        A = rng.normal(size=(7, 7))
        G = np.ascontiguousarray(A @ A.T + 0.1 * np.eye(7))
        a = rng.normal(size=7)
        C = np.ascontiguousarray(rng.normal(size=(12, 7)))
        x0 = rng.normal(size=7)
        b = C @ x0 - rng.uniform(0.0, 1.0, 12)  # x0 is feasible: the program is
        x, u, ok = k.dual_qp(G, a, C, b)
        assert ok
        solved += 1
        slack = C @ x - b
        scale = 1.0 + np.abs(u).max()
        assert slack.min() > -1e-9 and u.min() >= 0.0
        assert np.abs(G @ x + a - C.T @ u).max() < 1e-9 * scale
        assert np.abs(u * slack).max() < 1e-9 * scale
    assert solved == 100


def test_an_infeasible_quadratic_program_is_reported():
    G, a = np.eye(2), np.zeros(2)
    C = np.ascontiguousarray([[1.0, 0.0], [-1.0, 0.0]])  # x >= 1 and x <= 0
    _, _, ok = k.dual_qp(G, a, C, np.array([1.0, 0.0]))
    assert not ok


def test_an_answer_is_a_kkt_point_of_the_hitting_program():
    lower, upper = np.array(wp.JOINT_LOWER) + 0.05, np.array(wp.JOINT_UPPER) - 0.05
    for p_hit, normal in _requests(30):
        q, lam, converged, iterations = k.solve_hitting_pose(
            COMFORT, p_hit, normal, COMFORT, WEIGHTS, lower, upper, BOX, ANGLE)
        assert converged and iterations < k.MAX_ITERATIONS
        _, _, p, y, jp, jy = _chain(q)
        c = np.r_[p - p_hit + BOX, BOX - (p - p_hit), normal @ y - math.cos(ANGLE),
                  q - lower, upper - q]
        C = np.vstack([jp, -jp, normal @ jy, np.eye(7), -np.eye(7)])
        assert c.min() > -1e-12  # feasible
        assert lam.min() >= 0.0
        assert np.abs(2 * WEIGHTS * (q - COMFORT) - C.T @ lam).max() < 1e-8  # stationary
        assert np.abs(lam * c).max() < 1e-10  # complementary


def test_the_sqp_and_snopt_answer_a_request_alike(ik):
    sqp = HittingIK(solver="sqp")
    costs = []
    for p_hit, normal in _requests(20, seed=3):
        a, b = ik.solve(p_hit, normal), sqp.solve(p_hit, normal)
        assert a.success and b.success
        assert b.position_error <= BOX * math.sqrt(3) + 1e-9 and b.angle_error <= ANGLE + 1e-9
        assert np.abs(a.q - b.q).max() < 1e-4  # the same local minimum, to SNOPT's slack
        costs.append(b.cost - a.cost)
    # SNOPT stops at its tolerances (a little outside the bounds, a little short of the
    # minimum): the exact minimum costs no more than a hair above its answer.
    assert max(costs) < 1e-6


# A request of the teacher on a spinning serve (`spin --spin-max 150`, seed 5002) whose start
# walks the SQP into dependent active rows: a low forehand point (0.67 m high) with the face
# turned 43 deg up and toward the backhand (hitting point, normal, start; the cost is the comfort
# posture's).
SINGULAR_REQUEST = (
    (0.6384832571464346, -1.7571090680128638, 0.6656416135705597),
    (-0.19872406833859005, 0.709010394823828, 0.6766188030898336),
    (0.4087136767081662, 0.694972743766353, 1.10066641217637, 0.5656569629813819,
     -1.8357271043666223, 0.324213870969344, -1.0134529451583452))


def test_dependent_active_rows_are_no_answer_and_snopt_solves_that_start(ik):
    """The QP's active rows can turn dependent near a singular arm (N G^-1 N^T singular): the
    SQP then reports no answer instead of raising, and the SQP arm's run from that start is
    SNOPT's, to the bit."""
    p_hit, normal, start = (np.array(v) for v in SINGULAR_REQUEST)
    lower, upper = np.array(wp.JOINT_LOWER) + 0.05, np.array(wp.JOINT_UPPER) - 0.05
    _, _, converged, iterations = k.solve_hitting_pose(
        start, p_hit, normal, COMFORT, WEIGHTS, lower, upper, BOX, ANGLE)
    assert not converged and iterations < k.MAX_ITERATIONS
    posture = (COMFORT, WEIGHTS)
    np.testing.assert_array_equal(HittingIK(solver="sqp").solve_from(p_hit, normal, start, posture),
                                  ik.solve_from(p_hit, normal, start, posture))


def test_a_solver_it_does_not_have_is_refused():
    with pytest.raises(ValueError, match="solver must be one of"):
        HittingIK(solver="ipopt")
