"""A ball-only Drake world (table, net, floor, ball, aerodynamics) for physics tests."""

import numpy as np
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import VectorLogSink

from tt_drake.systems.aerodynamics import Aerodynamics, AerodynamicsConfig
from tt_drake.systems.world import WorldConfig, add_world, make_simulator, set_ball_state


class BallWorld:
    def __init__(self, aerodynamics: bool = True, log_period: float = 5e-4,
                 config: WorldConfig | None = None):
        builder = DiagramBuilder()
        self.config = config or WorldConfig(with_robot=False)
        self.world = add_world(builder, self.config)
        plant = self.world.plant
        aero = builder.AddSystem(Aerodynamics(
            plant.num_velocities(), self.world.ball_body.floating_velocities_start_in_v(),
            AerodynamicsConfig(enabled=aerodynamics)))
        builder.Connect(plant.get_state_output_port(self.world.ball), aero.get_input_port(0))
        builder.Connect(aero.get_output_port(0), plant.get_applied_generalized_force_input_port())
        self.logger = builder.AddSystem(VectorLogSink(13, log_period))
        builder.Connect(plant.get_state_output_port(self.world.ball), self.logger.get_input_port())
        self.diagram = builder.Build()
        self.simulator = make_simulator(self.diagram, self.config)
        self.context = self.simulator.get_mutable_context()
        self._initial = self.context.Clone()

    def run(self, launch_state, duration: float):
        """Simulate from ``launch_state`` (p, v[, omega]); returns (t, p, v, omega) samples."""
        self.context.SetTimeStateAndParametersFrom(self._initial)
        state = np.zeros(9)
        state[: len(launch_state)] = launch_state
        plant_context = self.world.plant.GetMyMutableContextFromRoot(self.context)
        set_ball_state(self.world, plant_context, state)
        self.logger.FindMutableLog(self.context).Clear()
        self.simulator.Initialize()
        self.simulator.AdvanceTo(duration)
        log = self.logger.FindLog(self.context)
        data = log.data()
        return log.sample_times(), data[4:7].T, data[10:13].T, data[7:10].T
