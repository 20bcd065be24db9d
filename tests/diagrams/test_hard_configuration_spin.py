"""The hard protocol's player gives the teacher's IK configuration the predicted spin and its
spinless racket velocities (docs/learned_player.md, "Why the hard player's returns scatter");
the paper profile's player, without the moving goal, does not. In a serve, the racket then moves
with the spinning ball's contact point at the hit."""

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


def _blade_slide(use_spin: bool, monkeypatch) -> tuple[float, float]:
    """Serve 0 of ``tt-drake serve --player momp --artefacts hard --distribution spin --seed
    2027``: how fast the measured blade slides past the spinning ball's contact point when the
    true ball reaches the stroke's hitting plane (m/s, tangential), and the ball's spin there."""
    import numpy as np

    import tt_drake.diagrams.episodes as episodes
    import tt_drake.systems.hitting_configuration as hc
    from tt_drake.constants import BALL
    from tt_drake.diagrams.ball_world import BallOnlyWorld
    from tt_drake.diagrams.episodes import episode_seed
    from tt_drake.diagrams.spin_report import TrueFlight

    class Chosen(hc.HittingConfiguration):
        def __init__(self, *args, use_spin=False, **kwargs):
            super().__init__(*args, use_spin=use_spin and chosen, **kwargs)

    chosen = use_spin
    monkeypatch.setattr(episodes, "HittingConfiguration", Chosen)  # what the diagram builds
    scenario = load_scenario()
    use_artefact_set(scenario.learned, "hard")
    scenario.launcher.distribution, scenario.launcher.run_seed = "spin", 2027
    diagram = ServeDiagram(scenario, "momp")
    result = diagram.run(episode_seed(2027, 0))
    assert result.outcome.hit
    stroke = diagram.player.player_state(diagram.player.GetMyContextFromRoot(
        diagram.context)).stroke
    truth = TrueFlight(BallOnlyWorld(log_period=1.0 / 600.0), result.launch_state).crossing(
        stroke.stimulus[:3], stroke.t_hit)
    v, w, t = truth[3:6], truth[6:9], truth[9]
    log = diagram.arm_logger.FindLog(diagram.context)
    x = np.array([np.interp(t, log.sample_times(), row) for row in log.data()])
    arm = diagram.diagram.GetSubsystemByName("hitting_configuration").planner.arm
    n = arm.racket_pose(x[:7]).rotation().matrix()[:, 1]
    slide = arm.racket_velocity(x[:7], x[7:])[3:] - (v + np.cross(w, -BALL.radius * n))
    return float(np.linalg.norm(slide - (slide @ n) * n)), float(np.linalg.norm(w))


def test_in_the_diagram_the_racket_follows_the_spinning_contact_point(monkeypatch):
    """The teacher's racket law asks the racket to move with the ball's contact point (no
    sliding, so the rubber's friction does not turn the return). With the spin in the
    configuration the measured blade does, to the arm's tracking; with the spinless one it slides
    past a ball spinning at ~100 rad/s (omega R ~ 2 m/s)."""
    slide, spin = _blade_slide(True, monkeypatch)
    spinless_slide, _ = _blade_slide(False, monkeypatch)
    assert spin > 50.0
    assert slide < 0.5 < 1.5 < spinless_slide  # measured: 0.20 and 2.38 m/s
