"""Hitting IK (systems/hitting_ik.py) checked against kinematics it does not use.

Poses are re-computed two ways outside the solver's plant: the numpy DH chain of
tt_drake.wam_params (itself tested against an independent DH build in test_wam.py) and
systems/wam.racket_pose on a second, separately built control plant. Racket twists are checked
against central finite differences of the DH pose.
"""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

from tt_drake import wam_params as wp
from tt_drake.constants import HITTING_REGION, PLANES, TARGET
from tt_drake.systems import wam
from tt_drake.systems.hitting_ik import (
    HITTING_COMFORT,
    SHOULDER,
    SNOPT_OPTIONS,
    WRIST_TO_CENTRE,
    HittingIK,
    snopt_options,
    velocity_limit_usage,
    within_velocity_limits,
)

LOWER = np.array(wp.JOINT_LOWER)
UPPER = np.array(wp.JOINT_UPPER)
MM = 1e-3
DEG = math.radians(1.0)


@pytest.fixture(scope="module")
def ik():
    return HittingIK()


@pytest.fixture(scope="module")
def other_plant():
    plant = wam.make_control_plant()
    context = plant.CreateDefaultContext()
    instance = plant.GetFrameByName(wam.RACKET_CENTER_FRAME).model_instance()
    return plant, context, instance


def _rotate(v, axis, angle):
    axis = axis / np.linalg.norm(axis)
    return (v * math.cos(angle) + np.cross(axis, v) * math.sin(angle)
            + axis * (axis @ v) * (1 - math.cos(angle)))


def _toward_target(p, pitch=0.0, yaw=0.0):
    """Unit normal from p toward the opponent's court centre, turned by pitch (face up for > 0)
    about the horizontal axis n x z, then by yaw about world z."""
    n = np.array([TARGET.x, TARGET.y, TARGET.z]) - p
    n /= np.linalg.norm(n)
    n = _rotate(n, np.cross(n, [0.0, 0.0, 1.0]), pitch)
    return _rotate(n, np.array([0.0, 0.0, 1.0]), yaw)


def _in_unreachable_corner(x, z):
    """The low forehand corner of the hitting region, at the edge of the arm's reach, where some
    tilted normals have no solution (docs/hitting_ik.md)."""
    return x >= 0.65 and z <= 1.05


def _requests(n=30, seed=3):
    rng = np.random.default_rng(seed)
    r = HITTING_REGION
    out = []
    for _ in range(n):
        p = np.array([rng.uniform(r.x_min, r.x_max), PLANES.hitting_y,
                      rng.uniform(r.z_min, r.z_max)])
        pitch, yaw = rng.uniform(-math.radians(15), math.radians(15), 2)
        out.append((p, _toward_target(p, pitch, yaw)))
    return out


def _dh_error(q, p, n):
    x_wc = wp.racket_center_in_world(q)
    angle = math.acos(np.clip(x_wc[:3, 1] @ n, -1.0, 1.0))
    return float(np.linalg.norm(x_wc[:3, 3] - p)), angle


def test_comfort_posture_is_a_centred_forehand_pose():
    q = np.array(HITTING_COMFORT)
    half = 0.5 * (UPPER - LOWER)
    assert np.all(np.abs(q - 0.5 * (UPPER + LOWER)) <= 0.6 * half)
    x_wc = wp.racket_center_in_world(q)
    np.testing.assert_allclose(x_wc[:3, 3], [0.3, PLANES.hitting_y, 1.1], atol=0.01)
    target_normal = np.array([0.0, 1.0, 0.2]) / math.hypot(1.0, 0.2)
    assert math.acos(x_wc[:3, 1] @ target_normal) < DEG
    assert HITTING_REGION.contains(x_wc[0, 3], x_wc[2, 3])


