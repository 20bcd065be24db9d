"""One BLAS thread, and one family of BLAS kernels, for the simulation's arithmetic.

A dot product split over several BLAS threads sums in another order than one thread does, so a
GPR prediction or a CrKR solve, and through them a stroke, would depend on how many threads the
process's BLAS runs: an episode played in a worker process (one core's worth of work, so one
thread) would not give the bits it gives in the parent process. Every episode therefore runs its
BLAS with one thread, wherever it is played (``tt_drake.diagrams.station.reset_episode``).

For the same reason OpenBLAS is asked for one family of kernels on every x86-64 machine: when it
loads it picks its kernels by the CPU (SkylakeX on Intel machines with AVX-512, Haswell on AMD
Zen), and two families sum a product in different orders, so a seed gave landing points that
differ by ~1e-10 m between an Intel and an AMD machine. :func:`pin_blas_kernels` (called when
``tt_drake`` is imported) sets ``OPENBLAS_CORETYPE`` to :data:`BLAS_CORE_TYPE` unless the
environment names one; OpenBLAS reads it when numpy or scipy first loads it, so it holds in a
process that imports ``tt_drake`` before numpy (the ``tt-drake`` command, the test suite through
its ``conftest.py``) and in every process started from one.
"""

import functools
import os
import platform

from threadpoolctl import ThreadpoolController

#: The environment variables BLAS and OpenMP libraries read when they load.
BLAS_THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
                         "BLIS_NUM_THREADS", "VECLIB_MAXIMUM_THREADS", "NUMEXPR_NUM_THREADS")


#: The OpenBLAS kernels every x86-64 machine runs (AVX2 and FMA: any x86-64 CPU since 2013 has
#: them).
BLAS_CORE_TYPE = "Haswell"


def pin_blas_kernels() -> None:
    """``OPENBLAS_CORETYPE`` = :data:`BLAS_CORE_TYPE` on x86-64, unless already set (module
    docstring). Effective only before OpenBLAS loads."""
    if platform.machine().lower() in ("x86_64", "amd64"):
        os.environ.setdefault("OPENBLAS_CORETYPE", BLAS_CORE_TYPE)


@functools.cache
def _controller() -> ThreadpoolController:
    # Finding the loaded libraries takes ~10 ms; limiting them again takes ~20 us.
    return ThreadpoolController()


def one_blas_thread() -> None:
    """Limit this process's BLAS/OpenMP thread pools to one thread: those already loaded
    (through threadpoolctl, a scikit-learn dependency) and, through the environment, any loaded
    later. Cheap enough to call at every episode's start."""
    for name in BLAS_THREAD_VARIABLES:
        os.environ[name] = "1"
    _controller().limit(limits=1)
