"""The benchmark's set-point replay simulates the same physics as the episode it replays."""

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


def test_reference_diagram_keeps_the_recipe_whatever_the_scenario():
    from tt_drake.diagrams.bench import ReferenceDiagram

    scenario = load_scenario()
    scenario.world.simulator.accuracy = 1e-3
    reference = ReferenceDiagram(scenario, 1.0)
    assert reference.simulator.get_integrator().get_target_accuracy() == 1e-4
    assert scenario.world.simulator.accuracy == 1e-3  # the scenario itself is left alone


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
