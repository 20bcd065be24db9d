"""Build the station, wire the analytical player to its ports, simulate one serve and save the
Meshcat recording: `python docs/examples/station.py [OUT.html] [--scenario S]` (default
out/station.html)."""

import argparse
from pathlib import Path

from pydrake.systems.framework import DiagramBuilder

from tt_drake.diagrams.commands.options import add_scenario_option
from tt_drake.diagrams.players import player_function
from tt_drake.diagrams.recording import make_meshcat
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.diagrams.station import awaiting_posture, build_station, reset_episode, station_ports
from tt_drake.seeds import episode_seed
from tt_drake.systems.wam import hold_first_setpoint
from tt_drake.systems.world import make_simulator

parser = argparse.ArgumentParser(description=__doc__)
parser.add_argument("out", nargs="?", default="out/station.html", help="the recording's page")
add_scenario_option(parser)
args = parser.parse_args()
scenario, meshcat = load_scenario(args.scenario), make_meshcat()
station = build_station(scenario, robots=1, meshcat=meshcat)  # make_station: the Diagram alone
builder = DiagramBuilder()
builder.AddSystem(station.diagram)
world, controller = station_ports(station.diagram)  # the ports a player reads and drives
seeded = player_function("analytical")(builder, world, controller, scenario)
diagram = builder.Build()
simulator = make_simulator(diagram, scenario.world, station.world.plant)
context = simulator.get_mutable_context()
hold_first_setpoint(diagram, context)
awaiting_posture(station.world, context, station.diagram)  # where the player waits
serve = reset_episode(simulator, context.Clone(), scenario.world.simulator,
                      [station.launcher, *seeded], station.world, episode_seed(1, 0))
station.visualizer.StartRecording()
simulator.Initialize()
simulator.AdvanceTo(serve.crossing.t + scenario.after_crossing)  # the referee may end it sooner
station.visualizer.PublishRecording()
port = station.diagram.GetOutputPort("outcome")
outcome = port.Eval(station.diagram.GetMyContextFromRoot(context))
print(f"{outcome.outcome}: landing {outcome.landing}, hit at {outcome.hit_time} s")
out = Path(args.out)
out.parent.mkdir(parents=True, exist_ok=True)
out.write_text(meshcat.StaticHtml(), encoding="utf-8")
print(f"wrote {out}")
