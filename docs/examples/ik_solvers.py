"""The teacher's inverse-kinematics runs solved by SNOPT and by the compiled SQP, start by start
(docs/hitting_ik.md, "Solvers").

    OPENBLAS_NUM_THREADS=1 python docs/examples/ik_solvers.py [--serves 20] [--seed 3]
        [--distribution D] [--spin-max W] [--scenario S] [--json FILE]

Plays ``--serves`` serves of the analytical player (SNOPT, the default solver) and records every
solver run (``HittingIK.solve_from``: the request, its start and its cost's posture). Then
solves each recorded run again from the same start with SNOPT and with the SQP
(``tt_drake.ik_kernel.solve_hitting_pose``), alternating the order run by run, and prints the
CPU time per run of each (``time.process_time``), the SQP's iterations, how many answers of each
pass the IK's forward-kinematics check, and, over the runs both pass, the largest joint
difference between the two answers (quantiles) and the difference of their costs.
"""

from __future__ import annotations

import argparse
import sys
import time
from unittest import mock

import numpy as np

from tt_drake.diagrams.commands.options import add_scenario_options, scenario_from_options
from tt_drake.diagrams.episodes import ServeDiagram, episode_seed
from tt_drake.ik_kernel import solve_hitting_pose
from tt_drake.outputs import write_json_atomic
from tt_drake.systems.hitting_ik import SOLVER_ANGLE_BOUND, SOLVER_POSITION_BOUND, HittingIK


def record_runs(scenario, serves: int, seed: int) -> list[tuple]:
    """Every solver run of the teacher over the serves: (p_hit, normal, start, (q_c, w))."""
    runs = []
    solve_from = HittingIK.solve_from

    def recorded(self, p_hit, normal, start, posture):
        runs.append((np.array(p_hit), np.array(normal), np.array(start),
                     (np.array(posture[0]), np.array(posture[1]))))
        return solve_from(self, p_hit, normal, start, posture)

    with mock.patch.object(HittingIK, "solve_from", recorded):
        diagram = ServeDiagram(scenario, "analytical")
        for i in range(serves):
            diagram.run(episode_seed(seed, i))
    return runs


def compare(runs: list[tuple]) -> dict:
    """Both solvers on every run (module docstring)."""
    arm = HittingIK()
    cpu = {"snopt": 0.0, "sqp": 0.0}
    passed = {"snopt": 0, "sqp": 0}
    iterations, converged, differences, costs = [], 0, [], []
    for k, (p_hit, normal, start, posture) in enumerate(runs):
        answers = {}
        for solver in (("snopt", "sqp") if k % 2 else ("sqp", "snopt")):
            c0 = time.process_time()
            if solver == "snopt":
                q = arm.solve_from(p_hit, normal, start, posture)
            else:
                q, _, ok, its = solve_hitting_pose(
                    start, p_hit, normal, posture[0], posture[1], arm.lower, arm.upper,
                    SOLVER_POSITION_BOUND, SOLVER_ANGLE_BOUND)
                converged += ok
                iterations.append(its)
            cpu[solver] += time.process_time() - c0
            answers[solver] = q
        ok = {s: arm.check(q, p_hit, normal)[2] for s, q in answers.items()}
        for s in ok:
            passed[s] += ok[s]
        if ok["snopt"] and ok["sqp"]:
            differences.append(float(np.abs(answers["sqp"] - answers["snopt"]).max()))
            costs.append(arm.cost(answers["sqp"], posture) - arm.cost(answers["snopt"], posture))
    n = max(len(runs), 1)
    quantiles = np.quantile(differences, [0.5, 0.9, 0.99, 1.0]).tolist() if differences else []
    return {"runs": len(runs), "sqp_converged": converged,
            "sqp_iterations_median": float(np.median(iterations)) if iterations else 0.0,
            "sqp_iterations_max": int(max(iterations, default=0)),
            "cpu_us_per_run": {s: 1e6 * c / n for s, c in cpu.items()},
            "passed_check": passed, "both_passed": len(differences),
            "joint_difference_quantiles_50_90_99_100": quantiles,
            "cost_difference_min_max": [min(costs, default=0.0), max(costs, default=0.0)]}


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--serves", type=int, default=20)
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--json", default=None, help="write the figures to this file")
    add_scenario_options(ap)
    args = ap.parse_args(argv)
    scenario = scenario_from_options(args)
    result = compare(record_runs(scenario, args.serves, args.seed))
    result.update(serves=args.serves, seed=args.seed)
    for key, value in result.items():
        print(f"{key}: {value}")
    if args.json:
        write_json_atomic(args.json, result)
    return result


if __name__ == "__main__":
    main(sys.argv[1:])
