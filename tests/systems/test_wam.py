"""The WAM model in Drake against docs/constants.md, "Barrett WAM", computed independently of the
model code.

The forward kinematics and gravity torques here are written from the Spong DH table and the
AC-02 inertial list directly (the numbers of docs/constants.md typed in below), not through
tt_drake.wam_params.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from pydrake.geometry import Role, SceneGraphInspector
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
from pydrake.multibody.tree import JointActuatorIndex
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator, SimulatorConfig
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from tt_drake import wam_params
from tt_drake.constants import CONTACT, MOUNT, TABLE
from tt_drake.drives import DriveEnvelope
from tt_drake.modelgen import wam as wam_gen
from tt_drake.systems import wam

# docs/constants.md, Barrett WAM: (a, alpha, d) for joints 1..7, Spong convention.
FACTS_DH = [(0.0, -math.pi / 2, 0.0), (0.0, math.pi / 2, 0.0), (0.045, -math.pi / 2, 0.55),
            (-0.045, math.pi / 2, 0.0), (0.0, -math.pi / 2, 0.3), (0.0, math.pi / 2, 0.0),
            (0.0, 0.0, 0.06)]
FACTS_LOWER = [-2.6, -2.0, -2.8, -0.9, -4.8, -1.6, -2.2]
FACTS_UPPER = [2.6, 2.0, 2.8, 3.1, 1.3, 1.6, 2.2]
FACTS_EFFORT = [75, 125, 39, 30, 3, 4, 1]
FACTS_LINK_MASS = [10.768, 3.8749, 1.8023, 2.4007, 0.12376, 0.41797, 0.068648]
FACTS_LINK_COM = [(-0.0044342, 0.12189, -0.00066489), (-0.0023698, 0.031056, 0.015421),
                  (-0.038259, 0.20751, 0.00003309), (0.0049851, -0.00022942, 0.13272),
                  (0.00008921, 0.0051122, 0.0043582), (0.00012262, -0.017032, 0.024683),
                  (-0.00007974, 0.00016313, -0.0032355)]
FACTS_BASE_MASS = 9.9706
RACKET_OFFSET = 0.30  # blade centre along z_7 (docs/constants.md)
G = 9.81


def _rot_z(t):
    return np.array([[math.cos(t), -math.sin(t), 0], [math.sin(t), math.cos(t), 0], [0, 0, 1.0]])


def _rot_x(t):
    return np.array([[1.0, 0, 0], [0, math.cos(t), -math.sin(t)], [0, math.sin(t), math.cos(t)]])


def _homogeneous(rotation=None, translation=(0.0, 0.0, 0.0)):
    x = np.eye(4)
    if rotation is not None:
        x[:3, :3] = rotation
    x[:3, 3] = translation
    return x


def independent_frames(q):
    """World poses of DH frames 0..7: mount (plate at MOUNT, hanging, facing +y) then the chain
    Rz(q_i) . Tz(d_i) . Tx(a_i) . Rx(alpha_i), each factor built separately."""
    # Base: half-turn about x (hang), then a quarter-turn about world z (x_0 toward +y).
    plate = _homogeneous(_rot_z(math.pi / 2) @ _rot_x(math.pi),
                         (MOUNT.mount_x, MOUNT.mount_y, MOUNT.mount_z))
    x = plate @ _homogeneous(translation=(0.0, 0.0, 0.346))
    frames = [x]
    for (a, alpha, d), theta in zip(FACTS_DH, q, strict=True):
        x = (x @ _homogeneous(_rot_z(theta)) @ _homogeneous(translation=(0.0, 0.0, d))
             @ _homogeneous(translation=(a, 0.0, 0.0)) @ _homogeneous(_rot_x(alpha)))
        frames.append(x)
    return frames


def independent_racket_center(q):
    return independent_frames(q)[-1] @ _homogeneous(translation=(0.0, 0.0, RACKET_OFFSET))


@pytest.fixture(scope="module")
def arm():
    """A continuous plant with only the WAM (registered with a SceneGraph) and a context."""
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlant(MultibodyPlantConfig(time_step=0.0), builder)
    instance = wam.add_wam(plant, scene_graph=scene_graph)
    plant.Finalize()
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    return plant, scene_graph, instance, diagram, context


def _plant_context(arm):
    plant, _, _, diagram, context = arm
    return plant.GetMyMutableContextFromRoot(context)


def test_racket_center_matches_independent_dh(arm):
    plant, _, instance, _, _ = arm
    context = _plant_context(arm)
    rng = np.random.default_rng(7)
    worst_p = worst_r = 0.0
    for _ in range(50):
        q = rng.uniform(FACTS_LOWER, FACTS_UPPER)
        plant.SetPositions(context, instance, q)
        pose = wam.racket_pose(plant, context, instance)
        expected = independent_racket_center(q)
        worst_p = max(worst_p, np.linalg.norm(pose.translation() - expected[:3, 3]))
        worst_r = max(worst_r, np.abs(pose.rotation().matrix() - expected[:3, :3]).max())
        # The numpy helper in wam_params agrees too (docs and planners use it).
        helper = wam_params.racket_center_in_world(q)
        assert np.allclose(helper, expected, atol=1e-12)
    assert worst_p <= 1e-9, f"position error {worst_p:.3g} m"
    assert worst_r <= 1e-9, f"rotation error {worst_r:.3g}"


def test_mount_and_orientation(arm):
    plant, _, instance, _, _ = arm
    context = _plant_context(arm)
    plant.SetPositions(context, instance, np.zeros(7))
    base = plant.GetFrameByName(wam.BASE_FRAME, instance).CalcPoseInWorld(context)
    np.testing.assert_allclose(base.translation(), [MOUNT.mount_x, MOUNT.mount_y, MOUNT.mount_z])
    shoulder = plant.GetBodyByName("wam_link1", instance).EvalPoseInWorld(context)
    np.testing.assert_allclose(shoulder.translation(), MOUNT.shoulder, atol=1e-12)
    r = base.rotation().matrix()
    np.testing.assert_allclose(r[:, 2], [0, 0, -1], atol=1e-12)  # joint 1 axis vertical, hanging
    np.testing.assert_allclose(r[:, 0], [0, 1, 0], atol=1e-12)  # robot front toward the table
    # Bending the elbow from the straight-down pose carries the hand toward the table (+y).
    q = np.zeros(7)
    q[3] = 1.5
    plant.SetPositions(context, instance, q)
    assert wam.racket_pose(plant, context, instance).translation()[1] > MOUNT.mount_y + 0.5


def test_limits_match_facts(arm):
    plant, _, instance, _, _ = arm
    for k, name in enumerate(wam.JOINT_NAMES):
        joint = plant.GetJointByName(name, instance)
        assert joint.position_lower_limits()[0] == FACTS_LOWER[k]
        assert joint.position_upper_limits()[0] == FACTS_UPPER[k]
        assert joint.velocity_lower_limits()[0] == -10.0
        assert joint.velocity_upper_limits()[0] == 10.0
    assert plant.num_actuators(instance) == 7
    efforts = []
    for index in plant.GetJointActuatorIndices(instance):
        actuator = plant.get_joint_actuator(JointActuatorIndex(int(index)))
        efforts.append(actuator.effort_limit())
        assert actuator.joint().name() == wam.JOINT_NAMES[len(efforts) - 1]
    assert efforts == FACTS_EFFORT


def test_masses_match_facts(arm):
    plant, _, instance, _, _ = arm
    context = _plant_context(arm)
    links = [plant.GetBodyByName(f"wam_link{i}", instance) for i in range(1, 8)]
    masses = [body.get_mass(context) for body in links]
    np.testing.assert_allclose(masses, FACTS_LINK_MASS, rtol=1e-12)
    assert sum(masses) == pytest.approx(19.456278, abs=1e-9)
    assert plant.GetBodyByName(wam.BASE_FRAME, instance).get_mass(context) == FACTS_BASE_MASS
    racket = plant.GetBodyByName(wam.RACKET_BODY, instance).get_mass(context)
    assert 0.15 <= racket <= 0.19
    total = plant.CalcTotalMass(context, [instance])
    assert total == pytest.approx(FACTS_BASE_MASS + sum(FACTS_LINK_MASS) + racket, abs=1e-9)


def test_centres_of_mass_in_dh_frames(arm):
    """Each link's CoM sits where docs/constants.md puts it in DH frame i, and that place is on the
    link: the upper arm's CoM lies between shoulder and elbow, the forearm's between elbow and
    wrist."""
    plant, _, instance, _, _ = arm
    context = _plant_context(arm)
    q = np.array(wam_params.AWAITING)
    plant.SetPositions(context, instance, q)
    frames = independent_frames(q)
    coms = []
    for i in range(1, 8):
        body = plant.GetBodyByName(f"wam_link{i}", instance)
        com = body.EvalPoseInWorld(context) @ body.CalcCenterOfMassInBodyFrame(context)
        expected = frames[i] @ np.append(FACTS_LINK_COM[i - 1], 1.0)
        np.testing.assert_allclose(com, expected[:3], atol=1e-9)
        coms.append(com)

    def distance_to_segment(p, a, b):
        t = np.clip((p - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
        return np.linalg.norm(p - (a + t * (b - a)))

    shoulder, elbow, wrist = frames[0][:3, 3], frames[3][:3, 3], frames[5][:3, 3]
    assert distance_to_segment(coms[2], shoulder, elbow) < 0.05
    assert distance_to_segment(coms[3], elbow, wrist) < 0.05


def test_gravity_torques_match_independent_computation(arm):
    """tau_g = sum_j J_j^T m_j g from the facts CoMs and the independent DH chain."""
    plant, _, instance, _, _ = arm
    context = _plant_context(arm)
    racket = wam_params.RACKET
    rng = np.random.default_rng(3)
    for _ in range(5):
        q = rng.uniform(FACTS_LOWER, FACTS_UPPER)
        plant.SetPositions(context, instance, q)
        frames = independent_frames(q)
        points = [(m, frames[i + 1] @ np.append(c, 1.0)) for i, (m, c) in
                  enumerate(zip(FACTS_LINK_MASS, FACTS_LINK_COM, strict=True))]
        points.append((racket.mass, frames[7] @ np.append(racket.com(), 1.0)))
        expected = np.zeros(7)
        for k in range(7):
            axis, origin = frames[k][:3, 2], frames[k][:3, 3]
            for m, p in points[k:]:
                expected[k] += np.cross(axis, p[:3] - origin) @ np.array([0.0, 0.0, -m * G])
        np.testing.assert_allclose(plant.CalcGravityGeneralizedForces(context), expected,
                                   atol=1e-9)


def test_inertias_physically_valid(arm):
    """Every body's inertia about its CoM is positive definite and obeys the triangle inequality
    (the reading of the AC-02 numbers chosen in wam_params; the other sign fails for link 3)."""
    plant, _, instance, _, _ = arm
    context = _plant_context(arm)
    for i in range(1, 8):
        body = plant.GetBodyByName(f"wam_link{i}", instance)
        spatial = body.CalcSpatialInertiaInBodyFrame(context)
        assert spatial.IsPhysicallyValid()
        moments = np.linalg.eigvalsh(spatial.Shift(spatial.get_com()).CalcRotationalInertia()
                                     .CopyToFullMatrix3())
        assert moments.min() > 0 and moments[0] + moments[1] >= moments[2]
    link3 = wam_params.LINK_INERTIA[2]
    flipped = link3.inertia_about_origin() * (2 * np.eye(3) - 1)  # negate the products
    c = np.array(link3.com)
    about_com = flipped - link3.mass * (c @ c * np.eye(3) - np.outer(c, c))
    assert np.linalg.eigvalsh(about_com).min() < 0


def test_collision_geometry_and_filters(arm):
    plant, scene_graph, instance, diagram, context = arm
    inspector: SceneGraphInspector = scene_graph.model_inspector()
    with_collision = set()
    for index in plant.GetBodyIndices(instance):
        body = plant.get_body(index)
        for geometry in plant.GetCollisionGeometriesForBody(body):
            with_collision.add(body.name())
            props = inspector.GetProximityProperties(geometry)
            name = inspector.GetName(geometry).split("::")[-1]
            surface = CONTACT.surface("racket" if name == wam.RACKET_BLADE_GEOMETRY else "robot")
            assert props.GetProperty("material", "point_contact_stiffness") == surface.stiffness
            assert props.GetProperty("material", "hunt_crossley_dissipation") == pytest.approx(
                surface.dissipation)
            friction = props.GetProperty("material", "coulomb_friction")
            assert friction.static_friction() == pytest.approx(surface.friction)
            assert friction.dynamic_friction() == pytest.approx(surface.friction)
    assert with_collision == {"wam_link4", "wam_link5", "wam_link6", wam.RACKET_BODY}
    racket = plant.GetBodyByName(wam.RACKET_BODY, instance)
    blade = inspector.GetGeometryIdByName(plant.GetBodyFrameIdOrThrow(racket.index()),
                                          Role.kProximity,
                                          f"{plant.GetModelInstanceName(instance)}::"
                                          f"{wam.RACKET_BLADE_GEOMETRY}")
    shape = inspector.GetShape(blade)
    assert shape.radius() == 0.076 and shape.length() >= 0.005
    # Blade centre in the racket body, with the cylinder axis (blade normal) along y_C.
    pose = inspector.GetPoseInFrame(blade)
    np.testing.assert_allclose(pose.translation(), wam.RACKET_CENTER_OFFSET, atol=1e-15)
    np.testing.assert_allclose(pose.rotation().matrix()[:, 2], [0, 1, 0], atol=1e-12)
    # Robot geometries never collide with each other.
    ids = [g for index in plant.GetBodyIndices(instance)
           for g in plant.GetCollisionGeometriesForBody(plant.get_body(index))]
    for a in ids:
        for b in ids:
            if a != b:
                assert inspector.CollisionFiltered(a, b)


def test_control_plant():
    control = wam.make_control_plant()
    assert control.is_finalized()
    assert control.num_positions() == control.num_velocities() == control.num_actuators() == 7
    assert control.num_model_instances() == 3  # world, default, the WAM
    context = control.CreateDefaultContext()
    instance = control.GetModelInstanceByName("wam7_racket")
    control.SetPositions(context, wam_params.AWAITING)
    expected = independent_racket_center(wam_params.AWAITING)
    np.testing.assert_allclose(wam.racket_pose(control, context, instance).GetAsMatrix4(),
                               expected, atol=1e-12)


def test_awaiting_posture_region(arm):
    plant, _, instance, _, _ = arm
    context = _plant_context(arm)
    q = np.array(wam_params.AWAITING)
    assert np.all(q > np.array(FACTS_LOWER) + 0.3) and np.all(q < np.array(FACTS_UPPER) - 0.3)
    plant.SetPositions(context, instance, q)
    pose = wam.racket_pose(plant, context, instance)
    x, y, z = pose.translation()
    normal = pose.rotation().matrix()[:, 1]
    print(f"AWAITING racket centre ({x:.3f}, {y:.3f}, {z:.3f}) m, normal {np.round(normal, 3)}")
    assert 0.2 <= x <= 0.4 and -2.1 <= y <= -1.9 and 1.0 <= z <= 1.2
    assert normal[1] > math.cos(math.radians(20))  # faces the table (+y)
    # Above and behind the table: the blade's lowest point clears the surface by > 0.2 m.
    assert z - wam_params.RACKET.blade_radius > TABLE.surface_z + 0.2
    assert y + wam_params.RACKET.blade_radius < TABLE.robot_edge_y - 0.3
    # Every joint of the arm (elbow, wrist) also stays above the table's height.
    for frame in independent_frames(q)[1:]:
        assert frame[2, 3] > TABLE.surface_z + 0.1


def test_gravity_torques_within_effort_limits(arm):
    plant, _, instance, _, _ = arm
    context = _plant_context(arm)
    plant.SetPositions(context, instance, wam_params.AWAITING)
    holding = -plant.CalcGravityGeneralizedForces(context)
    ratio = np.abs(holding) / np.array(FACTS_EFFORT)
    print("holding torques at AWAITING (N m):", np.round(holding, 3), "of limit:",
          np.round(ratio, 3))
    assert ratio.max() < 0.5


def _recipe_simulator(diagram, plant, instance):
    """A Simulator of ``diagram`` with the project's recipe (RK3, accuracy 1e-4, max step 2 ms)
    and the arm at AWAITING; returns it and the plant's context."""
    simulator = Simulator(diagram)
    ApplySimulatorConfig(SimulatorConfig(integration_scheme="runge_kutta3", accuracy=1e-4,
                                         max_step_size=2e-3), simulator)
    context = plant.GetMyMutableContextFromRoot(simulator.get_mutable_context())
    plant.SetPositions(context, instance, wam_params.AWAITING)
    return simulator, context


