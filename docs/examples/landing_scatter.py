"""Why the learned player's returns scatter: the landing error split along the stroke's chain
(docs/learned_player.md, "Why the hard player's returns scatter").

    OPENBLAS_NUM_THREADS=1 python docs/examples/landing_scatter.py --artefacts hard \\
        --distribution spin --serves 60 --seed 2026 [--library L --crkr C --predictor P] \\
        [--perception camera|oracle] [--json F] [--scenario S]

Plays the serves of ``tt-drake serve --player momp ... --configuration analytical`` with the
moving goal (``--seed S``: ``episode_seed(S, i)``, the pools dealt by run seed S) in this process
and, for every stroke that met the ball, compares five racket states (blade-centre velocity and
normal, by forward kinematics of the control plant, ``HittingIK``) at the time the TRUE ball
reaches the stroke's hitting surface (the ball-only Drake world, ``spin_report.TrueFlight``):

- ``oracle``: the teacher's aim + racket law + IK on the true ball there (its true spin);
- ``oracle_spinless``: the same with the spin taken as zero;
- ``goal``: the stroke's hitting configuration (theta_hit, theta_dot_hit), the one the
  ``HittingConfiguration`` gave for the player's last prediction;
- ``plan_t_hit`` / ``plan``: the executed plan (desired state) at the stroke's t_hit / at the
  true time;
- ``measured``: the arm's measured state at the true time (250 Hz log, linear in between).

Each racket state is turned into a landing point by the teacher's own model (the racket law
forward and the planner's ball model with the ball's true spin to the first table bounce,
``racket_law.landing_after_racket``). The landing shifts between consecutive states are the links
of the chain: prediction and spin (oracle -> goal), the DMP's arrival (goal -> plan at t_hit),
timing (t_hit -> true time), arm tracking (plan -> measured) and what the model leaves out
(measured -> the referee's landing: the contact itself, e.g. the friction on a spinning ball
whose contact point the racket does not follow). Prints, per link, the mean and standard
deviation of the lateral (x) and along-table (y) shift, and the racket-state differences.
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np

from tt_drake.ball_model import BallModel
from tt_drake.constants import BALL
from tt_drake.diagrams.ball_world import BallOnlyWorld
from tt_drake.diagrams.commands.options import add_scenario_option
from tt_drake.diagrams.episodes import ServeDiagram, episode_seed
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.diagrams.spin_report import TrueFlight
from tt_drake.models import use_artefact_set
from tt_drake.racket_law import RacketState, landing_after_racket, racket_restitution

STATES = ("oracle", "oracle_spinless", "goal", "plan_t_hit", "plan", "measured")
LINKS = (("spin in the aim (true ball)", "oracle", "oracle_spinless"),
         ("prediction and spin (oracle -> goal)", "oracle", "goal"),
         ("DMP arrival (goal -> plan at t_hit)", "goal", "plan_t_hit"),
         ("timing (plan at t_hit -> at true time)", "plan_t_hit", "plan"),
         ("arm tracking (plan -> measured)", "plan", "measured"),
         ("contact not in the model (measured -> referee)", "measured", "referee"))


def racket_state(arm, q, qd) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(blade centre, unit normal, blade-centre velocity) in the world for joint state (q, qd)."""
    pose = arm.racket_pose(q)
    return (pose.translation().copy(), pose.rotation().matrix()[:, 1].copy(),
            arm.racket_velocity(q, qd)[3:].copy())


def model_landing(model: BallModel, p, v_in, spin, normal, velocity) -> np.ndarray:
    """(x, y) of the first table bounce after the racket (normal, velocity) meets the ball
    (p, v_in, spin): the teacher's racket law forward and ball model; NaN if it misses the
    table."""
    rel = float(normal @ (np.asarray(velocity) - v_in))
    racket = RacketState(normal, np.asarray(velocity), racket_restitution(abs(rel)))
    landing = landing_after_racket(p, v_in, racket, spin, model)
    return np.full(2, np.nan) if landing is None else landing


def _interpolate(times, rows, t: float) -> np.ndarray:
    k = int(np.clip(np.searchsorted(times, t) - 1, 0, len(times) - 2))
    s = (t - times[k]) / (times[k + 1] - times[k])
    return (1.0 - s) * rows[k] + s * rows[k + 1]


