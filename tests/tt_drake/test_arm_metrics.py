"""The arm's saturation metric: a command at the effort limit, or with drives past what the
motor gives at the sample's joint speed (a - b q_dot, computed here from Barrett's numbers)."""

import numpy as np

from tt_drake.arm_metrics import arm_metrics
from tt_drake.drives import DriveEnvelope


def test_a_command_inside_the_effort_limit_saturates_a_fast_joints_drive():
    # J1 at 2.0 rad/s: the 48 V drive gives at most 42 * 0.457 * 48 / 3.473 (265.3 N m)
    # less 265.3 / 2.386 N m s/rad * 2.0 rad/s = 42.9 N m in the direction of motion.
    stall = 42 * 0.457 * 48 / 3.473
    upper = stall - stall / (100.218 / 42) * 2.0
    q = np.zeros((3, 7))
    qd = np.zeros((3, 7))
    qd[:, 0] = 2.0
    tau = np.zeros((3, 7))
    tau[:, 0] = [upper - 1.0, upper + 1.0, -74.0]  # below, above, braking within E
    ideal = arm_metrics(q, qd, tau)
    driven = arm_metrics(q, qd, tau, DriveEnvelope(48.0))
    assert ideal["saturated_fraction"] == 0.0
    assert driven["saturated_fraction"] == 1 / 3
    assert driven["saturated_samples_per_joint"] == [1, 0, 0, 0, 0, 0, 0]
    tau[:, 0] = 75.0  # the effort limit saturates either way
    assert arm_metrics(q, qd, tau)["saturated_fraction"] == 1.0