def _hold(q0, duration=2.0):
    """Simulate the arm under InverseDynamicsController commanded to stay at AWAITING, with the
    project's recipe (continuous plant, RK3, accuracy 1e-4, max step 2 ms). Returns the
    racket-centre positions at the start, the commanded posture and the end, and the
    uncontrolled fall over 0.1 s for comparison."""
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlant(MultibodyPlantConfig(time_step=0.0), builder)
    instance = wam.add_wam(plant, scene_graph=scene_graph)
    plant.Finalize()
    controller = wam.add_wam_controller(builder, plant, instance, wam.KP, wam.KI, wam.KD)
    desired = builder.AddSystem(ConstantVectorSource(wam.awaiting_state()))
    builder.Connect(desired.get_output_port(), controller.get_input_port_desired_state())
    zero = builder.AddSystem(ConstantVectorSource(np.zeros(7)))
    builder.Connect(zero.get_output_port(), controller.get_input_port_desired_acceleration())
    diagram = builder.Build()
    simulator, context = _recipe_simulator(diagram, plant, instance)
    target = wam.racket_pose(plant, context, instance).translation().copy()
    plant.SetPositions(context, instance, q0)
    start = wam.racket_pose(plant, context, instance).translation().copy()
    simulator.Initialize()
    simulator.AdvanceTo(duration)
    end = wam.racket_pose(plant, context, instance).translation().copy()
    return start, target, end