def test_random_requests_reach_pose_within_1mm_1deg_inside_limits(ik, other_plant):
    plant, context, instance = other_plant
    solved = skipped = 0
    for p, n in _requests():
        s = ik.solve(p, n)
        if not s.success:
            assert _in_unreachable_corner(p[0], p[2]), f"no solution at {p} normal {n}"
            skipped += 1
            continue
        solved += 1
        position_error, angle_error = _dh_error(s.q, p, n)
        assert position_error <= MM and angle_error <= DEG
        assert s.position_error <= 1e-4 and s.angle_error <= 1e-3
        assert abs(s.position_error - position_error) < 1e-9
        plant.SetPositions(context, instance, s.q)
        pose = wam.racket_pose(plant, context, instance)
        assert np.linalg.norm(pose.translation() - p) <= MM
        assert math.acos(np.clip(pose.rotation().matrix()[:, 1] @ n, -1, 1)) <= DEG
        assert np.all(s.q >= LOWER + ik.margin - 1e-9) and np.all(s.q <= UPPER - ik.margin + 1e-9)
        assert s.limit_margin >= ik.margin - 1e-9
    assert solved >= 27 and skipped <= 3


def test_warm_start_from_a_neighbouring_answer(ik):
    p = np.array([0.1, PLANES.hitting_y, 1.2])
    first = ik.solve(p, _toward_target(p))
    p2 = p + [0.02, 0.0, -0.02]
    second = ik.solve(p2, _toward_target(p2), q_seed=first.q)
    assert second.success and second.attempts == 1
    assert np.max(np.abs(second.q - first.q)) < 0.2  # same branch, small step


def test_a_requests_posture_replaces_the_comfort_posture_in_the_cost(ik):
    """``solve(posture=(q_c, w))`` minimises (q - q_c)^T diag(w) (q - q_c) instead of the comfort
    cost: each answer is at least as good as the other's under its own cost, and a heavy weight
    on the base joint keeps it nearer its q_c than the comfort answer does."""
    p = np.array([0.25, PLANES.hitting_y, 1.0])
    plain = ik.solve(p, _toward_target(p))
    p2 = p + [0.12, 0.0, -0.05]  # the hitting point moved toward the forehand
    n2 = _toward_target(p2)
    comfort = ik.solve(p2, n2, q_seed=plain.q)
    posture = (plain.q, np.array([100.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0]))
    near = ik.solve(p2, n2, q_seed=plain.q, posture=posture)
    assert plain.success and comfort.success and near.success
    assert near.cost == pytest.approx(ik.cost(near.q, posture))
    assert ik.cost(near.q, posture) <= ik.cost(comfort.q, posture) + 1e-9
    assert ik.cost(comfort.q) <= ik.cost(near.q) + 1e-9
    assert abs(near.q[0] - plain.q[0]) < abs(comfort.q[0] - plain.q[0])
    # Without a posture the answer is the comfort posture's, to the bit.
    np.testing.assert_array_equal(ik.solve(p2, n2, q_seed=plain.q, posture=None).q, comfort.q)
    for bad in ((plain.q, np.ones(6)), (plain.q,), (plain.q, -np.ones(7)),
                (np.full(7, np.nan), np.ones(7))):
        with pytest.raises(ValueError, match="posture"):
            ik.solve(p2, n2, posture=bad)


def test_snopts_print_level_does_not_change_an_answer(ik):
    """The solver runs at major print level 0 (``SNOPT_OPTIONS``): with the default level, the
    same requests, from the comfort start and warm-started from a neighbour's answer, give the
    same answers to the last bit, and a request the solver fails on from every start fails
    the same way."""
    loud = HittingIK()
    loud.solver_options = snopt_options(
        {k: v for k, v in SNOPT_OPTIONS.items() if k != "Major print level"})
    assert ik.solver_options.options["SNOPT"]["Major print level"] == 0
    requests = _requests(12, seed=11)
    # Within the wrist's reach, outside the joint limits' (test below): every start fails.
    requests.append((np.array([0.6731, -1.8364, 0.6298]), np.array([-0.1482, 0.6554, 0.7406])))
    previous = None
    for p, n in requests:
        quiet, default = ik.solve(p, n, q_seed=previous), loud.solve(p, n, q_seed=previous)
        np.testing.assert_array_equal(quiet.q, default.q)
        assert (quiet.success, quiet.attempts) == (default.success, default.attempts)
        previous = quiet.q
    assert not quiet.success and quiet.attempts >= 2


