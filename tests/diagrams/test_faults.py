"""Faults as scenario settings (docs/faults.md): the camera, the launcher's ranges and the
controller's model mismatch are scenario fields, validated on load, off by default, and do what
their docstrings say."""

import math

import numpy as np
import pytest
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, VectorLogSink

from tt_drake.camera_model import CameraConfig
from tt_drake.diagrams.episodes import ServeDiagram
from tt_drake.diagrams.scenario import (
    ControllerConfig,
    Scenario,
    ScenarioError,
    load_scenario,
    sets_field,
    validate,
)
from tt_drake.serves import DEFAULT_VY_RANGE, DEFAULT_X_RANGE, ServeSampler
from tt_drake.systems import wam
from tt_drake.systems.ball_launcher import LauncherConfig
from tt_drake.wam_params import AWAITING, SERVO_PERIOD

FAULT_SYSTEMS = ("joint_friction", "torque_noise_source", "torque_noise", "arm_torque")


def write(path, text):
    path.write_text(text)
    return str(path)


def test_example_scenarios_load_with_their_faults():
    camera = load_scenario("faulty_camera").camera
    assert (camera.dropout, camera.outlier, camera.outlier_min, camera.outlier_max) == (
        0.2, 0.05, 0.3, 0.3)
    assert camera.latency_frames == 1  # 0.016667 s is one 60 Hz frame, not two
    controller = load_scenario("model_mismatch").controller
    assert controller.mass_scale == controller.inertia_scale == 0.9
    assert all(c > 0 for c in controller.joint_coulomb)
    assert all(b > 0 for b in controller.joint_viscous)


def test_a_scenario_file_changes_only_what_it_names_of_the_default_scenario(tmp_path):
    """docs/faults/*.yaml say "the default scenario with ...": every field the file does not
    name is models/default.yaml's (its flight accuracy 1e-3 too, not the dataclass's 0)."""
    from pydrake.common.yaml import yaml_dump_typed

    expected = load_scenario()
    expected.camera.dropout = 0.2
    loaded = load_scenario(write(tmp_path / "dropouts.yaml", "camera:\n  dropout: 0.2\n"))
    assert loaded.world.flight_accuracy == load_scenario().world.flight_accuracy > 0.0
    assert yaml_dump_typed(loaded) == yaml_dump_typed(expected)


def test_a_scenario_file_is_read_on_top_of_the_scenario_its_base_names(tmp_path):
    """``base``: a file names the scenario it changes (a name, or a path from its own folder);
    the chain is followed to the default scenario, each file changing only what it names."""
    from pydrake.common.yaml import yaml_dump_typed

    (tmp_path / "sub").mkdir()
    write(tmp_path / "sub" / "ideal_cf.yaml",
          "base: ideal_robot\nteacher:\n  correction_fallbacks: true\n")
    path = write(tmp_path / "noisy.yaml", "base: sub/ideal_cf.yaml\ncamera:\n  sigma: 0.002\n")
    expected = load_scenario("ideal_robot")
    expected.teacher.correction_fallbacks = True
    expected.camera.sigma = 0.002
    loaded = load_scenario(path)
    assert loaded.controller.drive_voltage == 0.0 < load_scenario().controller.drive_voltage
    assert yaml_dump_typed(loaded) == yaml_dump_typed(expected)
    assert sets_field(path, "controller.drive_voltage")  # by its base
    assert sets_field(path, "camera.sigma") and not sets_field(path, "learned.configuration")


def test_the_fault_tables_files_are_the_ideal_robot_with_one_fault():
    """docs/faults/*.yaml are read on top of the ideal robot (``base``; the gains file on top of
    the model-mismatch file beside it): ideal drives, the ideal robot's teacher, the name the
    shipped artefacts accept, and the fault each names."""
    from pathlib import Path

    folder = Path(__file__).resolve().parents[2] / "docs" / "faults"
    ideal = load_scenario("ideal_robot")
    loaded = {path.stem: load_scenario(str(path)) for path in sorted(folder.glob("*.yaml"))}
    assert set(loaded) == {"dropouts", "latency", "outliers", "model_mismatch",
                           "model_mismatch_gains"}
    for scenario in loaded.values():
        assert scenario.name == "default" and scenario.controller.drive_voltage == 0.0
        assert scenario.teacher == ideal.teacher
    assert loaded["dropouts"].camera.dropout == 0.2 and loaded["dropouts"].camera.latency == 0.0
    assert loaded["latency"].camera.latency_frames == 1
    assert loaded["outliers"].camera.outlier == 0.05
    mismatch, gains = loaded["model_mismatch"].controller, loaded["model_mismatch_gains"].controller
    assert mismatch.mass_scale == gains.mass_scale == 0.9
    assert gains.joint_coulomb == mismatch.joint_coulomb
    assert gains.kp == [2500.0] * 7 and mismatch.kp == ideal.controller.kp