def test_holds_awaiting_posture():
    start, target, end = _hold(np.array(wam_params.AWAITING))
    drift = np.linalg.norm(end - start)
    print(f"racket-centre drift over 2 s at AWAITING: {drift:.3g} m")
    assert drift < 1e-3


def test_recovers_awaiting_posture_from_offset():
    """Started 0.05 rad off on every joint, the tracker pulls the racket back within 1 mm."""
    start, target, end = _hold(np.array(wam_params.AWAITING) + 0.05)
    assert np.linalg.norm(start - target) > 0.03
    error = np.linalg.norm(end - target)
    print(f"racket-centre error after 2 s from a 0.05 rad offset: {error:.3g} m")
    assert error < 1e-3


def test_uncontrolled_arm_falls(arm):
    """Without torques gravity moves the arm (the hold test is not trivially satisfied)."""
    plant, _, instance, diagram, _ = arm
    context = diagram.CreateDefaultContext()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    plant.SetPositions(plant_context, instance, wam_params.AWAITING)
    plant.get_actuation_input_port(instance).FixValue(plant_context, np.zeros(7))
    accelerations = plant.EvalTimeDerivatives(plant_context).CopyToVector()[7:]
    assert np.abs(accelerations).max() > 1.0


def test_urdf_file_is_up_to_date():
    committed = wam.model_file().read_text()
    assert committed == wam_gen.wam_urdf(), (
        "models/wam7_racket.urdf differs from tt_drake.modelgen.wam.wam_urdf(); regenerate it "
        "with `python -m tt_drake.modelgen.wam` and commit the result")