def test_unreachable_requests_report_failure(ik):
    far = np.array([0.3, PLANES.hitting_y + 3.0, 1.1])
    s = ik.solve(far, [0.0, 1.0, 0.0])
    assert not s.success and s.attempts == 0 and s.position_error > 2.0
    # Within the wrist's reach, but the shoulder's and wrist's limits forbid this low ball with
    # the face turned up: the solver runs from every start and fails.
    low = np.array([0.6731, -1.8364, 0.6298])
    normal = np.array([-0.1482, 0.6554, 0.7406])
    assert ik.may_reach(low, normal / np.linalg.norm(normal))
    s = ik.solve(low, normal)
    assert not s.success and s.attempts >= 2
    assert s.position_error > 1e-4 or s.angle_error > 1e-3
    corner = np.array([0.8, PLANES.hitting_y, 0.8])
    with pytest.raises(ValueError):
        ik.solve(corner, [0.0, 0.0, 0.0])


def _wrist_and_shoulder(q):
    frames = wp.dh_forward_kinematics(q)
    x_w0 = wp.shoulder_pose_in_world()
    return (x_w0 @ frames[5])[:3, 3], (x_w0 @ frames[0])[:3, 3]


def _elbow_reach(ik, samples):
    """The elbow angles of ``samples`` evenly over its shrunk range and |W - S| at each."""
    grid = np.linspace(ik.lower[3], ik.upper[3], samples)
    reach = [np.linalg.norm(np.subtract(*_wrist_and_shoulder((0, 0, 0, q4, 0, 0, 0))))
             for q4 in grid]
    return grid, reach


def test_the_blade_centre_is_the_wrist_centre_moved_along_z_c_and_the_elbow_sets_the_reach(ik):
    """C = W + L z_C for any posture (the wrist's axes meet at W), and |W - S| stays inside
    wrist_distance_range, whose ends are the extremes over the elbow's shrunk range."""
    rng = np.random.default_rng(11)
    r_min, r_max = ik.wrist_range
    for q in rng.uniform(ik.lower, ik.upper, (200, 7)):
        w, s = _wrist_and_shoulder(q)
        x_wc = wp.racket_center_in_world(q)
        assert np.allclose(x_wc[:3, 3] - w, WRIST_TO_CENTRE * x_wc[:3, 2], atol=1e-12)
        assert r_min - 1e-12 <= np.linalg.norm(w - s) <= r_max + 1e-12
    _, reach = _elbow_reach(ik, 20001)
    assert min(reach) == pytest.approx(r_min, abs=1e-9)
    assert max(reach) == pytest.approx(r_max, abs=1e-9)
    # The law of cosines for the two offset links, at the straightest elbow on the grid.
    links = (math.hypot(0.045, 0.55), math.hypot(0.045, 0.3))
    assert r_max <= sum(links) + 1e-12 and r_max == pytest.approx(sum(links), abs=1e-3)


def test_every_posture_passes_the_wrist_test_and_requests_beyond_it_have_no_answer(ik):
    """The early failure is sound: the request of any posture inside the shrunk limits (the
    elbow at either extreme of its reach included) may be reached; a request whose wrist circle
    lies 2-10 mm beyond the stretched arm is refused at once, whatever its normal's length, and
    the solver from every start finds no answer either."""
    rng = np.random.default_rng(12)
    r_min, r_max = ik.wrist_range
    grid, reach = _elbow_reach(ik, 2001)
    stretched, folded = grid[int(np.argmax(reach))], grid[int(np.argmin(reach))]
    postures = rng.uniform(ik.lower, ik.upper, (400, 7))
    postures[:100, 3] = stretched
    postures[100:150, 3] = folded
    for q in postures:
        x_wc = wp.racket_center_in_world(q)
        assert ik.may_reach(x_wc[:3, 3], x_wc[:3, 1])
    with pytest.raises(ValueError):
        ik.may_reach(x_wc[:3, 3], np.zeros(3))
    # Requests whose wrist circle stays 2-10 mm beyond the stretched arm: refused at once, and
    # the solver, run from every start by an instance without the test, finds no answer.
    unchecked = _WithoutWristTest()
    beyond = []
    while len(beyond) < 4:
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        p = SHOULDER + rng.uniform(0.9, 1.25) * u
        d = p - SHOULDER
        along = d @ n
        nearest = math.hypot(along, np.linalg.norm(d - along * n) - WRIST_TO_CENTRE)
        if 0.002 <= nearest - r_max <= 0.010:
            beyond.append((p, n))
    for p, n in beyond:
        assert not ik.may_reach(p, n) and not ik.may_reach(p, 2.5 * n)  # any length of normal
        refused = ik.solve(p, n)
        assert not refused.success and refused.attempts == 0
        solved = unchecked.solve(p, n)
        assert not solved.success and solved.attempts == len(unchecked.fallback_seeds)


