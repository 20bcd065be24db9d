"""Worker processes run their BLAS with one thread each."""

import os

from threadpoolctl import threadpool_info

from tt_drake.diagrams.parallel import run_episodes
from tt_drake.diagrams.scenario import load_scenario


def _blas_threads() -> int:
    return max((pool["num_threads"] for pool in threadpool_info()
                if pool["user_api"] == "blas"), default=0)


class _ThreadReport:
    """Stands in for a serve diagram: each "episode" reports the worker's BLAS threads."""

    def __init__(self, scenario, player):
        pass

    def run(self, seed, gamma=None):
        return seed, _blas_threads(), os.environ.get("OPENBLAS_NUM_THREADS")


def test_each_worker_runs_blas_with_one_thread():
    import numpy  # noqa: F401  (loads BLAS in this process before the workers fork)

    reports = list(run_episodes(load_scenario(), "idle", [3, 4, 5, 6], workers=2,
                                make_diagram=_ThreadReport))
    assert [r[0] for r in reports] == [3, 4, 5, 6]
    assert all(r[1] == 1 and r[2] == "1" for r in reports)


def test_an_episode_gives_the_same_bits_in_this_process_as_in_a_worker():
    """Summation order follows the BLAS thread count, so the GPR's and CrKR's arithmetic, and
    through them a stroke, would differ between a parent process running BLAS on several
    threads and a worker running one: every episode runs its BLAS with one thread."""
    from threadpoolctl import threadpool_limits

    from tests.data.make_recorded_outcomes import SERVE_SEED, serve_record, serve_scenario
    from tt_drake.seeds import episode_seed

    scenario = serve_scenario("momp", "paper", "real-train")
    seeds = [episode_seed(SERVE_SEED, i) for i in (2, 7)]
    threadpool_limits(limits=2)  # as a parent process on two cores runs its BLAS
    here = [serve_record(r) for r in run_episodes(scenario, "momp", seeds, workers=1)]
    assert _blas_threads() == 1
    there = [serve_record(r) for r in run_episodes(scenario, "momp", seeds, workers=2)]
    assert here == there
