"""The ball's free flight, compiled: classical Runge-Kutta (RK4) steps of

    p' = v,    v' = g - k |v| v + C_L (omega x v),    omega' = 0

(:mod:`tt_drake.ball_model`, docs/constants.md, "Aerodynamics") in machine code by numba.

Every prediction of the ball's flight (the launcher's serve check, the estimator, the hitting
point, the teacher's aim) is a loop of these steps; in Python floats a step costs ~1.4 µs, most
of it the interpreter. :func:`rk4_flight` runs ``steps`` steps in one call with the same IEEE
operations in the same order as the Python arithmetic it replaced (numba compiles without
``fastmath``: no reassociation, no fused multiply-add), so its results are those numbers to the
last bit (``tests/tt_drake/test_flight_kernel.py``).

The compiled code is cached on disk (numba's ``cache=True``): beside this file when the install
is writable, else in the user's cache directory (``NUMBA_CACHE_DIR`` if set). Where no cache
directory can be written (a read-only install and a read-only home) or the cache cannot be
written (a full disk) :func:`compiled` compiles in memory, once per process (~1 s). numba
invalidates a cached kernel when its source file changes, not when a function it calls in
another file does: :func:`acceleration`, which the kernels inline, lives in this file for that.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

#: The kernel's signature: position, velocity and spin (9 floats), drag k, Magnus C_L, gravity,
#: step h, number of steps; returns the position and velocity after them (6 floats). Declared,
#: so it compiles (or loads from the cache) once at import and converts what it is given.
SIGNATURE = "UniTuple(float64, 6)(" + ", ".join(["float64"] * 13) + ", int64)"


def compiled(signature: str):
    """numba's ``njit(signature, cache=True)``: compiled at import, or loaded from the on-disk
    cache. Where numba finds no directory to write the cache to (it raises RuntimeError) or
    cannot write it (OSError: a full disk, a file size limit), compiled without the cache."""

    def decorate(function):
        try:
            return njit(signature, cache=True)(function)
        except (RuntimeError, OSError):
            return njit(signature)(function)

    return decorate


@njit(inline="always")
def acceleration(vx, vy, vz, wx, wy, wz, k, c, g):
    """v' = g - k |v| v + C_L (omega x v), as three floats (inlined into the kernels)."""
    kd = k * math.sqrt(vx * vx + vy * vy + vz * vz)
    return (-kd * vx + c * (wy * vz - wz * vy),
            -kd * vy + c * (wz * vx - wx * vz),
            -g - kd * vz + c * (wx * vy - wy * vx))


@compiled(SIGNATURE)
def rk4_flight(px, py, pz, vx, vy, vz, wx, wy, wz, k, c, g, h, steps):
    """``steps`` RK4 steps of length ``h`` (s) of the flight ODE from (p, v) with spin omega,
    drag constant ``k`` (1/m), Magnus coefficient ``c`` (C_L) and gravity ``g`` (m/s^2): with
    a(v) = g - k |v| v + C_L (omega x v) and the stage velocities

        v1 = v,  v2 = v + h/2 a(v1),  v3 = v + h/2 a(v2),  v4 = v + h a(v3),

    each step is p+ = p + h/6 (v1 + 2 v2 + 2 v3 + v4), v+ = v + h/6 (a1 + 2 a2 + 2 a3 + a4).
    Returns (p+, v+) as six floats."""
    hh = 0.5 * h
    h6 = h / 6.0
    for _ in range(steps):
        ax1, ay1, az1 = acceleration(vx, vy, vz, wx, wy, wz, k, c, g)
        x2, y2, z2 = vx + hh * ax1, vy + hh * ay1, vz + hh * az1
        ax2, ay2, az2 = acceleration(x2, y2, z2, wx, wy, wz, k, c, g)
        x3, y3, z3 = vx + hh * ax2, vy + hh * ay2, vz + hh * az2
        ax3, ay3, az3 = acceleration(x3, y3, z3, wx, wy, wz, k, c, g)
        x4, y4, z4 = vx + h * ax3, vy + h * ay3, vz + h * az3
        ax4, ay4, az4 = acceleration(x4, y4, z4, wx, wy, wz, k, c, g)
        px, py, pz = (px + h6 * (vx + 2 * x2 + 2 * x3 + x4),
                      py + h6 * (vy + 2 * y2 + 2 * y3 + y4),
                      pz + h6 * (vz + 2 * z2 + 2 * z3 + z4))
        vx, vy, vz = (vx + h6 * (ax1 + 2 * ax2 + 2 * ax3 + ax4),
                      vy + h6 * (ay1 + 2 * ay2 + 2 * ay3 + ay4),
                      vz + h6 * (az1 + 2 * az2 + 2 * az3 + az4))
    return px, py, pz, vx, vy, vz


