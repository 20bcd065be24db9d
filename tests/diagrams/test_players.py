"""The players' registry: the built-in players by name, references resolved at first use, the
artefact check before any simulation, and names refused."""

import numpy as np
import pytest

from tt_drake.diagrams import episodes
from tt_drake.diagrams.players import (
    PlayerError,
    check_player,
    player_function,
    player_names,
    plays_learned_artefacts,
    register_player,
    unregister_player,
)
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.systems.momp_player import MOVING_GOAL_TORQUE_FRACTION
from tt_drake.wam_params import AWAITING


def test_the_built_in_players_resolve_to_their_functions():
    assert player_names()[:4] == ("idle", "analytical", "momp", "crkr")
    assert player_function("momp") is episodes.add_momp_player
    assert player_function("analytical") is episodes.add_analytical_player
    assert player_function(episodes.add_idle_player) is episodes.add_idle_player  # a function
    assert [plays_learned_artefacts(n) for n in ("idle", "analytical", "momp", "crkr")] == [
        False, False, True, True]
    assert not plays_learned_artefacts(episodes.add_idle_player)


def test_a_learned_player_without_its_artefacts_is_refused_before_any_simulation():
    scenario = load_scenario()  # no library named
    with pytest.raises(PlayerError, match="the momp player needs --library FILE"):
        check_player("momp", scenario)
    check_player("analytical", scenario)  # nothing to check
    with pytest.raises(PlayerError, match="unknown player 'nobody'"):
        check_player("nobody", scenario)


def test_a_registered_player_can_be_removed_again():
    register_player("for_a_moment", episodes.add_idle_player)
    assert player_names()[-1] == "for_a_moment"
    unregister_player("for_a_moment")
    assert "for_a_moment" not in player_names()
    with pytest.raises(PlayerError, match="unknown player 'for_a_moment'"):
        unregister_player("for_a_moment")


@pytest.mark.parametrize("name", ["", " padded", None])
def test_a_player_needs_a_name(name):
    with pytest.raises(PlayerError, match="a player's name must be a non-empty word"):
        register_player(name, episodes.add_idle_player)


def test_the_scenarios_teacher_settings_reach_the_analytical_player():
    """``teacher`` (the stock robot's settings by default; the shipped ``ideal_robot``
    scenario's teacher plays no refused plan's fallbacks, keeps 0.9 of the effort limits, waits
    at wam_params.AWAITING, for a direct hit until its hitting stage's start, and corrects only
    nearest the comfort posture) is the teacher's planner setting in the serve diagram, which
    keeps aiming at the scenario's referee target; its arm solves with SNOPT unless
    ``ik_solver`` names the compiled SQP."""
    from tt_drake.diagrams.episodes import ServeDiagram

    for name, on, min_hitting, fraction, base, lead in (
            ("default", True, 0.1, 1.2, -0.55, 0.5), ("ideal_robot", False, 0.0, 0.9, -0.8, 0.0)):
        scenario = load_scenario(name)
        scenario.referee.target_x = -0.2
        planner = ServeDiagram(scenario, "analytical").player.planner
        config = planner.config
        assert config.correction_fallbacks is on and config.plan_fallbacks is on
        assert config.times.min_hitting == min_hitting and config.times.direct_lead == lead
        assert config.posture_fallback is on
        assert config.torque_fraction == config.correction_torque_fraction == fraction
        assert planner.correction_budget == planner.effort_budget
        assert planner.effort_budget.fraction == fraction
        assert (config.target_x, config.target_y) == (-0.2, scenario.referee.target_y)
        np.testing.assert_array_equal(planner.q_await, (base, *AWAITING[1:]))
        assert planner.arm.solver == "snopt"
    scenario = load_scenario("default")
    scenario.teacher.torque_fraction = 0.9
    scenario.teacher.correction_torque_fraction = 1.0
    scenario.teacher.ik_solver = "sqp"
    planner = ServeDiagram(scenario, "analytical").player.planner
    assert planner.correction_budget.fraction == 1.0 and planner.effort_budget.fraction == 0.9
    assert planner.correction_budget.drive == planner.effort_budget.drive is not None
    assert planner.arm.solver == "sqp"


