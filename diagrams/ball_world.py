"""A ball-only world (table, net, floor, ball, aerodynamics) that replays launches fast: built
once, each run restores the initial context. Used to generate labelled ball flights and by the
physics tests; by default at the simulation recipe's accuracy throughout (no flight
accuracy)."""

import numpy as np
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import VectorLogSink

from tt_drake.diagrams.scenario import Scenario
from tt_drake.diagrams.station import add_station, robots_of
from tt_drake.systems.aerodynamics import AerodynamicsConfig
from tt_drake.systems.world import (
    RECIPE_FLIGHT_ACCURACY,
    WorldConfig,
    make_simulator,
    set_ball_state,
)


class BallOnlyWorld:
    def __init__(self, log_period: float = 5e-4, aerodynamics: bool = True,
                 config: WorldConfig | None = None):
        builder = DiagramBuilder()
        self.config = config or WorldConfig(with_robot=False,
                                             flight_accuracy=RECIPE_FLIGHT_ACCURACY)
        scenario = Scenario(world=self.config,
                            aerodynamics=AerodynamicsConfig(enabled=aerodynamics))
        station = add_station(builder, scenario, robots_of(self.config), launcher=False,
                              referee=False, controllers=False)
        self.world = station.world
        self.logger = builder.AddNamedSystem("ball_logger", VectorLogSink(13, log_period))
        builder.Connect(station.GetOutputPort("ball_state"), self.logger.get_input_port())
        self.diagram = builder.Build()
        self.simulator = make_simulator(self.diagram, self.config, self.world.plant)
        self.context = self.simulator.get_mutable_context()
        self._initial = self.context.Clone()

    def run(self, launch_state, duration: float):
        """Simulate from ``launch_state`` (p, v[, omega]) for ``duration`` s; returns copies of the
        logged (t, p, v, omega)."""
        self.context.SetTimeStateAndParametersFrom(self._initial)
        state = np.zeros(9)
        state[: len(launch_state)] = np.asarray(launch_state, dtype=float)
        plant_context = self.world.plant.GetMyMutableContextFromRoot(self.context)
        set_ball_state(self.world, plant_context, state)
        self.logger.FindMutableLog(self.context).Clear()
        self.simulator.Initialize()
        self.simulator.AdvanceTo(duration)
        log = self.logger.FindLog(self.context)
        data = log.data()
        return (log.sample_times().copy(), data[4:7].T.copy(), data[10:13].T.copy(),
                data[7:10].T.copy())
