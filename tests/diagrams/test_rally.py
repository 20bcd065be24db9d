"""The rally diagram: the mirrored robot, rallies of simple players, replay, summary and CLI."""

import json

import numpy as np
import pytest

from tt_drake.rally_rules import (
    SIDES,
    Exchange,
    RallyFault,
    mirror_matrix13,
    mirror_state13,
    to_side,
)


def test_the_mirror_is_a_half_turn_about_the_vertical_axis():
    from pydrake.common.eigen_geometry import Quaternion
    from pydrake.math import RotationMatrix

    rng = np.random.default_rng(3)
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    state = np.r_[q, rng.normal(size=9)]
    mirrored = np.asarray(mirror_state13(state))
    np.testing.assert_allclose(mirror_matrix13() @ state, mirrored, atol=1e-15)
    rz = RotationMatrix.MakeZRotation(np.pi)
    expected = (rz @ RotationMatrix(Quaternion(q))).matrix()
    np.testing.assert_allclose(RotationMatrix(Quaternion(mirrored[:4])).matrix(), expected,
                               atol=1e-12)
    for k in (4, 7, 10):  # p, omega, v: rotated by Rz(pi)
        np.testing.assert_allclose(mirrored[k:k + 3], rz.matrix() @ state[k:k + 3], atol=1e-15)
    # Twice is the identity: the quaternion's sign flips (a full turn), the same orientation.
    np.testing.assert_allclose(mirror_matrix13() @ mirror_matrix13(),
                               np.diag([-1.0] * 4 + [1.0] * 9))
    assert to_side(1, *to_side(1, 0.3, -1.2, 0.9)) == (0.3, -1.2, 0.9)


def test_the_mirrored_robots_racket_pose_is_the_mirrored_forward_kinematics():
    from pydrake.math import RigidTransform, RotationMatrix
    from pydrake.systems.framework import DiagramBuilder

    from tt_drake import wam_params
    from tt_drake.systems.wam import racket_pose
    from tt_drake.systems.world import WorldConfig, add_world

    world = add_world(DiagramBuilder(), WorldConfig(with_second_robot=True))
    plant = world.plant
    assert plant.num_positions() == 7 + 7 + 7  # ball (quaternion, p) and two arms
    context = plant.CreateDefaultContext()
    rz = RigidTransform(RotationMatrix.MakeZRotation(np.pi))
    rng = np.random.default_rng(5)
    lower, upper = np.array(wam_params.JOINT_LOWER), np.array(wam_params.JOINT_UPPER)
    for q in [np.array(wam_params.AWAITING)] + [rng.uniform(lower, upper) for _ in range(3)]:
        plant.SetPositions(context, world.robot, q)
        plant.SetPositions(context, world.robot_b, q)
        a, b = racket_pose(plant, context, world.robot), racket_pose(plant, context, world.robot_b)
        np.testing.assert_allclose((rz @ a).GetAsMatrix4(), b.GetAsMatrix4(), atol=1e-12)
    # The default world has one robot, as before.
    single = add_world(DiagramBuilder())
    assert single.robot_b is None and single.plant.num_positions() == 14


def test_a_rally_that_no_one_plays_ends_with_a_miss_by_a():
    from tt_drake.diagrams.rally import RallyDiagram, rally_scenario
    from tt_drake.diagrams.scenario import load_scenario

    result = RallyDiagram(rally_scenario(load_scenario()), ("idle", "idle")).run(7)
    assert result.exchanges == [] and not result.capped
    assert (result.fault.player, result.fault.kind) == (0, "missed")


def test_each_learned_player_reads_its_own_arms_measured_state():
    """The learned player's hold compares the measured arm with its plan: in a rally each side's
    ``arm_state`` is its own robot's state (not the other's, not the ball's)."""
    from tt_drake.diagrams.rally import RallyDiagram, rally_scenario
    from tt_drake.diagrams.scenario import load_scenario
    from tt_drake.models import shipped_artefact

    scenario = rally_scenario(load_scenario())
    scenario.learned.library = str(shipped_artefact("library"))
    scenario.learned.configuration = "analytical"
    rally = RallyDiagram(scenario, ("momp", "momp"))
    plant = rally.world.plant
    plant_context = plant.GetMyMutableContextFromRoot(rally.context)
    rng = np.random.default_rng(3)
    states = [rng.uniform(-1.0, 1.0, 14) for _ in range(2)]
    for robot, state in zip((rally.world.robot, rally.world.robot_b), states, strict=True):
        plant.SetPositionsAndVelocities(plant_context, robot, state)
    for side, state in zip(rally.sides, states, strict=True):
        player = side.GetSubsystemByName("momp_player")
        seen = player.GetInputPort("arm_state").Eval(player.GetMyContextFromRoot(rally.context))
        np.testing.assert_array_equal(seen, state)


