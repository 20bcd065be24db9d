"""The benchmark's set-point replay and C++-only physics diagram simulate the same physics as the
episode they replay."""

import numpy as np
import pytest
from pydrake.trajectories import PiecewisePolynomial

from tt_drake.diagrams.bench import _replay_player
from tt_drake.diagrams.episodes import ServeDiagram, episode_seed
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.wam_params import SERVO_PERIOD


def test_replayed_setpoints_return_the_ball_to_the_same_spot():
    scenario = load_scenario()
    seed = episode_seed(5, 0)
    played = ServeDiagram(scenario, "analytical", log_setpoints=True)
    original = played.run(seed)
    ticks, setpoints = played.setpoints()
    assert original.outcome.hit and original.outcome.landing is not None
    np.testing.assert_allclose(np.diff(ticks), SERVO_PERIOD, atol=1e-9)  # one per servo tick

    replay = ServeDiagram(scenario, _replay_player)
    replay.diagram.GetSubsystemByName("setpoint_replay").UpdateTrajectory(
        PiecewisePolynomial.FirstOrderHold(ticks, setpoints.T))
    again = replay.run(seed)
    # The same set-points and serve: the arm and the ball do the same, up to the integrator's
    # different step sequence (the player's 60 Hz camera no longer cuts steps).
    assert again.outcome.hit and again.outcome.outcome == original.outcome.outcome
    assert abs(again.outcome.hit_time - original.outcome.hit_time) < 1e-3
    np.testing.assert_allclose(again.outcome.landing, original.outcome.landing, atol=1e-3)
    assert again.arm["max_joint_speed"] == pytest.approx(original.arm["max_joint_speed"],
                                                         rel=1e-4)
    # The holds start at the player's first set-point: no start-up torque spike.
    assert original.arm["saturated_fraction"] == 0.0


@pytest.mark.parametrize("drive_aware", [False, True])
def test_the_cpp_only_physics_diagram_is_the_episodes_physics_to_the_bit(drive_aware):
    """Replaying an episode's set-points for its duration, with the camera's 60 Hz events and the
    accuracy schedule between the referee's segments, the C++-only diagram ends with the ball
    and the arm exactly where the episode left them: the integrator met the same events, so
    project / physics is the cost of the Python systems alone. With the drive-aware correction
    the physics diagram holds it too (its only Python system), and the same holds."""
    from tt_drake.diagrams.bench import PhysicsDiagram
    from tt_drake.serves import serve_sampler

    scenario = load_scenario()
    scenario.controller.drive_aware = drive_aware
    seed = episode_seed(5, 0)
    played = ServeDiagram(scenario, "analytical", log_setpoints=True)
    original = played.run(seed)
    assert original.outcome.hit
    ticks, setpoints = played.setpoints()
    physics = PhysicsDiagram(scenario, 1.0 / scenario.referee_rate)
    launch = serve_sampler(scenario.launcher).sample(seed).launch_state
    end = physics.run(launch, PiecewisePolynomial.FirstOrderHold(ticks, setpoints.T),
                      original.duration)
    assert end == original.duration

    def positions(diagram, instance):
        plant = diagram.world.plant
        return plant.GetPositions(plant.GetMyContextFromRoot(diagram.context), instance)

    for instance in ("ball", "robot"):
        np.testing.assert_array_equal(
            positions(physics, getattr(physics.world, instance)),
            positions(played, getattr(played.world, instance)))
    assert not np.allclose(positions(physics, physics.world.ball)[4:], launch[0:3], atol=0.1)


def test_reference_diagram_keeps_the_recipe_whatever_the_scenario():
    from tt_drake.diagrams.bench import ReferenceDiagram

    scenario = load_scenario()
    scenario.world.simulator.accuracy = 1e-3
    reference = ReferenceDiagram(scenario, 1.0)
    assert reference.simulator.get_integrator().get_target_accuracy() == 1e-4
    assert scenario.world.simulator.accuracy == 1e-3  # the scenario itself is left alone
    from tt_drake.serves import ServeSampler

    assert reference.run(ServeSampler("default").sample(3).launch_state, 0.25) == 0.25