@pytest.mark.parametrize("text, message", [
    ("base: no_such_scenario\n", "scenario file not found.*the base of"),
    ("base: 3\n", "base must name a scenario"),
    ("base: loop.yaml\n", "name each other as base"),
    ("- camera\n", "must hold a mapping"),
    ("base: ideal_robot\ncamera: {sigma: -1}\n", "camera.sigma"),
])
def test_a_bad_base_is_refused_naming_the_file(tmp_path, text, message):
    path = write(tmp_path / "loop.yaml", text)
    with pytest.raises(ScenarioError, match=message):
        load_scenario(path)


def test_latency_counts_whole_frames():
    assert CameraConfig(latency=1 / 60).latency_frames == 1
    assert CameraConfig(latency=0.016667).latency_frames == 1
    assert CameraConfig(latency=0.017).latency_frames == 2  # delivered at the second frame
    assert CameraConfig(latency=0.0).latency_frames == 0


@pytest.mark.parametrize("text, field", [
    ("camera: {dropout: 1.5}", "camera.dropout"),
    ("camera: {sigma: .nan}", "camera.sigma"),
    ("camera: {latency: -0.01}", "camera.latency"),
    ("camera: {rate: .inf}", "camera.rate"),
    ("camera: {outlier_min: 0.4, outlier_max: 0.3}", "camera.outlier_min"),
    ("controller: {mass_scale: 0.0}", "controller.mass_scale"),
    ("controller: {inertia_scale: .nan}", "controller.inertia_scale"),
    ("controller: {joint_coulomb: [1, 1, 1, 1, 1, 1, -1]}", "controller.joint_coulomb"),
    ("controller: {joint_viscous: [1, 1, 1]}", "controller.joint_viscous"),
    ("controller: {torque_noise: [0, 0, 0, 0, 0, 0, .inf]}", "controller.torque_noise"),
    ("controller: {coulomb_velocity: 0.0}", "controller.coulomb_velocity"),
    ("controller: {kp: [0, 900, 900, 900, 900, 900, 900]}", "controller.kp"),
    ("launcher: {vy_range: [-9.0, -4.0]}", "launcher.vy_range"),
    ("launcher: {x_range: [0.3, 0.1]}", "launcher.x_range"),
    ("teacher: {correction_torque_fraction: 0.0}", "teacher.correction_torque_fraction"),
    ("teacher: {correction_torque_fraction: 2.5}", "teacher.correction_torque_fraction"),
    ("teacher: {torque_fraction: 0.0}", "teacher.torque_fraction"),
    ("teacher: {torque_fraction: 2.5}", "teacher.torque_fraction"),
    ("teacher: {awaiting_base: 2.7}", "teacher.awaiting_base"),
    ("teacher: {awaiting_base: .nan}", "teacher.awaiting_base"),
    ("teacher: {direct_lead: -0.1}", "teacher.direct_lead"),
    ("learned: {supply_fraction: 0.0}", "learned.supply_fraction"),
    ("learned: {supply_fraction: 4.0}", "learned.supply_fraction"),
])
def test_invalid_fault_settings_are_refused_with_the_field_name(tmp_path, text, field):
    path = write(tmp_path / "bad.yaml", text)
    with pytest.raises(ScenarioError, match=field.replace(".", r"\.")):
        load_scenario(path)


def test_defaults_add_no_fault_and_keep_the_controller_model_exact():
    """Default settings build today's diagram: no friction, noise or torque adder, and the
    controller's model is the simulated arm."""
    scenario = Scenario()
    validate(scenario)
    assert scenario.launcher.x_range == list(DEFAULT_X_RANGE)
    assert scenario.launcher.vy_range == list(DEFAULT_VY_RANGE)
    assert scenario.camera == CameraConfig()
    diagram = ServeDiagram(scenario, "idle")
    names = {s.get_name() for s in diagram.diagram.GetSystems()}
    assert not names & set(FAULT_SYSTEMS)
    assert len(diagram.seeded) == 1  # the launcher only


def _gravity_torques(mass_scale, inertia_scale, q):
    """The controller's actuation holding the arm at rest at q (desired = actual, zero desired
    acceleration): its model's gravity compensation."""
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlant(MultibodyPlantConfig(time_step=0.0), builder)
    robot = wam.add_wam(plant)
    plant.Finalize()
    controller = wam.add_wam_controller(builder, plant, robot, mass_scale=mass_scale,
                                        inertia_scale=inertia_scale)
    x = np.r_[q, np.zeros(7)]
    state = builder.AddSystem(ConstantVectorSource(x))
    accel = builder.AddSystem(ConstantVectorSource(np.zeros(7)))
    builder.Connect(state.get_output_port(), controller.get_input_port_desired_state())
    builder.Connect(accel.get_output_port(), controller.get_input_port_desired_acceleration())
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    plant.SetPositionsAndVelocities(plant.GetMyMutableContextFromRoot(context), x)
    return controller.GetOutputPort("actuation").Eval(
        controller.GetMyContextFromRoot(context)), plant, plant.GetMyContextFromRoot(context)


