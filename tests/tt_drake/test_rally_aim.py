"""The rally's per-stroke aims (tt_drake.rally_aim): a pure function of (seed, stroke), drawn
from the configured ranges and kinds."""

import numpy as np
import pytest

from tt_drake.ball_model import BallModel, BallModelParams, PlaneCrossing
from tt_drake.constants import BALL, GRAVITY, PLANES, TABLE
from tt_drake.hitting_time import HittingBand
from tt_drake.racket_law import solve_outgoing_velocity
from tt_drake.rally_aim import (
    STROKE_KINDS,
    CompetitiveAim,
    draw_aim,
    draw_aims,
    opponent_hitting_point,
    passes_own_end,
)


def test_an_aim_is_a_pure_function_of_the_rallys_seed_and_the_strokes_index():
    c = CompetitiveAim()
    assert draw_aim(c, 7, 3) == draw_aim(c, 7, 3)
    assert draw_aim(c, 7, 3) != draw_aim(c, 7, 4) != draw_aim(c, 8, 4)


def test_the_draws_cover_their_ranges_with_the_kinds_probabilities():
    c = CompetitiveAim()
    aims = [draw_aim(c, 11, k) for k in range(4000)]
    for name, values in (("x", [a.target_x for a in aims]), ("y", [a.target_y for a in aims]),
                         ("flight_time", [a.flight_time for a in aims])):
        low, high = getattr(c, name)
        assert low <= min(values) and max(values) <= high
        # uniform: mean at the middle, standard deviation (high - low) / sqrt(12)
        assert np.mean(values) == pytest.approx((low + high) / 2, abs=0.02 * (high - low))
        assert np.std(values) == pytest.approx((high - low) / np.sqrt(12), rel=0.05)
    shares = [np.mean([a.kind == k for a in aims]) for k in STROKE_KINDS]
    np.testing.assert_allclose(shares, c.kinds, atol=0.025)
    drives = [a.topspin for a in aims if a.kind == "drive"]
    assert c.drive_topspin[0] <= min(drives) and max(drives) <= c.drive_topspin[1]
    assert {a.topspin for a in aims if a.kind == "push"} == {c.push_topspin}
    assert {a.topspin for a in aims if a.kind == "block"} == {c.block_topspin}


def test_bad_ranges_and_probabilities_are_named():
    bad = CompetitiveAim(y=[-0.2, 0.5], kinds=[0.5, 0.5, 0.5], flight_time=[0.8, 0.4])
    problems = " ".join(bad.problems())
    assert "rally.competitive.y" in problems and "kinds" in problems
    assert "flight_time" in problems
    assert CompetitiveAim().problems() == []


def test_a_strokes_draws_are_pure_and_the_first_is_its_aim():
    c = CompetitiveAim()
    aims = draw_aims(c, 7, 3)
    assert len(aims) == c.draws and aims == draw_aims(c, 7, 3)
    assert aims[0] == draw_aim(c, 7, 3)
    assert len(set(aims)) == c.draws  # each draw is a new aim
    fewer = draw_aims(CompetitiveAim(draws=3), 7, 3)
    assert fewer == aims[:3]  # the first draws do not depend on how many are allowed


@pytest.mark.parametrize("target", [(-0.3, 0.9), (0.4, 0.6), (-0.5, 1.2)])
def test_the_opponents_hitting_point_follows_the_return_through_the_mirror(target):
    """A return aimed (drag and Magnus included) from the striker's hitting plane at ``target``
    in the striker's frame bounces, in the opponent's frame (x, y) -> (-x, -y), at the mirrored
    target, and the opponent meets it on its own side after that bounce: at its hitting plane
    or, when the ball crosses the plane low, behind its table edge (its hitting-point rule)."""
    model = BallModel()
    p_hit = np.array([0.1, PLANES.hitting_y, 0.95])
    spin = np.array([-60.0, 5.0, 0.0])  # topspin for a ball travelling toward +y
    goal = (target[0], target[1], TABLE.surface_z + BALL.radius)
    v_out = solve_outgoing_velocity(p_hit, goal, 0.6, model, spin=spin)
    point = opponent_hitting_point(model, p_hit, v_out, spin, PLANES.hitting_y, HittingBand())
    assert point is not None
    bounce = point.bounces[0].position
    np.testing.assert_allclose(bounce[:2], (-target[0], -target[1]), atol=0.01)
    assert point.position[1] <= HittingBand().y_max + 1e-9
    assert point.velocity[1] < 0.0  # still coming toward the opponent
    # the mirrored spin: an axial vector under the proper rotation Rz(pi)
    assert np.sign(point.spin[0]) == -np.sign(spin[0])


def test_playable_is_the_reach_box():
    c = CompetitiveAim(playable_x=[-0.6, 0.5], playable_z=[0.7, 1.15])

    def at(x, z):
        return PlaneCrossing(0.0, np.array([x, PLANES.hitting_y, z]), np.zeros(3),
                             np.zeros(3), ())

    assert c.playable(at(0.0, 0.9)) and c.playable(at(-0.6, 0.7)) and c.playable(at(0.5, 1.15))
    assert not c.playable(at(0.51, 0.9)) and not c.playable(at(-0.61, 0.9))
    assert not c.playable(at(0.0, 0.69)) and not c.playable(at(0.0, 1.16))
    assert not c.playable(None)
    assert "draws" in " ".join(CompetitiveAim(draws=0).problems())
    assert "playable_z" in " ".join(CompetitiveAim(playable_z=[1.2, 0.7]).problems())


