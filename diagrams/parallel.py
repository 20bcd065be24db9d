"""Run serve episodes in parallel worker processes, each building its diagram once.

Diagrams and contexts are not picklable (docs/design.md), so every worker builds its own
:class:`ServeDiagram` in its initializer (fork start method: the parent's imports are shared) and
receives only episode seeds; results come back in submission order. With one worker everything
runs in this process.

Each worker process runs its BLAS with one thread (:func:`one_blas_thread`): a worker is one core's
worth of work, and BLAS threads of several workers oversubscribe the cores (docs/performance.md,
"The serve diagram's Python").
"""

import contextlib
import itertools
import os
from collections.abc import Callable, Iterable, Iterator

from tt_drake.blas import one_blas_thread
from tt_drake.diagrams.episodes import EpisodeResult, ServeDiagram
from tt_drake.diagrams.ray_executor import ray_session, run_ray
from tt_drake.diagrams.scenario import Scenario
from tt_drake.diagrams.workers import ExecutorError, fork_context, run_one

_WORKER: dict = {}


def default_workers() -> int:
    return max(1, len(os.sched_getaffinity(0)))


def _init(scenario: Scenario, player: str, make_diagram) -> None:
    one_blas_thread()
    _WORKER["diagram"] = make_diagram(scenario, player)


def _run(task: tuple) -> EpisodeResult:
    return run_one(_WORKER["diagram"], *task)


def run_episodes(scenario: Scenario, player: str, seeds: Iterable[int], workers: int = 1,
                 make_diagram: Callable = ServeDiagram, gamma=None,
                 executor: str = "local", weights: Iterable | None = None
                 ) -> Iterator[EpisodeResult]:
    """Yield the episodes of ``seeds`` in order (as they finish, in order). ``gamma``: the momp
    player's responsibilities for all of them (default: its library's). ``weights``: the momp
    player's primitive weights for each seed in turn (PoWER's exploration; default: its
    library's), taken as the seeds are. ``executor``: ``local`` (forked processes) or another
    name in :data:`EXECUTORS`."""
    if executor not in EXECUTORS:
        raise ExecutorError(f"unknown executor {executor!r}; choose one of {', '.join(EXECUTORS)}")
    if executor != "local":
        yield from EXECUTORS[executor](scenario, player, list(seeds), workers, make_diagram,
                                       gamma, weights)
        return
    # Seeds are streamed (a generator is never listed): only the first ``workers`` are looked
    # at to size the pool, and imap takes the rest as the workers need them.
    seeds = iter(seeds)
    head = list(itertools.islice(seeds, max(1, workers)))
    per_seed = itertools.repeat(None) if weights is None else iter(weights)
    if workers <= 1 or len(head) <= 1:
        diagram = make_diagram(scenario, player)
        for seed, w in zip(itertools.chain(head, seeds), per_seed, strict=False):
            yield run_one(diagram, seed, gamma, w)
        return
    pool = fork_context().Pool(len(head), initializer=_init,
                               initargs=(scenario, player, make_diagram))
    try:
        tasks = ((seed, gamma, w) for seed, w in
                 zip(itertools.chain(head, seeds), per_seed, strict=False))
        yield from pool.imap(_run, tasks, chunksize=1)
        pool.close()
    finally:
        pool.terminate()
        pool.join()


# Executors other than ``local``: name -> function(scenario, player, seeds, workers, make_diagram,
# gamma, weights) yielding EpisodeResults in seed order.
EXECUTORS: dict[str, Callable] = {"local": None, "ray": run_ray}


def executor_session(executor: str, workers: int):
    """A context in which many :func:`run_episodes` calls share the executor's set-up (Ray is
    started once); nothing to do for ``local``."""
    if executor == "ray":
        return ray_session(workers)
    return contextlib.nullcontext()
