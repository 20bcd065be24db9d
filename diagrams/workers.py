"""What a worker of every executor does (the local processes of
:mod:`tt_drake.diagrams.parallel`, the Ray actors of :mod:`tt_drake.diagrams.ray_executor`):
play one episode per call (with one BLAS thread, as every episode: ``tt_drake.blas``); the
context the local processes are forked from; and the error an executor that cannot run
gives."""

import gc
import multiprocessing

from tt_drake.diagrams.episodes import EpisodeResult
from tt_drake.errors import BadInputError


class ExecutorError(ValueError, BadInputError):
    """An unknown executor, or one whose optional dependency is not installed."""


def run_one(diagram, seed: int, gamma=None, weights=None) -> EpisodeResult:
    """``diagram.run`` for one seed; ``weights`` is passed only when given (a diagram of
    another player needs no primitive weights)."""
    if weights is None:
        return diagram.run(seed, gamma=gamma)
    return diagram.run(seed, gamma=gamma, weights=weights)


def fork_context():
    """multiprocessing's ``fork`` context, after a full garbage collection in this process.

    A forked child inherits the parent's uncollected garbage, and its own collector would run
    those objects' destructors in the child, where some are not safe: Drake's VTK render engine
    (a Gymnasium environment's frame renderer left in a reference cycle, say) joins rendering
    threads that do not exist in a forked child, and the child hangs. Collected first, they run
    here."""
    gc.collect()
    return multiprocessing.get_context("fork")
