"""The Barrett WAM with its racket in a MultibodyPlant, and its inverse-dynamics controller.

Frames (docs/world.md world frame: z up, +y from the robot's end toward the launcher, +x the robot's
forehand). The WAM hangs from the ceiling: its base plate (URDF link ``wam_base``, origin on the
plate, z toward the shoulder) is welded at ``(MOUNT.mount_x, MOUNT.mount_y, MOUNT.mount_z)`` with
orientation :data:`tt_drake.wam_params.BASE_ROTATION`, a half-turn about the horizontal axis
(1, 1, 0)/sqrt(2) (equivalently Rz(pi/2) Rx(pi)). That turns joint 1's axis ``z_0`` to -z
(vertical, hanging), puts the shoulder ``MOUNT.base_to_shoulder`` below the plate, and sends the
robot's front ``x_0`` (where positive q2 and q4 carry the hand) to +y, toward the table, so the
``y_0`` side, where the arm's forehand swing happens, is +x.

The racket-centre frame ``racket_center`` is at the blade centre; its y axis is the racket
normal, its z axis runs from the handle through the blade (tt_drake.wam_params docstring).
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import numpy as np
from pydrake.common import RandomDistribution, RandomGenerator
from pydrake.geometry import CollisionFilterDeclaration, GeometrySet, SceneGraph
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import BodyIndex, ModelInstanceIndex, SpatialInertia
from pydrake.symbolic import MakeVectorVariable, tanh
from pydrake.systems.controllers import InverseDynamicsController
from pydrake.systems.framework import Context, DiagramBuilder
from pydrake.systems.primitives import (
    Adder,
    Demultiplexer,
    MatrixGain,
    Multiplexer,
    PassThrough,
    RandomSource,
    Saturation,
    ZeroOrderHold,
)

from tt_drake import wam_params as wp
from tt_drake.constants import MOUNT
from tt_drake.drives import DriveEnvelope
from tt_drake.systems.arm_dynamics import chain_of
from tt_drake.systems.drive_correction import DriveAwareCorrection
from tt_drake.systems.symbolic_law import symbolic_law

MODEL_FILE = "wam7_racket.urdf"
BASE_FRAME = wp.BASE_LINK  # "wam_base": the base plate
RACKET_BODY = wp.RACKET_LINK  # "racket": body carrying the blade, frame = DH frame 7 (flange)
RACKET_CENTER_FRAME = wp.RACKET_CENTER_FRAME  # "racket_center": blade centre, y = normal
RACKET_BLADE_GEOMETRY = wp.RACKET_BLADE_GEOMETRY  # "racket_blade": the blade collision disc
RACKET_CENTER_OFFSET = (0.0, 0.0, wp.RACKET.center_offset)  # blade centre in the racket body
JOINT_NAMES = wp.JOINT_NAMES
NUM_JOINTS = wp.NUM_JOINTS

# InverseDynamicsController gains (per joint, acceleration units since the controller multiplies
# by the mass matrix: vd_cmd = vd_d + kp (q_d - q) + kd (v_d - v) + ki int(q_d - q)).
# kp = 900 1/s^2 gives a 30 rad/s (4.8 Hz) closed-loop bandwidth, well above the ~1 Hz content
# of a stroke and under the 500 Hz servo rate of the lab; kd = 2 sqrt(kp) = 60 1/s is critical
# damping. ki = 0: the control plant is the simulated arm itself, so there is no steady load for
# an integrator to learn, and any ki adds a slow closed-loop pole near -ki/kp whose tail outlives
# the transient (with ki = 20 a 0.05 rad offset still left 0.08 mm after 2 s instead of ~0) and
# winds up whenever the effort limits clamp a fast stroke. Pass a small ki (ki < kp kd for
# stability) if the control plant is ever made to differ from the simulated one.
KP = (900.0,) * NUM_JOINTS
KD = (60.0,) * NUM_JOINTS
KI = (0.0,) * NUM_JOINTS


def model_file() -> Path:
    """Path of the packaged URDF (``models/wam7_racket.urdf``, package ``tt_drake.models``)."""
    return Path(str(resources.files("tt_drake.models").joinpath(MODEL_FILE)))


def base_pose_in_world(mirrored: bool = False) -> RigidTransform:
    """X_WB: the base plate frame in the world (hanging from the ceiling mount). ``mirrored``:
    the mount at the other end of the table, the half-turn about the vertical axis through the
    table centre applied to it (the rally's second robot, :mod:`tt_drake.rally_rules`)."""
    pose = RigidTransform(RotationMatrix(np.array(wp.BASE_ROTATION)),
                          [MOUNT.mount_x, MOUNT.mount_y, MOUNT.mount_z])
    if mirrored:
        pose = RigidTransform(RotationMatrix.MakeZRotation(np.pi)) @ pose
    return pose


def shoulder_pose(plant: MultibodyPlant, robot: ModelInstanceIndex, context) -> np.ndarray:
    """X_W0 (4x4): ``robot``'s DH frame 0 in the world, where ``plant`` has its base plate
    (welded anywhere, e.g. mirrored) in ``context`` (a context of ``plant``): X_WB
    X_WB,default^-1 times :func:`tt_drake.wam_params.shoulder_pose_in_world`."""
    x_wb = plant.GetFrameByName(BASE_FRAME, robot).CalcPoseInWorld(context)
    return (x_wb @ base_pose_in_world().inverse()).GetAsMatrix4() @ wp.shoulder_pose_in_world()


def add_wam(plant: MultibodyPlant, *, weld_to_world: bool = True, urdf: str | Path | None = None,
            scene_graph: SceneGraph | None = None, mirrored: bool = False,
            name_prefix: str = "") -> ModelInstanceIndex:
    """Parse the WAM + racket into ``plant`` (not finalised) and return its model instance.

    ``weld_to_world``: weld ``wam_base`` at :func:`base_pose_in_world`. ``urdf``: another model
    file (default: the packaged one). The file's collision filter group already keeps the robot's
    geometries from colliding with each other; if ``scene_graph`` (the one the plant is
    registered with) is given, the same exclusion is also declared on it directly.
    ``mirrored``: weld at ``base_pose_in_world(mirrored=True)``; ``name_prefix``: a scoped
    prefix of the model instance's name (a second WAM needs one: ``"b"`` gives ``b::wam7_racket``).
    """
    path = Path(urdf) if urdf is not None else model_file()
    (instance,) = Parser(plant, model_name_prefix=name_prefix).AddModels(str(path))
    if weld_to_world:
        plant.WeldFrames(plant.world_frame(), plant.GetFrameByName(BASE_FRAME, instance),
                         base_pose_in_world(mirrored))
    if scene_graph is not None and plant.geometry_source_is_registered():
        scene_graph.collision_filter_manager().Apply(
            CollisionFilterDeclaration().ExcludeWithin(robot_geometries(plant, instance)))
    return instance


def robot_geometries(plant: MultibodyPlant, instance: ModelInstanceIndex) -> GeometrySet:
    """Every registered geometry of the robot (e.g. for contact bookkeeping)."""
    bodies = [plant.get_body(index) for index in plant.GetBodyIndices(instance)]
    return plant.CollectRegisteredGeometries(bodies)


def make_control_plant() -> MultibodyPlant:
    """A finalised, continuous plant with only the arm and its welded racket, fully actuated,
    welded exactly like the simulation's; the model that InverseDynamicsController uses."""
    plant = MultibodyPlant(time_step=0.0)
    add_wam(plant)
    plant.Finalize()
    return plant


def racket_pose(plant: MultibodyPlant, context: Context,
                instance: ModelInstanceIndex) -> RigidTransform:
    """X_WC: pose of the racket-centre frame in the world (y_C is the racket normal)."""
    return plant.GetFrameByName(RACKET_CENTER_FRAME, instance).CalcPoseInWorld(context)


def awaiting_state() -> np.ndarray:
    """Arm state [q; v] at rest in the AWAITING posture."""
    return np.concatenate([np.asarray(wp.AWAITING, dtype=float), np.zeros(NUM_JOINTS)])


def scaled_control_context(control_plant: MultibodyPlant, mass_scale: float = 1.0,
                           inertia_scale: float = 1.0) -> Context:
    """A context of ``control_plant`` whose link masses are ``mass_scale`` times the model's and
    whose rotational inertias about each link's centre of mass are ``inertia_scale`` times the
    model's (centres of mass unchanged): the controller's wrong belief about the arm."""
    context = control_plant.CreateDefaultContext()
    for index in range(1, control_plant.num_bodies()):  # body 0 is the world
        body = control_plant.get_body(BodyIndex(index))
        m = body.default_mass()
        if not m > 0.0:
            continue
        p = body.default_com()
        inertia_cm = body.default_spatial_inertia().Shift(p).CalcRotationalInertia()
        body.SetSpatialInertiaInBodyFrame(context, SpatialInertia.MakeFromCentralInertia(
            mass_scale * m, p, inertia_cm * inertia_scale))
    return context


def add_wam_controller(builder: DiagramBuilder, plant: MultibodyPlant,
                       instance: ModelInstanceIndex, kp=KP, ki=KI, kd=KD,
                       name: str = "wam_controller", mass_scale: float = 1.0,
                       inertia_scale: float = 1.0) -> InverseDynamicsController:
    """Add an InverseDynamicsController (own control plant, reference acceleration enabled).

    Connected here: plant arm state -> ``estimated_state``; ``actuation`` -> the plant's actuation
    input for ``instance``. Left for the caller: ``desired_state`` ([q_d; v_d], 14) and
    ``desired_acceleration`` (q̈_d, 7); both must be connected or exported. The control plant is
    reachable as ``controller.get_multibody_plant_for_control()``. ``mass_scale`` and
    ``inertia_scale`` != 1 make the controller's model differ from the simulated arm
    (:func:`scaled_control_context`).
    """
    control_plant = make_control_plant()
    context = None
    if mass_scale != 1.0 or inertia_scale != 1.0:
        context = scaled_control_context(control_plant, mass_scale, inertia_scale)
    controller = builder.AddSystem(InverseDynamicsController(
        control_plant, np.asarray(kp, dtype=float), np.asarray(ki, dtype=float),
        np.asarray(kd, dtype=float), True, context))
    controller.set_name(name)
    builder.Connect(plant.get_state_output_port(instance),
                    controller.get_input_port_estimated_state())
    builder.Connect(controller.GetOutputPort("actuation"),
                    plant.get_actuation_input_port(instance))
    return controller


def joint_friction_system(coulomb, viscous, velocity_scale: float):
    """A C++ SymbolicVectorSystem (:func:`tt_drake.systems.symbolic_law.symbolic_law`): arm
    state (q, v) (14) -> joint friction torques (7), ``tau_j = -c_j tanh(v_j / v_s) - b_j v_j``
    (Coulomb friction smoothed over ``v_s``, plus viscous friction)."""
    x = MakeVectorVariable(2 * NUM_JOINTS, "x")
    v = x[NUM_JOINTS:]
    tau = [-float(c) * tanh(v[j] / velocity_scale) - float(b) * v[j]
           for j, (c, b) in enumerate(zip(coulomb, viscous, strict=True))]
    return symbolic_law(x, tau)


class TorqueNoise:
    """Seeding handle of the torque-noise source (``set_seed(context, seed)`` like the other
    seeded systems); the source is Drake's C++ ``RandomSource``."""

    def __init__(self, source):
        self.source = source

    def GetMyMutableContextFromRoot(self, root):  # noqa: N802 (Drake's name)
        return self.source.GetMyMutableContextFromRoot(root)

    def set_seed(self, context, seed: int) -> None:
        self.source.SetRandomContext(context, RandomGenerator(int(seed) % 2**32))


def _reroute_actuation(builder: DiagramBuilder, plant: MultibodyPlant,
                       instance: ModelInstanceIndex, torque):
    """Disconnect ``torque`` (the output port now driving ``instance``'s actuation) from the
    plant; return the plant's actuation input port for the caller to drive."""
    actuation = plant.get_actuation_input_port(instance)
    builder.Disconnect(torque, actuation)
    return actuation


def add_drive_limits(builder: DiagramBuilder, plant: MultibodyPlant,
                     instance: ModelInstanceIndex, torque, voltage: float,
                     name: str = "arm_drives"):
    """The arm's DC drives at supply ``voltage`` between the commanded ``torque`` (the output
    port now driving the plant's actuation) and the plant: each joint gets
    ``clamp(tau, -a - b v, a - b v)`` (:mod:`tt_drake.drives`; the plant then applies the
    effort limits). Built from C++ primitives, so the integrator's steps call no Python: with
    ``u = tau + b v``, ``clamp(tau, -a - b v, a - b v) = clamp(u, -a, a) - b v``
    (MatrixGain on the arm state, Adder, Saturation). Returns the output port of the applied
    torque."""
    drive = DriveEnvelope(voltage)
    emf = np.hstack([np.zeros((NUM_JOINTS, NUM_JOINTS)), np.diag(drive.back_emf)])
    state = plant.get_state_output_port(instance)
    actuation = _reroute_actuation(builder, plant, instance, torque)
    plus = builder.AddNamedSystem(f"{name}_back_emf", MatrixGain(emf))
    minus = builder.AddNamedSystem(f"{name}_back_emf_removed", MatrixGain(-emf))
    shifted = builder.AddNamedSystem(f"{name}_voltage", Adder(2, NUM_JOINTS))
    supply = builder.AddNamedSystem(f"{name}_supply", Saturation(-drive.stall, drive.stall))
    applied = builder.AddNamedSystem(name, Adder(2, NUM_JOINTS))
    builder.Connect(state, plus.get_input_port())
    builder.Connect(state, minus.get_input_port())
    builder.Connect(torque, shifted.get_input_port(0))
    builder.Connect(plus.get_output_port(), shifted.get_input_port(1))
    builder.Connect(shifted.get_output_port(), supply.get_input_port())
    builder.Connect(supply.get_output_port(), applied.get_input_port(0))
    builder.Connect(minus.get_output_port(), applied.get_input_port(1))
    builder.Connect(applied.get_output_port(), actuation)
    return applied.get_output_port()


def add_drive_correction(builder: DiagramBuilder, plant: MultibodyPlant,
                         instance: ModelInstanceIndex, controller, torque, kp=KP, kd=KD,
                         voltage: float = 0.0, name: str = "drive_correction"):
    """Add :class:`tt_drake.systems.drive_correction.DriveAwareCorrection` to ``controller``'s
    torque: its desired state and acceleration are fed through C++ ``PassThrough`` systems that
    feed the correction too, and a C++ ``Adder`` of ``torque`` (the output port now driving the
    plant's actuation) and the correction drives the plant instead. The correction's model is
    the control plant's default one. Returns (the desired state's and the desired
    acceleration's input ports, the corrected torque's output port)."""
    chain = chain_of(controller.get_multibody_plant_for_control())
    drive = DriveEnvelope(voltage) if voltage else None
    correction = builder.AddNamedSystem(name, DriveAwareCorrection(chain, kp, kd, drive))
    desired = builder.AddNamedSystem(f"{name}_desired_state", PassThrough(2 * NUM_JOINTS))
    acceleration = builder.AddNamedSystem(f"{name}_desired_acceleration",
                                          PassThrough(NUM_JOINTS))
    builder.Connect(desired.get_output_port(), controller.get_input_port_desired_state())
    builder.Connect(desired.get_output_port(), correction.GetInputPort("desired_state"))
    builder.Connect(acceleration.get_output_port(),
                    controller.get_input_port_desired_acceleration())
    builder.Connect(acceleration.get_output_port(),
                    correction.GetInputPort("desired_acceleration"))
    builder.Connect(plant.get_state_output_port(instance), correction.GetInputPort("state"))
    actuation = _reroute_actuation(builder, plant, instance, torque)
    total = builder.AddNamedSystem(f"{name}_sum", Adder(2, NUM_JOINTS))
    builder.Connect(torque, total.get_input_port(0))
    builder.Connect(correction.GetOutputPort("correction"), total.get_input_port(1))
    builder.Connect(total.get_output_port(), actuation)
    return desired.get_input_port(), acceleration.get_input_port(), total.get_output_port()


def add_joint_faults(builder: DiagramBuilder, plant: MultibodyPlant,
                     instance: ModelInstanceIndex, controller, coulomb=None, viscous=None,
                     velocity_scale: float = 0.05, torque_noise=None,
                     period: float = wp.SERVO_PERIOD, torque=None) -> TorqueNoise | None:
    """Torques on the simulated arm that the controller does not know: joint friction
    (:func:`joint_friction_system`) and motor torque noise (Gaussian, standard deviation
    ``torque_noise[j]`` N m, drawn once per servo ``period``, ticks at k * period like the
    servo's, by a C++ ``RandomSource``). They are added to the controller's actuation before the
    plant's actuation input, replacing the direct connection :func:`add_wam_controller` made
    (or the one from ``torque``, the output port now driving the plant: the drives'); the
    controller's ``actuation`` output still reports what it commands. Returns the noise's
    seeding handle (None without noise). Nothing is added when every value is zero."""
    zero = [0.0] * NUM_JOINTS
    coulomb, viscous = list(coulomb or zero), list(viscous or zero)
    noise = list(torque_noise or zero)
    friction = any(coulomb) or any(viscous)
    if not friction and not any(noise):
        return None
    terms = []
    if friction:
        f = builder.AddNamedSystem("joint_friction",
                                   joint_friction_system(coulomb, viscous, velocity_scale))
        builder.Connect(plant.get_state_output_port(instance), f.get_input_port())
        terms.append(f.get_output_port())
    handle = None
    if any(noise):
        source = builder.AddNamedSystem("torque_noise_source", RandomSource(
            RandomDistribution.kGaussian, NUM_JOINTS, period))
        gain = builder.AddNamedSystem("torque_noise", MatrixGain(np.diag(noise)))
        builder.Connect(source.get_output_port(), gain.get_input_port())
        terms.append(gain.get_output_port())
        handle = TorqueNoise(source)
    adder = builder.AddNamedSystem("arm_torque", Adder(len(terms) + 1, NUM_JOINTS))
    if torque is None:
        torque = controller.GetOutputPort("actuation")
    actuation = _reroute_actuation(builder, plant, instance, torque)
    builder.Connect(torque, adder.get_input_port(0))
    for k, port in enumerate(terms):
        builder.Connect(port, adder.get_input_port(k + 1))
    builder.Connect(adder.get_output_port(), actuation)
    return handle


SERVO_HOLD = "servo_hold"  # the name of the servo's zero-order hold (in the player's diagram)


def add_servo_hold(builder: DiagramBuilder, setpoint, controller: InverseDynamicsController | None,
                   period: float = wp.SERVO_PERIOD):
    """Feed a player's set-point to ``controller`` (if not None) through one zero-order hold
    sampled every servo ``period`` (ticks at k * period), named :data:`SERVO_HOLD`; returns the
    hold, whose output is the 21 held values (q, q_dot, q_ddot).

    ``setpoint``: the player's 21-value output port (``setpoint``), or a pair of ports
    (``desired_state`` (14), ``desired_acceleration`` (7)) that a C++ ``Multiplexer`` joins. A
    C++ ``Demultiplexer`` splits the held values into the controller's ``desired_state`` and
    ``desired_acceleration``, so the player is asked for its set-point once per tick through one
    port (docs/performance.md, "The serve diagram's Python").

    The WAM takes one set-point per servo tick (docs/constants.md), so the controller holds it
    in between. Holding also keeps a Python player out of the integrator's derivative evaluations
    (three per RK3 step): the hold samples it once per tick and its output is cached. A player
    feeding a hold evaluates its plan half a period ahead (``setpoint_lead = period / 2``) so that
    the held value is the plan at the middle of its tick: no average lag.
    """
    if isinstance(setpoint, tuple):
        join = builder.AddNamedSystem("servo_setpoint_join", Multiplexer([14, 7]))
        builder.Connect(setpoint[0], join.get_input_port(0))
        builder.Connect(setpoint[1], join.get_input_port(1))
        setpoint = join.get_output_port()
    hold = builder.AddNamedSystem(SERVO_HOLD, ZeroOrderHold(period, 21))
    builder.Connect(setpoint, hold.get_input_port())
    if controller is not None:
        split = builder.AddNamedSystem("servo_setpoint_split", Demultiplexer([14, 7]))
        builder.Connect(hold.get_output_port(), split.get_input_port())
        builder.Connect(split.get_output_port(0), controller.get_input_port_desired_state())
        builder.Connect(split.get_output_port(1),
                        controller.get_input_port_desired_acceleration())
    return hold


def hold_first_setpoint(diagram, root_context) -> None:
    """Set the servo hold of ``diagram`` (if it has one, :func:`add_servo_hold`) to the player's
    current set-point, so that nothing sees the hold's default zeros before its first tick."""
    if diagram.HasSubsystemNamed(SERVO_HOLD):
        hold = diagram.GetSubsystemByName(SERVO_HOLD)
        hold_context = hold.GetMyMutableContextFromRoot(root_context)
        hold.SetVectorState(hold_context, hold.get_input_port().Eval(hold_context))
