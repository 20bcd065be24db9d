"""Hitting-point, t_hit and spin errors of the predictions a player's stroke is planned on
(the command: :mod:`tt_drake.diagrams.commands.spin_report`).

For every serve (episode i: ``episode_seed(S, i)``, the pools dealt by run seed S, as in
``tt-drake serve``): the full serve episode with camera perception. With ``--ceiling`` the run's
serves are first played by the oracle strategies (``tt-drake serve --ceiling``'s machinery,
:func:`tt_drake.diagrams.serve.returnable_serves`, on ``--workers`` processes) and only the
returnable ones are reported.

**Analytical player** (the players re-plan until the hitting stage is committed; the analytical
player's corrections re-plan it until ``correct_lead`` = 80 ms before the hit). Every stroke the
player stores is recorded with the estimate it was planned from. Four moments, two at each end of
the hitting stage:

- ``commit``: the planner's prediction from the last estimate available when the hitting stage
  began (the swing start, the commit in the paper's sense);
- ``start``: the stroke in effect then, planned on the last estimate before it that moved the
  prediction (re-planning thresholds: 3 mm, 2 ms, 10 rad/s);
- ``cutoff``: the planner's prediction from the last estimate available 80 ms before the final
  stroke's t_hit: the last one a correction may use, i.e. the prediction the stroke is finally
  committed on;
- ``final``: the last stroke, the one the racket was driven to (the last correction, or the
  swing start's stroke when none moved the prediction more than the racket forgives: 10 mm,
  5 ms, 20 rad/s, or none was reachable for the arm).

For each: the hitting-point position error ``*_p_hit_error_mm``, the t_hit error
``*_t_hit_error_ms``, the spin-at-impact error ``*_impact_spin_error`` (rad/s, norm), the
estimator's spin error (norm, rad/s) at the estimate used (``*_spin_error``) and how long before
the predicted hit that estimate was taken (``*_lead_ms``).

**MoMP player**: the hitting stage is committed at its last re-plan; its final stroke's stimulus
and t_hit (``final_*``; no spin).

**Truth**: the same launch flown in the ball-only Drake world (no racket in the way; a 600 Hz log
with Hermite interpolation). The predicted hitting point lies on the virtual hitting plane or,
for a ball the plane cannot serve, where the ball falls through the band's height
(:mod:`tt_drake.hitting_time`); the true point is where the true ball crosses the same surface
(the plane, or that height falling, the crossing nearest the predicted time), and the t_hit
error is the difference of those times. Spin truth: the ball body's angular velocity, world
frame.

Prints a summary (median, 90th percentile of each quantity) and writes per-serve rows.
"""

from __future__ import annotations

import numpy as np
from pydrake.systems.primitives import VectorLogSink

from tt_drake.constants import PLANES
from tt_drake.diagrams.players import player_function
from tt_drake.hitting_point import plane_crossing_from_samples
from tt_drake.stages import HITTING
from tt_drake.systems.analytical_player import AnalyticalPlayer

#: A predicted hitting point this close to the hitting plane is on it (m).
ON_PLANE = 1e-6
PLAYER_CHOICES = ("analytical", "momp")