def serve_row(diagram: ServeDiagram, ball_world, planner, seed: int) -> dict:
    """One serve (module docstring); ``analysed`` False when no stroke met the ball."""
    result = diagram.run(seed)
    outcome = result.outcome
    row = {"seed": seed, "outcome": outcome.as_dict().get("outcome"),
           "returned": bool(outcome.returned), "on_target": bool(outcome.on_target),
           "landing": None if outcome.landing is None else list(map(float, outcome.landing)),
           "analysed": False}
    player = diagram.player
    state = player.player_state(player.GetMyContextFromRoot(diagram.context))
    stroke = state.stroke
    if stroke is None or not outcome.hit or stroke.held or stroke.fallback:
        return row
    truth = TrueFlight(ball_world, result.launch_state).crossing(stroke.stimulus[:3],
                                                                 stroke.t_hit)
    if truth is None:
        return row
    p, v, w, t_true = truth[0:3], truth[3:6], truth[6:9], float(truth[9])
    arm = planner.arm
    states = {}
    for name, spin in (("oracle", w), ("oracle_spinless", np.zeros(3))):
        solved = planner.stroke(p, v, t_true, spin, None)
        states[name] = None if solved is None else racket_state(arm, solved.q_hit, solved.qd_hit)
    states["goal"] = racket_state(arm, stroke.q_hit, stroke.qd_hit)
    q, qd, _ = state.plan.evaluate(stroke.t_hit)
    states["plan_t_hit"] = racket_state(arm, q, qd)
    q, qd, _ = state.plan.evaluate(t_true)
    states["plan"] = racket_state(arm, q, qd)
    log = diagram.arm_logger.FindLog(diagram.context)
    x = _interpolate(log.sample_times(), log.data().T, t_true)
    states["measured"] = racket_state(arm, x[:7], x[7:])
    model = planner.model
    landings = {name: (np.full(2, np.nan) if s is None
                       else model_landing(model, p, v, w, s[1], s[2]))
                for name, s in states.items()}
    landings["referee"] = (np.full(2, np.nan) if outcome.landing is None
                           else np.asarray(outcome.landing, dtype=float))
    racket = {}
    for name, s in states.items():
        if s is None:
            continue
        centre, normal, vel = s
        off = p - centre  # the ball's centre from the blade centre, in the blade's plane
        racket[name] = {"normal": normal.tolist(), "velocity": vel.tolist(),
                        "blade_offset_mm": float(1e3 * np.linalg.norm(off - (off @ normal)
                                                                      * normal))}
    # How fast the blade slides past the ball's contact point (the teacher's racket law makes
    # it zero: the racket moves with the spinning ball's contact point).
    centre, normal, vel = states["measured"]
    contact = v + np.cross(w, -BALL.radius * normal)
    slide = vel - contact
    stimulus = np.asarray(stroke.stimulus, dtype=float)
    row.update({
        "slip": float(np.linalg.norm(slide - (slide @ normal) * normal)),
        "spinless": bool(getattr(stroke, "spinless", False)),
        "analysed": True, "t_hit_error_ms": 1e3 * (stroke.t_hit - t_true),
        "p_hit_error_mm": float(1e3 * np.linalg.norm(stimulus[:3] - p)),
        "spin_true": w.tolist(),
        "spin_predicted": stimulus[6:9].tolist() if stimulus.size >= 9 else None,
        "racket": racket, "model_landing": {k: v.tolist() for k, v in landings.items()},
        "primitives": stroke.primitives.tolist(), "mixture": stroke.mixture.tolist()})
    return row


def _angle_deg(a, b) -> float:
    return float(np.degrees(np.arccos(np.clip(np.dot(a, b), -1.0, 1.0))))


