"""Worker processes run their BLAS with one thread each, and do not inherit garbage whose
destructor cannot run in a forked child."""

import os
import subprocess
import sys
import textwrap

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


#: A parent holding a VTK render engine in unreachable garbage (a Gymnasium env's frame renderer
#: left in a reference cycle) that only a full collection frees; each worker collects in full
#: before it builds its diagram, as its collector does some time into its work.
_INHERITED_RENDERER = textwrap.dedent("""
    import gc
    import numpy as np
    from tt_drake import wam_params as wp
    from tt_drake.diagrams.episodes import ServeDiagram
    from tt_drake.diagrams.gym_render import FrameRenderer
    from tt_drake.diagrams.parallel import run_episodes
    from tt_drake.diagrams.scenario import load_scenario

    class Holder:
        pass

    def collect_then_build(scenario, player):
        gc.collect()
        return ServeDiagram(scenario, player)

    scenario = load_scenario()
    renderer = FrameRenderer(scenario.world)
    renderer.frame(np.asarray(wp.AWAITING), np.r_[1.0, 0, 0, 0, 0, 3.0, -5.0])
    keep = [Holder()]
    keep[0].cycle, keep[0].renderer = keep[0], renderer
    del renderer
    gc.collect()  # reachable: moved to the oldest generation
    keep.clear()  # now garbage
    results = list(run_episodes(scenario, "idle", [1, 2, 3, 4], workers=2,
                                make_diagram=collect_then_build))
    print(len(results))
""")


def test_workers_do_not_inherit_a_render_engine_to_destroy():
    """Without the collection before the fork the workers hang in the render engine's
    destructor (EGL joins a thread of the parent's); with it the four episodes come back."""
    done = subprocess.run([sys.executable, "-c", _INHERITED_RENDERER], capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split()[-1] == "4"