def test_mass_scale_scales_the_controllers_gravity_compensation():
    q = np.asarray(AWAITING, dtype=float) + 0.3
    tau1, plant, context = _gravity_torques(1.0, 1.0, q)
    tau09, _, _ = _gravity_torques(0.9, 1.0, q)
    gravity = plant.CalcGravityGeneralizedForces(context)  # the simulated arm's tau_g(q)
    np.testing.assert_allclose(tau1, -gravity, atol=1e-9)
    np.testing.assert_allclose(tau09, -0.9 * gravity, atol=1e-9)  # tau_g is linear in masses
    # Gravity does not see rotational inertia about the centre of mass.
    np.testing.assert_allclose(_gravity_torques(1.0, 0.5, q)[0], -gravity, atol=1e-9)


def test_scaled_control_context_scales_mass_matrix_by_both_factors():
    plant = wam.make_control_plant()
    q = np.asarray(AWAITING, dtype=float)
    contexts = [plant.CreateDefaultContext(), wam.scaled_control_context(plant, 0.9, 0.9),
                wam.scaled_control_context(plant, 0.9, 1.0)]
    masses = []
    for context in contexts:
        plant.SetPositions(context, q)
        masses.append(plant.CalcMassMatrix(context))
    np.testing.assert_allclose(masses[1], 0.9 * masses[0], rtol=1e-12, atol=1e-14)
    assert not np.allclose(masses[2], 0.9 * masses[0], rtol=1e-6)  # inertias not scaled


def test_joint_friction_opposes_motion_with_tanh_coulomb_and_viscous_parts():
    coulomb = [1.5, 2.5, 0.8, 0.6, 0.06, 0.08, 0.02]
    viscous = [0.5, 0.5, 0.2, 0.2, 0.01, 0.01, 0.003]
    system = wam.joint_friction_system(coulomb, viscous, 0.1)
    context = system.CreateDefaultContext()
    v = np.array([2.0, -1.0, 0.05, -0.05, 0.0, 3.0, -7.0])
    system.get_input_port().FixValue(context, np.r_[np.zeros(7), v])
    tau = system.get_output_port().Eval(context)
    expected = -np.asarray(coulomb) * np.tanh(v / 0.1) - np.asarray(viscous) * v
    np.testing.assert_allclose(tau, expected, rtol=1e-12)
    assert np.all(tau * v <= 0.0)  # dissipative


def _torque_noise_run(seed, sigma):
    """Noise added to the actuation of an arm held at AWAITING, logged at 4 kHz for 0.1 s."""
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlant(MultibodyPlantConfig(time_step=0.0), builder)
    robot = wam.add_wam(plant)
    plant.Finalize()
    controller = wam.add_wam_controller(builder, plant, robot)
    x = np.r_[np.asarray(AWAITING, dtype=float), np.zeros(7)]
    state = builder.AddSystem(ConstantVectorSource(x))
    accel = builder.AddSystem(ConstantVectorSource(np.zeros(7)))
    builder.Connect(state.get_output_port(), controller.get_input_port_desired_state())
    builder.Connect(accel.get_output_port(), controller.get_input_port_desired_acceleration())
    handle = wam.add_joint_faults(builder, plant, robot, controller, torque_noise=sigma)
    (gain,) = [s for s in builder.GetSystems() if s.get_name() == "torque_noise"]
    log = builder.AddSystem(VectorLogSink(7, 2.5e-4))
    builder.Connect(gain.get_output_port(), log.get_input_port())
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    plant.SetPositionsAndVelocities(plant.GetMyMutableContextFromRoot(context), x)
    handle.set_seed(handle.GetMyMutableContextFromRoot(context), seed)
    simulator.AdvanceTo(0.1)
    data = log.FindLog(context)
    return data.sample_times(), data.data().T


def test_torque_noise_is_held_per_servo_tick_and_seeded():
    sigma = [2.0, 2.0, 1.0, 1.0, 0.1, 0.1, 0.05]
    t, a = _torque_noise_run(3, sigma)
    _, b = _torque_noise_run(3, sigma)
    _, c = _torque_noise_run(4, sigma)
    np.testing.assert_array_equal(a, b)  # the same seed replays
    assert not np.allclose(a, c)  # another seed draws other noise
    # A log entry at a tick's time is published before that tick's draw (the same order as
    # the servo holds' set-points in ServeDiagram.setpoints).
    ticks = np.ceil(t / SERVO_PERIOD - 1e-9).astype(int)
    inside = np.diff(ticks) == 0
    np.testing.assert_array_equal(np.diff(a, axis=0)[inside], 0.0)  # held within a tick
    assert np.all(np.any(np.diff(a, axis=0)[~inside] != 0.0, axis=1))  # new at each tick
    per_tick = a[np.r_[True, ~inside]] / np.asarray(sigma)  # one row per tick, unit variance
    assert per_tick.shape[0] >= 50
    assert abs(per_tick.std() - 1.0) < 0.15
    assert abs(per_tick.mean()) < 0.15


