"""Each joint's peak speed in the teacher's serve episodes, beside the stock WAM motors' no-load
speeds at the joints (docs/constants.md, "Drives").

    python docs/examples/joint_speeds.py [--distribution default] [--seed 6002] [--serves 60]
                                         [--scenario ideal_robot]

Runs the analytical player on ``--serves`` serves (base seed ``--seed``) and prints, per joint,
the median, 90th percentile and largest peak |q_dot| over the episodes (the arm logger's
250 Hz samples of the simulated arm), and the share of episodes whose peak exceeds the joint's
no-load speed (:data:`NO_LOAD_SPEED`).
"""

import argparse

import numpy as np

from tt_drake.diagrams.commands.options import add_scenario_option
from tt_drake.diagrams.episodes import ServeDiagram
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.drives import DriveEnvelope
from tt_drake.seeds import episode_seed
from tt_drake.wam_params import DESIGN_VOLTAGE

# Joint-side no-load speed (rad/s) of the stock WAM drives at their 48 V design voltage:
# Barrett's listed motor no-load speeds over the transmission ratios (tt_drake.drives).
NO_LOAD_SPEED = DriveEnvelope(DESIGN_VOLTAGE).no_load_speed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--distribution", default="default")
    parser.add_argument("--seed", type=int, default=6002)
    parser.add_argument("--serves", type=int, default=60)
    add_scenario_option(parser)
    args = parser.parse_args()
    scenario = load_scenario(args.scenario)
    scenario.launcher.distribution = args.distribution
    diagram = ServeDiagram(scenario, "analytical")
    peaks = []
    for i in range(args.serves):
        diagram.run(episode_seed(args.seed, i))
        x = diagram.arm_logger.FindLog(diagram.context).data().T
        peaks.append(np.abs(x[:, 7:]).max(0))
    peaks = np.array(peaks)
    print(f"{args.distribution}, {args.serves} serves (seed {args.seed}), rad/s per joint J1..J7")
    print("  peak, median:     ", np.round(np.median(peaks, 0), 2))
    print("  peak, 90th pct:   ", np.round(np.percentile(peaks, 90, 0), 2))
    print("  peak, largest:    ", np.round(peaks.max(0), 2))
    print("  no-load speed:    ", np.round(NO_LOAD_SPEED, 2))
    print("  share above it:   ", np.round((peaks > NO_LOAD_SPEED).mean(0), 3))


if __name__ == "__main__":
    main()
