"""One BLAS thread for the simulation's arithmetic.

A dot product split over several BLAS threads sums in another order than one thread does, so a
GPR prediction or a CrKR solve, and through them a stroke, would depend on how many threads the
process's BLAS runs: an episode played in a worker process (one core's worth of work, so one
thread) would not give the bits it gives in the parent process. Every episode therefore runs its
BLAS with one thread, wherever it is played (``tt_drake.diagrams.station.reset_episode``).
"""

import functools
import os

from threadpoolctl import ThreadpoolController

#: The environment variables BLAS and OpenMP libraries read when they load.
BLAS_THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
                         "BLIS_NUM_THREADS", "VECLIB_MAXIMUM_THREADS", "NUMEXPR_NUM_THREADS")


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
