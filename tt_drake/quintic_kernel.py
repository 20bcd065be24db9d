"""A quintic segment's positions, velocities and accelerations at many times, compiled.

For s = clip(t - t0, 0, T) and coefficients c_0..c_5 per joint (:class:`tt_drake.stages.Quintic`)::

    q   = ((((c5 s + c4) s + c3) s + c2) s + c1) s + c0
    q'  = (((5 c5 s + 4 c4) s + 3 c3) s + 2 c2) s + c1
    q'' = ((20 c5 s + 12 c4) s + 6 c3) s + 2 c2

and past the segment's end (e = t - (t0 + T) > 0) the position continued with the end velocity,
q + q' e, at zero acceleration. The players evaluate segments thousands of times per serve (the
set-point tables, the limit and effort checks of every candidate stroke); as numpy array
expressions each evaluation costs ~20 array operations of a few elements, most of it call
overhead. :func:`quintic_many` does the same IEEE operations in the same order per element
(numba compiles without ``fastmath``: no reassociation, no fused multiply-add), so its values are
the numpy expressions' (:func:`quintic_many_numpy`, kept as the reference it is checked against)
to the last bit (``tests/tt_drake/test_stages.py``, ``docs/examples/compiled_kernels.py``).
Compiled once and cached on disk like the flight kernel (:func:`tt_drake.flight_kernel.compiled`).
"""

from __future__ import annotations

import numpy as np

from tt_drake.flight_kernel import compiled

#: coefficients (n_dof, 6), t0, duration, times (K,) -> (q, q_dot, q_ddot), each (K, n_dof).
SIGNATURE = "UniTuple(float64[:, :], 3)(float64[:, :], float64, float64, float64[:])"


@compiled(SIGNATURE)
def quintic_many(coeffs, t0, duration, times):
    """(q, q_dot, q_ddot) of the quintic ``coeffs`` (n_dof, 6) starting at ``t0`` and lasting
    ``duration`` at every time of ``times`` (module docstring), each (K, n_dof)."""
    n = coeffs.shape[0]
    k_times = times.shape[0]
    q = np.empty((k_times, n))
    v = np.empty((k_times, n))
    a = np.empty((k_times, n))
    t_end = t0 + duration
    for i in range(k_times):
        s = times[i] - t0
        if s < 0.0:
            s = 0.0
        if s > duration:
            s = duration
        extra = times[i] - t_end
        for j in range(n):
            c0, c1, c2 = coeffs[j, 0], coeffs[j, 1], coeffs[j, 2]
            c3, c4, c5 = coeffs[j, 3], coeffs[j, 4], coeffs[j, 5]
            qj = ((((c5 * s + c4) * s + c3) * s + c2) * s + c1) * s + c0
            vj = (((5.0 * c5 * s + 4.0 * c4) * s + 3.0 * c3) * s + 2.0 * c2) * s + c1
            aj = ((20.0 * c5 * s + 12.0 * c4) * s + 6.0 * c3) * s + 2.0 * c2
            if extra > 0.0:
                qj = qj + vj * extra
                aj = 0.0
            q[i, j] = qj
            v[i, j] = vj
            a[i, j] = aj
    return q, v, a


def quintic_many_numpy(coeffs, t0: float, duration: float, times):
    """:func:`quintic_many` as numpy array expressions over all times and joints at once: the
    same operations element by element, in the same order (the reference the kernel is checked
    against; about ten times slower for a segment's 80 samples)."""
    t = np.asarray(times, dtype=float).reshape(-1, 1)
    s = np.clip(t - t0, 0.0, duration)
    c = np.asarray(coeffs, dtype=float)
    q = ((((c[:, 5] * s + c[:, 4]) * s + c[:, 3]) * s + c[:, 2]) * s + c[:, 1]) * s + c[:, 0]
    v = (((5 * c[:, 5] * s + 4 * c[:, 4]) * s + 3 * c[:, 3]) * s + 2 * c[:, 2]) * s + c[:, 1]
    a = ((20 * c[:, 5] * s + 12 * c[:, 4]) * s + 6 * c[:, 3]) * s + 2 * c[:, 2]
    extra = t - (t0 + duration)
    past = extra[:, 0] > 0.0
    q[past] = q[past] + v[past] * extra[past]
    a[past] = 0.0
    return q, v, a