#: last_table_contact's signature: the state (9 floats), drag k, Magnus C_L, gravity, step dt,
#: max_time, the contact height and the table's half width and half length; returns a float.
BACKWARD_SIGNATURE = "float64(" + ", ".join(["float64"] * 17) + ")"


@compiled(BACKWARD_SIGNATURE)
def last_table_contact(px, py, pz, vx, vy, vz, wx, wy, wz, k, c, g, dt, max_time, contact_z,
                       half_width, half_length):
    """How long ago (s) the ball's centre, followed back in time by RK4 steps of -``dt``
    (:func:`rk4_flight`), was at or below ``contact_z`` over the table (|x| <= half_width,
    |y| <= half_length) before getting back to the net's plane y = 0; -1.0 if it gets there
    first or ``max_time`` passes (``tt_drake.hitting_time.last_robot_bounce``'s loop, the same
    steps and tests)."""
    t = 0.0
    while t < max_time:
        px, py, pz, vx, vy, vz = rk4_flight(px, py, pz, vx, vy, vz, wx, wy, wz, k, c, g, -dt, 1)
        t += dt
        if py >= 0.0:
            return -1.0
        if pz <= contact_z and abs(px) <= half_width and abs(py) <= half_length:
            return t
    return -1.0


#: Kinds of stop event :func:`flight_until` evaluates itself: the centre crossing a plane
#: y = a from the side ``b`` (stop = b (y - a)), reaching the time a (stop = a - t), or none.
STOP_PLANE, STOP_TIME, STOP_NEVER = 0, 1, 2
#: What ended a compiled flight (:func:`variational_flight`, :func:`flight_until`).
UNTIL_CONTACT, UNTIL_STOP, UNTIL_FLOOR, UNTIL_TIME = 1, 2, 3, 4
#: variational_flight's signature: position, velocity and spin (3 each), the sensitivities dp and
#: dv (3 x 6, row-major, 18 each; position, velocity and the two sensitivities are updated in
#: place), the time reached and the duration, the step, drag k, Magnus C_L, gravity and the
#: contact height; the 6 + 36 values of a pending step (out); returns (status, time, step).
VARIATIONAL_SIGNATURE = ("Tuple((int64, float64, float64))(float64[:], float64[:], float64[:], "
                         "float64[:], float64[:], float64, float64, float64, float64, float64, "
                         "float64, float64, float64[:])")


