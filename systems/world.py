"""The table-tennis world in a MultibodyPlant: table, net, floor, ball and (optionally) the WAM.

Simulation recipe (DESIGN.md, facts.md section 4): a continuous plant (``time_step = 0``), point
contact with Hunt-Crossley dissipation, stiction tolerance 1e-2 m/s, integrated by error-controlled
RK3 with accuracy 1e-4 and a maximum step of 2 ms. These are the defaults of
:class:`WorldConfig`; scenario YAML files may override them.
"""


from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlant, MultibodyPlantConfig
from pydrake.multibody.tree import ModelInstanceIndex
from pydrake.systems.analysis import Simulator, SimulatorConfig
from pydrake.systems.framework import DiagramBuilder


def default_plant_config() -> MultibodyPlantConfig:
    return MultibodyPlantConfig(time_step=0.0, contact_model="point", stiction_tolerance=1e-2)


def default_simulator_config() -> SimulatorConfig:
    return SimulatorConfig(integration_scheme="runge_kutta3", accuracy=1e-4, max_step_size=2e-3,
                           use_error_control=True)


@dataclass
class ModelFiles:
    """Model files, by name inside the package's ``models/`` folder or as paths."""

    table: str = "table_world.sdf"
    ball: str = "ball.sdf"
    robot: str = "wam7_racket.urdf"


@dataclass
class WorldConfig:
    plant: MultibodyPlantConfig = field(default_factory=default_plant_config)
    simulator: SimulatorConfig = field(default_factory=default_simulator_config)
    models: ModelFiles = field(default_factory=ModelFiles)
    with_robot: bool = True
    # A second WAM at the other end of the table (the rally, docs/rally.md): the first one's
    # model and mount turned a half-turn about the vertical axis through the table centre.
    with_second_robot: bool = False


SECOND_ROBOT_PREFIX = "b"  # the second robot's model instance is ``b::<the robot's model>``


class ModelFileError(FileNotFoundError):
    """A model file named by the scenario does not exist."""


def model_path(name: str) -> Path:
    """Resolve a model file: an existing path as given, else a file in ``tt_drake.models``."""
    path = Path(name)
    if path.is_file():
        return path
    packaged = Path(str(resources.files("tt_drake.models").joinpath(name)))
    if packaged.is_file():
        return packaged
    raise ModelFileError(f"model file not found: {name}")


@dataclass
class World:
    """Handles to the plant and its model instances."""

    plant: MultibodyPlant
    scene_graph: object
    table: ModelInstanceIndex
    ball: ModelInstanceIndex
    robot: ModelInstanceIndex | None
    robot_b: ModelInstanceIndex | None = None  # the second robot (``with_second_robot``)

    @property
    def ball_body(self):
        return self.plant.GetBodyByName("ball", self.ball)


def add_world(builder: DiagramBuilder, config: WorldConfig | None = None) -> World:
    """Add the plant with every model of ``config`` and finalise it."""
    config = config or WorldConfig()
    plant, scene_graph = AddMultibodyPlant(config.plant, builder)
    parser = Parser(plant)
    table = ball = robot = robot_b = None
    name = config.models.table
    try:  # Drake's parser errors on a file that parses as XML but is no valid model: one line
        (table,) = parser.AddModels(str(model_path(name)))
        name = config.models.ball
        (ball,) = parser.AddModels(str(model_path(name)))
        if config.with_robot:
            from tt_drake.systems.wam import add_wam

            name = config.models.robot
            robot = add_wam(plant, urdf=model_path(name))
            if config.with_second_robot:
                robot_b = add_wam(plant, urdf=model_path(name), mirrored=True,
                                  name_prefix=SECOND_ROBOT_PREFIX)
    except (RuntimeError, ValueError) as err:
        first = next((line for line in str(err).splitlines() if line.strip()), type(err).__name__)
        raise ModelFileError(f"cannot load model file {name}: {first.strip()}") from None
    plant.Finalize()
    return World(plant, scene_graph, table, ball, robot, robot_b)


def ball_state_indices(world: World) -> tuple[int, int]:
    """Start indices of the ball's (q, v) in the plant's full state vector [q; v]:
    q = (quaternion wxyz, position xyz), v = (angular velocity, translational velocity)."""
    plant = world.plant
    body = world.ball_body
    v_start = plant.num_positions() + body.floating_velocities_start_in_v()
    return body.floating_positions_start(), v_start


def set_ball_state(world: World, plant_context, launch_state) -> None:
    """Put the ball at the launch state (p, v, omega) with identity orientation."""
    from pydrake.math import RigidTransform
    from pydrake.multibody.math import SpatialVelocity

    body = world.ball_body
    world.plant.SetFreeBodyPose(plant_context, body, RigidTransform(list(launch_state[0:3])))
    world.plant.SetFreeBodySpatialVelocity(
        plant_context, body, SpatialVelocity(w=list(launch_state[6:9]), v=list(launch_state[3:6])))


def make_simulator(diagram, config: WorldConfig) -> Simulator:
    from pydrake.systems.analysis import ApplySimulatorConfig

    simulator = Simulator(diagram)
    ApplySimulatorConfig(config.simulator, simulator)
    return simulator

