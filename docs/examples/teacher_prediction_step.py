"""The teacher's predictions at several RK4 steps against its old 2 ms step.

    OPENBLAS_NUM_THREADS=1 python docs/examples/teacher_prediction_step.py [--serves 3]
        [--seed 3] [--perception oracle] [--distribution default] [--steps 0.004 0.01]
        [--in-serves N] [--scenario S]

Plays ``--serves`` analytical serves (recorded, as the teacher stage plays them) and keeps every
(estimate, time, spin) the player predicted from; then predicts from each again
(``StrokePlanner.predict``: the hitting point along the path, ``last_robot_bounce`` included)
with the planner's model at 2 ms and at each ``--steps``, the test for a bounce behind the ball
at that step or at the player's 2 ms (``BOUNCE_TEST_STEP``), the variants alternating prediction
by prediction; prints the CPU time per prediction, how many predictions differ in having a
hitting point, and the largest difference to the 2 ms prediction in position (m), velocity
(m/s), time (s) and spin (rad/s).

With ``--in-serves N`` it instead plays N serves twice each, the player's model at 2 ms and at
``PREDICTION_STEP`` (the order alternating serve by serve, in one process), and prints the CPU
time of the player's predictions and of the whole serve per serve for each. Used for
docs/performance.md ("The teacher": ``analytical_player.PREDICTION_STEP``).
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

import tt_drake.systems.analytical_player as ap
from tt_drake.constants import PLANES
from tt_drake.diagrams.commands.options import add_scenario_option
from tt_drake.diagrams.episodes import ServeDiagram, episode_seed
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.hitting_time import HittingBand, choose_hitting_point


def recorded_predictions(serves: int, seed: int, perception: str, distribution: str,
                         scenario: str = "default") -> list:
    """The (estimate, time, spin, bounces behind) of every prediction the teacher made in
    ``serves`` serves of ``scenario`` (a name in models/ or a YAML path)."""
    scenario = load_scenario(scenario)
    scenario = dataclasses.replace(scenario, perception=perception, launcher=dataclasses.replace(
        scenario.launcher, distribution=distribution))
    calls = []
    original = ap.StrokePlanner.predict

    def predict(self, state6, t_state, spin=None, bounces_behind=None):
        calls.append((np.array(state6), float(t_state), None if spin is None else np.array(spin),
                      bounces_behind))
        return original(self, state6, t_state, spin, bounces_behind)

    ap.StrokePlanner.predict = predict
    try:
        diagram = ServeDiagram(scenario, "analytical", record=True)
        for i in range(serves):
            diagram.run(episode_seed(seed, i))
    finally:
        ap.StrokePlanner.predict = original
    return calls


def in_serves(serves: int, seed: int, perception: str, distribution: str,
              scenario: str = "default") -> None:
    """The predictions' and the serves' CPU per serve at 2 ms and at ``PREDICTION_STEP``."""
    scenario = load_scenario(scenario)
    scenario = dataclasses.replace(scenario, perception=perception, launcher=dataclasses.replace(
        scenario.launcher, distribution=distribution))
    spent = {True: 0.0, False: 0.0}
    total = {True: 0.0, False: 0.0}
    calls = {True: 0, False: 0}
    current = [True]
    original = ap.StrokePlanner.predict

    def predict(self, *a):
        c0 = time.process_time()
        try:
            return original(self, *a)
        finally:
            spent[current[0]] += time.process_time() - c0
            calls[current[0]] += 1

    ap.StrokePlanner.predict = predict
    try:
        diagram = ServeDiagram(scenario, "analytical", record=True)
        planner = diagram.diagram.GetSubsystemByName("analytical_player").planner
        diagram.run(episode_seed(seed, 0))
        for on in (True, False):
            spent[on], calls[on] = 0.0, 0
        for i in range(serves):
            for on in ((True, False) if i % 2 else (False, True)):
                current[0] = on
                planner.model = ap.planner_ball_model(ap.PREDICTION_STEP if on else 2e-3)
                c0 = time.process_time()
                diagram.run(episode_seed(seed, i))
                total[on] += time.process_time() - c0
    finally:
        ap.StrokePlanner.predict = original
    for on, label in ((False, "2 ms"), (True, f"{1e3 * ap.PREDICTION_STEP:g} ms")):
        print(f"{label}: predictions {1e3 * spent[on] / serves:.1f} CPU ms per serve "
              f"({calls[on] / serves:.1f} calls), serve {1e3 * total[on] / serves:.1f} CPU ms "
              f"({serves} recorded {distribution} serves, {perception}, seed {seed})")


def _predict(model, bounce_step, state6, t_state, spin, bounces_behind):
    """``StrokePlanner.predict`` with ``model`` and the bounce test at ``bounce_step``."""
    state6 = np.asarray(state6, dtype=float)
    if state6[4] >= 0.0 or state6[1] <= PLANES.hitting_y:
        return None
    w = np.zeros(3) if spin is None else np.asarray(spin, dtype=float)
    hit = choose_hitting_point(model, np.r_[state6, w], PLANES.hitting_y, HittingBand(),
                               bounce_step=bounce_step, bounces_behind=bounces_behind)
    return None if hit is None else (hit.position, hit.velocity, t_state + hit.t, hit.spin)


def main() -> None:
    ap_ = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap_.add_argument("--serves", type=int, default=3)
    ap_.add_argument("--seed", type=int, default=3)
    ap_.add_argument("--perception", default="oracle")
    ap_.add_argument("--distribution", default="default")
    ap_.add_argument("--steps", type=float, nargs="+", default=[0.004, 0.01])
    ap_.add_argument("--in-serves", type=int, default=0, help="time the predictions in serves")
    add_scenario_option(ap_)
    args = ap_.parse_args()
    if args.in_serves:
        in_serves(args.in_serves, args.seed, args.perception, args.distribution, args.scenario)
        return
    calls = recorded_predictions(args.serves, args.seed, args.perception, args.distribution,
                                 args.scenario)
    # (label, forward step, bounce-test step): the old 2 ms for both first.
    variants = [("2 ms", 2e-3, 2e-3)]
    for dt in args.steps:
        variants.append((f"{1e3 * dt:g} ms, bounce test {1e3 * dt:g} ms", dt, dt))
        variants.append((f"{1e3 * dt:g} ms, bounce test {1e3 * ap.BOUNCE_TEST_STEP:g} ms", dt,
                         ap.BOUNCE_TEST_STEP))
    models = [ap.planner_ball_model(dt) for _, dt, _ in variants]
    out = [[] for _ in variants]
    cpu = [0.0] * len(variants)
    for i, (s, t, w, b) in enumerate(calls):  # each prediction by every variant, order rotating
        for j in range(len(variants)):
            k = (i + j) % len(variants)
            c0 = time.process_time()
            out[k].append(_predict(models[k], variants[k][2], s, t, w, b))
            cpu[k] += time.process_time() - c0
    reference = out[0]
    hits = sum(r is not None for r in reference)
    print(f"{len(calls)} predictions of {args.serves} {args.distribution} serves "
          f"({args.perception}, seed {args.seed}), {hits} with a hitting point; "
          f"2 ms: {1e3 * cpu[0] / len(calls):.3f} CPU ms per prediction")
    for (label, _, _), results, spent in zip(variants[1:], out[1:], cpu[1:], strict=True):
        differ = sum((a is None) != (b is None) for a, b in zip(reference, results, strict=True))
        both = [(a, b) for a, b in zip(reference, results, strict=True)
                if a is not None and b is not None]
        worst = [max((float(np.max(np.abs(np.subtract(b[k], a[k])))) for a, b in both),
                     default=0.0) for k in range(4)]
        print(f"  {label}: {1e3 * spent / len(calls):.3f} CPU ms per prediction "
              f"({cpu[0] / spent:.2f}x); {differ} differ in having a hitting point; largest "
              f"difference: position {worst[0]:.1e} m, velocity {worst[1]:.1e} m/s, time "
              f"{worst[2]:.1e} s, spin {worst[3]:.1e} rad/s")


if __name__ == "__main__":
    main()