def test_each_robot_starts_where_its_own_player_waits():
    """Robot A with the teacher (its base at ``teacher.awaiting_base``) and robot B with the
    idle player (wam_params.AWAITING) start at rest each at its own player's awaiting posture,
    in its own frame (B's is the mirror's: its joint angles are A's kind)."""
    from tt_drake.diagrams.rally import RallyDiagram, rally_scenario
    from tt_drake.diagrams.scenario import load_scenario
    from tt_drake.wam_params import AWAITING

    scenario = load_scenario()
    scenario.teacher.awaiting_base = -0.3
    rally = RallyDiagram(rally_scenario(scenario), ("analytical", "idle"))
    plant = rally.world.plant
    plant_context = plant.GetMyContextFromRoot(rally.context)
    for robot, base in ((rally.world.robot, -0.3), (rally.world.robot_b, AWAITING[0])):
        np.testing.assert_array_equal(plant.GetPositions(plant_context, robot),
                                      (base, *AWAITING[1:]))
        np.testing.assert_array_equal(plant.GetVelocities(plant_context, robot), np.zeros(7))


@pytest.fixture(scope="module")
def analytical_pair():
    from tt_drake.diagrams.rally import RallyDiagram, rally_scenario
    from tt_drake.diagrams.scenario import load_scenario

    scenario = load_scenario()
    scenario.rally.max_exchanges = 2
    return RallyDiagram(rally_scenario(scenario), ("analytical", "analytical"))


def test_two_analytical_players_exchange_and_the_rally_replays_from_its_seed(analytical_pair):
    from tt_drake.diagrams.rally import RallyDiagram

    first = analytical_pair.run(11)
    # A returns the serve, B returns A's ball: the cap (2) ends the rally.
    assert [e.player for e in first.exchanges] == [0, 1] and first.capped
    for e in first.exchanges:  # each aimed at the rally target, in its own frame
        assert e.landing == pytest.approx((-0.3, 0.9), abs=0.15)
    other = analytical_pair.run(12)
    again = analytical_pair.run(11)
    fresh = RallyDiagram(analytical_pair.scenario, analytical_pair.players).run(11)
    for replay in (again, fresh):
        assert replay.as_dict() | {"wall_time": 0} == first.as_dict() | {"wall_time": 0}
    assert other.launch_state != first.launch_state


def test_summary_counts_lengths_caps_and_each_players_success():
    from tt_drake.diagrams.rally import RallyResult, summarize_rallies

    def ex(player, speed):
        return Exchange(player, 1.0, (0.0, 0.9), speed, (30.0, 40.0, 0.0))

    results = [
        RallyResult(1, [0.0] * 9, [ex(0, 3.0), ex(1, 4.0), ex(0, 5.0)], None, True, 4.0, 1.0),
        RallyResult(2, [0.0] * 9, [ex(0, 3.0)], RallyFault(1, "net", 2.0, 6.0, (0, 0, 0)),
                    False, 2.0, 1.0),
        RallyResult(3, [0.0] * 9, [], RallyFault(0, "missed", 1.0, 7.0, (0, 0, 0)), False, 1.0,
                    1.0),
    ]
    s = summarize_rallies(results)
    assert s["mean_length"] == pytest.approx(4 / 3, abs=1e-3)
    assert (s["median_length"], s["capped"]) == (1.0, 1)
    assert s["faults"] == {"A:missed": 1, "B:net": 1}
    a, b = s["players"]["A"], s["players"]["B"]
    # A: 3 returns of 4 balls, 3 of them from the launcher (2 returned, 1 missed)
    assert (a["returns"], a["balls"], a["success_rate"]) == (3, 4, 0.75)
    assert (a["robot_balls"], a["success_rate_on_robot_balls"]) == (1, 1.0)
    assert (b["returns"], b["balls"], b["robot_balls"]) == (1, 2, 2)
    assert b["incoming_speed"]["p50"] == 5.0 and b["incoming_spin"]["p50"] == 25.0
    assert a["incoming_spin"]["n"] == 4 and a["incoming_spin"]["p95"] == 50.0
    assert set(SIDES) == set(s["players"])


@pytest.mark.parametrize("args, message", [
    (["--players", "analytical", "robot"], "unknown player 'robot'"),
    (["--rallies", "0"], "must be > 0"),
    (["--players", "momp", "analytical", "--library", "/nonexistent/library.npz", "--crkr",
      "/nonexistent/crkr.npz"], "/nonexistent/"),
    (["--max-exchanges", "0"], "must be > 0"),
    (["--players", "momp", "momp", "--artefacts", "hard", "--library", "mine.npz"],
     "--artefacts"),
    (["--artefacts", "nowhere"], "neither an artefact set"),
])
def test_bad_rally_input_exits_2_with_one_line_and_no_file(tmp_path, capsys, args, message):
    from tt_drake.diagrams.cli import main

    out = tmp_path / "rally.json"
    try:
        code = main(["rally", "--quiet", "--json", str(out), *args])
    except SystemExit as exit:  # argparse's errors
        code = exit.code
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and message in err
    assert not out.exists()


