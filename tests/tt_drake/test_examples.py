"""The documentation's example scripts run and write small PNGs; the benchmark reports numbers."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

from tt_drake import wam_params as wp
from tt_drake.benchmarks import bench_momp_planning
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.imitation import quintic_demonstration
from tt_drake.systems.joint_stops import JointStopsConfig, awaiting_inertia, stop_stiffness

EXAMPLES = Path(__file__).resolve().parents[2] / "docs" / "examples"


@pytest.mark.parametrize(
    "name",
    ["dmp_imitation", "momp_mixture", "power_toy", "responsibility_pruning", "crkr_two_branch"],
)
def test_example_writes_plot(name, tmp_path):
    spec = importlib.util.spec_from_file_location(f"example_{name}", EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    out = tmp_path / f"{name}.png"
    module.main(str(out))
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert out.stat().st_size < 200_000


def test_benchmark_reports_timings_without_asserting_them():
    res = bench_momp_planning(n_primitives=20, n_dof=3, repeats=3)
    assert res["samples"] == 251 and res["n_primitives"] == 20
    assert 0 < res["min_ms"] <= res["median_ms"] and 1 <= res["mean_kept_primitives"] <= 20


def test_quintic_demonstration_boundary_states():
    d = quintic_demonstration(0.4, [0.0, 1.0], [1.0, 0.5], [2.0, -1.0], backswing=[0.3, 0.0])
    np.testing.assert_allclose(d.q[0], [0, 1])
    np.testing.assert_allclose(d.q[-1], [1, 0.5], atol=1e-12)
    np.testing.assert_allclose(d.qd[0], 0, atol=1e-12)
    np.testing.assert_allclose(d.qd[-1], [2, -1], atol=1e-12)
    np.testing.assert_allclose(d.qdd[[0, -1]], 0, atol=1e-9)
    np.testing.assert_allclose(np.gradient(d.q, d.t, axis=0)[1:-1], d.qd[1:-1], atol=1e-3)


def _run(*episodes):
    return {"episodes": [dict(seed=i, outcome=o, hit=o != "missed", returned=o == "returned",
                              on_target=False, faults=[], landing=landing)
                         for i, (o, landing) in enumerate(episodes)]}


def test_serve_comparison_flags_outcome_and_landing_changes():
    from tt_drake.benchmarks import compare_serve_records

    a = _run(("returned", [0.1, 0.5, 0.76]), ("missed", None), ("returned", [0.0, 0.9, 0.76]))
    same = _run(("returned", [0.1, 0.5004, 0.76]), ("missed", None),
                ("returned", [0.0, 0.9, 0.76]))
    r = compare_serve_records(a, same)
    assert r["same"] and r["max_landing_shift"] == pytest.approx(4e-4)
    moved = _run(("returned", [0.1, 0.5, 0.76]), ("net", None), ("returned", [0.0, 0.902, 0.76]))
    r = compare_serve_records(a, moved)
    assert not r["same"] and [d["index"] for d in r["differ"]] == [1, 2]
    assert r["differ"][0]["fields"] == ["outcome", "hit"]
    assert r["differ"][1]["fields"] == ["landing"]
    with pytest.raises(ValueError):
        compare_serve_records(a, _run(("missed", None)))


def test_the_floors_stub_player_plays_the_recorded_setpoints():
    """docs/examples/python_floor.py compares like with like: its stub systems hold the recorded
    set-points, so the ball is returned to where the replay (and the player) returned it."""
    from tt_drake.diagrams.bench import _record_setpoints, _replay_player
    from tt_drake.diagrams.episodes import ServeDiagram, episode_seed
    from tt_drake.diagrams.scenario import load_scenario

    spec = importlib.util.spec_from_file_location("example_floor", EXAMPLES / "python_floor.py")
    floor = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(floor)
    scenario = load_scenario()
    seed = episode_seed(5, 0)
    _, (trajectory,) = _record_setpoints(scenario, "analytical", [seed])
    replay = ServeDiagram(scenario, _replay_player)
    replay.diagram.GetSubsystemByName("setpoint_replay").UpdateTrajectory(trajectory)
    expected = replay.run(seed).outcome
    assert expected.hit and expected.landing is not None
    table = floor.setpoint_table(trajectory)
    np.testing.assert_array_equal(table[3], trajectory.value(3 * floor.SERVO_PERIOD).ravel())
    for stubbed in (floor.floor_diagram(scenario), floor.merged_floor_diagram(scenario)):
        stubbed.diagram.GetSubsystemByName("stub_player").table = table
        got = stubbed.run(seed).outcome
        # The same set-points; the stubs' events cut the integrator's steps elsewhere.
        assert got.outcome == expected.outcome and got.hit
        np.testing.assert_allclose(got.landing, expected.landing, atol=1e-3)


def test_the_gym_episode_timer_times_each_episode_once(tmp_path):
    """docs/examples/gym_episode_cpu.py plays one episode per seed to its end and reports its
    CPU time; the JSON it writes holds what it printed."""
    pytest.importorskip("gymnasium")
    spec = importlib.util.spec_from_file_location("example_gym_cpu",
                                                  EXAMPLES / "gym_episode_cpu.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    out = tmp_path / "cpu.json"
    assert module.main(["--episodes", "2", "--seed", "5", "--action", "absolute",
                        "--scenario", "ideal_robot", "--json", str(out)]) == 0
    r = json.loads(out.read_text())
    assert r["scenario"] == "ideal_robot"
    assert r["episodes"] == 2 and len(r["cpu"]) == 2 and all(c > 0.0 for c in r["cpu"])
    assert r["cpu_per_episode"] == pytest.approx(np.mean(r["cpu"]))
    with pytest.raises(SystemExit):
        module.main(["--episodes", "0"])


def test_the_compiled_kernels_example_finds_them_equal_to_what_they_replace():
    """docs/examples/compiled_kernels.py checks the compiled flight and backward bounce test
    against their Python-float arithmetic and the compiled quintic against its numpy
    expressions (to the bit), and the compiled inverse dynamics against Drake's (1e-9 N m),
    exiting 0 only if all agree."""
    spec = importlib.util.spec_from_file_location("example_kernels",
                                                  EXAMPLES / "compiled_kernels.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert module.main(["--repeats", "20"]) == 0


def test_the_ik_request_count_finds_the_wrist_test_behind_every_failure_without_a_solver_run():
    """docs/examples/ik_requests.py: on three serves of seed 7 the teacher's requests the
    wrist test refuses (hundreds) are exactly those that failed without a solver run, and every
    request is counted once (solved, refused, or failed in the solver)."""
    spec = importlib.util.spec_from_file_location("example_ik_requests",
                                                  EXAMPLES / "ik_requests.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    c = module.main(["--serves", "3", "--seed", "7"])
    assert c["requests"] == c["solved"] + c["refused_by_wrist_test"] + c["failed_in_solver"]
    assert c["refused_by_wrist_test"] == c["outside_the_wrists_reach"] > 0


def test_the_ik_solver_comparison_finds_every_converged_sqp_answer_within_the_tolerances():
    """docs/examples/ik_solvers.py: on two serves of seed 7 the SQP converges from every
    start the teacher's SNOPT runs had, and a converged answer meets the solver's bounds, which
    lie inside the IK's acceptance: each one passes the forward-kinematics check."""
    spec = importlib.util.spec_from_file_location("example_ik_solvers",
                                                  EXAMPLES / "ik_solvers.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    r = module.main(["--serves", "2", "--seed", "7"])
    assert r["runs"] > 0 and r["sqp_converged"] == r["runs"]
    assert r["passed_check"]["sqp"] == r["runs"]


def test_the_base_angle_the_hitting_postures_ask_for_grows_toward_the_forehand():
    """docs/examples/base_angles.py: across the hitting region the IK's base angle rises
    strictly with the hitting point's x (+x is the forehand), about 1.5 rad from 0.3 m to the
    backhand to 0.8 m to the forehand, and the stock teacher's awaiting base lies inside that
    span, nearer its middle than wam_params.AWAITING's."""
    spec = importlib.util.spec_from_file_location("example_base_angles",
                                                  EXAMPLES / "base_angles.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    from tt_drake.diagrams.scenario import TeacherConfig
    from tt_drake.wam_params import AWAITING

    answers = module.base_angles()
    assert [x for x, _ in answers] == list(module.CROSSINGS_X)  # every point reached
    bases = np.array([b for _, b in answers])
    assert np.all(np.diff(bases) > 0.0)
    assert 1.2 < bases[-1] - bases[0] < 1.8
    middle = 0.5 * (bases[0] + bases[-1])
    stock = TeacherConfig().awaiting_base
    assert bases[0] < stock < bases[-1]
    assert abs(stock - middle) < abs(AWAITING[0] - middle)


def test_the_limit_excursion_example_splits_the_wrists_command_into_its_terms():
    """docs/examples/limit_excursions.py: on rally-train validation serve 14 of seed 5101 the
    stock teacher's wrist passes its limit; the computed torque's own, coupling and bias terms
    (the control plant's inverse dynamics, linear in the acceleration command) add up to the
    command the controller logged, and the wrist's own term pulls it back toward its
    set-point while the coupling pushes it on."""
    spec = importlib.util.spec_from_file_location("example_limit_excursions",
                                                  EXAMPLES / "limit_excursions.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    scenario = load_scenario("default")
    scenario.launcher.distribution = "rally-train"
    found, records = module.excursions(scenario, "analytical", 15, 5101, 1)
    assert found >= 1 and len(records) == 1
    r = records[0]
    own, coupling, bias = r["terms"]
    assert r["excess"] > 0.0
    assert own + coupling + bias == pytest.approx(r["logged"][r["joint"]], abs=1e-6)
    ahead = r["angle"] - r["setpoint"]
    assert abs(ahead) > r["excess"]  # it ran past its set-point by more than past its limit
    assert np.sign(own) == -np.sign(ahead) and np.sign(coupling) == np.sign(ahead)


def test_the_joint_stops_cost_example_compares_stations_that_agree_inside_the_limits():
    """docs/examples/joint_stops_cost.py: inside the joint limits the stations with and without
    the stops give the same derivatives to the bit; a wrist 10 mrad past its upper limit gets
    the stop's torque, so its acceleration with the stops is lower by about k d / I."""
    spec = importlib.util.spec_from_file_location("example_joint_stops_cost",
                                                  EXAMPLES / "joint_stops_cost.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    with_stops, without = module.StationDerivatives(True), module.StationDerivatives(False)
    assert module.same_inside_the_limits(with_stops, without, 20)
    wrist = 5
    for station in (with_stops, without):
        station.q0 = station.q0.copy()
        station.q0[wrist] = wp.JOINT_UPPER[wrist] + 0.01
    plant, robot = with_stops.world.plant, with_stops.world.robot
    wrist_v = plant.num_positions() + plant.GetJointByName(
        wp.JOINT_NAMES[wrist], robot).velocity_start()
    drop = without.at(0)[wrist_v] - with_stops.at(0)[wrist_v]
    # The wrist stop's stiffness and the wrist's inertia, as the stops take them.
    inertia = awaiting_inertia(plant, robot)[wrist]
    k = stop_stiffness([inertia], JointStopsConfig().natural_frequency)[0]
    assert 0.3 * k * 0.01 / inertia < drop < 3.0 * k * 0.01 / inertia


def test_the_setpoint_rows_example_holds_the_python_outputs_values_to_the_bit():
    """docs/examples/setpoint_rows_cost.py: the rows written at each planning tick and picked by
    the C++ selector give the hold the row of every servo tick, as the Python output does: the
    held values integrate to the same state to the bit, and to the sum of the rows times the
    servo period."""
    spec = importlib.util.spec_from_file_location("example_setpoint_rows_cost",
                                                  EXAMPLES / "setpoint_rows_cost.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    _, python = module.run("python", 0.2)
    _, state = module.run("state", 0.2)
    assert np.array_equal(python, state)
    # The integral of the held rows: row k held over [2k ms, 2k + 2 ms) from its tick on.
    ticks = int(round(0.2 / module.SERVO_PERIOD))
    expected = module.SERVO_PERIOD * sum(module.row(k) for k in range(ticks))
    np.testing.assert_allclose(python, expected, rtol=0, atol=1e-12)