@compiled(VARIATIONAL_SIGNATURE)
def variational_flight(pos, vel, w, dp, dv, t, duration, dt, k, c, g, contact_z, pending):
    """RK4 flight steps of at most ``dt`` (the last shortened to end at ``duration``) from time
    ``t``, each with the sensitivities of (p, v) to the initial velocity and spin (``dp``,
    ``dv``: 3 x 6 each, columns v0 and omega0). They obey the variational equation

        dp' = dv,    dv' = J(v) dv + [0 | B(v)],    B(v) = -C_L [v]x,
        J(v) = d(v')/dv = -k (|v| I + v v^T / |v|) + C_L [omega]x,

    integrated by the step's own RK4 stages: with the stage velocities v_i (:func:`rk4_flight`),
    D_i = J(v_i) X_i + [0 | B(v_i)], X1 = dv, X2 = dv + h/2 D1, X3 = dv + h/2 D2,
    X4 = dv + h D3,

        dp+ = dp + h/6 (X1 + 2 X2 + 2 X3 + X4),    dv+ = dv + h/6 (D1 + 2 D2 + 2 D3 + D4),

    the exact derivative of the RK4 step. ``pos``, ``vel``, ``dp``, ``dv`` are advanced in
    place. Returns (UNTIL_TIME, t, h) at ``duration``; or (UNTIL_CONTACT, t, h) before a step of
    length h that takes the ball's centre down through ``contact_z`` (the table's contact height:
    the caller decides whether it meets the table), that step's p, v, dp, dv in ``pending``
    (3 + 3 + 18 + 18)."""
    n1 = np.empty(18)
    n2 = np.empty(18)
    D = np.empty((4, 18))
    X = np.empty((4, 18))
    V = np.empty((4, 3))
    A = np.empty((4, 3))
    wx, wy, wz = w[0], w[1], w[2]
    h = dt
    while duration - t > 1e-12:
        h = min(dt, duration - t)
        hh = 0.5 * h
        h6 = h / 6.0
        # The stage velocities and accelerations (rk4_flight's, in the same order).
        for i in range(4):
            if i == 0:
                x, y, z = vel[0], vel[1], vel[2]
            else:
                f = hh if i < 3 else h
                x = vel[0] + f * A[i - 1, 0]
                y = vel[1] + f * A[i - 1, 1]
                z = vel[2] + f * A[i - 1, 2]
            V[i, 0], V[i, 1], V[i, 2] = x, y, z
            A[i, 0], A[i, 1], A[i, 2] = acceleration(x, y, z, wx, wy, wz, k, c, g)
        # The sensitivities' stages: X_1 = dv, D_i = J(v_i) X_i + [0 | B(v_i)].
        for i in range(4):
            if i == 0:
                for e in range(18):
                    X[0, e] = dv[e]
            else:
                f = hh if i < 3 else h
                for e in range(18):
                    X[i, e] = dv[e] + f * D[i - 1, e]
            x, y, z = V[i, 0], V[i, 1], V[i, 2]
            speed = math.sqrt(x * x + y * y + z * z)
            kd = k * speed
            ks = k / speed if speed > 0.0 else 0.0
            J0, J1, J2 = -kd - ks * x * x, -ks * x * y - c * wz, -ks * x * z + c * wy
            J3, J4, J5 = -ks * y * x + c * wz, -kd - ks * y * y, -ks * y * z - c * wx
            J6, J7, J8 = -ks * z * x - c * wy, -ks * z * y + c * wx, -kd - ks * z * z
            for col in range(6):
                a0, a1, a2 = X[i, col], X[i, 6 + col], X[i, 12 + col]
                D[i, col] = J0 * a0 + J1 * a1 + J2 * a2
                D[i, 6 + col] = J3 * a0 + J4 * a1 + J5 * a2
                D[i, 12 + col] = J6 * a0 + J7 * a1 + J8 * a2
            # + [0 | B(v)], B = -C_L [v]x, row-major; its zero entries are added too, as the
            # arithmetic this replaced did (-0.0 + 0.0 is +0.0).
            D[i, 4] += c * z
            D[i, 5] += -c * y
            D[i, 9] += -c * z
            D[i, 11] += c * x
            D[i, 15] += c * y
            D[i, 16] += -c * x
            D[i, 3] += 0.0
            D[i, 10] += 0.0
            D[i, 17] += 0.0
        npx = pos[0] + h6 * (V[0, 0] + 2 * V[1, 0] + 2 * V[2, 0] + V[3, 0])
        npy = pos[1] + h6 * (V[0, 1] + 2 * V[1, 1] + 2 * V[2, 1] + V[3, 1])
        npz = pos[2] + h6 * (V[0, 2] + 2 * V[1, 2] + 2 * V[2, 2] + V[3, 2])
        nvx = vel[0] + h6 * (A[0, 0] + 2 * A[1, 0] + 2 * A[2, 0] + A[3, 0])
        nvy = vel[1] + h6 * (A[0, 1] + 2 * A[1, 1] + 2 * A[2, 1] + A[3, 1])
        nvz = vel[2] + h6 * (A[0, 2] + 2 * A[1, 2] + 2 * A[2, 2] + A[3, 2])
        for e in range(18):
            n1[e] = dp[e] + h6 * (X[0, e] + 2 * X[1, e] + 2 * X[2, e] + X[3, e])
            n2[e] = dv[e] + h6 * (D[0, e] + 2 * D[1, e] + 2 * D[2, e] + D[3, e])
        if npz < contact_z <= pos[2] and nvz < 0.0:
            pending[0], pending[1], pending[2] = npx, npy, npz
            pending[3], pending[4], pending[5] = nvx, nvy, nvz
            for e in range(18):
                pending[6 + e] = n1[e]
                pending[24 + e] = n2[e]
            return UNTIL_CONTACT, t, h
        pos[0], pos[1], pos[2] = npx, npy, npz
        vel[0], vel[1], vel[2] = nvx, nvy, nvz
        for e in range(18):
            dp[e] = n1[e]
            dv[e] = n2[e]
        t = t + h
    return UNTIL_TIME, t, h


