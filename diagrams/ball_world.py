"""A ball-only world (table, net, floor, ball, aerodynamics) that replays launches fast: built
once, each run restores the initial context. Used to generate labelled ball flights and by the
physics tests; by default at the simulation recipe's accuracy throughout (no flight
accuracy)."""

import numpy as np
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import VectorLogSink

from tt_drake.systems.aerodynamics import AerodynamicsConfig, add_aerodynamics
from tt_drake.systems.world import (
    RECIPE_FLIGHT_ACCURACY,
    WorldConfig,
    add_world,
    make_simulator,
    set_ball_state,
)


class BallOnlyWorld:
    def __init__(self, log_period: float = 5e-4, aerodynamics: bool = True,
                 config: WorldConfig | None = None):
        builder = DiagramBuilder()
        self.config = config or WorldConfig(with_robot=False,
                                             flight_accuracy=RECIPE_FLIGHT_ACCURACY)
        self.world = add_world(builder, self.config)
        plant = self.world.plant
        add_aerodynamics(builder, self.world, AerodynamicsConfig(enabled=aerodynamics))
        self.logger = builder.AddNamedSystem("ball_logger", VectorLogSink(13, log_period))
        builder.Connect(plant.get_state_output_port(self.world.ball), self.logger.get_input_port())
        self.diagram = builder.Build()
        self.simulator = make_simulator(self.diagram, self.config)
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
