"""What the arm did in an episode: joint-limit excess, joint speed, torque saturation.

Computed from sampled arm states (q, q_dot) and the controller's commanded torques. The plant
silently clamps each actuator to its effort limit (docs/constants.md), and drives of a supply
voltage to their speed-dependent bounds (tt_drake.drives), so saturation is seen by comparing
the command with what the actuator gives at the sample's joint speed.
"""

import numpy as np

from tt_drake import wam_params as wp


def arm_metrics(q: np.ndarray, qd: np.ndarray, tau: np.ndarray, drive=None) -> dict:
    """``q``, ``qd``, ``tau``: (n_samples, 7); ``drive``: the arm's
    :class:`tt_drake.drives.DriveEnvelope` (None: ideal drives). A sample is saturated where the
    command reaches the effort limit or, with drives, leaves their bounds at its joint speed.
    Returns plain floats and lists for JSON."""
    lower, upper = np.asarray(wp.JOINT_LOWER), np.asarray(wp.JOINT_UPPER)
    effort = np.asarray(wp.EFFORT_LIMIT)
    excess = np.maximum(np.maximum(q - upper, lower - q), 0.0)
    saturated = np.abs(tau) >= effort * (1.0 - 1e-9)
    if drive is not None and tau.size:
        low, high = drive.bounds(qd)
        saturated |= (tau > high) | (tau < low)
    return {
        "joint_limit_excess": float(excess.max()) if excess.size else 0.0,
        "max_joint_speed": float(np.abs(qd).max()) if qd.size else 0.0,
        "saturated_fraction": float(saturated.any(axis=1).mean()) if tau.size else 0.0,
        "saturated_samples_per_joint": saturated.sum(axis=0).astype(int).tolist(),
    }