def test_every_arm_starts_at_rest_where_its_player_waits_and_stays_there():
    """The episode starts the arm at its player's awaiting posture (the teacher's base turned
    to ``teacher.awaiting_base``, the learned player's and the idle one's wam_params.AWAITING),
    with the servo hold already holding it: with no ball near, the controller keeps the arm
    there (gravity compensated, no start-up jerk), within 1 mrad and 0.01 rad/s after 0.1 s."""
    from tt_drake.diagrams.episodes import ServeDiagram
    from tt_drake.models import use_artefact_set

    scenario = load_scenario("default")
    scenario.teacher.awaiting_base = -0.3
    use_artefact_set(scenario.learned, "hard")
    for player, base in (("analytical", -0.3), ("momp", AWAITING[0]), ("idle", AWAITING[0])):
        diagram = ServeDiagram(scenario, player)
        plant, robot = diagram.world.plant, diagram.world.robot
        context = diagram.context
        plant_context = plant.GetMyContextFromRoot(context)
        expected = np.array((base, *AWAITING[1:]))
        np.testing.assert_array_equal(plant.GetPositions(plant_context, robot), expected)
        np.testing.assert_array_equal(plant.GetVelocities(plant_context, robot), np.zeros(7))
        diagram.simulator.Initialize()
        diagram.simulator.AdvanceTo(0.1)  # the ball is launched but far from the robot
        np.testing.assert_allclose(plant.GetPositions(plant_context, robot), expected, atol=1e-3)
        np.testing.assert_allclose(plant.GetVelocities(plant_context, robot), 0.0, atol=1e-2)


def test_the_scenarios_drives_reach_every_players_effort_check(tmp_path):
    """``controller.drive_voltage`` (48 V by default; 0 in the shipped ``ideal_robot``
    scenario) is the voltage of the teacher's effort check, of the learned player's and of
    its hitting configuration's planner; a bad voltage is named."""
    from tt_drake.diagrams.episodes import ServeDiagram
    from tt_drake.diagrams.scenario import ScenarioError
    from tt_drake.drives import DriveEnvelope
    from tt_drake.models import use_artefact_set

    for name, drive in (("ideal_robot", None), ("default", DriveEnvelope(48.0))):
        scenario = load_scenario(name)
        planner = ServeDiagram(scenario, "analytical").player.planner
        assert planner.effort_budget.drive == drive
        assert planner.effort_budget.fraction == planner.config.torque_fraction
        assert planner.effort_budget.supply_fraction == planner.config.supply_fraction
        # Plans keep each joint within the supply's share of its no-load speed (and 10 rad/s).
        speed = np.full(7, 10.0) if drive is None else np.minimum(
            10.0, planner.config.supply_fraction * drive.no_load_speed)
        np.testing.assert_array_equal(planner.limits.velocity, speed)
        use_artefact_set(scenario.learned, "hard")
        diagram = ServeDiagram(scenario, "momp")
        configuration = diagram.diagram.GetSubsystemByName("hitting_configuration")
        assert configuration.planner.effort_budget.drive == drive
        assert diagram.player.config.drive_voltage == (0.0 if drive is None else 48.0)
        # Its plans ask the moving goal's multiple of the effort limits and the scenario's share
        # of the supply (the teacher's), each joint within that share of its no-load speed.
        budget, share = diagram.player.effort_budget, scenario.learned.supply_fraction
        assert (budget.fraction, budget.supply_fraction) == (MOVING_GOAL_TORQUE_FRACTION, share)
        assert budget.drive == drive and share == planner.config.supply_fraction
        np.testing.assert_array_equal(diagram.player.limits.velocity, np.full(7, 10.0) if drive
                                      is None else np.minimum(10.0, share * drive.no_load_speed))
    scenario = load_scenario()
    for bad in (12.0, 120.0, -1.0):
        scenario.controller.drive_voltage = bad
        problems = scenario.controller.problems()
        assert any("drive_voltage" in p and "24-90 V" in p for p in problems), problems
    scenario.controller.drive_voltage = 48.0
    assert scenario.controller.problems() == []
    bad = tmp_path / "bad.yaml"
    bad.write_text("controller:\n  drive_voltage: 100.0\n")
    with pytest.raises(ScenarioError, match="drive_voltage"):
        load_scenario(str(bad))
