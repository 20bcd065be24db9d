"""Where the integrator spends its steps in a serve episode, by phase (docs/performance.md).

    python docs/examples/integrator_phases.py momp [--serves 10] [--seed 3] [--accuracy A]
        [--scenario S]

Builds the serve diagram (learned players: the shipped artefacts in models/learned/) and, with a
simulator monitor (called after every simulator step), counts the error-controlled integrator's
steps, derivative evaluations and error-control step shrinkages over each phase of the episode,
told apart by the ball's state at the end of each simulator step:

- ``flight in``: the serve's flight before the racket's hit, away from the table;
- ``table``: the ball's centre within 1 cm of its contact height over the table (or below it);
- ``racket``: the ball within 6 cm of the racket-centre frame (the blade: contact);
- ``flight out``: after the hit (the ball moving away from the robot), away from the table;

and the ball's spin (|omega|) in each. ``--accuracy`` overrides the scenario's integrator
accuracy (the default: 1e-4) and ``--flight-accuracy`` its accuracy away from contacts
(:class:`tt_drake.systems.world.ContactAccuracy`; the default scenario: 1e-3, 0: off).
"""

from __future__ import annotations

import argparse
from collections import defaultdict

import numpy as np
from pydrake.systems.framework import EventStatus

from tt_drake.diagrams.commands.options import add_scenario_option
from tt_drake.diagrams.episodes import ServeDiagram, episode_seed
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.models import use_artefact_set
from tt_drake.systems.world import ContactAccuracy

PHASES = ("flight in", "table", "racket", "flight out")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("player")
    ap.add_argument("--serves", type=int, default=10)
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--accuracy", type=float, default=None)
    ap.add_argument("--flight-accuracy", type=float, default=None)
    ap.add_argument("--spin-max", type=float, default=0.0,
                    help="> 0: the spin distribution with this spin per axis (rad/s)")
    add_scenario_option(ap)
    args = ap.parse_args()
    scenario = load_scenario(args.scenario)
    use_artefact_set(scenario.learned)  # the shipped paper set, as `tt-drake serve` plays it
    if args.accuracy is not None:
        scenario.world.simulator.accuracy = args.accuracy
    if args.flight_accuracy is not None:
        scenario.world.flight_accuracy = args.flight_accuracy
    if args.spin_max > 0.0:
        scenario.launcher.distribution, scenario.launcher.spin_max = "spin", args.spin_max
    d = ServeDiagram(scenario, args.player)
    schedule = None  # this script's monitor replaces the simulator's: it calls the schedule
    if scenario.world.flight_accuracy > 0.0:
        schedule = ContactAccuracy(d.simulator, d.diagram, scenario.world.simulator.accuracy,
                                   scenario.world.flight_accuracy)
    plant, world = d.world.plant, d.world
    ball = world.ball_body
    racket = (plant.GetFrameByName("racket_center", world.robot)
              if world.robot is not None else None)
    contact_z = 0.76 + 0.02
    steps = defaultdict(float)
    evals = defaultdict(float)
    shrinks = defaultdict(float)
    sim_time = defaultdict(float)
    spin = defaultdict(list)
    last = {}

    def monitor(root):
        if schedule is not None:
            schedule(root)
        pc = plant.GetMyContextFromRoot(root)
        pose = plant.EvalBodyPoseInWorld(pc, ball)
        p = pose.translation()
        vel = plant.EvalBodySpatialVelocityInWorld(pc, ball)
        v, w = vel.translational(), vel.rotational()
        near_racket = (racket is not None and np.linalg.norm(
            racket.CalcPoseInWorld(pc).translation() - p) < 0.06)
        if near_racket:
            phase = "racket"
        elif p[2] < contact_z + 0.01 and abs(p[0]) < 0.7625 and abs(p[1]) < 1.37:
            phase = "table"
        else:
            phase = "flight out" if v[1] > 0.0 else "flight in"
        integ = d.simulator.get_integrator()  # each run makes a new one (ApplySimulatorConfig)
        n, e, s, t = (integ.get_num_steps_taken(), integ.get_num_derivative_evaluations(),
                      integ.get_num_step_shrinkages_from_error_control(), root.get_time())
        if last:
            steps[phase] += n - last["n"]
            evals[phase] += e - last["e"]
            shrinks[phase] += s - last["s"]
            sim_time[phase] += t - last["t"]
            spin[phase].append(float(np.linalg.norm(w)))
        last.update(n=n, e=e, s=s, t=t)
        return EventStatus.Succeeded()

    d.simulator.set_monitor(monitor)
    for i in range(args.serves):
        last.clear()
        d.run(episode_seed(args.seed, i))
    acc, flight = scenario.world.simulator.accuracy, scenario.world.flight_accuracy
    print(f"{args.player}, {args.serves} serves (seed {args.seed}), accuracy {acc:g}, flight "
          f"accuracy {flight:g}: per serve")
    print(f"{'phase':12s} {'sim ms':>8s} {'steps':>8s} {'evals':>8s} {'shrinks':>8s} "
          f"{'mean step ms':>12s} {'median |w| rad/s':>16s}")
    n = args.serves
    for ph in PHASES:
        if steps[ph] == 0:
            continue
        print(f"{ph:12s} {1e3 * sim_time[ph] / n:8.1f} {steps[ph] / n:8.1f} {evals[ph] / n:8.1f} "
              f"{shrinks[ph] / n:8.1f} {1e3 * sim_time[ph] / steps[ph]:12.3f} "
              f"{np.median(spin[ph]):16.1f}")
    tot = sum(steps.values())
    print(f"{'total':12s} {1e3 * sum(sim_time.values()) / n:8.1f} {tot / n:8.1f} "
          f"{sum(evals.values()) / n:8.1f} {sum(shrinks.values()) / n:8.1f}")


if __name__ == "__main__":
    main()