class _WithoutWristTest(HittingIK):
    """Runs the solver on every request."""

    def may_reach(self, p_hit, normal) -> bool:
        return True


def _fd_twist(q, qdot, h=1e-6):
    """[ω; v] of the racket centre from central differences of the DH pose along q̇."""
    plus = wp.racket_center_in_world(q + h * qdot)
    minus = wp.racket_center_in_world(q - h * qdot)
    v = (plus[:3, 3] - minus[:3, 3]) / (2 * h)
    r = wp.racket_center_in_world(q)[:3, :3]
    skew = (plus[:3, :3] - minus[:3, :3]) / (2 * h) @ r.T  # dR/dt R^T = [ω]x
    return np.concatenate([[skew[2, 1], skew[0, 2], skew[1, 0]], v])


def test_joint_velocities_reproduce_the_racket_twist(ik):
    rng = np.random.default_rng(11)
    for p, n in _requests(8, seed=5):
        s = ik.solve(p, n)
        if not s.success:
            continue
        v = rng.normal(size=3) * 2.0
        w = rng.normal(size=3)
        twist = np.concatenate([w, v])
        for gain in (0.0, 1.0, 5.0):
            qdot = ik.joint_velocities(s.q, v, w, null_gain=gain)
            np.testing.assert_allclose(ik.racket_velocity(s.q, qdot), twist, atol=1e-9)
            np.testing.assert_allclose(_fd_twist(s.q, qdot), twist, atol=1e-6)
        # Default: a non-rotating racket.
        qdot = ik.joint_velocities(s.q, v)
        np.testing.assert_allclose(ik.racket_velocity(s.q, qdot), np.r_[0, 0, 0, v], atol=1e-9)


def test_null_space_motion_goes_toward_comfort_without_changing_the_twist(ik):
    p = np.array([-0.1, PLANES.hitting_y, 1.4])
    s = ik.solve(p, _toward_target(p, pitch=math.radians(10)))
    assert s.success and np.linalg.norm(s.q - ik.comfort) > 0.3
    v = np.array([0.5, 3.0, 1.0])
    base = ik.joint_velocities(s.q, v, null_gain=0.0)
    moved = ik.joint_velocities(s.q, v, null_gain=2.0)
    extra = moved - base
    assert np.linalg.norm(extra) > 1e-3
    np.testing.assert_allclose(ik.jacobian(s.q) @ extra, 0.0, atol=1e-9)
    assert extra @ (ik.comfort - s.q) > 0.0  # a projection is positive semi-definite
    # The gain scales it linearly; the least-norm part is orthogonal to it.
    np.testing.assert_allclose(ik.joint_velocities(s.q, v, null_gain=4.0) - base, 2 * extra,
                               atol=1e-9)
    assert abs(base @ extra) < 1e-9


def test_velocity_limit_helpers_report_without_clipping(ik):
    q = np.array(HITTING_COMFORT)
    slow = ik.joint_velocities(q, [0.0, 2.0, 0.5])
    assert within_velocity_limits(slow) and velocity_limit_usage(slow) < 1.0
    fast = ik.joint_velocities(q, [0.0, 40.0, 0.0])
    assert not within_velocity_limits(fast) and velocity_limit_usage(fast) > 1.0
    np.testing.assert_allclose(ik.racket_velocity(q, fast)[3:], [0.0, 40.0, 0.0], atol=1e-8)


