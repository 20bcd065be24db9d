"""The table-tennis world in a MultibodyPlant: table, net, floor, ball and (optionally) the WAM.

Simulation recipe (docs/design.md): a continuous plant (``time_step = 0``), point
contact with Hunt-Crossley dissipation, stiction tolerance 1e-2 m/s, integrated by error-controlled
RK3 with accuracy 1e-4 and a maximum step of 2 ms. These are the defaults of
:class:`WorldConfig`; scenario YAML files may override them. With ``flight_accuracy`` (default
1e-3, as in the default scenario; 0 keeps the recipe's accuracy throughout) the accuracy is relaxed
to it while nothing can touch the ball (:class:`ContactAccuracy`); every contact keeps the
recipe's.
"""


import math
import os
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

from pydrake.math import RigidTransform
from pydrake.multibody.math import SpatialVelocity
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlant, MultibodyPlantConfig
from pydrake.multibody.tree import ModelInstanceIndex
from pydrake.systems.analysis import (
    ApplySimulatorConfig,
    Simulator,
    SimulatorConfig,
    SimulatorStatus,
)
from pydrake.systems.framework import Diagram, DiagramBuilder, EventStatus

from tt_drake.constants import BALL, NET, TABLE
from tt_drake.errors import BadInputError
from tt_drake.systems.hitting_ik import REACH_BOUND
from tt_drake.systems.joint_stops import JointStopsConfig
from tt_drake.systems.wam import add_wam, shoulder_pose
from tt_drake.wam_params import RACKET_CENTER_FRAME


def default_plant_config() -> MultibodyPlantConfig:
    return MultibodyPlantConfig(time_step=0.0, contact_model="point", stiction_tolerance=1e-2)


def default_simulator_config() -> SimulatorConfig:
    return SimulatorConfig(integration_scheme="runge_kutta3", accuracy=1e-4, max_step_size=2e-3,
                           use_error_control=True)


@dataclass
class ModelFiles:
    """Model files: a bare file name (``ball.sdf``) is the package's ``models/`` file, whatever
    the working folder holds; a path (with a folder: ``./ball.sdf``, ``/abs/ball.sdf``) is that
    file (:func:`model_path`)."""

    table: str = "table_world.sdf"
    ball: str = "ball.sdf"
    robot: str = "wam7_racket.urdf"


@dataclass
class WorldConfig:
    plant: MultibodyPlantConfig = field(default_factory=default_plant_config)
    simulator: SimulatorConfig = field(default_factory=default_simulator_config)
    models: ModelFiles = field(default_factory=ModelFiles)
    with_robot: bool = True
    # > 0: the integrator's accuracy while nothing can touch the ball (ContactAccuracy); the
    # simulator's own accuracy applies near every contact. 0: the simulator's accuracy always
    # (the recipe: RECIPE_FLIGHT_ACCURACY).
    flight_accuracy: float = 1e-3
    # A second WAM at the other end of the table (the rally, docs/rally.md): the first one's
    # model and mount turned a half-turn about the vertical axis through the table centre.
    with_second_robot: bool = False
    # The arm's mechanical stops at its joint limits (systems/joint_stops.py): the continuous
    # plant ignores the limits the model file gives.
    joint_stops: JointStopsConfig = field(default_factory=JointStopsConfig)


#: ``WorldConfig.flight_accuracy`` of the simulation recipe itself: one accuracy throughout.
RECIPE_FLIGHT_ACCURACY = 0.0

SECOND_ROBOT_PREFIX = "b"  # the second robot's model instance is ``b::<the robot's model>``


class ModelFileError(FileNotFoundError, BadInputError):
    """A model file named by the scenario does not exist."""


def is_explicit_path(name: str) -> bool:
    """Whether ``name`` names a file by its path (it has a folder part: ``./ball.sdf``,
    ``sub/ball.sdf``, an absolute path) rather than by a bare name resolved in the package."""
    return os.path.isabs(name) or any(sep in name for sep in {"/", os.sep})


def model_path(name: str) -> Path:
    """Resolve a model file: a bare name is the file of that name in ``tt_drake.models`` (a file
    of the same name in the working folder is not looked at: ``./ball.sdf`` names that one); a
    path (:func:`is_explicit_path`) is resolved to an absolute path."""
    if is_explicit_path(name):
        path = Path(name).expanduser().resolve()
    else:
        path = Path(str(resources.files("tt_drake.models").joinpath(name)))
    if path.is_file():
        return path
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
    body = world.ball_body
    world.plant.SetFreeBodyPose(plant_context, body, RigidTransform(list(launch_state[0:3])))
    world.plant.SetFreeBodySpatialVelocity(
        plant_context, body, SpatialVelocity(w=list(launch_state[6:9]), v=list(launch_state[3:6])))


