"""The hard protocol's player gives the teacher's IK configuration the predicted spin and its
spinless racket velocities (docs/learned_player.md, "Why the hard player's returns scatter");
the paper profile's player, without the moving goal, does not."""

import pytest

from tt_drake.diagrams.episodes import ServeDiagram
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.models import use_artefact_set


@pytest.mark.parametrize("moving_goal", [True, False])
def test_the_configuration_uses_the_spin_with_the_moving_goal_only(moving_goal):
    scenario = load_scenario()
    use_artefact_set(scenario.learned, "hard")
    scenario.learned.moving_goal = moving_goal
    diagram = ServeDiagram(scenario, "momp")
    configuration = diagram.diagram.GetSubsystemByName("hitting_configuration")
    assert configuration.source == "analytical" and configuration.uses_spin == moving_goal
    player = diagram.player
    port = player.GetInputPort("theta_dot_hit_spinless")
    assert port.HasValue(player.GetMyContextFromRoot(diagram.context)) == moving_goal
