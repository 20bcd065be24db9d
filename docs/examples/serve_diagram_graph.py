"""Draw the serve diagram of a player and the station from Drake's Graphviz output: writes
docs/img/serve_diagram_<player>.dot and docs/img/station.dot and, where Graphviz's `dot` is
installed (a development tool, not a dependency), the SVGs rendered from them.

    python docs/examples/serve_diagram_graph.py [PLAYER] [--depth N] [--scenario S]

``--depth`` (default 1) is how many levels of sub-diagrams are drawn open: at 1 the station is
one box with its named ports, and the player's systems are wired to them.
"""

import argparse
import shutil
import subprocess
from pathlib import Path

from tt_drake.diagrams.commands.options import add_scenario_option
from tt_drake.diagrams.episodes import ServeDiagram
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.diagrams.station import make_station
from tt_drake.models import use_artefact_set

OUT = Path(__file__).resolve().parents[1] / "img"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("player", nargs="?", default="analytical")
    parser.add_argument("--depth", type=int, default=1)
    add_scenario_option(parser)
    args = parser.parse_args()
    scenario = load_scenario(args.scenario)
    if args.player in ("momp", "crkr"):
        use_artefact_set(scenario.learned, "paper", configuration_given=args.player == "crkr")
    graphs = {f"serve_diagram_{args.player}": ServeDiagram(scenario, args.player).diagram,
              "station": make_station(scenario, robots=1)}
    for name, diagram in graphs.items():
        dot = OUT / f"{name}.dot"
        dot.write_text(diagram.GetGraphvizString(max_depth=args.depth), encoding="utf-8")
        print(f"wrote {dot}")
        if shutil.which("dot"):
            svg = dot.with_suffix(".svg")
            subprocess.run(["dot", "-Tsvg", str(dot), "-o", str(svg)], check=True)
            print(f"wrote {svg}")
        else:
            print("Graphviz's dot is not installed: render the .dot with any Graphviz viewer")


if __name__ == "__main__":
    main()
