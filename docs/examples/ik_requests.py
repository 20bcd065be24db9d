"""The teacher's inverse-kinematics requests in serve episodes: how many, how many failed, how
many of those the wrist test refused without a solver run, and their CPU time
(docs/hitting_ik.md, docs/performance.md).

    OPENBLAS_NUM_THREADS=1 python docs/examples/ik_requests.py [--serves 30] [--seed 3]
        [--distribution D] [--spin-max W] [--scenario S]

Plays ``--serves`` serves of the analytical player (the serves of ``tt-drake bench --seed``
by default) with ``HittingIK.solve`` wrapped by a ``time.process_time`` accumulator, and, for
every request, asks ``HittingIK.may_reach`` apart (``outside_the_wrists_reach``: it should equal
the failures without a solver run). Prints the requests per serve, their CPU, and
the failures split into those the wrist test refuses (no solver run) and those the solver tried
from every start.
"""

from __future__ import annotations

import argparse
import time

from tt_drake.diagrams.commands.options import add_scenario_options, scenario_from_options
from tt_drake.diagrams.episodes import ServeDiagram, episode_seed
from tt_drake.systems.hitting_ik import HittingIK


def count_requests(scenario, serves: int, seed: int) -> dict:
    """Plays the serves and returns the counts and CPU seconds of the IK requests."""
    counts = {"requests": 0, "solved": 0, "refused_by_wrist_test": 0, "failed_in_solver": 0,
              "outside_the_wrists_reach": 0, "cpu_solved": 0.0, "cpu_failed": 0.0}
    solve = HittingIK.solve

    def counted(self, p_hit, normal, q_seed=None, posture=None):
        c0 = time.process_time()
        answer = solve(self, p_hit, normal, q_seed, posture)
        cpu = time.process_time() - c0
        counts["requests"] += 1
        counts["outside_the_wrists_reach"] += not self.may_reach(p_hit, normal)
        if answer.success:
            counts["solved"] += 1
            counts["cpu_solved"] += cpu
        else:
            counts["cpu_failed"] += cpu
            refused = answer.attempts == 0
            counts["refused_by_wrist_test" if refused else "failed_in_solver"] += 1
        return answer

    HittingIK.solve = counted
    try:
        diagram = ServeDiagram(scenario, "analytical")
        for i in range(serves):
            diagram.run(episode_seed(seed, i))
    finally:
        HittingIK.solve = solve
    return counts


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--serves", type=int, default=30)
    ap.add_argument("--seed", type=int, default=3)
    add_scenario_options(ap)
    args = ap.parse_args(argv)
    scenario = scenario_from_options(args)
    c = count_requests(scenario, args.serves, args.seed)
    n = args.serves
    failed = c["refused_by_wrist_test"] + c["failed_in_solver"]
    print(f"analytical, {n} {scenario.launcher.distribution} serves (seed {args.seed}): "
          f"{c['requests'] / n:.1f} IK requests per serve, {1e3 * c['cpu_solved'] / n:.1f} CPU ms "
          f"for the {c['solved']} solved, {1e3 * c['cpu_failed'] / n:.2f} CPU ms for the "
          f"{failed} failed: {c['refused_by_wrist_test']} refused by the wrist test, "
          f"{c['failed_in_solver']} by the solver from every start")
    return c


if __name__ == "__main__":
    main()