def find_plant(diagram):
    """The subsystem named ``plant`` of ``diagram`` or, depth first, of a diagram inside it (a
    station nests the plant)."""
    if diagram.HasSubsystemNamed("plant"):
        return diagram.GetSubsystemByName("plant")
    for system in diagram.GetSystems():
        if isinstance(system, Diagram):
            found = find_plant(system)
            if found is not None:
                return found
    return None


def make_simulator(diagram, config: WorldConfig, plant=None) -> Simulator:
    """A simulator of ``diagram`` at ``config.simulator``; with ``config.flight_accuracy`` > 0
    also the :class:`ContactAccuracy` monitor of ``plant`` (default: :func:`find_plant`)."""
    return simulator_and_schedule(diagram, config, plant)[0]


def simulator_and_schedule(diagram, config: WorldConfig, plant=None):
    """:func:`make_simulator` and its monitor's :class:`ContactAccuracy` (None without one), for
    whoever also advances in segments (:func:`advance_in_segments`) with the same schedule."""
    simulator = Simulator(diagram)
    ApplySimulatorConfig(config.simulator, simulator)
    schedule = contact_accuracy(simulator, diagram, config, plant)
    if schedule is not None:
        simulator.set_monitor(schedule)
    return simulator, schedule


def contact_accuracy(simulator: Simulator, diagram, config: WorldConfig, plant=None):
    """The :class:`ContactAccuracy` schedule of ``config`` for ``simulator`` (None when
    ``config.flight_accuracy`` is 0); ``plant``: as :func:`make_simulator`'s."""
    if config.flight_accuracy <= 0.0:
        return None
    return ContactAccuracy(simulator, diagram, config.simulator.accuracy, config.flight_accuracy,
                           plant=plant)


def advance_in_segments(simulator: Simulator, schedule, end: float, period: float):
    """``simulator.AdvanceTo(end)`` with ``schedule`` (a :class:`ContactAccuracy`) deciding the
    accuracy once per ``period`` instead of after every integrator step: the simulation advances
    to the next multiple of ``period`` (``k * period``, the same times as a periodic event of that
    period, so the integrator stops nowhere it would not stop anyway when such an event exists),
    the schedule sets the accuracy from the state there, and so on. One Python call per period
    (250 Hz: ~400 per serve) instead of one per step (~1,400). The schedule's horizon must cover
    ``period`` plus a step: a contact within ``period`` of a decision is then already within the
    horizon at the decision before (docs/performance.md, "The integrator's accuracy"). While this
    runs the
    simulator has no monitor; afterwards ``schedule`` is its monitor (as :func:`make_simulator`
    leaves it). The monitor it had is not read back and set again: each such round trip through
    pybind wraps the previous wrapper, so a worker that played ~1,000 serves hit Python's
    recursion limit inside the monitor. Returns the last AdvanceTo status (the referee's
    termination ends the loop)."""
    boundary = SimulatorStatus.ReturnReason.kReachedBoundaryTime
    simulator.clear_monitor()
    context = simulator.get_context()
    try:
        k = math.floor(context.get_time() / period + 1e-9)
        while True:
            schedule(context)
            k += 1
            stop = min(k * period, end)
            status = simulator.AdvanceTo(stop)
            if stop >= end or status.reason() != boundary:
                return status
    finally:
        simulator.set_monitor(schedule)