def test_singular_arm_raises(ik):
    with pytest.raises(ValueError, match="singular"):
        ik.joint_velocities(np.zeros(7), [0.0, 1.0, 0.0])


def test_racket_pose_matches_dh(ik):
    rng = np.random.default_rng(2)
    for _ in range(5):
        q = rng.uniform(LOWER, UPPER)
        np.testing.assert_allclose(ik.racket_pose(q).GetAsMatrix4(),
                                   wp.racket_center_in_world(q), atol=1e-12)


def test_reachability_example_writes_its_figure(tmp_path, capsys):
    """docs/examples/hitting_ik_reach.py: only the low forehand corner is unreachable."""
    path = Path(__file__).resolve().parents[2] / "docs" / "examples" / "hitting_ik_reach.py"
    spec = importlib.util.spec_from_file_location("hitting_ik_reach", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    out_png = tmp_path / "reach.png"
    out = module.main(["--out", str(out_png)])
    assert out_png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and out_png.stat().st_size < 150_000
    xs, zs = module.grid()
    for result in out.values():
        for iz, ix in zip(*np.nonzero(result["success"] == 0), strict=True):
            assert _in_unreachable_corner(xs[ix], zs[iz])
    assert out["nominal"]["success"].sum() >= 87
    assert "| nominal |" in capsys.readouterr().out


def test_free_spin_velocities_give_the_blade_velocity_with_smaller_joint_speeds():
    from tt_drake.systems.hitting_ik import HITTING_COMFORT, HittingIK

    ik = HittingIK()
    rng = np.random.default_rng(3)
    for _ in range(10):
        q = np.asarray(HITTING_COMFORT) + rng.uniform(-0.2, 0.2, 7)
        v = rng.uniform(-1.0, 1.0, 3) + np.array([0.0, 2.5, 0.5])
        free = ik.joint_velocities_free_spin(q, v, null_gain=0.0)
        held = ik.joint_velocities(q, v, null_gain=0.0)
        np.testing.assert_allclose(ik.racket_velocity(q, free)[3:], v, atol=1e-9)
        # minimum norm over all joint velocities giving v, so never above the held-racket one
        assert np.linalg.norm(free) <= np.linalg.norm(held) + 1e-12


def _independent_holding_torques(q):
    """The torque that holds the arm still at q, from the AC-02 link masses and centres of
    mass on the independent DH chain of test_wam (not through the plant): joint k carries
    sum over links j >= k of ((p_j - o_k) x m_j g) . z_k, with the opposite sign."""
    from tests.systems.test_wam import (
        FACTS_LINK_COM,
        FACTS_LINK_MASS,
        G,
        independent_frames,
    )

    frames = independent_frames(q)
    points = [(m, (frames[i + 1] @ np.append(c, 1.0))[:3]) for i, (m, c) in
              enumerate(zip(FACTS_LINK_MASS, FACTS_LINK_COM, strict=True))]
    points.append((wp.RACKET.mass, (frames[7] @ np.append(wp.RACKET.com(), 1.0))[:3]))
    holding = np.zeros(7)
    for k in range(7):
        axis, origin = frames[k][:3, 2], frames[k][:3, 3]
        for m, p in points[k:]:
            holding[k] -= np.cross(axis, p - origin) @ np.array([0.0, 0.0, -m * G])
    return holding


def test_torques_at_rest_hold_the_arm_against_gravity(ik):
    """At rest (q_dot = q_ddot = 0) tau = -tau_g(q): the inverse dynamics include gravity (the
    InverseDynamicsController adds it, so the effort check must count it too)."""
    rng = np.random.default_rng(8)
    postures = [np.zeros(7), np.asarray(wp.AWAITING), np.asarray(HITTING_COMFORT),
                *rng.uniform(LOWER, UPPER, (5, 7))]
    for q in postures:
        expected = _independent_holding_torques(q)
        np.testing.assert_allclose(ik.torques(q, np.zeros(7), np.zeros(7)), expected, atol=1e-9)
    # Not a vanishing quantity at the hitting posture: the shoulder holds ~24 N m, and the wrist
    # joint 5 a sixth of its 3 N m limit.
    holding = _independent_holding_torques(np.asarray(HITTING_COMFORT))
    assert abs(holding[1]) > 20.0 and abs(holding[4]) > 0.15 * wp.EFFORT_LIMIT[4]


def test_torques_are_the_manipulator_equation(ik, other_plant):
    """tau = M(q) q_ddot + C(q, q_dot) q_dot - tau_g(q), with M, C q_dot and tau_g from another
    plant's CalcMassMatrix, CalcBiasTerm and CalcGravityGeneralizedForces; applied to the
    plant, tau gives back q_ddot (forward dynamics)."""
    plant, context, _ = other_plant
    rng = np.random.default_rng(9)
    for _ in range(5):
        q = rng.uniform(LOWER, UPPER)
        qdot = rng.uniform(-5.0, 5.0, 7)
        qddot = rng.uniform(-100.0, 100.0, 7)
        plant.SetPositions(context, q)
        plant.SetVelocities(context, qdot)
        mass = plant.CalcMassMatrix(context)
        bias = plant.CalcBiasTerm(context)
        gravity = plant.CalcGravityGeneralizedForces(context)
        tau = ik.torques(q, qdot, qddot)
        np.testing.assert_allclose(tau, mass @ qddot + bias - gravity, atol=1e-8)
        np.testing.assert_allclose(np.linalg.solve(mass, tau - bias + gravity), qddot,
                                   atol=1e-8)


def test_effort_check_counts_the_holding_torque(ik):
    """A plan that keeps the arm at rest at the hitting posture needs exactly the holding torque:
    the effort check passes it with a budget at that torque and refuses it just below."""
    from tt_drake.stages import HITTING, Quintic, StagePlan, within_effort

    q = np.asarray(HITTING_COMFORT)
    zero = np.zeros(7)
    plan = StagePlan([(HITTING, Quintic.fit(0.0, 0.2, q, zero, zero, q, zero, zero))])
    holding = np.abs(_independent_holding_torques(q))
    assert within_effort(plan, ik.torques, holding + 1e-9)
    shoulder_short = holding + 1e-9
    shoulder_short[1] = 0.99 * holding[1]
    assert not within_effort(plan, ik.torques, shoulder_short)


def test_speed_scaled_velocities_move_slow_joints_less():
    """With speed scales s (the drives' no-load speeds) the free-spin solution still gives the
    blade velocity, is the least sum (q̇_j / s_j)² among all that do (so never above the
    unscaled solution in that norm), asks less of the slow base joint, and with unit scales is
    the unscaled solution bit for bit."""
    from tt_drake.drives import DriveEnvelope
    from tt_drake.systems.hitting_ik import HITTING_COMFORT, HittingIK

    ik = HittingIK()
    scale = DriveEnvelope(48.0).no_load_speed
    rng = np.random.default_rng(5)
    base_plain, base_scaled = [], []
    for _ in range(10):
        q = np.asarray(HITTING_COMFORT) + rng.uniform(-0.2, 0.2, 7)
        v = rng.uniform(-1.0, 1.0, 3) + np.array([0.0, 2.5, 0.5])
        plain = ik.joint_velocities_free_spin(q, v, null_gain=0.0)
        scaled = ik.joint_velocities_free_spin(q, v, null_gain=0.0, speed_scale=scale)
        np.testing.assert_allclose(ik.racket_velocity(q, scaled)[3:], v, atol=1e-9)
        assert np.sum((scaled / scale) ** 2) <= np.sum((plain / scale) ** 2) + 1e-12
        # Any other solution (plain plus a null-space step) is no better in the scaled norm.
        null = np.eye(7) - np.linalg.pinv(ik.jacobian(q)[3:]) @ ik.jacobian(q)[3:]
        other = scaled + null @ rng.normal(size=7)
        assert np.sum((other / scale) ** 2) >= np.sum((scaled / scale) ** 2) - 1e-12
        base_plain.append(abs(plain[0]))
        base_scaled.append(abs(scaled[0]))
        np.testing.assert_array_equal(
            ik.joint_velocities_free_spin(q, v, speed_scale=np.ones(7)),
            ik.joint_velocities_free_spin(q, v))
    assert np.mean(base_scaled) < np.mean(base_plain)
