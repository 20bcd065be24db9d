"""Teacher demonstrations: what one serve episode of a planning player leaves for learning.

Per serve (paper sections III-B and III-C):

- ``features`` (24): the estimator's (p, v) at the four camera frames after the ball passes the
  virtual plane s (:func:`tt_drake.hitting_point.observation_frames`), NaN if not tracked;
- ``true_hit`` (7): the true ball state where it crossed the virtual hitting plane (p, v, t);
- ``stimulus`` (7): the player's own prediction it struck with (p_hit, v_hit, t_hit);
- ``q_hit``, ``qd_hit`` (7 each): the hitting configuration;
- stage trajectories sampled at 500 Hz from the executed plan: time, stage index (into
  :data:`tt_drake.stages.STAGES`), q, q_dot, q_ddot; and each stage's duration;
- ``recorded``: the same stages as the arm performed them, rows of the same layout taken from the
  plant's measured joint state (q, q_dot) and generalized acceleration (q_ddot) logged at the
  500 Hz servo rate, so with the controller's tracking error (paper section III-C: the
  demonstrations are the arm's recorded joint trajectories); ``spin_hit`` (3): the spin at impact
  the teacher's stroke assumed (its model's prediction through the bounce, NaN if none);
- the referee's outcome (hit, returned, on target, reward, landing).

:class:`DemonstrationRecorder` adds the loggers it needs to the serve diagram and extracts the
record after each episode; :mod:`tt_drake.diagrams.collect` writes the records in chunks.
"""

import math

import numpy as np
from pydrake.systems.primitives import VectorLogSink

from tt_drake.ball_model import CompliantBounceBallModel
from tt_drake.constants import PLANES
from tt_drake.diagrams.players import player_system
from tt_drake.hitting_point import observation_frames, plane_crossing_from_samples
from tt_drake.stages import AWAITING, FOLLOW_THROUGH, HITTING, PREPARATION, STAGES

SAMPLE_RATE = 500.0
NAN7 = [math.nan] * 7


class DemonstrationRecorder:
    def __init__(self, builder, world, scenario):
        plant = world.plant
        period = self.referee_period = 1.0 / scenario.referee_rate
        self.ball_log = builder.AddNamedSystem("demo_ball_logger", VectorLogSink(13, period))
        builder.Connect(plant.get_state_output_port(world.ball), self.ball_log.get_input_port())
        self.estimator_log = self.status_log = None
        if builder.HasSubsystemNamed("ball_flight_estimator"):
            estimator = builder.GetSubsystemByName("ball_flight_estimator")
            self.estimator_log = builder.AddNamedSystem("demo_estimate_logger",
                                                        VectorLogSink(6, 1.0 / 60.0))
            builder.Connect(estimator.GetOutputPort("state"),
                            self.estimator_log.get_input_port())
            self.status_log = builder.AddNamedSystem("demo_status_logger",
                                                     VectorLogSink(2, 1.0 / 60.0))
            builder.Connect(estimator.GetOutputPort("status"), self.status_log.get_input_port())
        # The arm as measured: 500 Hz is the servo's clock, so no new integrator stop.
        self.arm_log = self.acceleration_log = None
        if world.robot is not None:
            self.arm_log = builder.AddNamedSystem("demo_arm_logger",
                                                  VectorLogSink(14, 1.0 / SAMPLE_RATE))
            builder.Connect(plant.get_state_output_port(world.robot),
                            self.arm_log.get_input_port())
            self.acceleration_log = builder.AddNamedSystem("demo_arm_acceleration_logger",
                                                           VectorLogSink(7, 1.0 / SAMPLE_RATE))
            builder.Connect(plant.get_generalized_acceleration_output_port(world.robot),
                            self.acceleration_log.get_input_port())
        self.player = player_system(builder)

    def _logs(self):
        return [log for log in (self.ball_log, self.estimator_log, self.status_log,
                                self.arm_log, self.acceleration_log) if log]

    def clear(self, context) -> None:
        for log in self._logs():
            log.FindMutableLog(context).Clear()

    def extract(self, diagram, context, outcome) -> dict:
        ball = self.ball_log.FindLog(context)
        t, x = ball.sample_times(), ball.data().T
        true_hit = true_crossing(t, x, outcome.hit_time)
        features = [math.nan] * 24
        if self.estimator_log is not None:
            states = self.estimator_log.FindLog(context).data().T
            status = self.status_log.FindLog(context).data().T
            frames = observation_frames(states, status[:, 0] > 0.5)
            if frames is not None:
                features = states[frames].reshape(-1).tolist()
        record = {"features": features, "true_hit": true_hit, "stimulus": NAN7, "q_hit": NAN7,
                  "qd_hit": NAN7, "durations": [0.0] * len(STAGES),
                  "trajectory": np.zeros((0, 23)), "recorded": np.zeros((0, 23)),
                  "spin_hit": [math.nan] * 3, **_outcome_fields(outcome)}
        if self.player is None:
            return record
        player = self.player
        state = player.player_state(player.GetMyContextFromRoot(context))
        stroke = state.stroke
        if stroke is None:
            return record
        record.update(stimulus=[*stroke.p_hit, *stroke.v_hit, stroke.t_hit],
                      q_hit=list(stroke.q_hit), qd_hit=list(stroke.qd_hit))
        spans = stage_spans(state.plan, stroke.t_hit)
        record["trajectory"], record["durations"] = sample_stages(state.plan, stroke.t_hit, spans)
        spin = getattr(stroke, "spin", None)
        if spin is not None:
            record["spin_hit"] = [float(w) for w in spin]
        if self.arm_log is not None:
            # The referee reports the contact at its first tick after it: up to a period late.
            contact = (None if outcome.hit_time is None
                       else outcome.hit_time - self.referee_period)
            arm = self.arm_log.FindLog(context)
            acc = self.acceleration_log.FindLog(context)
            record["recorded"] = recorded_stages(arm.sample_times(), arm.data().T,
                                                 acc.data().T, spans, contact)
        return record


