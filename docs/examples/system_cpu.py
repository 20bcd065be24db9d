"""CPU time per serve of each Python system of the serve diagram, without a profiler.

    OPENBLAS_NUM_THREADS=1 python docs/examples/system_cpu.py momp [--serves 10] [--seed 3]
        [--perception camera|oracle] [--distribution D] [--record] [--scenario S]

(``--perception oracle --record``: the serves as the paper protocol's teacher stage plays them,
``tt-drake collect --perception oracle``: recorded, so not ended when the outcome is decided.)

Wraps the update and output functions of the Python systems (EKF, hitting-point predictor,
players, servo set-points, referee, the ContactAccuracy monitor; those a checkout lacks are left
out) with a ``time.process_time`` accumulator before the diagram is
built, runs one warm-up episode, then ``--serves`` episodes, and prints each system's CPU
milliseconds per serve and share of the serve (cProfile's per-call overhead inflates Python-heavy
code about twofold; this wrapper's two ``process_time`` calls are system calls of ~2 µs each on
this machine's VM, so a system called ~1,400 times per serve reads ~3 ms high). Used for
docs/performance.md; run it in two checkouts to compare them.
"""

from __future__ import annotations

import argparse
import functools
import gc
import time
from collections import defaultdict

from tt_drake.diagrams.commands.options import add_scenario_option
from tt_drake.diagrams.episodes import ServeDiagram, episode_seed
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.models import use_artefact_set

# (label, module, class (None: a module function), method). Labels indented by two spaces are
# parts of the row above them: left out of the sum.
WRAPPED = [
    ("EKF", "tt_drake.systems.ball_flight_estimator", "BallFlightEstimator", "_update"),
    ("  its filter step", "tt_drake.estimation", "BallFlightEKF", "step"),
    ("hitting-point predictor", "tt_drake.systems.hitting_point_predictor",
     "HittingPointPredictor", "_update"),
    ("  early predictions", "tt_drake.systems.hitting_point_predictor",
     "HittingPointPredictor", "_crossing"),
    ("  refreshed predictions", "tt_drake.systems.hitting_point_predictor",
     "HittingPointPredictor", "_refreshed"),
    ("MoMP planning tick", "tt_drake.systems.momp_player", "MoMPTrajectorySource", "_update"),
    ("  re-plans", "tt_drake.systems.momp_player", "MoMPTrajectorySource", "_plan_primitives"),
    ("  effort checks (in re-plans)", "tt_drake.systems.momp_player", "MoMPTrajectorySource",
     "_within_effort"),
    ("  the hold's check", "tt_drake.systems.momp_player", "MoMPTrajectorySource",
     "_hold_if_lost"),
    ("analytical planning tick", "tt_drake.systems.analytical_player", "AnalyticalPlayer",
     "_update"),
    ("  predictions", "tt_drake.systems.analytical_player", "StrokePlanner", "predict"),
    ("  strokes (aim, racket, IK)", "tt_drake.systems.analytical_player", "StrokePlanner",
     "stroke"),
    ("  of which the aim", "tt_drake.systems.analytical_player", None, "aim_candidates"),
    ("  of which the IK", "tt_drake.systems.hitting_ik", "HittingIK", "solve"),
    ("  plans (before corrections)", "tt_drake.systems.analytical_player", "StrokePlanner",
     "plan"),
    ("  corrections' plans", "tt_drake.systems.analytical_player", "StrokePlanner", "correct"),
    ("  feasibility checks", "tt_drake.systems.analytical_player", "StrokePlanner", "feasible"),
    ("  of which effort", "tt_drake.systems.analytical_player", None, "within_effort"),
    ("servo set-points (state)", "tt_drake.systems.stage_player", "StagePlanPlayer",
     "_calc_state"),
    ("servo set-points (accel.)", "tt_drake.systems.stage_player", "StagePlanPlayer",
     "_calc_accel"),
    ("servo set-point (one port)", "tt_drake.systems.stage_player", "StagePlanPlayer",
     "_calc_setpoint"),
    ("referee", "tt_drake.systems.referee", "Referee", "_update"),
    ("ContactAccuracy monitor", "tt_drake.systems.world", "ContactAccuracy", "__call__"),
]


def with_serves(scenario, perception=None, distribution=None):
    """The scenario with another perception (camera, oracle) and serve distribution, if given."""
    import dataclasses

    if perception is not None:
        scenario = dataclasses.replace(scenario, perception=perception)
    if distribution is not None:
        scenario = dataclasses.replace(
            scenario, launcher=dataclasses.replace(scenario.launcher, distribution=distribution))
    return scenario


def main() -> None:
    import importlib

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("player")
    ap.add_argument("--serves", type=int, default=10)
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--perception", default=None, help="camera or oracle (default: scenario's)")
    ap.add_argument("--distribution", default=None, help="the launcher's serves (e.g. spin)")
    ap.add_argument("--record", action="store_true", help="record demonstrations (collect's)")
    add_scenario_option(ap)
    args = ap.parse_args()
    spent = defaultdict(float)
    calls = defaultdict(int)
    clock = time.process_time
    for label, module, cls, name in WRAPPED:
        owner = importlib.import_module(module)
        owner = owner if cls is None else getattr(owner, cls, None)
        inner = getattr(owner, name, None)
        if inner is None:  # not in this checkout (another version of the code)
            continue

        def timed(*a, _inner=inner, _label=label, **k):
            t0 = clock()
            try:
                return _inner(*a, **k)
            finally:
                spent[_label] += clock() - t0
                calls[_label] += 1

        setattr(owner, name, functools.wraps(inner)(timed))
    scenario = with_serves(load_scenario(args.scenario), args.perception, args.distribution)
    use_artefact_set(scenario.learned)  # the shipped paper set, as `tt-drake serve` plays it
    diagram = ServeDiagram(scenario, args.player, record=args.record)
    diagram.run(episode_seed(args.seed, 0))
    spent.clear()
    calls.clear()
    gc_started = []

    def gc_clock(phase, info):  # the cyclic garbage collector's own time
        if phase == "start":
            gc_started.append(clock())
        elif gc_started:
            spent["garbage collector"] += clock() - gc_started.pop()

    gc.callbacks.append(gc_clock)
    c0 = clock()
    for i in range(args.serves):
        diagram.run(episode_seed(args.seed, i))
    total = clock() - c0
    gc.callbacks.remove(gc_clock)
    n = args.serves
    print(f"{args.player} ({scenario.perception}, {scenario.launcher.distribution} serves"
          f"{', recorded' if args.record else ''}): "
          f"{1e3 * total / n:.1f} CPU ms per serve ({n} serves, seed {args.seed})")
    rows = [(label, spent[label]) for label, _, _, _ in WRAPPED if label in spent]
    rows.append(("these systems together",
                 sum(cpu for label, cpu in rows if not label.startswith(" "))))
    rows.append(("garbage collector", spent["garbage collector"]))
    for label, cpu in rows:
        count = f"{calls[label] / n:7.1f} calls" if label in calls else ""
        print(f"  {label:28s} {1e3 * cpu / n:6.1f} ms {100 * cpu / total:5.1f} % {count}")


if __name__ == "__main__":
    main()