def test_the_stock_robots_reach_leaves_out_a_short_ball_met_falling_through_the_band_floor():
    # A short backspin return (it bounces ~0.56 m past the net on the opponent's side) that
    # crosses the opponent's hitting plane too low: the opponent's rule meets it behind the
    # table where it falls through the band's floor, z_min = 0.65 m, falling at > 3 m/s.
    band = HittingBand()
    point = opponent_hitting_point(BallModel(), [-0.13, -1.81, 0.95], [0.27, 3.69, 3.94],
                                   [-26.5, 3.2, 10.5], PLANES.hitting_y, band)
    assert point.position[2] == pytest.approx(band.z_min, abs=1e-9)
    assert point.position[1] > PLANES.hitting_y and point.velocity[2] < -3.0
    assert len(point.bounces) == 1 and -0.7 < point.bounces[0].position[1] < -0.4
    # The stock robot's box (the default) leaves it out; the ideal robot's keeps it.
    assert not CompetitiveAim().playable(point)
    assert CompetitiveAim(playable_z=[0.65, 1.15]).playable(point)


def test_a_deeper_slow_return_crosses_the_opponents_plane_higher_and_the_box_reaches_up_for_it():
    # Slow returns (0.8 s from the striker's plane, no spin) aimed ever deeper: the deeper the
    # bounce, the later in its rise after the bounce the ball reaches the opponent's hitting
    # plane, so the higher it crosses there.
    model, band = BallModel(), HittingBand()
    p_hit = np.array([0.1, PLANES.hitting_y, 0.95])
    points = []
    for depth in (0.9, 1.1, 1.25):
        goal = (0.0, depth, TABLE.surface_z + BALL.radius)
        v_out = solve_outgoing_velocity(p_hit, goal, 0.8, model)
        points.append(opponent_hitting_point(model, p_hit, v_out, np.zeros(3),
                                             PLANES.hitting_y, band))
    for point in points:
        assert point is not None and len(point.bounces) == 1
        assert point.position[1] == pytest.approx(PLANES.hitting_y)  # met at the plane
    assert points[0].position[2] < points[1].position[2] < points[2].position[2]
    deep = points[1]
    # The ball landing 1.1 m past the net crosses above 1.15 m: the stock robot's default box,
    # topped at 1.25 m, keeps it; a box topped at 1.15 m (the ideal robot's) refuses it.
    assert 1.15 < deep.position[2] < 1.25
    assert CompetitiveAim().playable(deep)
    assert not CompetitiveAim(playable_z=[0.7, 1.15]).playable(deep)


def test_against_a_learned_opponent_the_reach_is_the_learned_players():
    c = CompetitiveAim(playable_z=[0.65, 1.15], learned_playable_z=[0.72, 1.1])
    assert c.against(True).playable_z == [0.72, 1.1]
    assert c.against(False) == c and c.against(False) is not c
    assert c.playable_z == [0.65, 1.15]  # the scenario's settings are left as they are
    assert "learned_playable_z" in " ".join(
        CompetitiveAim(learned_playable_z=[1.2, 0.7]).problems())


def _crossing_height(p, v, dt=1e-5):
    """The ball centre's height where it crosses the striker's end plane y = -L/2, by explicit
    small steps of v' = g - k |v| v (no spin), independent of the ball model's RK4."""
    p, v = np.array(p, dtype=float), np.array(v, dtype=float)
    k, g = BallModelParams().drag_k, np.array([0.0, 0.0, -GRAVITY])
    while p[1] < TABLE.robot_edge_y:
        p_next = p + dt * v
        v = v + dt * (g - k * np.linalg.norm(v) * v)
        if p_next[1] >= TABLE.robot_edge_y:
            s = (TABLE.robot_edge_y - p[1]) / (p_next[1] - p[1])
            return p[2] + s * (p_next[2] - p[2])
        p = p_next
    return p[2]


@pytest.mark.parametrize("vz", [-0.5, 0.0, 1.0, 2.0, 3.0, 4.0])
def test_a_return_from_behind_the_end_passes_it_only_above_the_surface(vz):
    """A return struck 0.3 m behind the striker's end line, below the table's height, passes
    only if its centre crosses the end's plane at least R + clearance above the playing surface
    (else it strikes the table's end: Law 2.1.2); one struck over the table always passes."""
    p, v, clearance = [0.1, -1.67, 0.70], [0.0, 6.0, vz], 0.02
    z = _crossing_height(p, v)
    threshold = TABLE.surface_z + BALL.radius + clearance
    if abs(z - threshold) > 1e-3:  # away from the threshold the two integrations agree
        assert passes_own_end(p, v, np.zeros(3), clearance) == (z >= threshold)
    assert passes_own_end([0.1, -1.2, 0.70], v, np.zeros(3), clearance)


def test_the_end_check_sees_a_mix_of_both_and_a_bad_clearance_is_named():
    """The grid above holds returns on both sides of the threshold, and the setting is
    checked like the others."""
    heights = [_crossing_height([0.1, -1.67, 0.70], [0.0, 6.0, vz])
               for vz in (-0.5, 0.0, 1.0, 2.0, 3.0, 4.0)]
    threshold = TABLE.surface_z + BALL.radius + 0.02
    assert min(heights) < threshold < max(heights)
    assert "end_clearance" in " ".join(CompetitiveAim(end_clearance=-0.1).problems())