_MODEL = CompliantBounceBallModel(dt=1e-3)


def true_crossing(t, x, hit_time: float | None) -> list[float]:
    """The true ball state (p, v, t) where it crosses the virtual hitting plane, from the logged
    plant states x = (quaternion, p, omega, v). A ball struck just before the plane (the racket
    meets it at the blade face) is carried the last few centimetres by the ball model from its
    last sample before the hit."""
    before = t < hit_time if hit_time is not None else np.ones(len(t), dtype=bool)
    crossing = plane_crossing_from_samples(t[before], x[before, 4:7], x[before, 10:13],
                                           PLANES.hitting_y)
    if crossing is not None:
        return [*crossing[1], *crossing[2], crossing[0]]
    if not before.any():
        return NAN7
    k = int(np.flatnonzero(before)[-1])
    state = np.r_[x[k, 4:7], x[k, 10:13], x[k, 7:10]]
    hit = _MODEL.predict_plane(state, PLANES.hitting_y, max_time=0.2)
    return NAN7 if hit is None else [*hit.position, *hit.velocity, t[k] + hit.t]


def _outcome_fields(outcome) -> dict:
    landing = outcome.landing or (math.nan, math.nan)
    return {"hit": outcome.hit, "returned": outcome.returned, "on_target": outcome.on_target,
            "reward": outcome.reward, "landing": list(landing)}


def stage_spans(plan, t_hit: float) -> dict:
    """Each executed stage's time span {stage: (start, end)}: preparation spans its re-planned
    segments, the hitting stage ends at ``t_hit``, awaiting is the return to the awaiting posture
    after the follow-through."""
    spans = {}
    for stage, seg in plan.segments:
        lo, hi = spans.get(stage, (seg.t0, seg.t_end))
        spans[stage] = (min(lo, seg.t0), max(hi, seg.t_end))
    if HITTING in spans:
        spans[HITTING] = (spans[HITTING][0], t_hit)
    if AWAITING in spans and FOLLOW_THROUGH in spans:
        spans[AWAITING] = (spans[FOLLOW_THROUGH][1], spans[AWAITING][1])  # the return only
    return spans


_RECORDED_STAGES = (PREPARATION, HITTING, FOLLOW_THROUGH, AWAITING)


def sample_stages(plan, t_hit: float, spans: dict | None = None
                  ) -> tuple[np.ndarray, list[float]]:
    """The executed stroke sampled at 500 Hz, each stage on a grid ending at the stage's end, as
    rows (t, stage, q (7), q_dot (7), q_ddot (7)), and each stage's duration, in :data:`STAGES`
    order (spans: :func:`stage_spans`)."""
    spans = stage_spans(plan, t_hit) if spans is None else spans
    rows = []
    durations = []
    for index, stage in enumerate(STAGES):
        lo, hi = spans.get(stage, (0.0, 0.0))
        durations.append(max(0.0, hi - lo))
        if hi <= lo or stage not in _RECORDED_STAGES:
            continue
        # The grid ends exactly at the stage's end (t_hit for the hitting stage).
        for t in hi - np.arange(0.0, hi - lo + 1e-9, 1.0 / SAMPLE_RATE)[::-1]:
            q, qd, qdd = plan.evaluate(t)
            rows.append(np.r_[t, index, q, qd, qdd])
    return (np.array(rows) if rows else np.zeros((0, 23))), durations


def recorded_stages(times, state, acceleration, spans: dict,
                    contact: float | None = None) -> np.ndarray:
    """The arm's logged samples inside each stage's span, rows (t, stage, q (7), q_dot (7),
    q_ddot (7)) as :func:`sample_stages` lays them out: ``state`` (K, 14) is the plant's measured
    (q, q_dot) and ``acceleration`` (K, 7) its generalized acceleration at ``times`` (K,), copied
    unchanged. A sample on the boundary of two stages belongs to the earlier one. The hitting
    stage ends before ``contact`` (the racket's contact with the ball, if any, usually a few ms
    before t_hit): the impact's acceleration spike is the ball's doing, not the stroke's shape,
    and a demonstration keeping it puts it into the last basis functions' weights."""
    times = np.asarray(times, dtype=float)
    rows = []
    taken = np.zeros(len(times), dtype=bool)
    order = sorted((span[0], STAGES.index(stage), span) for stage, span in spans.items()
                   if stage in _RECORDED_STAGES and span[1] > span[0])
    for _, index, (lo, hi) in order:  # in time order
        inside = (times >= lo - 1e-9) & (times <= hi + 1e-9) & ~taken
        taken |= inside
        if index == STAGES.index(HITTING) and contact is not None:
            inside &= times < contact
        k = np.flatnonzero(inside)
        rows.append(np.column_stack([times[k], np.full(len(k), index), state[k, :7],
                                     state[k, 7:14], acceleration[k]]))
    out = np.vstack(rows) if rows else np.zeros((0, 23))
    return out[np.argsort(out[:, 0], kind="stable")]