def summarise(rows: list[dict], target) -> str:
    done = [r for r in rows if r["analysed"]]
    out = [f"{len(rows)} serves, {len(done)} strokes analysed; "
           f"{sum(r['returned'] for r in rows)} legal returns, "
           f"{sum(r['on_target'] for r in rows)} on target"]
    land = np.array([r["landing"] for r in rows if r["returned"] and r["landing"]])
    if len(land):
        out.append(f"legal returns' landing: mean ({land[:, 0].mean():+.3f}, "
                   f"{land[:, 1].mean():.3f}) m, std ({land[:, 0].std():.3f}, "
                   f"{land[:, 1].std():.3f}) m; target ({target[0]}, {target[1]})")
    for name in (*STATES, "referee"):
        pts = np.array([r["model_landing"][name] for r in done])
        pts = pts[np.isfinite(pts).all(axis=1)]
        if len(pts):
            out.append(f"  landing from {name:16s}: mean ({pts[:, 0].mean():+.3f}, "
                       f"{pts[:, 1].mean():.3f}), std ({pts[:, 0].std():.3f}, "
                       f"{pts[:, 1].std():.3f}) m  [{len(pts)}]")
    out.append("| link | lateral shift mean / std (mm) | along-table shift mean / std (mm) "
               "| racket velocity change median / p90 (m/s) | normal change median / p90 "
               "(deg) |")
    out.append("|---|---|---|---|---|")
    for label, a, b in LINKS:
        d = np.array([np.subtract(r["model_landing"][b], r["model_landing"][a]) for r in done])
        d = 1e3 * d[np.isfinite(d).all(axis=1)]
        dv, dn = [], []
        for r in done:
            ra, rb = r["racket"].get(a), r["racket"].get(b)
            if ra is not None and rb is not None:
                dv.append(float(np.linalg.norm(np.subtract(rb["velocity"], ra["velocity"]))))
                dn.append(_angle_deg(ra["normal"], rb["normal"]))
        rk = (f"{np.median(dv):.3f} / {np.percentile(dv, 90):.3f} | "
              f"{np.median(dn):.2f} / {np.percentile(dn, 90):.2f}") if dv else "- | -"
        out.append(f"| {label} | {d[:, 0].mean():+.0f} / {d[:, 0].std():.0f} | "
                   f"{d[:, 1].mean():+.0f} / {d[:, 1].std():.0f} | {rk} |" if len(d) else
                   f"| {label} | - | - | {rk} |")
    t_err = [r["t_hit_error_ms"] for r in done]
    p_err = [r["p_hit_error_mm"] for r in done]
    offs = [r["racket"]["measured"]["blade_offset_mm"] for r in done]
    out.append(f"t_hit - true time: median {np.median(t_err):+.1f} ms, |.| p90 "
               f"{np.percentile(np.abs(t_err), 90):.1f} ms; hitting point error median "
               f"{np.median(p_err):.1f} mm, p90 {np.percentile(p_err, 90):.1f} mm; ball from "
               f"the blade centre (measured) median {np.median(offs):.0f} mm")
    spins = [np.linalg.norm(r["spin_true"]) for r in done]
    slips = [r["slip"] for r in done]
    out.append(f"true spin at the hitting surface: median {np.median(spins):.0f} rad/s; the "
               f"measured blade slides past the ball's contact point at median "
               f"{np.median(slips):.2f} m/s, p90 {np.percentile(slips, 90):.2f} m/s")
    spinless = [r for r in done if r["spinless"]]
    if spinless:
        out.append(f"{len(spinless)} strokes took the spinless velocities (refused with the "
                   "spin-aware ones)")
    kept = np.array([r["landing"] for r in done if r["returned"] and not r["spinless"]])
    if len(kept) and spinless:
        out.append(f"legal returns' landing without them: std ({kept[:, 0].std():.3f}, "
                   f"{kept[:, 1].std():.3f}) m [{len(kept)}]")
    return "\n".join(out)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--artefacts", default="hard")
    ap.add_argument("--library")
    ap.add_argument("--crkr")
    ap.add_argument("--predictor")
    ap.add_argument("--distribution", default="spin")
    ap.add_argument("--perception", choices=("camera", "oracle"), default="camera")
    ap.add_argument("--serves", type=int, default=60)
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--json")
    add_scenario_option(ap)
    args = ap.parse_args()

    scenario = load_scenario(args.scenario)
    use_artefact_set(scenario.learned, args.artefacts)
    learned = scenario.learned
    for name in ("library", "crkr", "predictor"):
        if getattr(args, name):
            setattr(learned, name, getattr(args, name))
    learned.moving_goal, learned.configuration = True, "analytical"
    scenario.perception = args.perception
    scenario.launcher.distribution = args.distribution
    scenario.launcher.run_seed = args.seed  # as `tt-drake serve --seed S` deals a pool
    diagram = ServeDiagram(scenario, "momp", log_ball=True)
    planner = diagram.diagram.GetSubsystemByName("hitting_configuration").planner
    ball_world = BallOnlyWorld(log_period=1.0 / 600.0)
    rows = []
    for i in range(args.serves):
        rows.append({"index": i, **serve_row(diagram, ball_world, planner,
                                             episode_seed(args.seed, i))})
        print(i, rows[-1]["outcome"], file=sys.stderr, flush=True)
    print(summarise(rows, (scenario.referee.target_x, scenario.referee.target_y)))
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"seed": args.seed, "distribution": args.distribution,
                       "perception": args.perception, "rows": rows}, f)
    return 0


if __name__ == "__main__":
    sys.exit(main())
