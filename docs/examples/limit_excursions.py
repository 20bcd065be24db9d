"""Why an arm passes a joint's position limit although its plan stays inside it
(docs/analytical_player.md, "Drives"): plays serves of ``tt-drake serve`` in one process and,
for each episode in which a joint leaves its limits, prints at the sample where that joint is
farthest past its limit:

- the joint, how far past the limit, the set-point the servo held then and how far the joint
  had run past it;
- the torque the InverseDynamicsController commanded for that joint,
  tau_j = sum_k M_jk(q) vd_k + b_j(q, v) with its acceleration command
  vd = qdd_d + kp (q_d - q) + kd (v_d - v), split into the joint's own term M_jj vd_j, the
  coupling sum_{k != j} M_jk vd_k and the bias b_j (gravity and Coriolis), from the control
  plant's inverse dynamics (``HittingIK.chain``: its mass matrix and ``torques``);
- which joints' commands the drives clamped at that sample.

With the arm's joint stops (the default: systems/joint_stops.py) a joint goes only the stop's
few milliradians past its limit; ``--no-stops`` takes them out of the plant, to show how far the
controller alone would take it.

    OPENBLAS_NUM_THREADS=1 python docs/examples/limit_excursions.py --distribution rally-train \\
        --serves 40 --seed 5101 [--no-stops] [--player analytical] [--scenario S] [--show 3]
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from tt_drake import wam_params as wp
from tt_drake.diagrams.episodes import ServeDiagram
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.drives import EffortBudget, drive_envelope
from tt_drake.seeds import episode_seed
from tt_drake.systems.hitting_ik import HittingIK
from tt_drake.systems.wam import KD, KP


def torque_terms(ik: HittingIK, q, v, vd, joint: int) -> tuple[float, float, float]:
    """(own, coupling, bias) of joint ``joint``'s computed torque at (q, v) for the
    acceleration command ``vd``: M_jj vd_j, sum_{k != j} M_jk vd_k and b_j(q, v)."""
    row = ik.chain.mass_matrix(q)[joint]
    own = row[joint] * vd[joint]
    bias = ik.torques(q, v, np.zeros(len(q)))[joint]
    return float(own), float(row @ vd - own), float(bias)


def excursions(scenario, player: str, serves: int, seed: int, show: int):
    """Play serves 0 .. ``serves`` - 1 of ``seed``; returns (the number of episodes with a joint
    past its limit, a record of the first ``show`` of them: the serve, its outcome, the joint
    (0-based), how far past the limit, the set-point, the measured angle, the computed torque's
    terms, the logged command and the joints whose commands the drives clamped)."""
    scenario.launcher.run_seed = seed
    diagram = ServeDiagram(scenario, player, log_setpoints=True)
    if diagram.arm_logger is None:
        raise ValueError("the scenario has no robot")
    ik = HittingIK()
    bounds = EffortBudget(1.0, drive_envelope(scenario.controller.drive_voltage)).bounds
    lower, upper = np.asarray(wp.JOINT_LOWER), np.asarray(wp.JOINT_UPPER)
    kp, kd = np.asarray(KP), np.asarray(KD)
    found, records = 0, []
    for i in range(serves):
        result = diagram.run(episode_seed(seed, i))
        arm = diagram.arm_logger.FindLog(diagram.context)
        x, t = arm.data().T, arm.sample_times()
        q, v = x[:, :7], x[:, 7:]
        excess = np.maximum(q - upper, lower - q)
        if excess.max() <= 0.0:
            continue
        found += 1
        if len(records) >= show:
            continue
        k, j = np.unravel_index(int(np.argmax(excess)), excess.shape)
        held = diagram.setpoint_logs[0].FindLog(diagram.context)
        s = int(np.searchsorted(held.sample_times(), t[k], side="right")) - 1
        q_d, v_d, a_d = np.split(held.data()[:, s], 3)
        vd = a_d + kp * (q_d - q[k]) + kd * (v_d - v[k])
        tau = diagram.torque_logger.FindLog(diagram.context).data()[:, k]
        low, high = bounds(v[k])
        records.append({"serve": i, "outcome": result.outcome.outcome, "joint": int(j),
                        "time": float(t[k]), "excess": float(excess[k, j]),
                        "setpoint": float(q_d[j]), "angle": float(q[k, j]),
                        "terms": torque_terms(ik, q[k], v[k], vd, j),
                        "acceleration_command": float(vd[j]), "logged": tau.copy(),
                        "applied_base": float(np.clip(tau[0], low[0], high[0])),
                        "clamped": [n for n in range(7) if not low[n] <= tau[n] <= high[n]]})
    return found, records


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--player", default="analytical")
    ap.add_argument("--distribution", default="rally-train")
    ap.add_argument("--serves", type=int, default=40)
    ap.add_argument("--seed", type=int, default=5101)
    ap.add_argument("--scenario", default="default")
    ap.add_argument("--show", type=int, default=3, help="episodes to print (default 3)")
    ap.add_argument("--no-stops", action="store_true",
                    help="take the joint stops out of the plant")
    args = ap.parse_args(argv)
    if args.serves < 1 or args.show < 1:
        ap.error("--serves and --show must be >= 1")
    scenario = load_scenario(args.scenario)
    scenario.launcher.distribution = args.distribution
    if args.no_stops:
        scenario.world.joint_stops.enabled = False
    found, records = excursions(scenario, args.player, args.serves, args.seed, args.show)
    for r in records:
        j = r["joint"]
        own, coupling, bias = r["terms"]
        print(f"serve {r['serve']} ({r['outcome']}): joint {j + 1} {r['excess']:.3f} rad past "
              f"its limit at t = {r['time']:.3f} s, {r['angle'] - r['setpoint']:+.3f} rad from "
              f"its set-point {r['setpoint']:+.3f}")
        print(f"  its command {own + coupling + bias:+.2f} N m (logged {r['logged'][j]:+.2f}): "
              f"own term {own:+.2f}, coupling from the other joints {coupling:+.2f}, bias "
              f"{bias:+.2f}; acceleration command {r['acceleration_command']:+.0f} rad/s^2")
        print(f"  commands the drives clamped: joints {[n + 1 for n in r['clamped']] or 'none'}; "
              f"base {r['logged'][0]:+.1f} N m commanded, {r['applied_base']:+.1f} applied")
    print(f"{found} of {args.serves} episodes with a joint past its limit")
    return 0


if __name__ == "__main__":
    sys.exit(main())
