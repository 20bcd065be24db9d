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
directory can be written (a read-only install and a read-only home) :func:`compiled` compiles
in memory, once per process.
"""

from __future__ import annotations

import math

from numba import njit

#: The kernel's signature: position, velocity and spin (9 floats), drag k, Magnus C_L, gravity,
#: step h, number of steps; returns the position and velocity after them (6 floats). Declared,
#: so it compiles (or loads from the cache) once at import and converts what it is given.
SIGNATURE = "UniTuple(float64, 6)(" + ", ".join(["float64"] * 13) + ", int64)"


def compiled(signature: str):
    """numba's ``njit(signature, cache=True)``, or without the on-disk cache where numba finds
    no directory to write it to (it raises RuntimeError then)."""

    def decorate(function):
        try:
            return njit(signature, cache=True)(function)
        except RuntimeError:
            return njit(signature)(function)

    return decorate


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
        # Stage 1: a1 = a(v).
        kd = k * math.sqrt(vx * vx + vy * vy + vz * vz)
        ax1 = -kd * vx + c * (wy * vz - wz * vy)
        ay1 = -kd * vy + c * (wz * vx - wx * vz)
        az1 = -g - kd * vz + c * (wx * vy - wy * vx)
        # Stage 2: v2 = v + h/2 a1, a2 = a(v2).
        x2, y2, z2 = vx + hh * ax1, vy + hh * ay1, vz + hh * az1
        kd = k * math.sqrt(x2 * x2 + y2 * y2 + z2 * z2)
        ax2 = -kd * x2 + c * (wy * z2 - wz * y2)
        ay2 = -kd * y2 + c * (wz * x2 - wx * z2)
        az2 = -g - kd * z2 + c * (wx * y2 - wy * x2)
        # Stage 3: v3 = v + h/2 a2, a3 = a(v3).
        x3, y3, z3 = vx + hh * ax2, vy + hh * ay2, vz + hh * az2
        kd = k * math.sqrt(x3 * x3 + y3 * y3 + z3 * z3)
        ax3 = -kd * x3 + c * (wy * z3 - wz * y3)
        ay3 = -kd * y3 + c * (wz * x3 - wx * z3)
        az3 = -g - kd * z3 + c * (wx * y3 - wy * x3)
        # Stage 4: v4 = v + h a3, a4 = a(v4).
        x4, y4, z4 = vx + h * ax3, vy + h * ay3, vz + h * az3
        kd = k * math.sqrt(x4 * x4 + y4 * y4 + z4 * z4)
        ax4 = -kd * x4 + c * (wy * z4 - wz * y4)
        ay4 = -kd * y4 + c * (wz * x4 - wx * z4)
        az4 = -g - kd * z4 + c * (wx * y4 - wy * x4)
        px, py, pz = (px + h6 * (vx + 2 * x2 + 2 * x3 + x4),
                      py + h6 * (vy + 2 * y2 + 2 * y3 + y4),
                      pz + h6 * (vz + 2 * z2 + 2 * z3 + z4))
        vx, vy, vz = (vx + h6 * (ax1 + 2 * ax2 + 2 * ax3 + ax4),
                      vy + h6 * (ay1 + 2 * ay2 + 2 * ay3 + ay4),
                      vz + h6 * (az1 + 2 * az2 + 2 * az3 + az4))
    return px, py, pz, vx, vy, vz