def _driven_arm(torque, voltage):
    """The WAM without gravity, a constant torque command through drives of ``voltage`` V
    (None: straight to the plant), simulated with the project's recipe."""
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlant(MultibodyPlantConfig(time_step=0.0), builder)
    instance = wam.add_wam(plant, scene_graph=scene_graph)
    plant.mutable_gravity_field().set_gravity_vector(np.zeros(3))
    plant.Finalize()
    command = builder.AddSystem(ConstantVectorSource(np.asarray(torque, dtype=float)))
    builder.Connect(command.get_output_port(), plant.get_actuation_input_port(instance))
    if voltage is not None:
        wam.add_drive_limits(builder, plant, instance, command.get_output_port(), voltage)
    diagram = builder.Build()
    simulator, context = _recipe_simulator(diagram, plant, instance)
    return diagram, simulator, plant, instance, context


def test_drive_chain_applies_the_envelope():
    """The C++ chain (gain, adder, saturation) gives clamp(tau, -a - b v, a - b v) at random
    arm states and commands (the plant then applies the effort limit)."""
    drive = DriveEnvelope(48.0)
    rng = np.random.default_rng(2)
    for _ in range(20):
        tau = rng.uniform(-300.0, 300.0, 7)
        diagram, simulator, plant, instance, context = _driven_arm(tau, 48.0)
        v = rng.uniform(-1.5, 1.5, 7) * drive.no_load_speed
        plant.SetVelocities(context, instance, v)
        drives = diagram.GetSubsystemByName("arm_drives")
        applied = drives.get_output_port().Eval(
            drives.GetMyContextFromRoot(simulator.get_context()))
        emf = drive.back_emf * v
        np.testing.assert_allclose(applied, np.clip(tau, -drive.stall - emf, drive.stall - emf),
                                   rtol=1e-12, atol=1e-9)


def test_a_driven_joint_runs_up_to_its_no_load_speed():
    """The base joint commanded with its full 75 N m from rest: with the 48 V drives it runs up
    to its no-load speed (2.39 rad/s; the drive's torque falls linearly with speed to zero
    there) and no faster; with ideal actuators it keeps accelerating."""
    drive = DriveEnvelope(48.0)
    torque = np.zeros(7)
    torque[0] = FACTS_EFFORT[0]
    speeds = {}
    for voltage in (48.0, None):
        _, simulator, plant, instance, context = _driven_arm(torque, voltage)
        simulator.Initialize()
        peak = 0.0
        for t in np.arange(0.05, 1.0001, 0.05):
            simulator.AdvanceTo(t)
            peak = max(peak, abs(plant.GetVelocities(context, instance)[0]))
        speeds[voltage] = (plant.GetVelocities(context, instance)[0], peak)
    final, peak = speeds[48.0]
    print("J1 speed after 1 s (rad/s): drives", final, "peak", peak, "ideal", speeds[None][0])
    assert final == pytest.approx(drive.no_load_speed[0], rel=0.02)
    assert peak <= drive.no_load_speed[0] * 1.02
    assert speeds[None][0] > 3.0 * drive.no_load_speed[0]
