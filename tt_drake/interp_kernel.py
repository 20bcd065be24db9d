"""One value of a piecewise-linear table, compiled (numba, cached as
:mod:`tt_drake.flight_kernel`'s kernels are): ``numpy.interp`` for a scalar, the same arithmetic,
so the same number to the bit (``tests/tt_drake/test_filter_kernel.py``). The racket's and the
table's restitution (:func:`tt_drake.ball_model.hunt_crossley_restitution`) is read from a table
hundreds of times per stroke the teacher plans; ``numpy.interp``'s call costs more than the
interpolation.
"""

from __future__ import annotations

from tt_drake.flight_kernel import compiled


@compiled("float64(float64, float64[::1], float64[::1])")
def interp_one(x, xp, fp):
    """f(x) on the table (xp ascending, fp): fp[0] left of it, fp[-1] right of it, fp[j] at a
    knot xp[j], else s (x - xp[j]) + fp[j] with s = (fp[j+1] - fp[j]) / (xp[j+1] - xp[j]) and
    xp[j] < x < xp[j+1] (numpy.interp's formula; NaN in, NaN out)."""
    n = xp.shape[0]
    if x != x:
        return x
    if x <= xp[0]:
        return fp[0]
    if x >= xp[n - 1]:
        return fp[n - 1]
    lo, hi = 0, n - 1  # xp[lo] <= x < xp[hi]
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if xp[mid] <= x:
            lo = mid
        else:
            hi = mid
    if xp[lo] == x:
        return fp[lo]
    slope = (fp[lo + 1] - fp[lo]) / (xp[lo + 1] - xp[lo])
    return slope * (x - xp[lo]) + fp[lo]
