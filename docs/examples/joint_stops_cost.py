"""What the joint stops cost the integrator (docs/performance.md, "What runs when"): the default
station's time derivatives evaluated with and without the stops (systems/joint_stops.py), the
arm inside its limits, in one process, the two alternated; CPU microseconds per evaluation.

    OPENBLAS_NUM_THREADS=1 python docs/examples/joint_stops_cost.py [--evaluations 4000] \\
        [--rounds 2]

Inside the limits the stops add no torque, so both stations give the same derivatives to the
bit (checked on every evaluation).
"""

import argparse
import sys
import time

import numpy as np

from tt_drake import wam_params as wp
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.diagrams.station import arm_port, build_station


class StationDerivatives:
    """The default station (one robot, stops on or off) with the arm held at the awaiting
    posture by its controller's desired state; ``at(k)`` evaluates the time derivatives with the
    arm's joints moved by ``k`` x 1e-4 rad."""

    def __init__(self, stops: bool):
        scenario = load_scenario("default")
        scenario.world.joint_stops.enabled = stops
        station = build_station(scenario, 1)
        self.diagram, self.world = station.diagram, station.world
        self.context = self.diagram.CreateDefaultContext()
        self.diagram.GetInputPort(arm_port(0, "desired_state")).FixValue(
            self.context, np.concatenate([wp.AWAITING, np.zeros(wp.NUM_JOINTS)]))
        self.diagram.GetInputPort(arm_port(0, "desired_acceleration")).FixValue(
            self.context, np.zeros(wp.NUM_JOINTS))
        self.plant_context = self.world.plant.GetMyMutableContextFromRoot(self.context)
        self.derivatives = self.diagram.AllocateTimeDerivatives()
        self.q0 = np.asarray(wp.AWAITING, dtype=float)

    def at(self, k: int) -> np.ndarray:
        self.world.plant.SetPositions(self.plant_context, self.world.robot,
                                      self.q0 + 1e-4 * (k % 50))
        self.diagram.CalcTimeDerivatives(self.context, self.derivatives)
        return self.derivatives.get_vector().CopyToVector()


def cost(station: StationDerivatives, evaluations: int) -> float:
    """CPU microseconds per derivative evaluation."""
    start = time.process_time()
    for k in range(evaluations):
        station.at(k)
    return (time.process_time() - start) / evaluations * 1e6


def same_inside_the_limits(with_stops, without, evaluations: int) -> bool:
    """Whether the two stations' derivatives agree to the bit on the arm's part (the stations'
    state vectors differ by the stops' one constant state)."""
    n = with_stops.world.plant.num_multibody_states()
    return all(np.array_equal(with_stops.at(k)[:n], without.at(k)[:n])
               for k in range(evaluations))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--evaluations", type=int, default=4000)
    ap.add_argument("--rounds", type=int, default=2)
    args = ap.parse_args(argv)
    if args.evaluations < 1 or args.rounds < 1:
        ap.error("--evaluations and --rounds must be >= 1")
    stations = {"without stops": StationDerivatives(False),
                "with stops": StationDerivatives(True)}
    if not same_inside_the_limits(stations["with stops"], stations["without stops"], 50):
        print("the stations' derivatives differ inside the limits")
        return 1
    totals = dict.fromkeys(stations, 0.0)
    for _ in range(args.rounds):
        for name, station in stations.items():
            us = cost(station, args.evaluations)
            totals[name] += us / args.rounds
            print(f"{name}: {us:.2f} CPU us per derivative evaluation")
    extra = totals["with stops"] - totals["without stops"]
    print(f"mean: {totals['without stops']:.2f} -> {totals['with stops']:.2f} us "
          f"({extra:+.2f} us, {100 * extra / totals['without stops']:+.1f} %)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