def test_rally_cli_writes_the_summary_and_one_record_per_rally(tmp_path, capsys):
    from tt_drake.diagrams.cli import main

    out = tmp_path / "rally.json"
    code = main(["rally", "--quiet", "--players", "analytical", "idle", "--rallies", "1",
                 "--seed", "3", "--json", str(out)])
    assert code == 0
    data = json.loads(out.read_text())
    (rally,) = data["rallies"]
    # A returns the serve; B, which never swings, misses it.
    assert rally["exchanges"] == 1 and rally["fault"]["player"] == "B"
    assert rally["fault"]["kind"] in ("missed", "double_bounce")
    assert data["summary"]["players"]["B"]["success_rate"] == 0.0
    assert data["players"] == ["analytical", "idle"] and data["scenario"]["rally"]
    assert "1 rally from a serve ball (seed 3)" in capsys.readouterr().out
    # The learned players' configuration is for the predicted spin unless told otherwise.
    assert data["scenario"]["learned"]["spin_aware"] is True
    assert main(["rally", "--quiet", "--players", "idle", "idle", "--rallies", "1",
                 "--spinless-configuration", "--json", str(out)]) == 0
    assert json.loads(out.read_text())["scenario"]["learned"]["spin_aware"] is False


def test_a_rally_plays_an_artefact_sets_library_and_moving_goal_with_its_own_aim(capsys):
    """``--artefacts hard``: the hard set's primitive library and moving goal; the hitting
    configuration stays the rally's (analytical, or the set's CrKR model only when asked for)
    and the hitting point the physical model's (no predictor); no flag: the paper set, as
    before."""
    from tt_drake.diagrams.cli import build_parser
    from tt_drake.diagrams.commands.options import scenario_from_options
    from tt_drake.diagrams.commands.rally import use_rally_artefacts
    from tt_drake.models import shipped_artefact

    parser = build_parser()

    def learned(*extra):
        args = parser.parse_args(["rally", "--players", "momp", "momp", *extra])
        args.player = None
        scenario = scenario_from_options(args)
        if args.configuration is None:
            scenario.learned.configuration = "analytical"
        use_rally_artefacts(tuple(args.players), scenario, args.artefacts)
        return scenario.learned

    hard = learned("--artefacts", "hard")
    assert hard.library == str(shipped_artefact("library", "hard"))
    assert hard.moving_goal and hard.configuration == "analytical"
    assert hard.crkr == "" and hard.predictor == ""
    assert "learned-hard" in capsys.readouterr().err
    crkr = learned("--artefacts", "hard", "--configuration", "crkr")
    assert crkr.crkr == str(shipped_artefact("crkr", "hard")) and crkr.predictor == ""
    for extra in ((), ("--artefacts", "paper")):
        paper = learned(*extra)
        assert paper.library == str(shipped_artefact("library")) and not paper.moving_goal


@pytest.mark.slow
def test_rallies_on_two_workers_are_the_serial_rallies():
    from tt_drake.diagrams.rally import run_rallies
    from tt_drake.diagrams.scenario import load_scenario

    def rallies(workers):
        data = run_rallies(load_scenario(), ("analytical", "analytical"), 3, 5, progress=False,
                           workers=workers, max_exchanges=2)
        return [r | {"wall_time": 0} for r in data["rallies"]]

    assert rallies(2) == rallies(1)