class RecordingAnalyticalPlayer(AnalyticalPlayer):
    """An AnalyticalPlayer that keeps ``history``: (time, estimate time, stroke, estimated
    spin, committed) for every stroke it stores; cleared by the caller before each episode."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.history: list[tuple] = []

    def _update(self, context, state):
        before = self.player_state(context).stroke
        super()._update(context, state)
        after = state.get_mutable_abstract_state(self._state_index).get_value()
        if after.stroke is not None and after.stroke is not before:
            spin = (np.array(self._spin.Eval(context)) if self._spin.HasValue(context)
                    else np.zeros(3))
            self.history.append((context.get_time(), after.seen, after.stroke, spin,
                                 after.committed))


def logged_player(name: str):
    """The player of ``tt-drake serve`` (the analytical one records its strokes), plus a logger
    of the estimator's spin at the referee's rate (the rate of ServeDiagram's own loggers: no
    extra integrator stops)."""

    def add(builder, world, controller, scenario) -> list:
        if name == "analytical":
            seeded = player_function("analytical")(builder, world, controller, scenario,
                                                   player_type=RecordingAnalyticalPlayer)
        else:
            seeded = player_function(name)(builder, world, controller, scenario)
        if builder.HasSubsystemNamed("ball_flight_estimator"):
            estimator = builder.GetSubsystemByName("ball_flight_estimator")
            log = builder.AddNamedSystem("spin_logger",
                                         VectorLogSink(3, 1.0 / scenario.referee_rate))
            builder.Connect(estimator.GetOutputPort("spin"), log.get_input_port())
        return seeded

    return add


def _at(times: np.ndarray, values: np.ndarray, t: float) -> np.ndarray:
    """The last logged row at or before ``t``; RuntimeError if the log's times go back (a log
    left holding an earlier episode)."""
    if np.any(np.diff(times) < 0.0):
        raise RuntimeError("a log holds more than one episode: clear it before each run")
    k = int(np.searchsorted(times, t + 1e-9)) - 1
    return values[max(k, 0)]


class TrueFlight:
    """The launched ball's path in the ball-only Drake world: (t, p, v, omega) samples."""

    def __init__(self, world, launch_state, duration: float = 2.0):
        self.t, self.p, self.v, self.w = world.run(launch_state, duration)

    def crossing(self, p_pred, t_pred: float) -> np.ndarray | None:
        """(p, v, omega, t) where the ball crosses the surface the predicted hitting point
        ``p_pred`` lies on (module docstring), or None."""
        p_pred = np.asarray(p_pred, dtype=float)
        if abs(p_pred[1] - PLANES.hitting_y) < ON_PLANE:
            hit = plane_crossing_from_samples(self.t, self.p, self.v, PLANES.hitting_y)
        else:  # falling through the height z = p_pred[2]: the crossing nearest t_pred
            z = self.p[:, 2]
            falls = np.nonzero((z[:-1] > p_pred[2]) & (z[1:] <= p_pred[2]))[0]
            if len(falls) == 0:
                return None
            i = int(falls[np.argmin(np.abs(self.t[falls] - t_pred))])
            swap = [0, 2, 1]  # z in the role of y: a crossing "from above" is a fall
            hit = plane_crossing_from_samples(self.t[i:i + 2], self.p[i:i + 2][:, swap],
                                              self.v[i:i + 2][:, swap], p_pred[2])
            if hit is not None:
                hit = (hit[0], hit[1][swap], hit[2][swap])
        if hit is None:
            return None
        tc, pc, vc = hit
        return np.r_[pc, vc, _at(self.t, self.w, tc), tc]


def true_crossing(world, launch_state) -> np.ndarray | None:
    """(p, v, omega, t) where the launched ball's centre crosses the hitting plane in the
    ball-only Drake world, or None."""
    flight = TrueFlight(world, launch_state)
    return flight.crossing(np.array([0.0, PLANES.hitting_y, 0.0]), 0.0)


def _errors(flight: TrueFlight, prefix: str, p_hit, t_hit: float, spin=None) -> dict:
    """Position (mm), time (ms) and spin-at-impact (rad/s) errors of one prediction."""
    truth = flight.crossing(p_hit, t_hit)
    if truth is None:
        return {f"{prefix}_p_hit_error_mm": float("nan")}
    out = {f"{prefix}_p_hit_error_mm": float(1e3 * np.linalg.norm(np.asarray(p_hit) - truth[0:3])),
           f"{prefix}_t_hit_error_ms": float(1e3 * (t_hit - truth[9])),
           f"{prefix}_on_plane": bool(abs(p_hit[1] - PLANES.hitting_y) < ON_PLANE)}
    if spin is not None:
        out[f"{prefix}_impact_spin_error"] = float(np.linalg.norm(np.asarray(spin) - truth[6:9]))
    return out


def serve_report(diagram, ball_world, seed: int) -> dict:
    """One serve's row of the analytical player (module docstring); ``committed`` False and no
    errors when the player never began a hitting stage."""
    player = diagram.player
    player.history.clear()
    # ServeDiagram clears its own loggers at each run, not this one (a log lives in the context's
    # cache, which restoring the initial state does not reset).
    diagram.diagram.GetSubsystemByName("spin_logger").FindMutableLog(diagram.context).Clear()
    result = diagram.run(seed)
    ctx = diagram.context
    row = {"seed": seed, "outcome": str(result.outcome.as_dict().get("outcome")),
           "returned": bool(result.outcome.returned)}
    state = player.player_state(player.GetMyContextFromRoot(ctx))
    hit = next((seg for stage, seg in state.plan.segments if stage == HITTING), None)
    if not state.committed or hit is None or state.stroke is None:
        row["committed"] = False
        return row
    flight = TrueFlight(ball_world, result.launch_state)
    t_commit = float(hit.t0)
    ball_log = diagram.ball_logger.FindLog(ctx)
    ball_t, ball_w = ball_log.sample_times(), ball_log.data()[7:10].T

    def true_spin(t):
        return _at(ball_t, ball_w, t)

    history = player.history
    start = [h for h in history if h[0] <= t_commit + 1e-9 and not h[4]]
    row.update({"committed": True, "t_commit": t_commit, "strokes": len(history),
                "corrections": sum(1 for h in history if h[4])})
    for prefix, entry in (("start", start[-1] if start else None), ("final", history[-1])):
        if entry is None:
            continue
        _, seen, stroke, spin_est, _ = entry
        row.update(_errors(flight, prefix, stroke.p_hit, stroke.t_hit, stroke.spin))
        row[f"{prefix}_spin_error"] = float(np.linalg.norm(spin_est - true_spin(seen)))
        row[f"{prefix}_lead_ms"] = float(1e3 * (stroke.t_hit - seen))
    # The planner's predictions from the estimate at the commit time itself and at the last
    # moment a correction may still be made (``correct_lead`` before the final stroke's t_hit).
    t_cutoff = float(history[-1][2].t_hit) - player.planner.config.correct_lead
    for prefix, t in (("commit", t_commit), ("cutoff", t_cutoff)):
        row.update(_prediction_at(diagram, player.planner, flight, prefix, t, true_spin))
    return row


