"""What a worker of every executor does (the local processes of
:mod:`tt_drake.diagrams.parallel`, the Ray actors of :mod:`tt_drake.diagrams.ray_executor`):
run its BLAS with one thread and play one episode per call; and the error an executor that
cannot run gives."""

import os

from threadpoolctl import threadpool_limits

from tt_drake.diagrams.episodes import EpisodeResult
from tt_drake.errors import BadInputError


class ExecutorError(ValueError, BadInputError):
    """An unknown executor, or one whose optional dependency is not installed."""


BLAS_THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
                         "BLIS_NUM_THREADS", "VECLIB_MAXIMUM_THREADS", "NUMEXPR_NUM_THREADS")


def one_blas_thread() -> None:
    """Limit this process's BLAS/OpenMP thread pools to one thread: those already loaded (through
    threadpoolctl, a scikit-learn dependency) and, through the environment, any loaded later."""
    for name in BLAS_THREAD_VARIABLES:
        os.environ[name] = "1"
    threadpool_limits(limits=1)


def run_one(diagram, seed: int, gamma=None, weights=None) -> EpisodeResult:
    """``diagram.run`` for one seed; ``weights`` is passed only when given (a diagram of
    another player needs no primitive weights)."""
    if weights is None:
        return diagram.run(seed, gamma=gamma)
    return diagram.run(seed, gamma=gamma, weights=weights)
