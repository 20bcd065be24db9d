"""How much faster two processes work than one on this machine, for a fixed piece of work.

    OPENBLAS_NUM_THREADS=1 python docs/examples/cpu_scaling.py [--kernel python|serve] [--rounds 3]
        [--scenario S]

Runs the same work in 1 process, then in ``--workers`` (default 2) forked processes started
together (a barrier), alternately for ``--rounds`` rounds, and prints per round each run's wall
time, each process's CPU time and the speed-up ``workers * t_1 / t_N`` (t: wall time of one
process's work). ``python``: a pure-Python arithmetic loop (fits in the L1 cache: what the cores
themselves give). ``serve``: ``--serves`` idle serve episodes of ``--scenario`` (default: the
default scenario; Drake's plant, contact and integrator plus the Python systems; the diagram is
built before the timer).
A ceiling well below ``workers`` on the ``python`` kernel is the machine's (for example two
virtual CPUs sharing one physical core), not the code's. Used for docs/performance.md.
"""

from __future__ import annotations

import argparse
import time

from tt_drake.diagrams.commands.options import add_scenario_option
from tt_drake.diagrams.workers import fork_context


def _python_work(n: int) -> float:
    x = 0.0
    for i in range(n):
        x += (i % 7) * 0.5 - x * 1e-9
    return x


def _job(args) -> tuple[float, float]:
    kernel, size, barrier, scenario = args
    if kernel == "serve":
        from tt_drake.diagrams.episodes import ServeDiagram, episode_seed
        from tt_drake.diagrams.scenario import load_scenario

        diagram = ServeDiagram(load_scenario(scenario), "idle")
        diagram.run(episode_seed(1, 0))  # warm-up
    if barrier is not None:
        barrier.wait()
    t0, c0 = time.perf_counter(), time.process_time()
    if kernel == "serve":
        for i in range(size):
            diagram.run(episode_seed(1, i))
    else:
        _python_work(size)
    return time.perf_counter() - t0, time.process_time() - c0


def _run(kernel: str, size: int, workers: int,
         scenario: str = "default") -> list[tuple[float, float]]:
    context = fork_context()
    if workers == 1:
        process = context.Pool(1)
        try:
            return process.map(_job, [(kernel, size, None, scenario)])
        finally:
            process.close()
            process.join()
    manager = context.Manager()
    barrier = manager.Barrier(workers)
    pool = context.Pool(workers)
    try:
        return pool.map(_job, [(kernel, size, barrier, scenario)] * workers, chunksize=1)
    finally:
        pool.close()
        pool.join()
        manager.shutdown()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--kernel", choices=("python", "serve"), default="python")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--loops", type=int, default=20_000_000, help="python kernel's iterations")
    ap.add_argument("--serves", type=int, default=10, help="serve kernel's episodes")
    add_scenario_option(ap)
    args = ap.parse_args()
    size = args.serves if args.kernel == "serve" else args.loops
    print(f"kernel {args.kernel}, {args.workers} workers")
    for r in range(args.rounds):
        (one_wall, one_cpu), = _run(args.kernel, size, 1, args.scenario)
        many = _run(args.kernel, size, args.workers, args.scenario)
        walls = [w for w, _ in many]
        cpus = [c for _, c in many]
        speedup = args.workers * one_wall / max(walls)
        print(f"  round {r + 1}: 1 process {one_wall:.2f} s wall ({one_cpu:.2f} CPU); "
              f"{args.workers} processes {', '.join(f'{w:.2f}' for w in walls)} s wall "
              f"({', '.join(f'{c:.2f}' for c in cpus)} CPU); speed-up {speedup:.2f}x, "
              f"CPU per process {sum(cpus) / len(cpus) / one_cpu:.2f}x one's")


if __name__ == "__main__":
    main()
