"""pytest's root configuration: importing tt_drake before any test module loads numpy pins
OpenBLAS's kernels (tt_drake/blas.py), so the recorded outcomes hold on every x86-64 machine."""

import tt_drake  # noqa: F401
