"""Arm solution of a hitting movement: joint angles and joint velocities for a racket state.

The analytical player decides *where* the racket must meet the ball (the hitting point on the
virtual hitting plane), *which way* the racket must face (its normal) and *how fast* it must move
(the racket's linear and angular velocity). This module turns those into the arm's joint angles
``q`` and joint velocities ``q̇`` on Drake's own model of the arm (the control plant of
:func:`tt_drake.systems.wam.make_control_plant`, welded at the ceiling mount exactly like the
simulation).

Frames and conventions
----------------------
* ``W``: the world frame of docs/world.md (z up, +y toward the opponent, +x the robot's forehand).
* ``C``: the racket-centre frame ``racket_center`` (blade centre; ``y_C`` is the racket normal,
  ``z_C`` runs from the handle through the blade). ``X_WC(q)`` is its pose in the world.
* Spatial velocity of the racket: ``V_WC = [ω_WC; v_WC]`` (angular first, then the linear
  velocity of the blade centre, both expressed in ``W``), Drake's ordering. With
  ``J(q) = ∂V_WC/∂q̇`` (6 x 7, from ``CalcJacobianSpatialVelocity``), ``V_WC = J(q) q̇``.

Position problem (:meth:`HittingIK.solve`)
------------------------------------------
Given a hitting point ``p`` and a unit normal ``n`` (both in ``W``)::

    minimise    (q - q_c)ᵀ diag(w) (q - q_c)          q_c = HITTING_COMFORT, w_i = 1 / h_i²
    subject to  |p_WC(q) - p|_∞ ≤ 1e-5 m               (blade centre on the hitting point)
                ∠(y_C(q), n) ≤ 5e-4 rad                 (racket faces n; spin about n is free)
                q_lo + m ≤ q ≤ q_hi - m                 (joint limits shrunk by m = 0.05 rad)

with ``h_i`` the half-range of joint ``i``, so each joint's distance is measured in units of its
own range. It is solved with Drake's ``InverseKinematics`` and SNOPT (about 1 ms per solve), or
with ``solver="sqp"`` by the compiled SQP of :mod:`tt_drake.ik_kernel` (the same program, about
four times faster; docs/hitting_ik.md, "Solvers"); the answer is then re-checked with the
plant's forward kinematics (:meth:`HittingIK.check`), and only a pose within 1e-4 m and
1e-3 rad, inside the shrunk limits, counts as ``success``. The solver's face sign is strict:
``y_C`` points *along* ``n``, the forehand rubber.

Requests no posture can meet fail without a solver run (:meth:`HittingIK.may_reach`). The WAM's
wrist joints 5-7 turn about axes through one point ``W`` and its shoulder joints 1-3 about axes
through ``S`` (DH frame 0's origin), so the blade centre is ``C = W + L z_C`` with
``L = d_7 + RACKET.center_offset`` = 0.36 m along ``z_C``, which is perpendicular to the normal
``y_C``, and ``|W - S|`` depends on the elbow alone: ``|W - S|² = A + B cos q4 + C sin q4``,
inside ``[r_min, r_max]`` = [0.281, 0.855] m over the elbow's shrunk range. For a request
``(p, n)``, with ``d = p - S`` split into ``d_n = d·n`` and ``d_t = |d - d_n n|``, the wrist
circle ``p - L z`` (``z ⊥ n``) lies between ``sqrt(d_n² + (d_t - L)²)`` and
``sqrt(d_n² + (d_t + L)²)`` from the shoulder; a request whose range misses ``[r_min, r_max]``
by more than an accepted answer's slack (1e-4 m + L x 1e-3 rad, doubled) has no answer.

Velocity problem (:meth:`HittingIK.joint_velocities`)
-----------------------------------------------------
The arm has one redundant degree of freedom. With the right pseudo-inverse
``J⁺ = Jᵀ (J Jᵀ)⁻¹`` (J has full row rank away from singularities)::

    q̇ = J⁺ V + (I - J⁺ J) k (q_c - q)

The first term is the least-norm joint velocity giving the racket twist ``V``; the second moves
the elbow toward the comfort posture inside the null space of ``J`` and so leaves ``J q̇ = V``
unchanged. Nothing is clipped: :func:`within_velocity_limits` tells whether every
``|q̇_i| ≤ 10 rad/s``; a singular arm (``V`` not reproducible) raises ``ValueError``.

A :class:`HittingIK` owns one plant context and is not thread-safe; build one per worker.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
from pydrake.math import RigidTransform
from pydrake.multibody.inverse_kinematics import InverseKinematics
from pydrake.multibody.tree import JacobianWrtVariable
from pydrake.solvers import SnoptSolver, SolverOptions

from tt_drake import wam_params as wp
from tt_drake.ik_kernel import solve_hitting_pose
from tt_drake.systems.arm_dynamics import chain_of
from tt_drake.systems.wam import RACKET_CENTER_FRAME, make_control_plant

NUM_JOINTS = wp.NUM_JOINTS
JOINT_LOWER = np.array(wp.JOINT_LOWER, dtype=float)
JOINT_UPPER = np.array(wp.JOINT_UPPER, dtype=float)
JOINT_MID = 0.5 * (JOINT_LOWER + JOINT_UPPER)
JOINT_HALF_RANGE = 0.5 * (JOINT_UPPER - JOINT_LOWER)
VELOCITY_LIMIT = np.array(wp.VELOCITY_LIMIT, dtype=float)

# Hitting comfort posture, rad. The racket centre is at (0.302, -1.821, 1.103) m, on the virtual
# hitting plane in the middle of the hitting region (x 0.3 m to the forehand, 0.34 m above the
# table), and the racket normal is (0.006, 0.981, 0.193), 0.4 deg from (0, 1, 0.2)/|.|: facing
# the opponent and tilted 11 deg upward. The handle lies horizontal with the blade out to the
# forehand (z_C = (1.00, -0.02, 0.07)); the elbow is 0.21 m to the backhand side (x = -0.21), the
# same branch as wam_params.AWAITING, so a stroke from the ready posture does not change branch.
# Chosen by minimising sum(((q - mid) / half_range)^4) over 200 random SNOPT starts with the
# racket centre at (0.30, -1.82, 1.10) and the normal along (0, 1, 0.2), then rounded to 0.01
# rad. Every joint stays within 58 % of its half-range from mid-range (J4 at 5 %), at least
# 0.67 rad from any limit. The next-best local minimum (an elbow-up, wrist-flipped branch) scores
# more than twice as high.
HITTING_COMFORT: tuple[float, ...] = (-0.53, 1.10, 1.46, 1.21, -2.80, -0.93, -1.24)

JOINT_MARGIN = 0.05  # rad kept clear of every joint limit by the IK
POSITION_TOLERANCE = 1e-4  # m, acceptance of an IK answer (forward-kinematics check)
ANGLE_TOLERANCE = 1e-3  # rad, acceptance of the racket normal
# Bounds handed to the solver: tighter than the acceptance tolerances so that SNOPT's own
# feasibility tolerance (~1e-6) cannot push an answer over them.
SOLVER_POSITION_BOUND = 1e-5  # m, per axis
SOLVER_ANGLE_BOUND = 5e-4  # rad
# SNOPT's major-iteration cap per start. Successful solves need far fewer; the cap bounds the time a
# start spends creeping along an infeasible boundary (in the reachability sweep it cut the worst
# request from ~240 ms to ~40 ms without losing any of the 431 reachable requests; 50 lost three).
SNOPT_MAJOR_ITERATIONS = 100
#: SNOPT's options for every solve: the major-iteration cap above, and major print level 0.
#: At its default level SNOPT formats a log line at every major iteration although no print
#: file is open; the iterates do not depend on it, and a solve costs about a quarter less
#: (docs/performance.md, "The teacher").
SNOPT_OPTIONS = {"Major iterations limit": SNOPT_MAJOR_ITERATIONS, "Major print level": 0}
DEFAULT_NULL_GAIN = 1.0  # 1/s, k in the null-space term of joint_velocities
#: The solvers of the position problem: Drake's SNOPT, or the compiled SQP of
#: :mod:`tt_drake.ik_kernel` (SNOPT from the same start where it does not converge).
SOLVERS = ("snopt", "sqp")
# Spare starting postures for the IK after the comfort and AWAITING starts fail: four fixed draws
# from the middle half of each joint's range (seeded, so every run tries the same ones). SNOPT
# occasionally stalls from both natural starts at a reachable pose (2 of 440 in the reachability
# sweep of docs/hitting_ik.md); a spread-out start then finds an answer.
SPARE_SEEDS: tuple[tuple[float, ...], ...] = tuple(
    tuple(float(v) for v in row) for row in np.random.default_rng(2010).uniform(
        JOINT_MID - 0.5 * JOINT_HALF_RANGE, JOINT_MID + 0.5 * JOINT_HALF_RANGE, (4, NUM_JOINTS)))
# An upper bound on the racket centre's distance from the shoulder (DH frame 0), by the triangle
# inequality over the chain: each DH step moves d_i along z then a_i along x (perpendicular), so
# at most sqrt(a_i^2 + d_i^2), and the blade centre is RACKET.center_offset past the flange;
# 1.257 m (the true reach is ~1.21 m), whatever the joint angles: the accuracy schedule's bound
# (systems/world.py). The IK's own test of a request is tighter (HittingIK.may_reach).
REACH_BOUND = float(sum(np.hypot(row.a, row.d) for row in wp.DH_TABLE) + wp.RACKET.center_offset)
SHOULDER = np.array(wp.shoulder_pose_in_world()[:3, 3])
# L: the blade centre's distance from the wrist centre W along z_C (module docstring).
WRIST_TO_CENTRE = float(wp.DH_TABLE[6].d + wp.RACKET.center_offset)
# How far an accepted answer's wrist circle may lie from the request's: its blade centre within
# POSITION_TOLERANCE of p and its normal within ANGLE_TOLERANCE of n (tilting the circle by at
# most that angle), doubled.
_WRIST_SLACK = 2.0 * (POSITION_TOLERANCE + WRIST_TO_CENTRE * ANGLE_TOLERANCE)
# Smallest singular value of J accepted by joint_velocities; below it the arm is singular.
_MIN_SINGULAR_VALUE = 1e-6


@dataclass(frozen=True)
class IKSolution:
    """The arm's answer to one hitting pose request.

    ``q``: joint angles (rad, 7). ``success``: the forward kinematics of ``q`` put the racket
    centre within :data:`POSITION_TOLERANCE` of the point, ``y_C`` within
    :data:`ANGLE_TOLERANCE` of the normal, and every joint inside the limits shrunk by the margin.
    ``position_error`` |p_WC(q) - p| (m); ``angle_error`` ∠(y_C(q), n) (rad); ``cost``
    (q - q_c)ᵀ diag(w) (q - q_c); ``limit_margin``: smallest distance of a joint to its *true*
    limit (rad; negative if outside); ``attempts``: solver runs used; ``solve_ms``: wall time.
    When ``success`` is False, ``q`` is the least-bad attempt and must not be commanded.
    """

    q: np.ndarray
    success: bool
    position_error: float
    angle_error: float
    cost: float
    limit_margin: float
    attempts: int
    solve_ms: float


def within_velocity_limits(qdot, limit=VELOCITY_LIMIT) -> bool:
    """True if every ``|q̇_i| ≤ limit_i`` (default: the lab's 10 rad/s)."""
    return bool(np.all(np.abs(np.asarray(qdot, dtype=float)) <= np.asarray(limit, dtype=float)))


def velocity_limit_usage(qdot, limit=VELOCITY_LIMIT) -> float:
    """max_i |q̇_i| / limit_i: above 1 the joint-speed limit is violated."""
    return float(np.max(np.abs(np.asarray(qdot, dtype=float)) / np.asarray(limit, dtype=float)))


def wrist_distance_range(q4_lower: float, q4_upper: float) -> tuple[float, float]:
    """(r_min, r_max): the least and greatest |W - S|, wrist centre to shoulder centre, over
    the elbow angles q4 in [q4_lower, q4_upper]. |W - S|² = A + B cos q4 + C sin q4 (one
    rotation between two fixed offsets; A, B, C from the DH chain at q4 = 0, π/2, π), whose
    extremes are the range's ends and q4* = atan2(C, B) (greatest), q4* + π (least) where
    they lie inside it."""
    def squared(q4: float) -> float:
        frames = wp.dh_forward_kinematics((0.0, 0.0, 0.0, q4, 0.0, 0.0, 0.0))
        return float(np.sum((frames[5][:3, 3] - frames[0][:3, 3]) ** 2))

    at_0, at_half, at_pi = squared(0.0), squared(0.5 * np.pi), squared(np.pi)
    a, b = 0.5 * (at_0 + at_pi), 0.5 * (at_0 - at_pi)
    c = at_half - a
    peak = float(np.arctan2(c, b))
    candidates = [q4_lower, q4_upper]
    for q4 in (peak, peak + np.pi, peak - np.pi):
        if q4_lower <= q4 <= q4_upper:
            candidates.append(q4)
    values = [np.sqrt(max(a + b * np.cos(q4) + c * np.sin(q4), 0.0)) for q4 in candidates]
    return float(min(values)), float(max(values))


def snopt_options(settings: dict | None = None) -> SolverOptions:
    """Drake's ``SolverOptions`` holding ``settings`` for SNOPT (default :data:`SNOPT_OPTIONS`)."""
    options = SolverOptions()
    for name, value in (SNOPT_OPTIONS if settings is None else settings).items():
        options.SetOption(SnoptSolver.id(), name, value)
    return options


def _posture(posture) -> tuple[np.ndarray, np.ndarray]:
    """(q_c, w) of :meth:`HittingIK.solve` as two float arrays of 7, w finite and >= 0;
    ValueError otherwise."""
    try:
        q_c, w = (np.asarray(x, dtype=float).reshape(NUM_JOINTS) for x in posture)
    except (TypeError, ValueError) as err:
        raise ValueError(f"posture must be (q_c, w), two arrays of {NUM_JOINTS} numbers") from err
    if not (np.all(np.isfinite(q_c)) and np.all(np.isfinite(w)) and np.all(w >= 0.0)):
        raise ValueError("posture's q_c must be finite and its weights w finite and >= 0")
    return q_c, w


def _unit(v, name: str) -> np.ndarray:
    v = np.asarray(v, dtype=float).reshape(3)
    norm = float(np.linalg.norm(v))
    if not np.isfinite(norm) or norm < 1e-12:
        raise ValueError(f"{name} must be a finite nonzero 3-vector, got {v}")
    return v / norm


class HittingIK:
    """Joint angles and velocities of the WAM for a racket state; built once, reused per stroke.

    ``comfort``: the posture q_c the IK cost and the null-space motion pull toward (default
    :data:`HITTING_COMFORT`). ``weights``: w in the cost (default 1 / half_range², so every joint's
    deviation counts in units of its own range). ``margin``: rad kept clear of each joint limit.
    ``fallback_seeds``: extra starting postures tried, in order, when the first start fails
    (default: the comfort posture, wam_params.AWAITING, then :data:`SPARE_SEEDS`).
    ``solver``: ``"snopt"`` (Drake's SNOPT) or ``"sqp"`` (the compiled SQP of
    :mod:`tt_drake.ik_kernel`, SNOPT from the same start where it does not converge): the same
    program, each start's answer to its own tolerance (docs/hitting_ik.md, "Solvers").
    """

    def __init__(self, comfort=HITTING_COMFORT, weights=None, margin: float = JOINT_MARGIN,
                 fallback_seeds=None, solver: str = "snopt"):
        if solver not in SOLVERS:
            raise ValueError(f"solver must be one of {SOLVERS}, not {solver!r}")
        self.solver = solver
        self.plant = make_control_plant()
        self.context = self.plant.CreateDefaultContext()
        self._frame_c = self.plant.GetFrameByName(RACKET_CENTER_FRAME)
        self._world = self.plant.world_frame()
        self.chain = chain_of(self.plant)  # the arm's inverse dynamics, compiled
        self.comfort = np.asarray(comfort, dtype=float).reshape(NUM_JOINTS)
        self.weights = (1.0 / JOINT_HALF_RANGE**2 if weights is None
                        else np.asarray(weights, dtype=float).reshape(NUM_JOINTS))
        self.margin = float(margin)
        self.lower = JOINT_LOWER + self.margin
        self.upper = JOINT_UPPER - self.margin
        if np.any(self.comfort < self.lower) or np.any(self.comfort > self.upper):
            raise ValueError("comfort posture lies outside the shrunk joint limits")
        if fallback_seeds is None:
            fallback_seeds = (self.comfort, wp.AWAITING, *SPARE_SEEDS)
        seeds = [np.asarray(s, dtype=float).reshape(NUM_JOINTS) for s in fallback_seeds]
        self.fallback_seeds = tuple(seeds)
        self._solver = SnoptSolver()
        if not self._solver.available():
            raise RuntimeError("SNOPT is not available in this pydrake build")
        self.solver_options = snopt_options()
        self.wrist_range = wrist_distance_range(self.lower[3], self.upper[3])

    def may_reach(self, p_hit, normal) -> bool:
        """False if no posture inside the shrunk limits puts the blade centre at ``p_hit``
        facing ``normal`` (need not be unit) within the acceptance tolerances: the wrist circle
        of the request misses the elbow's range of |W - S| (module docstring). True does not
        promise an answer (the other joints' limits are not looked at)."""
        normal = _unit(normal, "normal")
        d = np.asarray(p_hit, dtype=float).reshape(3) - SHOULDER
        along = float(d @ normal)
        across = float(np.linalg.norm(d - along * normal))
        nearest = math.hypot(along, across - WRIST_TO_CENTRE)
        farthest = math.hypot(along, across + WRIST_TO_CENTRE)
        r_min, r_max = self.wrist_range
        return nearest <= r_max + _WRIST_SLACK and farthest >= r_min - _WRIST_SLACK

    # ----------------------------------------------------------------------------- kinematics
    def _set(self, q) -> np.ndarray:
        q = np.asarray(q, dtype=float).reshape(NUM_JOINTS)
        self.plant.SetPositions(self.context, q)
        return q

    def racket_pose(self, q) -> RigidTransform:
        """X_WC(q): the racket-centre frame in the world (y_C = racket normal)."""
        self._set(q)
        return self._frame_c.CalcPoseInWorld(self.context)

    def jacobian(self, q) -> np.ndarray:
        """J(q), 6 x 7: V_WC = [ω_WC; v_WC] = J q̇, the racket-centre frame's spatial velocity
        in the world (angular rows first), w.r.t. the joint velocities."""
        self._set(q)
        return self.plant.CalcJacobianSpatialVelocity(
            self.context, JacobianWrtVariable.kV, self._frame_c, np.zeros(3), self._world,
            self._world)

    def racket_velocity(self, q, qdot) -> np.ndarray:
        """V_WC = J(q) q̇ = [ω_WC; v_WC] (6,): racket angular velocity and blade-centre velocity,
        both in the world frame."""
        return self.jacobian(q) @ np.asarray(qdot, dtype=float).reshape(NUM_JOINTS)

    def cost(self, q, posture=None) -> float:
        """(q - q_c)ᵀ diag(w) (q - q_c), with ``posture`` = (q_c, w) if given (:meth:`solve`),
        else the comfort posture and its weights."""
        comfort, weights = (self.comfort, self.weights) if posture is None else posture
        d = np.asarray(q, dtype=float) - comfort
        return float(d @ (weights * d))

    # ----------------------------------------------------------------------------- positions
    def check(self, q, p_hit, normal) -> tuple[float, float, bool]:
        """(|p_WC(q) - p_hit|, the angle between y_C(q) and the unit ``normal``, whether ``q``
        is an answer): within POSITION_TOLERANCE and ANGLE_TOLERANCE, inside the shrunk
        limits (1e-9 rad of slack)."""
        pose = self.racket_pose(q)
        position_error = float(np.linalg.norm(pose.translation() - p_hit))
        cos = float(np.clip(pose.rotation().matrix()[:, 1] @ normal, -1.0, 1.0))
        angle_error = float(np.arccos(cos))
        inside = bool(np.all(q >= self.lower - 1e-9) and np.all(q <= self.upper + 1e-9))
        ok = position_error <= POSITION_TOLERANCE and angle_error <= ANGLE_TOLERANCE and inside
        return position_error, angle_error, ok

    def solve_from(self, p_hit, normal, seed, posture) -> np.ndarray:
        """One solver run from ``seed`` minimising the cost of ``posture`` = (q_c, w), its
        answer not checked (:meth:`check`): the compiled SQP if it is the :attr:`solver` and
        converges, else SNOPT. ``p_hit`` (3) and the unit ``normal`` as :meth:`solve` takes
        them."""
        comfort, weights = posture
        if self.solver == "sqp":
            q, _, converged, _ = solve_hitting_pose(
                seed, p_hit, normal, comfort, weights, self.lower, self.upper,
                SOLVER_POSITION_BOUND, SOLVER_ANGLE_BOUND)
            if converged:
                return q
        ik = InverseKinematics(self.plant, self.context, with_joint_limits=False)
        q = ik.q()
        ik.AddPositionConstraint(self._frame_c, np.zeros(3), self._world,
                                 p_hit - SOLVER_POSITION_BOUND, p_hit + SOLVER_POSITION_BOUND)
        ik.AddAngleBetweenVectorsConstraint(self._world, normal, self._frame_c,
                                            np.array([0.0, 1.0, 0.0]), 0.0, SOLVER_ANGLE_BOUND)
        prog = ik.get_mutable_prog()
        prog.AddBoundingBoxConstraint(self.lower, self.upper, q)
        prog.AddQuadraticErrorCost(np.diag(weights), comfort, q)
        result = self._solver.Solve(prog, seed, self.solver_options)
        return np.asarray(result.GetSolution(q), dtype=float)

    def _multistart(self, p_hit, normal, seeds, posture) -> tuple[tuple, int]:
        """Solve from each distinct start in turn until one passes the check; returns
        ((badness, q, position_error, angle_error, ok), attempts) of the success, or of the
        attempt closest to the request (badness = position error + 0.1 m/rad x angle error,
        only used to rank failures)."""
        best = None
        tried: list[np.ndarray] = []
        for seed in seeds:
            if any(np.array_equal(seed, t) for t in tried):
                continue
            tried.append(seed)
            q = self.solve_from(p_hit, normal, seed, posture)
            position_error, angle_error, ok = self.check(q, p_hit, normal)
            badness = position_error + 0.1 * angle_error
            if best is None or ok or badness < best[0]:
                best = (badness, q, position_error, angle_error, ok)
            if ok:
                break
        return best, len(tried)

    def solve(self, p_hit, normal, q_seed=None, posture=None) -> IKSolution:
        """Joint angles putting the racket centre at ``p_hit`` (m, world) with ``y_C`` along
        ``normal`` (world; need not be unit), closest to the comfort posture (module docstring).
        ``posture``: (q_c, w) in the cost instead of the comfort posture and its weights, for
        this request (the teacher's corrections: the posture nearest the committed one, in units
        of each joint's speed limit); the null-space motion of the velocity problem keeps
        pulling toward :attr:`comfort`.

        Starts from ``q_seed`` (e.g. the previous stroke's answer) if given, else the comfort
        posture; on failure the :attr:`fallback_seeds` are tried in turn. The first start whose
        answer passes the forward-kinematics check is returned; if none does, the attempt closest
        to the request is returned with ``success=False``.
        """
        start = time.perf_counter()
        p_hit = np.asarray(p_hit, dtype=float).reshape(3)
        normal = _unit(normal, "normal")
        posture = (self.comfort, self.weights) if posture is None else _posture(posture)
        seeds = [np.clip(s, self.lower, self.upper) for s in self.fallback_seeds]
        if q_seed is not None:
            seeds.insert(0, np.clip(np.asarray(q_seed, dtype=float).reshape(NUM_JOINTS),
                                    self.lower, self.upper))
        if not self.may_reach(p_hit, normal):
            # No posture meets the request: no solver run; report the first start as a failure.
            seeds = seeds[:1]
            best = (0.0, seeds[0], *self.check(seeds[0], p_hit, normal))
            attempts = 0
        else:
            best, attempts = self._multistart(p_hit, normal, seeds, posture)
        _, q, position_error, angle_error, ok = best
        return IKSolution(
            q=q, success=ok, position_error=position_error, angle_error=angle_error,
            cost=self.cost(q, posture),
            limit_margin=float(np.min(np.minimum(q - JOINT_LOWER, JOINT_UPPER - q))),
            attempts=attempts, solve_ms=1e3 * (time.perf_counter() - start))

    # ----------------------------------------------------------------------------- dynamics
    def torques(self, q, qdot, qddot) -> np.ndarray:
        """Joint torques tau = M(q) q_ddot + C(q, q_dot) q_dot - tau_g(q) that the arm (with its
        racket) needs to follow (q, q_dot, q_ddot), for one sample (7,) or many (K, 7) at once:
        the recursive Newton-Euler algorithm on the control plant's bodies, the model the
        InverseDynamicsController uses (:mod:`tt_drake.rnea`, compiled; it agrees with Drake's
        ``CalcInverseDynamics`` with the plant's gravity as applied force to ~1e-13 N m). At
        rest the result is -tau_g(q), the torque that holds the arm up (at HITTING_COMFORT 23.9
        N m on the shoulder, 0.52 N m on the wrist's 3 N m joint 5)."""
        return self.chain.torques(q, qdot, qddot)

    # ----------------------------------------------------------------------------- velocities
    def joint_velocities(self, q, v_racket, omega_racket=None,
                         null_gain: float = DEFAULT_NULL_GAIN) -> np.ndarray:
        """q̇ = J⁺ [ω; v] + (I - J⁺ J) k (q_c - q) at posture ``q`` (module docstring).

        ``v_racket``: blade-centre velocity (m/s, world); ``omega_racket``: racket angular
        velocity (rad/s, world; default zero, a non-rotating racket); ``null_gain`` k (1/s).
        The result reproduces V = [ω; v] exactly (J q̇ = V to rounding); it is not clipped, so
        check it with :func:`within_velocity_limits`. Raises ``ValueError`` if J is singular
        (smallest singular value below 1e-6), where V cannot be reproduced in general.
        """
        q = np.asarray(q, dtype=float).reshape(NUM_JOINTS)
        v = np.asarray(v_racket, dtype=float).reshape(3)
        w = np.zeros(3) if omega_racket is None else np.asarray(omega_racket, dtype=float)
        twist = np.concatenate([w.reshape(3), v])
        jac = self.jacobian(q)
        # J⁺ = Jᵀ (J Jᵀ)⁻¹ from the SVD J = U S Vᵀ: J⁺ = V_r S⁻¹ Uᵀ, and the null space of J is
        # the last right-singular vector (J is 6 x 7), so I - J⁺ J = n nᵀ.
        u, s, vt = np.linalg.svd(jac)
        if s[-1] < _MIN_SINGULAR_VALUE:
            raise ValueError(f"arm is singular at q = {q} (smallest singular value {s[-1]:.2e})")
        qdot = vt[:6].T @ ((u.T @ twist) / s)
        if null_gain != 0.0:
            null = vt[6]
            qdot = qdot + null * (null @ (null_gain * (self.comfort - q)))
        return qdot

    def joint_velocities_free_spin(self, q, v_racket, null_gain: float = DEFAULT_NULL_GAIN,
                                   speed_scale=None) -> np.ndarray:
        """q̇ = J_v⁺ v + (I - J_v⁺ J_v) k (q_c - q): the blade centre's linear velocity only
        (J_v, the 3 x 7 translational rows), the racket free to rotate.

        For a hit this is what matters: the ball meets the blade at its centre, so the racket's
        rotation adds only ω x (t/2) n to the contact point's velocity (2 cm/s at 4 rad/s) and
        turns the face by |ω| times the ~1 ms contact (0.2° at 4 rad/s). Freed from holding
        ω = 0, the arm reaches the same blade velocity with much smaller joint speeds (the wrist
        need not counter-rotate; measured: 2.5 instead of 10-17 rad/s for forehand strokes):
        the minimum-norm solution plus null-space motion toward comfort.

        ``speed_scale`` (rad/s per joint, e.g. the drives' no-load speeds): the least-squares
        norm is taken in units of each joint's scale, sum (q̇_j / s_j)², so that slow joints
        (the base) give way to fast ones (the wrist): with S = diag(s) and q̇ = S y,
        y = (J_v S)⁺ v + (I - (J_v S)⁺ J_v S) S⁻¹ k (q_c - q). None: s_j = 1.
        """
        q = np.asarray(q, dtype=float).reshape(NUM_JOINTS)
        scale = (np.ones(NUM_JOINTS) if speed_scale is None
                 else np.asarray(speed_scale, dtype=float).reshape(NUM_JOINTS))
        jv = self.jacobian(q)[3:] * scale
        pinv = np.linalg.pinv(jv, rcond=1e-6)
        y = pinv @ np.asarray(v_racket, dtype=float).reshape(3)
        if null_gain != 0.0:
            y = y + (np.eye(NUM_JOINTS) - pinv @ jv) @ (null_gain * (self.comfort - q) / scale)
        qdot = scale * y
        return qdot
