"""The estimator's prediction noise, compiled (numba, cached as :mod:`tt_drake.flight_kernel`'s
kernels are): P- = (P_f + Q + (P_f + Q)^T) / 2 with P_f = F P F^T, the last step of
:meth:`tt_drake.estimation.BallFlightEKF.predict` (the white-acceleration and spin noise Q of
:mod:`tt_drake.estimation`'s docstring, symmetrised), in one call instead of a dozen numpy
operations on 9 x 9 arrays, with the same elementwise arithmetic, so the same numbers to the bit
(``tests/tt_drake/test_filter_kernel.py``).

The filter's products (F P F^T, the gain and the Joseph form) stay numpy's: BLAS sums them in an
order of its own, so a compiled product would differ from it by rounding, and the teacher's
strokes on spinning serves are sensitive to that (a re-plan threshold crossed or not).
"""

from __future__ import annotations

import numpy as np

from tt_drake.flight_kernel import compiled

#: add_process_noise's signature: P (9 x 9), the four noise terms and the array P- is written to.
NOISE_SIGNATURE = ("void(float64[:, ::1], float64, float64, float64, float64, "
                   "float64[:, ::1])")


@compiled(NOISE_SIGNATURE)
def add_process_noise(P, pp, pv, vv, ww, P_out):
    """P- = ((P + Q) + (P + Q)^T) / 2 with Q = [[pp I, pv I, 0], [pv I, vv I, 0], [0, 0, ww I]]
    (the prediction's noise, :meth:`tt_drake.estimation.BallFlightEKF.noise_terms`): the
    elementwise arithmetic of ``M = P + Q; 0.5 * (M + M.T)``, so the same numbers to the bit."""
    n = P.shape[0]
    Q = np.zeros((n, n))
    for i in range(3):
        Q[i, i] = pp
        Q[i, i + 3] = pv
        Q[i + 3, i] = pv
        Q[i + 3, i + 3] = vv
        Q[i + 6, i + 6] = ww
    for i in range(n):
        for j in range(n):
            P_out[i, j] = 0.5 * ((P[i, j] + Q[i, j]) + (P[j, i] + Q[j, i]))