def test_a_competitive_rally_plays_each_strokes_drawn_aim_and_replays():
    """With ``rally.aim: competitive`` an analytical stroke that lands near one of its drawn
    targets leaves with that aim's topspin, and the opponent meets its return inside the reach
    box (at the hitting point the opponent's rule chooses on the return's measured state); at
    least one stroke does; the same seed gives the same rally. On the ideal robot, whose arm
    follows the planned brush: the stock drives' lag can change a stroke's spin."""
    from tt_drake.diagrams.rally import RallyDiagram, rally_scenario
    from tt_drake.diagrams.scenario import load_scenario
    from tt_drake.racket_impact import topspin
    from tt_drake.rally_aim import draw_aims, opponent_hitting_point
    from tt_drake.systems.analytical_player import StrokePlanner

    scenario = load_scenario("ideal_robot")
    scenario.rally.max_exchanges = 3
    scenario.rally.aim = "competitive"
    competitive = scenario.rally.competitive
    diagram = RallyDiagram(rally_scenario(scenario), ("analytical", "analytical"))
    rally = diagram.run(21)
    assert rally.length >= 2
    seeds = [p.seed(p.GetMyContextFromRoot(diagram.context)) for p in diagram.player_systems]
    assert len(set(seeds)) == 2  # each side draws its own aims
    planner = StrokePlanner()
    aimed = 0
    for k, exchange in enumerate(rally.exchanges):
        stroke = k // 2  # the sides alternate: a side's k-th exchange is its stroke k // 2
        landing = np.asarray(exchange.landing)
        near = [aim for aim in draw_aims(competitive, seeds[exchange.player], stroke)
                if np.hypot(*(landing - (aim.target_x, aim.target_y))) < 0.15]
        if not near:
            continue  # the cooperative aim's stroke, or a stroke that missed its target
        aimed += 1
        assert any(topspin(exchange.outgoing) == pytest.approx(aim.topspin, abs=12.0)
                   for aim in near)
        out = np.asarray(exchange.outgoing)
        point = opponent_hitting_point(planner.model, out[0:3], out[3:6], out[6:9],
                                       planner.config.plane_y, planner.config.band)
        # chosen on the first prediction of the incoming ball: a return that landed at its
        # target lies in the box within the stroke's errors (0.1 m)
        assert point is not None
        assert competitive.playable_x[0] - 0.1 <= point.position[0] <= \
            competitive.playable_x[1] + 0.1
        assert competitive.playable_z[0] - 0.1 <= point.position[2] <= \
            competitive.playable_z[1] + 0.1
    assert aimed >= 1
    again = RallyDiagram(rally_scenario(scenario), ("analytical", "analytical")).run(21)
    assert again.as_dict() | {"wall_time": 0} == rally.as_dict() | {"wall_time": 0}


def test_learned_players_play_the_competitive_aim_ball_by_ball():
    """With the competitive aim the learned players' hitting configuration (the analytical IK
    on the predicted stimulus) strokes each ball for its drawn aim: each side draws from its own
    seed, its predictor counts the balls it let go (the stroke index), and the returns land
    near one of their drawn targets (a rally of seed 21 on the ideal robot, which no stroke
    ends: on the stock robot its third stroke goes out, a ball its striker counts)."""
    from tt_drake.diagrams.rally import RallyDiagram, rally_scenario
    from tt_drake.diagrams.scenario import load_scenario
    from tt_drake.models import shipped_artefact
    from tt_drake.rally_aim import draw_aims

    scenario = load_scenario("ideal_robot")
    scenario.learned.library = str(shipped_artefact("library"))
    scenario.learned.configuration = "analytical"
    scenario.learned.spin_aware = True
    scenario.rally.max_exchanges = 6
    scenario.rally.aim = "competitive"
    diagram = RallyDiagram(rally_scenario(scenario), ("momp", "momp"))
    rally = diagram.run(21)
    assert rally.length >= 2
    configurations = [side.GetSubsystemByName("hitting_configuration") for side in diagram.sides]
    seeds = [c.seed(c.GetMyContextFromRoot(diagram.context)) for c in configurations]
    assert len(set(seeds)) == 2
    for k, side in enumerate(diagram.sides):
        predictor = side.GetSubsystemByName("hitting_point_predictor")
        balls = predictor.GetOutputPort("balls").Eval(predictor.GetMyContextFromRoot(
            diagram.context))[0]
        assert balls == sum(e.player == k for e in rally.exchanges)  # each return flew away
    for k, exchange in enumerate(rally.exchanges):
        targets = [(a.target_x, a.target_y)
                   for a in draw_aims(scenario.rally.competitive, seeds[exchange.player], k // 2)]
        assert min(np.hypot(*(np.asarray(exchange.landing) - t)) for t in targets) < 0.2


def test_a_crkr_configuration_keeps_its_aim_in_a_competitive_rally():
    """A learned player with the CrKR hitting configuration cannot play drawn aims: the
    competitive rally leaves its configuration without aims (and unseeded), and gives the
    analytical opponent's strokes the reach of a learned receiver."""
    from tt_drake.diagrams.rally import RallyDiagram, rally_scenario
    from tt_drake.diagrams.scenario import load_scenario
    from tt_drake.models import shipped_artefact

    scenario = load_scenario("ideal_robot")
    scenario.learned.library = str(shipped_artefact("library"))
    scenario.learned.crkr = str(shipped_artefact("crkr"))
    scenario.learned.configuration = "crkr"
    scenario.rally.aim = "competitive"
    diagram = RallyDiagram(rally_scenario(scenario), ("momp", "analytical"))
    configuration = diagram.sides[0].GetSubsystemByName("hitting_configuration")
    assert configuration.aims is None and configuration not in diagram.seeded
    teacher = diagram.player_systems[1]
    assert teacher.aims.playable_z == scenario.rally.competitive.learned_playable_z