def test_parallel_timing_runs_every_serve_and_projects_from_the_steady_rate():
    from tt_drake.diagrams.bench import PROJECTED_SERVES, _time_parallel

    seeds = [episode_seed(2, i) for i in range(4)]
    p = _time_parallel(load_scenario(), "idle", seeds, 2, serial_wall=1.0, serial_cpu=0.5)
    assert p["serves"] == 4 and p["workers"] == 2
    assert 0 < p["start_up"] < p["total_wall"]
    assert p["projected_wall_10000"] == pytest.approx(
        p["start_up"] + PROJECTED_SERVES * p["wall_per_serve"])
    assert p["speedup"] == pytest.approx(1.0 / p["wall_per_serve"])
    # The workers' episodes report their CPU time: one thread's work, so no more than its wall.
    assert 0 < p["episode_cpu"] <= p["episode_wall"]
    assert p["core_share"] == pytest.approx(p["episode_wall"] / p["episode_cpu"])
    assert p["cpu_inflation"] == pytest.approx(p["episode_cpu"] / 0.5)
    assert p["between_episodes"] == pytest.approx(2 * p["wall_per_serve"] / p["episode_wall"])


def test_alternation_runs_every_serve_on_every_diagram_in_rotating_order():
    from tt_drake.diagrams.bench import _alternate

    played = []

    def runner(name):
        def run(i):
            played.append((name, i))
            return 0.1 * i + {"a": 0.0, "b": 0.01, "c": 0.02}[name]
        return run

    out = _alternate({name: runner(name) for name in "abc"}, 4)
    # One untimed warm-up each on serve 0, then serve by serve, the order rotating by one.
    assert played[:3] == [("a", 0), ("b", 0), ("c", 0)]
    assert out["calls"] == [("a", 0), ("b", 0), ("c", 0), ("b", 1), ("c", 1), ("a", 1),
                            ("c", 2), ("a", 2), ("b", 2), ("a", 3), ("b", 3), ("c", 3)]
    assert played[3:] == out["calls"]
    # Each diagram's times and durations are listed in the order of the serves.
    assert out["b"]["duration"] == pytest.approx([0.01, 0.11, 0.21, 0.31])
    assert all(len(out[name]["cpu"]) == len(out[name]["wall"]) == 4 for name in "abc")


def test_per_serve_ratios_are_summarised_by_their_quartiles():
    from tt_drake.diagrams.bench import _spread

    s = _spread([1.0, 4.0, 9.0, 16.0], [1.0, 2.0, 3.0, 4.0])  # ratios 1, 2, 3, 4
    assert s == pytest.approx({"median": 2.5, "q1": 1.75, "q3": 3.25, "min": 1.0, "max": 4.0})


def test_the_reference_runs_each_serve_for_the_projects_duration_of_it():
    from tt_drake.diagrams.bench import run_bench

    scenario = load_scenario()
    r = run_bench(scenario, serves=2, seed=4, player="idle")
    # The untimed pass that sets the reference's durations simulates what the timed pass does.
    assert r["durations_equal"] == 2
    s = r["per_serve_cpu_ratio_to_reference"]
    assert s["min"] <= s["q1"] <= s["median"] <= s["q3"] <= s["max"]
    assert r["cpu_ratio_project_to_reference"] == pytest.approx(
        r["project"]["cpu_per_serve"] / r["reference"]["cpu_per_serve"])
    # The untimed count of Drake's calls into Python: none in the C++ reference; the referee's
    # update at its rate in the project's diagram (a tick at each end of the episode).
    calls = r["drake_python_calls"]
    assert calls["reference"]["total"] == 0
    project = calls["project"]
    assert project["callbacks"]["Referee"]["Referee._update"] == pytest.approx(
        scenario.referee_rate, abs=1.0 / project["simulated"])
    assert project["steps_per_second"] > scenario.referee_rate
