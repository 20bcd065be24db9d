"""Run serve episodes in parallel worker processes, each building its diagram once.

Diagrams and contexts are not picklable (facts.md section 4), so every worker builds its own
:class:`ServeDiagram` in its initializer (fork start method: the parent's imports are shared) and
receives only episode seeds; results come back in submission order. With one worker everything
runs in this process.
"""

import multiprocessing
import os
from collections.abc import Callable, Iterable, Iterator

from tt_drake.diagrams.episodes import EpisodeResult, ServeDiagram
from tt_drake.diagrams.scenario import Scenario

_WORKER: dict = {}


def default_workers() -> int:
    return max(1, len(os.sched_getaffinity(0)))


def _init(scenario: Scenario, player: str, make_diagram) -> None:
    _WORKER["diagram"] = make_diagram(scenario, player)


def _run(seed: int) -> EpisodeResult:
    return _WORKER["diagram"].run(seed)


def run_episodes(scenario: Scenario, player: str, seeds: Iterable[int], workers: int = 1,
                 make_diagram: Callable = ServeDiagram) -> Iterator[EpisodeResult]:
    """Yield the episodes of ``seeds`` in order (as they finish, in order)."""
    seeds = list(seeds)
    if workers <= 1 or len(seeds) <= 1:
        diagram = make_diagram(scenario, player)
        for seed in seeds:
            yield diagram.run(seed)
        return
    context = multiprocessing.get_context("fork")
    pool = context.Pool(min(workers, len(seeds)), initializer=_init,
                        initargs=(scenario, player, make_diagram))
    try:
        yield from pool.imap(_run, seeds, chunksize=1)
        pool.close()
    finally:
        pool.terminate()
        pool.join()