class ContactAccuracy:
    """A simulator monitor (called after every integrator step) that sets the error-controlled
    integrator's target accuracy: ``contact`` (the scenario's, 1e-4) whenever the ball may touch
    the table, the net, the floor or the racket within ``horizon`` seconds, ``flight`` (looser)
    otherwise.

    Most of a serve's integrator steps are spent where nothing touches the ball: in flight, the
    swinging arm under its controller limits the steps to ~1 ms at 1e-4 (the ball alone, even
    spinning, takes the 2 ms maximum; docs/performance.md). A looser accuracy there changes the
    arm's tracking by far less than anything the players or the referee resolve, while every
    contact (the table bounce, the racket hit) is still integrated at the recipe's accuracy. The
    ball may touch something within the horizon if (with p, v its centre and velocity, R its
    radius):

    - table: over the table (+5 cm) and ``p_z - (z_table + R) < max(0, -v_z) horizon + 1 cm``;
    - net: ``|p_y| < 10 cm + |v_y| horizon``, below the net's top + R + 5 cm and within its
      span (posts included) + R + 5 cm;
    - floor: ``p_z < R + 2 cm + max(0, -v_z) horizon``;
    - racket: within ``12 cm + (|v|_1 + 10 m/s) horizon`` of the blade centre (the racket
      moving at up to 10 m/s).

    The decision uses the state at the end of each step, so the step that reaches a contact is
    already taken at the contact accuracy (the horizon spans five 2 ms steps). The serve episodes
    call it once per 4 ms referee tick instead (:func:`advance_in_segments`): the horizon still
    covers the time to the next decision plus a step."""

    def __init__(self, simulator: Simulator, diagram, contact: float, flight: float,
                 horizon: float = 0.01, plant=None):
        self._simulator = simulator
        self._plant = plant = plant or find_plant(diagram)
        ball = plant.GetBodyByName("ball")
        self._ball = ball.model_instance()
        self._accuracy = (float(contact), float(flight))
        self._horizon = float(horizon)
        r = BALL.radius
        self._contact_z = TABLE.surface_z + r
        self._half = (0.5 * TABLE.width + 0.05, 0.5 * TABLE.length + 0.05)
        self._net_top = TABLE.surface_z + NET.height + r + 0.05
        self._net_x = NET.half_span + r + 0.05
        self._radius = r
        # Every robot's racket (the rally has two): the blade centre stays within REACH_BOUND of
        # its shoulder, so a ball farther than that (plus the racket's distance) needs no
        # forward kinematics. Each robot's shoulder is where its base is welded (shoulder_pose).
        default = plant.CreateDefaultContext()
        self._rackets = []
        for i in range(plant.num_model_instances()):
            instance = ModelInstanceIndex(i)
            if not plant.HasFrameNamed(RACKET_CENTER_FRAME, instance):
                continue
            frame = plant.GetFrameByName(RACKET_CENTER_FRAME, instance)
            shoulder = tuple(float(c) for c in shoulder_pose(plant, instance, default)[:3, 3])
            self._rackets.append((frame.body(), frame.GetFixedPoseInBodyFrame().translation(),
                                  shoulder, REACH_BOUND))
        # The ball's position and velocity in the plant's state [q; v] (q: quaternion, then
        # position; v: angular, then translational velocity).
        self._p = ball.floating_positions_start() + 4
        self._v = plant.num_positions() + ball.floating_velocities_start_in_v() + 3
        # Per call (about 1,400 per serve) the monitor reads the plant's state through a view
        # bound to the simulator's context at the first call and returns one kept status: no
        # context or state wrapper is made per step (docs/performance.md). The
        # integrator is asked for at every call: ApplySimulatorConfig (each episode) replaces it.
        self._root = None
        self._plant_context = None
        self._state = None
        self._succeeded = EventStatus.Succeeded()

    def near_contact(self, plant_context) -> bool:
        """Whether the ball may touch the table, net, floor or racket within the horizon."""
        return self._near(plant_context.get_continuous_state_vector().get_value().tolist(),
                          plant_context)

    def _near(self, x: list, plant_context) -> bool:
        """:meth:`near_contact` on the plant's state ``x`` ([q; v] as floats)."""
        p, v = self._p, self._v
        px, py, pz, vx, vy, vz = x[p], x[p + 1], x[p + 2], x[v], x[v + 1], x[v + 2]
        h = self._horizon
        fall = max(0.0, -vz) * h
        if (abs(px) < self._half[0] and abs(py) < self._half[1]
                and pz - self._contact_z < fall + 0.01):
            return True
        if abs(py) < 0.1 + abs(vy) * h and pz < self._net_top and abs(px) < self._net_x:
            return True
        if pz < self._radius + 0.02 + fall:
            return True
        reach = 0.12 + (abs(vx) + abs(vy) + abs(vz) + 10.0) * h
        for body, offset, shoulder, arm_reach in self._rackets:
            dx, dy, dz = shoulder[0] - px, shoulder[1] - py, shoulder[2] - pz
            if math.sqrt(dx * dx + dy * dy + dz * dz) > arm_reach + reach:
                continue
            c = self._plant.EvalBodyPoseInWorld(plant_context, body).multiply(offset)
            dx, dy, dz = c[0] - px, c[1] - py, c[2] - pz
            if dx * dx + dy * dy + dz * dz < reach * reach:
                return True
        return False

    def __call__(self, root_context):
        if root_context is not self._root:
            # Bound once per context: the simulator keeps its context, and holding the root's
            # wrapper keeps pybind handing out this same object for it.
            self._root = root_context
            self._plant_context = self._plant.GetMyContextFromRoot(root_context)
            self._state = self._plant_context.get_continuous_state_vector().get_value()
        near = self._near(self._state.tolist(), self._plant_context)
        target = self._accuracy[0] if near else self._accuracy[1]
        integrator = self._simulator.get_mutable_integrator()
        if integrator.get_target_accuracy() != target:
            integrator.set_target_accuracy(target)
        return self._succeeded
