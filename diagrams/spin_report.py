"""Spin and hitting-point errors at the moment the analytical player commits the hitting stage.

    python -m tt_drake.diagrams.spin_report --serves N --seed S [--scenario Y] [--distribution D]
        [--json FILE]

For every serve (episode seeds as in ``tt-drake serve``): the full serve episode with the
analytical player and camera perception, logging the estimator's spin; the commit time is the
start of the hitting stage in the player's final plan. Compared there:

- the estimated spin against Drake's (the ball body's angular velocity, world frame);
- the hitting point the player's planner predicts from the estimate at the commit
  (``commit_p_hit_error_mm``), and the one its final stroke was planned on after any corrections
  during the hitting stage (``p_hit_error_mm``, ``t_hit_error_ms``), against the true crossing
  of the virtual hitting plane: the same launch state flown in the ball-only Drake world (no
  racket in the way; Hermite interpolation of a 600 Hz log);
- the spin at impact the final stroke was planned with against Drake's at the crossing.

Prints a one-line summary per quantity (median, 90th percentile) and writes per-serve rows.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from tt_drake.constants import PLANES

LOG_PERIOD = 1.0 / 240.0


def _logged_analytical_player(builder, world, controller, scenario) -> list:
    """The analytical player of ``tt-drake serve``, plus loggers of the estimator's spin and
    status."""
    from pydrake.systems.primitives import VectorLogSink

    from tt_drake.diagrams.episodes import PLAYERS

    seeded = PLAYERS["analytical"](builder, world, controller, scenario)
    estimator = builder.GetSubsystemByName("ball_flight_estimator")
    for name, port, size in (("spin_logger", "spin", 3), ("spin_status_logger", "status", 2),
                             ("spin_state_logger", "state", 6)):
        log = builder.AddNamedSystem(name, VectorLogSink(size, LOG_PERIOD))
        builder.Connect(estimator.GetOutputPort(port), log.get_input_port())
    return seeded


def _at(times: np.ndarray, values: np.ndarray, t: float) -> np.ndarray:
    """The last logged row at or before ``t``."""
    k = int(np.searchsorted(times, t + 1e-9)) - 1
    return values[max(k, 0)]


def true_crossing(world, launch_state) -> np.ndarray | None:
    """(p, v, omega, t) where the launched ball's centre crosses the hitting plane in the
    ball-only Drake world, or None."""
    from tt_drake.hitting_point import plane_crossing_from_samples

    t, p, v, w = world.run(launch_state, 2.0)
    hit = plane_crossing_from_samples(t, p, v, PLANES.hitting_y)
    if hit is None:
        return None
    tc, pc, vc = hit
    return np.r_[pc, vc, _at(t, w, tc), tc]


def serve_report(diagram, ball_world, seed: int) -> dict:
    """One serve's row (see the module docstring); NaN entries when the player never
    committed."""
    from tt_drake.stages import HITTING

    result = diagram.run(seed)
    ctx = diagram.context
    row = {"seed": seed, "outcome": str(result.outcome.as_dict().get("outcome")),
           "returned": bool(result.outcome.returned)}
    player = diagram.player
    state = player.player_state(player.GetMyContextFromRoot(ctx))
    hit = next((seg for stage, seg in state.plan.segments if stage == HITTING), None)
    crossing = true_crossing(ball_world, result.launch_state)
    if not state.committed or hit is None or state.stroke is None or crossing is None:
        row["committed"] = False
        return row
    t_commit = float(hit.t0)
    spin_log = diagram.diagram.GetSubsystemByName("spin_logger").FindLog(ctx)
    status_log = diagram.diagram.GetSubsystemByName("spin_status_logger").FindLog(ctx)
    ball_log = diagram.ball_logger.FindLog(ctx)
    state_log = diagram.diagram.GetSubsystemByName("spin_state_logger").FindLog(ctx)
    spin_est = _at(spin_log.sample_times(), spin_log.data().T, t_commit)
    status = _at(status_log.sample_times(), status_log.data().T, t_commit)
    tracking = status[0] > 0.5
    at_commit = player.planner.predict(_at(state_log.sample_times(), state_log.data().T,
                                           t_commit), float(status[1]), spin_est)
    spin_true = _at(ball_log.sample_times(), ball_log.data()[7:10].T, t_commit)
    stroke = state.stroke
    row.update({
        "committed": True, "t_commit": t_commit, "tracking_at_commit": bool(tracking),
        "spin_estimate": spin_est.tolist(), "spin_true": spin_true.tolist(),
        "spin_error": float(np.linalg.norm(spin_est - spin_true)),
        "commit_p_hit_error_mm": (float(1e3 * np.linalg.norm(at_commit[0] - crossing[0:3]))
                                  if at_commit is not None else float("nan")),
        "p_hit_error_mm": float(1e3 * np.linalg.norm(stroke.p_hit - crossing[0:3])),
        "t_hit_error_ms": float(1e3 * (stroke.t_hit - crossing[9])),
        "impact_spin_error": float(np.linalg.norm(stroke.spin - crossing[6:9])),
        "true_impact_spin": crossing[6:9].tolist(),
    })
    return row


def summarise(rows: list[dict]) -> dict:
    done = [r for r in rows if r.get("committed")]
    out = {"serves": len(rows), "committed": len(done),
           "return_rate": sum(r["returned"] for r in rows) / max(len(rows), 1)}
    for key in ("spin_error", "impact_spin_error", "commit_p_hit_error_mm", "p_hit_error_mm"):
        a = np.array([r[key] for r in done])
        a = a[np.isfinite(a)]
        if len(a):
            out[key] = {"median": float(np.median(a)), "p90": float(np.percentile(a, 90))}
    a = np.abs([r["t_hit_error_ms"] for r in done])
    if len(a):
        out["abs_t_hit_error_ms"] = {"median": float(np.median(a)),
                                     "p90": float(np.percentile(a, 90))}
    return out


def main(argv=None) -> int:
    from tt_drake.diagrams.ball_world import BallOnlyWorld
    from tt_drake.diagrams.episodes import ServeDiagram, episode_seed
    from tt_drake.diagrams.scenario import load_scenario, validate
    from tt_drake.outputs import check_writable, write_json_atomic

    p = argparse.ArgumentParser(prog="python -m tt_drake.diagrams.spin_report")
    p.add_argument("--serves", type=int, required=True)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--scenario", default="default")
    p.add_argument("--distribution", default=None)
    p.add_argument("--json", default=None)
    args = p.parse_args(argv)
    try:
        if args.serves <= 0:
            raise ValueError(f"--serves must be positive, got {args.serves}")
        scenario = load_scenario(args.scenario)
        if args.distribution is not None:
            scenario.launcher.distribution = args.distribution
            validate(scenario, "--distribution")
        if args.json:
            check_writable(args.json)
    except (ValueError, OSError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    diagram = ServeDiagram(scenario, _logged_analytical_player, log_ball=True,
                           end_when_decided=True)
    ball_world = BallOnlyWorld(log_period=1.0 / 600.0)
    rows = [serve_report(diagram, ball_world, episode_seed(args.seed, i))
            for i in range(args.serves)]
    summary = summarise(rows)
    print(summary)
    if args.json:
        write_json_atomic(args.json, {"scenario": scenario.name, "seed": args.seed,
                                      "distribution": scenario.launcher.distribution,
                                      "summary": summary, "serves": rows})
    return 0


if __name__ == "__main__":
    sys.exit(main())
