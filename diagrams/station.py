"""The station: the table-tennis world every diagram is built on, in the style of Drake's
``MakeHardwareStation``: one Diagram with its ports exported by name, to which a script wires
players, loggers or anything else.

Inside (docs/design.md, "The serve diagram"): the MultibodyPlant and SceneGraph of the scenario's
world (table, net, floor, ball, 0-2 WAMs), the ball launcher, the aerodynamics (drag and Magnus),
the referee (one robot: :class:`tt_drake.systems.referee.Referee`; two:
:class:`tt_drake.systems.rally_referee.RallyReferee`), and per robot its
InverseDynamicsController with the scenario's joint faults; with ``meshcat``, a
``MeshcatVisualizer``; with ``camera``, a :class:`tt_drake.systems.ball_camera.BallCamera` of
the scenario's camera (the players see the ball through cameras of their own:
:func:`tt_drake.diagrams.episodes.add_perception`). Ports (``wam_A_*`` for the first robot,
``wam_B_*`` for the second, the rally's, mirrored through the net):

| port | direction | size | what |
|---|---|---|---|
| ``wam_A_desired_state`` | in | 14 | the controller's desired q, q_dot (rad, rad/s) |
| ``wam_A_desired_acceleration`` | in | 7 | the controller's desired q_ddot (rad/s^2) |
| ``wam_A_state`` | out | 14 | the arm's measured q, q_dot |
| ``wam_A_torque`` | out | 7 | the torques the controller commands (N m) |
| ``wam_A_acceleration`` | out | 7 | the arm's joint accelerations |
| ``ball_state`` | out | 13 | the ball: quaternion, p (m), omega (rad/s), v (m/s), world frame |
| ``ball_state_B`` | out | 13 | two robots: the ball in robot B's frame (the mirror, Rz(pi)) |
| ``camera_frames`` | out | 5 | with ``camera``: the last frame x, y, z (m), capture time, valid |
| ``contact_results`` | out | abstract | the plant's contact results |
| ``outcome`` | out | abstract | one robot: the referee's :class:`tt_drake.referee_rules.Outcome` |
| ``reward`` | out | 1 | one robot: the outcome's reward |
| ``rally`` | out | abstract | two robots: the rally referee's record |

The station adds no event the serve and rally diagrams lacked before, so the episodes built on
it are those built without it, bit for bit (tests/diagrams/test_recorded_outcomes.py). A
``meshcat`` visualizer publishes at its own rate: the integrator then also stops at those times.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import MeshcatVisualizer, MeshcatVisualizerParams
from pydrake.systems.analysis import ApplySimulatorConfig
from pydrake.systems.framework import BasicVector, Diagram, DiagramBuilder, LeafSystem
from pydrake.systems.primitives import Adder, MatrixGain

from tt_drake.blas import one_blas_thread
from tt_drake.diagrams.players import ControllerPorts, WorldPorts
from tt_drake.rally_rules import SIDES, mirror_matrix13
from tt_drake.referee_rules import Outcome
from tt_drake.seeds import episode_seed
from tt_drake.systems.aerodynamics import add_aerodynamics
from tt_drake.systems.ball_camera import BallCamera
from tt_drake.systems.ball_launcher import BallLauncher
from tt_drake.systems.joint_stops import make_joint_stops
from tt_drake.systems.rally_referee import RallyReferee
from tt_drake.systems.referee import RacketCentre, Referee
from tt_drake.systems.table_clearance import TableClearance
from tt_drake.systems.wam import (
    RACKET_CENTER_FRAME,
    add_drive_correction,
    add_drive_limits,
    add_joint_faults,
    add_wam_controller,
)
from tt_drake.systems.world import World, add_world, set_ball_state
from tt_drake.wam_params import AWAITING

#: The station's name inside the diagrams built on it.
STATION = "station"


def arm_port(side: int, what: str) -> str:
    """The name of robot ``side``'s (0: A, 1: B) port ``what`` (``state``, ``desired_state``,
    ``desired_acceleration``, ``torque``, ``acceleration``)."""
    return f"wam_{SIDES[side]}_{what}"


class OutcomeReward(LeafSystem):
    """The referee's outcome's reward as a vector output (``reward``, 1)."""

    def __init__(self):
        super().__init__()
        self.DeclareAbstractInputPort(
            "outcome", AbstractValue.Make(Outcome("missed", False, False, False)))
        self.DeclareVectorOutputPort("reward", BasicVector(1), self._calc)

    def _calc(self, context, output):
        output.SetAtIndex(0, float(self.get_input_port(0).Eval(context).reward))


@dataclass
class Station:
    """A station's parts and ports: the ``diagram`` (the station as a Diagram of its own, from
    :func:`build_station`; None when its parts were added to a caller's builder by
    :func:`add_station`), the ``world``, the ``launcher``, the ``referee`` (None without one),
    the ``controllers`` (one per robot), ``seeded``: its systems that draw random numbers (the
    arm's torque noise, the station camera), the Meshcat ``visualizer`` (None without one), and
    the named ports of the module docstring (``GetInputPort``, ``GetOutputPort``: the Diagram's
    exported ports, or the parts' own ports inside the caller's builder)."""

    diagram: Diagram | None
    world: World
    launcher: BallLauncher | None = None
    referee: object | None = None
    controllers: list = field(default_factory=list)
    seeded: list = field(default_factory=list)
    visualizer: object | None = None
    inputs: dict = field(default_factory=dict)
    outputs: dict = field(default_factory=dict)

    def GetInputPort(self, name: str):  # noqa: N802 (Drake's name: a Station reads as a Diagram)
        """The input port ``name`` (KeyError naming the ports if there is none)."""
        if self.diagram is not None:
            return self.diagram.GetInputPort(name)
        return _port(self.inputs, name, "input")

    def GetOutputPort(self, name: str):  # noqa: N802
        """The output port ``name`` (KeyError naming the ports if there is none)."""
        if self.diagram is not None:
            return self.diagram.GetOutputPort(name)
        return _port(self.outputs, name, "output")


def _port(ports: dict, name: str, kind: str):
    try:
        return ports[name]
    except KeyError:
        raise KeyError(f"the station has no {kind} port {name!r}; it has "
                       f"{', '.join(ports)}") from None


def build_station(scenario, robots: int = 1, meshcat=None, **parts) -> Station:
    """The station of ``scenario`` with ``robots`` WAMs (0, 1 or 2) as a Diagram of its own
    (named ``station``, its ports exported by name), and its parts' handles; ``parts``: as
    :func:`add_station`'s."""
    builder = DiagramBuilder()
    station = add_station(builder, scenario, robots, meshcat, **parts)
    for name, port in station.inputs.items():
        builder.ExportInput(port, name)
    for name, port in station.outputs.items():
        builder.ExportOutput(port, name)
    station.diagram = builder.Build()
    station.diagram.set_name(STATION)
    return station


def add_station(builder: DiagramBuilder, scenario, robots: int = 1, meshcat=None,
                end_when_decided: bool = True, launcher: bool = True, referee: bool = True,
                aerodynamics: bool = True, controllers: bool = True, world_config=None,
                camera: bool = False) -> Station:
    """Add the station's parts to ``builder`` (no sub-diagram: the serve and rally diagrams are
    built this way, so that their systems and state are laid out as before the station) and
    return their handles and named ports.

    ``end_when_decided``: the (one-robot) referee ends the simulation once the outcome is
    decided. ``launcher``, ``referee``, ``aerodynamics``, ``controllers``: leave a part out (the
    ball-only world has no launcher or referee, the recording scene only the plant; a station
    with only the plant may have ``scenario`` None). ``world_config``: the world's settings
    instead of ``scenario.world`` (with_robot and with_second_robot follow ``robots`` either
    way). ``camera``: a camera of ``scenario.camera`` on the ball, its frames the
    ``camera_frames`` port (the camera is in ``seeded``). The process's BLAS runs one thread
    from here on, for the players built on the station too (:func:`tt_drake.blas.one_blas_thread`,
    :func:`reset_episode`)."""
    if robots not in (0, 1, 2):
        raise ValueError(f"a station has 0, 1 or 2 robots, not {robots!r}")
    one_blas_thread()
    config = copy.copy(world_config if world_config is not None else scenario.world)
    config.with_robot, config.with_second_robot = robots >= 1, robots == 2
    world = add_world(builder, config)
    plant = world.plant
    station = Station(None, world)
    outputs = station.outputs
    if launcher:
        station.launcher = builder.AddNamedSystem("ball_launcher",
                                                  BallLauncher(scenario.launcher))
    forces = []  # the plant's applied generalized forces, summed below
    if aerodynamics:
        forces.append(add_aerodynamics(builder, world, scenario.aerodynamics,
                                       connect=False).get_output_port(0))
    ball = outputs["ball_state"] = plant.get_state_output_port(world.ball)
    outputs["contact_results"] = plant.get_contact_results_output_port()
    robot_instances = [r for r in (world.robot, world.robot_b) if r is not None]
    if referee and robots <= 1:
        referee_system = station.referee = builder.AddNamedSystem(
            "referee", _referee(scenario, world, end_when_decided))
        builder.Connect(ball, referee_system.get_input_port(0))
        if world.robot is not None:
            builder.Connect(plant.get_state_output_port(world.robot),
                            referee_system.GetInputPort("robot_state"))
        builder.Connect(plant.get_contact_results_output_port(),
                        referee_system.get_input_port(2))
        outputs["outcome"] = referee_system.GetOutputPort("outcome")
        reward = builder.AddNamedSystem("reward", OutcomeReward())
        builder.Connect(referee_system.GetOutputPort("outcome"), reward.get_input_port(0))
        outputs["reward"] = reward.GetOutputPort("reward")
    elif referee:
        referee_system = station.referee = builder.AddNamedSystem(
            "rally_referee", _rally_referee(scenario, world))
        builder.Connect(ball, referee_system.GetInputPort("ball_state"))
        builder.Connect(plant.get_contact_results_output_port(),
                        referee_system.GetInputPort("contact_results"))
        outputs["rally"] = referee_system.GetOutputPort("rally")
    if robots == 2:
        mirror = builder.AddNamedSystem("mirror_B", MatrixGain(mirror_matrix13()))
        builder.Connect(ball, mirror.get_input_port())
        outputs["ball_state_B"] = mirror.get_output_port()
    if camera:
        station_camera = builder.AddNamedSystem("station_camera", BallCamera(scenario.camera))
        builder.Connect(ball, station_camera.get_input_port(0))
        outputs["camera_frames"] = station_camera.GetOutputPort("measurement")
        station.seeded.append(station_camera)
    for k, robot in enumerate(robot_instances):
        state = plant.get_state_output_port(robot)
        if config.joint_stops.enabled:
            stops = builder.AddNamedSystem(
                "joint_stops" if robots == 1 else f"joint_stops_{SIDES[k]}",
                make_joint_stops(plant, robot, config.joint_stops))
            builder.Connect(state, stops.get_input_port())
            forces.append(stops.get_output_port())
        if referee and robots == 2:
            builder.Connect(state, station.referee.GetInputPort(
                f"robot_{SIDES[k].lower()}_state"))
        outputs[arm_port(k, "state")] = state
        outputs[arm_port(k, "acceleration")] = plant.get_generalized_acceleration_output_port(
            robot)
        if controllers:
            _add_controller(builder, scenario, world, robot, k, robots, station)
    _apply_generalized_forces(builder, plant, forces)
    if meshcat is not None:
        station.visualizer = MeshcatVisualizer.AddToBuilder(
            builder, world.scene_graph, meshcat, MeshcatVisualizerParams())
    return station


def _apply_generalized_forces(builder: DiagramBuilder, plant, forces: list) -> None:
    """Drive the plant's applied generalized force with the sum of ``forces`` (output ports of
    the plant's full generalized-force size): one port directly, several through a C++
    ``Adder``."""
    if not forces:
        return
    target = plant.get_applied_generalized_force_input_port()
    if len(forces) == 1:
        builder.Connect(forces[0], target)
        return
    total = builder.AddNamedSystem("applied_generalized_force",
                                   Adder(len(forces), plant.num_velocities()))
    for k, port in enumerate(forces):
        builder.Connect(port, total.get_input_port(k))
    builder.Connect(total.get_output_port(), target)


def robots_of(config) -> int:
    """How many robots a ``WorldConfig`` has (0, 1 or 2)."""
    return int(config.with_robot) + int(config.with_robot and config.with_second_robot)


def make_station(scenario, robots: int = 1, meshcat=None, camera: bool = False) -> Diagram:
    """The station Diagram of ``scenario`` with ``robots`` WAMs (1: the serve's, 2: the
    rally's), with a ``meshcat`` (``pydrake.geometry.Meshcat``) its visualizer, with ``camera``
    a camera's frames: the ports of the module docstring's table. Its parts are reachable by
    name (``plant``, ``ball_launcher``, ``referee`` or ``rally_referee``, ``wam_controller`` or
    ``wam_controller_A`` and ``_B``, ``station_camera``)."""
    return build_station(scenario, robots, meshcat, camera=camera).diagram


def _referee(scenario, world: World, end_when_decided: bool):
    """The serve's referee, with the robot's racket and bodies and the table's geometries."""
    plant, kwargs = world.plant, {}
    if world.robot is not None:
        frame = plant.GetFrameByName(RACKET_CENTER_FRAME, world.robot)
        table = table_top_geometries(world)
        kwargs = dict(racket_centre=RacketCentre(plant, world.robot, frame),
                      robot_body_indices=_robot_bodies(plant, world.robot),
                      table_geometry_ids=table,
                      table_clearance=_table_clearance(world, world.robot, table))
    return Referee(scenario.referee, scenario.referee_rate, stop_when_decided=end_when_decided,
                   **kwargs)


def _rally_referee(scenario, world: World):
    """The rally's referee, with both robots' racket centres and bodies and the table's
    geometries."""
    plant = world.plant
    robots = (world.robot, world.robot_b)
    centres = tuple(RacketCentre(plant, r, plant.GetFrameByName(RACKET_CENTER_FRAME, r))
                    for r in robots)
    table = table_top_geometries(world)
    return RallyReferee(scenario.rally, scenario.referee, scenario.referee_rate, centres,
                        robot_body_indices=tuple(_robot_bodies(plant, r) for r in robots),
                        table_geometry_ids=table,
                        table_clearances=tuple(_table_clearance(world, r, table) for r in robots))


def _robot_bodies(plant, robot) -> list:
    """The body indices of ``robot``: its arm links and its racket."""
    return [plant.get_body(i).index() for i in plant.GetBodyIndices(robot)]


def _table_clearance(world: World, robot, table: list) -> TableClearance | None:
    """The bound that spares the referee the contact query while ``robot`` cannot reach the
    table top (None where it cannot be built for the world's model)."""
    return TableClearance.of(world.plant, robot, table, world.scene_graph.model_inspector())


def table_top_geometries(world: World) -> list:
    """The table top's collision geometries: those named ``table_top`` on the table model's
    bodies (a static model's links are bodies of their own, welded to the world)."""
    plant, inspector = world.plant, world.scene_graph.model_inspector()
    return [g for i in plant.GetBodyIndices(world.table)
            for g in plant.GetCollisionGeometriesForBody(plant.get_body(i))
            if inspector.GetName(g).endswith("table_top")]


def _add_controller(builder, scenario, world: World, robot, side: int, robots: int,
                    station: Station) -> None:
    """Robot ``side``'s InverseDynamicsController (its desired inputs and commanded torques
    exported), its drives with ``controller.drive_voltage`` and, for the serve's robot, the
    scenario's joint faults."""
    c = scenario.controller
    name = "wam_controller" if robots == 1 else f"wam_controller_{SIDES[side]}"
    controller = add_wam_controller(builder, world.plant, robot, c.kp, c.ki, c.kd, name=name,
                                    mass_scale=c.mass_scale, inertia_scale=c.inertia_scale)
    desired_state = controller.get_input_port_desired_state()
    desired_acceleration = controller.get_input_port_desired_acceleration()
    torque = controller.GetOutputPort("actuation")
    if c.drive_aware:
        desired_state, desired_acceleration, torque = add_drive_correction(
            builder, world.plant, robot, controller, torque, c.kp, c.kd, c.drive_voltage,
            name="drive_correction" if robots == 1 else f"drive_correction_{SIDES[side]}")
    station.inputs[arm_port(side, "desired_state")] = desired_state
    station.inputs[arm_port(side, "desired_acceleration")] = desired_acceleration
    station.outputs[arm_port(side, "torque")] = torque
    station.controllers.append(controller)
    if c.drive_voltage:
        torque = add_drive_limits(builder, world.plant, robot, torque, c.drive_voltage,
                                  name="arm_drives" if robots == 1 else f"arm_drives_{SIDES[side]}")
    if robots == 1:
        noise = add_joint_faults(builder, world.plant, robot, controller, c.joint_coulomb,
                                 c.joint_viscous, c.coulomb_velocity, c.torque_noise,
                                 torque=torque)
        if noise is not None:
            station.seeded.append(noise)


def station_ports(diagram, side: int = 0):
    """What a player function reads from the world and the controller, as the station's ports
    for robot ``side``: (world view, controller view)
    (:class:`tt_drake.diagrams.players.WorldPorts`,
    :class:`tt_drake.diagrams.players.ControllerPorts`). ``diagram``: the station Diagram (a
    subsystem of the builder the player is added to) or the :class:`Station` of
    :func:`add_station` (its parts in that builder). Robot B's view sees the ball in its own
    frame (``ball_state_B``)."""
    ball = diagram.GetOutputPort("ball_state" if side == 0 else "ball_state_B")
    world = WorldPorts(ball, diagram.GetOutputPort(arm_port(side, "state")),
                       diagram.GetOutputPort(arm_port(side, "acceleration")))
    controller = ControllerPorts(diagram.GetInputPort(arm_port(side, "desired_state")),
                                 diagram.GetInputPort(arm_port(side, "desired_acceleration")))
    return world, controller


def awaiting_posture(world: World, root_context, station=None) -> None:
    """Every robot of ``world`` at rest in ``root_context``, where its player waits: at the
    joint angles of the desired state on ``station``'s ``wam_<A|B>_desired_state`` input there
    (a station Diagram, or the :class:`Station` of :func:`add_station`; hold the players' first
    set-points first, :func:`tt_drake.systems.wam.hold_first_setpoint`), so that no arm starts
    away from its player's awaiting posture; at ``wam_params.AWAITING`` without ``station``."""
    plant_context = world.plant.GetMyMutableContextFromRoot(root_context)
    for side, robot in enumerate((world.robot, world.robot_b)):
        if robot is None:
            continue
        q = np.asarray(AWAITING, dtype=float)
        if station is not None:
            port = station.GetInputPort(arm_port(side, "desired_state"))
            q = np.array(port.Eval(port.get_system().GetMyContextFromRoot(root_context))[:7])
        world.plant.SetPositions(plant_context, robot, q)


def reset_episode(simulator, initial, simulator_config, seeded: list, world: World,
                  seed: int):
    """Start the episode of ``seed`` on ``simulator`` (not yet initialised): the saved
    ``initial`` context's time, state and parameters; a fresh integrator at
    ``simulator_config`` (its step-size history would otherwise make an episode depend on the
    ones before it: a landing point moved 7e-7 m); the seeds: ``seeded[0]``, the launcher, gets
    ``seed`` itself, system k > 0 ``episode_seed(seed, k)``; the ball at the launcher's serve.
    Returns the serve (``tt_drake.serves.Serve``). The process's BLAS runs one thread from
    here on (:func:`tt_drake.blas.one_blas_thread`), so that an episode gives the same bits in
    a worker process and in this one, whatever its caller did to BLAS since the build."""
    one_blas_thread()
    context = simulator.get_mutable_context()
    context.SetTimeStateAndParametersFrom(initial)
    ApplySimulatorConfig(simulator_config, simulator)
    for k, system in enumerate(seeded):
        system.set_seed(system.GetMyMutableContextFromRoot(context),
                        seed if k == 0 else episode_seed(seed, k))
    launcher = seeded[0]
    serve = launcher.serve(launcher.GetMyContextFromRoot(context))
    set_ball_state(world, world.plant.GetMyMutableContextFromRoot(context), serve.launch_state)
    return serve
