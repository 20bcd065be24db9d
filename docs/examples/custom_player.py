"""A player of one's own (a LeafSystem holding the racket turned away), registered once, played
in a serve, as robot B of a rally and in a Gymnasium step environment (docs/diagrams.md):
`python docs/examples/custom_player.py [--scenario S]`."""

import argparse

import numpy as np
from pydrake.systems.framework import LeafSystem

from tt_drake.diagrams.commands.options import add_scenario_option
from tt_drake.diagrams.episodes import ServeDiagram
from tt_drake.diagrams.gym_envs import ReturnBallStepEnv
from tt_drake.diagrams.players import register_player
from tt_drake.diagrams.rally import RallyDiagram, rally_scenario
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.wam_params import AWAITING

POSTURE = np.r_[np.asarray(AWAITING) + [0.4, -0.3, 0, 0.2, 0, 0, 0], np.zeros(7)]


class Statue(LeafSystem):
    def __init__(self):
        super().__init__()
        self.DeclareVectorOutputPort("desired_state", 14, lambda c, out: out.SetFromVector(POSTURE))
        self.DeclareVectorOutputPort("desired_acceleration", 7, lambda c, out: out.SetZero())


def add_statue(builder, world, controller, scenario) -> list:
    """The player function: add the systems, drive the controller, return the seeded ones."""
    statue = builder.AddNamedSystem("statue", Statue())
    builder.Connect(statue.get_output_port(0), controller.get_input_port_desired_state())
    builder.Connect(statue.get_output_port(1), controller.get_input_port_desired_acceleration())
    return []


parser = argparse.ArgumentParser(description=__doc__)
add_scenario_option(parser)
args = parser.parse_args()
register_player("statue", add_statue)
print("serve:", ServeDiagram(load_scenario(args.scenario), "statue").run(5).outcome.outcome)
rally = RallyDiagram(rally_scenario(load_scenario(args.scenario)), ("analytical", "statue")).run(11)
print("rally:", [e.player for e in rally.exchanges], rally.fault.kind, "by", rally.fault.player)
env = ReturnBallStepEnv(scenario=args.scenario, player="statue")
env.reset(options={"serve_seed": 5})
while not any((step := env.step(np.zeros(7)))[2:4]):  # until terminated or truncated
    pass
print("gym:", step[4]["outcome"]["outcome"], "reward", step[1])