def test_scenario_fields_reach_the_camera_estimator_and_launcher(tmp_path):
    path = write(tmp_path / "s.yaml", "camera: {sigma: 0.006, dropout: 0.1, latency: 0.034}\n"
                                      "launcher: {x_range: [0.0, 0.2], vy_range: [-5.0, -4.0]}\n"
                                      "world: {with_robot: false}\n")
    scenario = load_scenario(path)
    diagram = ServeDiagram(scenario, "idle")
    from tt_drake.diagrams.episodes import add_perception

    builder = DiagramBuilder()
    from tt_drake.systems.world import add_world

    (camera,), estimator = add_perception(builder, add_world(builder, scenario.world), scenario)
    assert camera.config.sigma == 0.006 and camera.config.latency_frames == 3
    assert estimator.config.meas_sigma == 0.006
    sampler = diagram.launcher.sampler
    for seed in range(20):
        state = sampler.sample(seed).launch_state
        assert 0.0 <= state[0] <= 0.2
        assert -5.0 <= state[4] <= -4.0


def test_default_launcher_ranges_draw_the_same_serves_as_the_module_constants():
    launcher = ServeSampler("default", x_range=LauncherConfig().x_range,
                            vy_range=LauncherConfig().vy_range)
    plain = ServeSampler("default")
    for seed in range(5):
        np.testing.assert_array_equal(launcher.sample(seed).launch_state,
                                      plain.sample(seed).launch_state)


def test_controller_config_problems_lists_every_bad_field():
    config = ControllerConfig(mass_scale=math.nan, coulomb_velocity=-1.0,
                              torque_noise=[-1.0] * 7)
    problems = " ".join(config.problems())
    for name in ("mass_scale", "coulomb_velocity", "torque_noise"):
        assert f"controller.{name}" in problems
    assert ControllerConfig().problems() == []


def _hold_awaiting(mass_scale, ki=0.0, duration=1.5):
    """The arm commanded to hold AWAITING for ``duration`` s with a controller whose masses
    and inertias are ``mass_scale`` times the arm's; returns (q_d - q, M(q), tau_g(q))."""
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlant(MultibodyPlantConfig(time_step=0.0), builder)
    robot = wam.add_wam(plant)
    plant.Finalize()
    controller = wam.add_wam_controller(builder, plant, robot, ki=[ki] * 7,
                                        mass_scale=mass_scale, inertia_scale=mass_scale)
    x = np.r_[np.asarray(AWAITING, dtype=float), np.zeros(7)]
    state = builder.AddSystem(ConstantVectorSource(x))
    accel = builder.AddSystem(ConstantVectorSource(np.zeros(7)))
    builder.Connect(state.get_output_port(), controller.get_input_port_desired_state())
    builder.Connect(accel.get_output_port(), controller.get_input_port_desired_acceleration())
    simulator = Simulator(builder.Build())
    context = simulator.get_mutable_context()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    plant.SetPositionsAndVelocities(plant_context, x)
    simulator.AdvanceTo(duration)
    q = plant.GetPositions(plant_context)
    return (x[:7] - q, plant.CalcMassMatrix(plant_context),
            plant.CalcGravityGeneralizedForces(plant_context))


def test_wrong_masses_leave_the_static_offset_of_the_gravity_error_and_ki_removes_it():
    """At rest the arm needs -tau_g (Drake's tau_g: the generalized gravity force); the
    controller gives s M kp e - s tau_g with s = mass_scale, so the arm settles where
    e = (1 - s) / s M^-1 (-tau_g) / kp. An integral term learns the missing torque."""
    e, mass, gravity = _hold_awaiting(0.9)
    expected = (0.1 / 0.9) * np.linalg.solve(mass, -gravity) / 900.0
    assert np.max(np.abs(expected)) > 1e-3  # a visible sag
    np.testing.assert_allclose(e, expected, atol=2e-5)
    e_exact, _, _ = _hold_awaiting(1.0)
    np.testing.assert_allclose(e_exact, 0.0, atol=1e-6)
    e_integral, _, _ = _hold_awaiting(0.9, ki=2000.0, duration=4.0)
    assert np.max(np.abs(e_integral)) < 0.05 * np.max(np.abs(expected))
