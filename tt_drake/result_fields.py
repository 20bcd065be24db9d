"""The ``fields`` legend of a serve result file: what each field and each vector component is,
and its unit.

Episode records (``EpisodeResult.as_dict``) keep their vectors as plain lists, so that a record
is compact and the pipeline's readers index them; this legend, written into every file beside
them, names the components. Positions and velocities are in the world frame (docs/world.md:
origin on the floor under the table's centre, z up, +y from the robot's end toward the
launcher, +x the robot's forehand side). Joint vectors are the WAM's joints 1-7.
"""

from __future__ import annotations

_P = ["x", "y", "z"]
_V = ["vx", "vy", "vz"]
_W = ["wx", "wy", "wz"]
_JOINTS = [f"joint_{i}" for i in range(1, 8)]


def _vector(meaning: str, components: list[str], units: list[str]) -> dict:
    return {"meaning": meaning, "components": components, "units": units}


def _scalar(meaning: str, unit: str | None = None) -> dict:
    return {"meaning": meaning, "unit": unit}


#: One entry per field of an episode record; nested records (``arm``, ``stroke``) by name.
EPISODE_FIELDS: dict = {
    "seed": _scalar("the episode's seed (tt_drake.diagrams.episodes.episode_seed(run seed, i))"),
    "launch_state": _vector("the ball's state when the launcher released it",
                            _P + _V + _W, ["m"] * 3 + ["m/s"] * 3 + ["rad/s"] * 3),
    "predicted_crossing": _vector(
        "the launcher's model prediction of the ball crossing the hitting plane: position, "
        "velocity, and time after the launch", _P + _V + ["t"], ["m"] * 3 + ["m/s"] * 3 + ["s"]),
    "duration": _scalar("simulated time of the episode", "s"),
    "wall_time": _scalar("wall-clock time the episode took to simulate", "s"),
    "outcome": _scalar("the referee's verdict: returned, missed, fault, ..."),
    "hit": _scalar("the racket touched the ball"),
    "returned": _scalar("a legal return (docs/rules.md): hit after at most one bounce on the "
                        "robot's half, then first bounce on the opponent's half (touching the "
                        "net on the way or not)"),
    "net_touch": _scalar("the return touched the net assembly"),
    "on_target": _scalar("a legal return landing within referee.target_radius of the target"),
    "faults": _scalar("the referee's fault labels (empty for a clean episode): double_bounce, "
                      "net, own_half, out, table_side, double_hit, no_landing, "
                      "robot_table"),
    "returnable": _scalar("with --ceiling: the bound calls this serve returnable (one of its "
                          "oracle strategies returned it legally)"),
    "returnable_by": _scalar("with --ceiling: the first oracle strategy that returned it, or "
                             "null"),
    "landing": _vector("where the returned ball first touched the table (world frame)",
                       ["x", "y"], ["m", "m"]),
    "target_distance": _scalar("distance of the landing point from the target", "m"),
    "hit_time": _scalar("simulation time of the racket's contact (in a recording the clock "
                        "runs on from the earlier episodes)", "s"),
    "reward": _scalar("reward in [0, 1] (tt_drake.referee_rules): 0 missed, 0.2 hit but "
                      "not returned, 0.3 + 0.7 exp(-d^2 / (2 sigma^2)) for a legal return"),
    "arm": {
        "joint_limit_excess": _scalar("largest excursion of a joint beyond its limit", "rad"),
        "max_joint_speed": _scalar("largest joint speed", "rad/s"),
        "saturated_fraction": _scalar("fraction of samples with a torque at its effort limit "
                                      "(with drives: or past their bound at the joint speed)"),
        "saturated_samples_per_joint": _vector("samples at the effort limit (or the drives' "
                                               "bound), per joint",
                                               _JOINTS, ["count"] * 7),
    },
    "stroke": {
        "stimulus": _vector("the learned player's stimulus: predicted hitting point and the "
                            "ball's velocity there", _P + _V, ["m"] * 3 + ["m/s"] * 3),
        "t_hit": _scalar("planned hitting time (simulation clock)", "s"),
        "theta_hit": _vector("hitting configuration: joint angles at the hit", _JOINTS,
                             ["rad"] * 7),
        "theta_dot_hit": _vector("hitting configuration: joint velocities at the hit", _JOINTS,
                                 ["rad/s"] * 7),
        "primitives": _scalar("library indices of the hitting primitives in the mixture"),
        "mixture": _scalar("their mixture weights nu_i (Eq. 6), in the order of primitives"),
        "replans": _scalar("how many times the stroke was planned"),
        "fallback": _scalar("the primitives' plan left the limits: the teacher's quintics "
                            "carried the stroke"),
        "held": _scalar("present and true when the measured arm left the plan and the stroke "
                        "was abandoned for a hold"),
        "spinless": _scalar("present and true when the last move of the goal took the racket "
                            "velocity without the spin's contact-point term"),
        "teacher_stroke": _scalar("present and true when the stroke played is another of the "
                                  "teacher's strokes for the prediction (the configuration's "
                                  "was refused); theta_hit, theta_dot_hit are the played one's"),
        "early_prediction": _scalar("the hitting stage began before the predictor's final "
                                    "(GPR) prediction, on an early physical-model one"),
    },
}

#: The run summary's fields.
SUMMARY_FIELDS: dict = {
    "serves": _scalar("number of serves"),
    "hit_rate": _scalar("share of serves the racket touched (0-1)"),
    "return_rate": _scalar("share of legal returns (0-1)"),
    "target_rate": _scalar("share of legal returns on target (0-1)"),
    "mean_reward": _scalar("mean reward per serve"),
    "joint_limit_violations": _scalar("episodes with a joint beyond its limit"),
    "max_joint_speed": _scalar("largest joint speed over the run", "rad/s"),
    "episodes_with_saturation": _scalar("episodes with a torque at its effort limit"),
    "robot_table_contacts": _scalar("episodes in which the robot touched the table"),
    "fallback_strokes": _scalar("learned strokes carried by the teacher's quintics"),
    "double_bounce_faults": _scalar("strokes that hit the ball after its second bounce on the "
                                    "robot's half (a lost point)"),
    "returnable_rate": _scalar("with --ceiling: share of serves the returnable bound calls "
                               "returnable (docs/rules.md)"),
    "returnable_serves": _scalar("with --ceiling: their number"),
    "returns_of_returnable": _scalar("with --ceiling: the player's legal returns of them"),
    "return_rate_of_returnable": _scalar("with --ceiling: returns_of_returnable / "
                                         "returnable_serves (null if none is returnable)"),
    "returns_outside_ceiling": _scalar("with --ceiling: the player's legal returns of serves the "
                                       "bound calls unreturnable (0 unless the bound is wrong)"),
    "beyond_reach_serves": _scalar("with --ceiling: serves whose ball never comes within the "
                                   "racket's reach (unreturnable, not played by the bound)"),
}


def serve_fields() -> dict:
    """The legend written as ``fields`` into a ``tt-drake serve --json`` file."""
    return {"summary": SUMMARY_FIELDS, "episodes": EPISODE_FIELDS}