#: flight_until's signature: the state (9), drag k, Magnus C_L, gravity, step dt, time t,
#: max_time, the contact height, the floor height, the stop's kind and its two numbers, and the
#: 6 values of a pending step (out); returns (what ended it, t, h, p and v at t: 6 floats).
UNTIL_SIGNATURE = ("Tuple((int64, float64, float64, float64, float64, float64, float64, float64, "
                   "float64))(" + ", ".join(["float64"] * 17) + ", int64, float64, float64, "
                   "float64[:])")


@compiled(UNTIL_SIGNATURE)
def flight_until(px, py, pz, vx, vy, vz, wx, wy, wz, k, c, g, dt, t, max_time, contact_z, floor,
                 kind, a, b, pending):
    """``BallModel.advance``'s flight between bounces: RK4 steps of ``dt`` (the last shortened
    to end at ``max_time``) from (p, v) at time ``t`` until

    - UNTIL_CONTACT: a step takes the centre down through ``contact_z`` (the caller decides
      whether it meets the table); that step's (p, v) in ``pending``;
    - UNTIL_STOP: the stop event is <= 0 after a step (kind STOP_PLANE: b (y - a); STOP_TIME:
      a - t);
    - UNTIL_FLOOR: the centre falls below ``floor``;
    - UNTIL_TIME: ``max_time`` is reached.

    Returns (what ended it, t, h, p, v): the state at t, before the step of length h that ended
    it. The steps and tests are ``advance``'s, in its order, so its results are the same."""
    h = dt
    while t < max_time:
        h = dt if max_time - t > dt else max_time - t
        npx, npy, npz, nvx, nvy, nvz = rk4_flight(px, py, pz, vx, vy, vz, wx, wy, wz, k, c, g,
                                                   h, 1)
        if npz < contact_z <= pz and nvz < 0.0:
            pending[0], pending[1], pending[2] = npx, npy, npz
            pending[3], pending[4], pending[5] = nvx, nvy, nvz
            return UNTIL_CONTACT, t, h, px, py, pz, vx, vy, vz
        if kind == STOP_PLANE:
            event = b * (npy - a)
        elif kind == STOP_TIME:
            event = a - (t + h)
        else:
            event = 1.0
        if event <= 0.0:
            return UNTIL_STOP, t, h, px, py, pz, vx, vy, vz
        if npz < floor:
            return UNTIL_FLOOR, t, h, px, py, pz, vx, vy, vz
        px, py, pz, vx, vy, vz = npx, npy, npz, nvx, nvy, nvz
        t = t + h
    return UNTIL_TIME, t, h, px, py, pz, vx, vy, vz


#: net_crossing_height's signature: the state (9), drag k, Magnus C_L, gravity, step h, at most
#: ``steps`` steps and the contact height; returns a float.
CROSSING_SIGNATURE = "float64(" + ", ".join(["float64"] * 13) + ", int64, float64)"


@compiled(CROSSING_SIGNATURE)
def net_crossing_height(px, py, pz, vx, vy, vz, wx, wy, wz, k, c, g, h, steps, contact_z):
    """The centre's height where the flight crosses the net's plane y = 0 going +y, linearly
    interpolated inside the RK4 step of ``h`` that crosses it; -inf if the centre first falls
    below ``contact_z`` or ``steps`` steps pass (:func:`tt_drake.racket_law.net_clearance`)."""
    for _ in range(steps):
        npx, npy, npz, nvx, nvy, nvz = rk4_flight(px, py, pz, vx, vy, vz, wx, wy, wz, k, c, g,
                                                   h, 1)
        if npy >= 0.0 > py:
            s = -py / (npy - py)
            return pz + s * (npz - pz)
        if npz < contact_z:
            return -math.inf
        px, py, pz, vx, vy, vz = npx, npy, npz, nvx, nvy, nvz
    return -math.inf

