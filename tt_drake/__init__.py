"""tt-drake: a simulated Barrett WAM learns table tennis with a Mixture of Motor Primitives, on
Drake. Importing the package pins OpenBLAS's kernels (:func:`tt_drake.blas.pin_blas_kernels`)
so that a seed gives the same numbers on every x86-64 machine."""

from tt_drake.blas import pin_blas_kernels

pin_blas_kernels()