def _prediction_at(diagram, planner, flight: TrueFlight, prefix: str, t: float,
                   true_spin) -> dict:
    """The errors of the planner's prediction from the last estimate available at ``t`` (the
    estimator's outputs logged at the referee's rate) and of the estimator's spin then."""
    ctx = diagram.context

    def logged(logger):
        log = logger.FindLog(ctx)
        return _at(log.sample_times(), log.data().T, t)

    status = logged(diagram.status_logger)
    spin_est = logged(diagram.diagram.GetSubsystemByName("spin_logger"))
    out = {f"{prefix}_t": t, f"{prefix}_p_hit_error_mm": float("nan"),
           f"{prefix}_spin_error": float(np.linalg.norm(spin_est - true_spin(float(status[1]))))}
    if status[0] < 0.5:
        return out
    prediction = planner.predict(logged(diagram.estimate_logger), float(status[1]), spin_est)
    if prediction is not None:
        out.update(_errors(flight, prefix, prediction[0], prediction[2], prediction[3]))
        out[f"{prefix}_lead_ms"] = float(1e3 * (prediction[2] - status[1]))
    return out


def momp_report(diagram, ball_world, seed: int) -> dict:
    """One serve's row of the MoMP player: its last (re-)plan's stimulus and t_hit."""
    result = diagram.run(seed)
    row = {"seed": seed, "outcome": str(result.outcome.as_dict().get("outcome")),
           "returned": bool(result.outcome.returned)}
    stroke = result.stroke
    if stroke is None:
        row["committed"] = False
        return row
    flight = TrueFlight(ball_world, result.launch_state)
    row.update({"committed": True, "strokes": int(stroke["replans"])})
    row.update(_errors(flight, "final", np.asarray(stroke["stimulus"][:3]), stroke["t_hit"]))
    return row


MOMENTS = ("commit", "start", "cutoff", "final")
SUMMARY_KEYS = tuple(f"{m}_{q}" for q in ("p_hit_error_mm", "spin_error", "impact_spin_error",
                                          "lead_ms") for m in MOMENTS)


def _stats(a) -> dict:
    a = np.asarray(a, dtype=float)
    a = a[np.isfinite(a)]
    return ({"median": float(np.median(a)), "p90": float(np.percentile(a, 90)), "n": int(len(a))}
            if len(a) else {"n": 0})


def summarise(rows: list[dict]) -> dict:
    done = [r for r in rows if r.get("committed")]
    out = {"serves": len(rows), "committed": len(done),
           "return_rate": sum(r["returned"] for r in rows) / max(len(rows), 1)}
    for key in SUMMARY_KEYS:
        if any(key in r for r in done):
            out[key] = _stats([r.get(key, np.nan) for r in done])
    for prefix in MOMENTS:
        key = f"{prefix}_t_hit_error_ms"
        if any(key in r for r in done):
            out[f"{prefix}_abs_t_hit_error_ms"] = _stats(np.abs([r.get(key, np.nan)
                                                                  for r in done]))
            out[f"{prefix}_on_plane"] = sum(bool(r.get(f"{prefix}_on_plane")) for r in done)
    return out


def format_summary(summary: dict) -> str:
    lines = [f"{summary['serves']} serves, {summary['committed']} committed, legal return "
             f"{summary['return_rate']:.1%}"]
    for key, s in summary.items():
        if isinstance(s, dict) and s.get("n"):
            lines.append(f"  {key:28s} median {s['median']:8.2f}  p90 {s['p90']:8.2f}  "
                         f"(n = {s['n']})")
    return "\n".join(lines)
