"""The table clearance bound (tt_drake/clearance_kernel.py, systems/table_clearance.py): a lower
bound on the distance between the arm's collision geometries and the table top, so that the
referee may skip the contact query while it is positive."""

import math

import numpy as np
import pytest
from pydrake.geometry import Box, Capsule, Cylinder, HalfSpace, Sphere

from tt_drake.diagrams.scenario import load_scenario
from tt_drake.diagrams.station import build_station, table_top_geometries
from tt_drake.systems.table_clearance import MARGIN, TableClearance, bounding_radius
from tt_drake.systems.wam import model_file
from tt_drake.wam_params import AWAITING, JOINT_LOWER, JOINT_UPPER

#: The racket centre 4 cm under the long table's surface (tests/diagrams/test_robot_table.py).
Q_TOUCH = np.array([-0.20, 0.91, 1.43, 0.62, -2.89, 0.01, -1.06])


def _station(table: str | None = None, urdf: str | None = None, robots: int = 1):
    scenario = load_scenario()
    if table is not None:
        scenario.world.models.table = table
    if urdf is not None:
        scenario.world.models.robot = urdf
    return build_station(scenario, robots)


def _true_distance(station, robot, q) -> float:
    """The least signed distance between the robot's collision geometries and the table top's
    at ``q``, by SceneGraph's exact query."""
    world = station.world
    plant, scene_graph = world.plant, world.scene_graph
    context = station.diagram.CreateDefaultContext()
    plant.SetPositions(plant.GetMyMutableContextFromRoot(context), robot, q)
    query = scene_graph.get_query_output_port().Eval(scene_graph.GetMyContextFromRoot(context))
    arm = [g for i in plant.GetBodyIndices(robot)
           for g in plant.GetCollisionGeometriesForBody(plant.get_body(i))]
    return min(query.ComputeSignedDistancePairClosestPoints(a, t).distance
               for a in arm for t in table_top_geometries(station.world))


@pytest.fixture(scope="module")
def long_station(long_table):
    return _station(long_table, robots=2)


def test_the_gap_is_a_lower_bound_on_the_arms_distance_to_the_table(long_station):
    """On a table the arm can reach: at 150 configurations spread over the joint range and 150
    near a touch, gap(q) <= the exact distance where arm and table are apart, and gap(q) <= 0
    where they overlap (some do), so that the referee asks for the contacts there (may_touch).
    Both robots (B is mirrored)."""
    rng = np.random.default_rng(11)
    lower, upper = np.array(JOINT_LOWER), np.array(JOINT_UPPER)
    configurations = np.vstack([rng.uniform(lower, upper, (150, 7)),
                                np.clip(Q_TOUCH + rng.uniform(-0.4, 0.4, (150, 7)), lower, upper)])
    referee = long_station.referee
    world = long_station.world
    touching = 0
    for robot, clearance in zip((world.robot, world.robot_b), referee.table_clearances,
                                strict=True):
        assert clearance is not None
        for q in configurations[::2] if robot == world.robot_b else configurations:
            exact = _true_distance(long_station, robot, q)
            gap = clearance.gap(q)
            if exact >= 0.0:
                assert gap <= exact + 1e-12
            else:  # overlapping (exact is minus the penetration depth)
                touching += 1
                assert gap <= 0.0 and clearance.may_touch(q)
    assert touching >= 20


def test_the_gap_is_near_the_distance_when_the_arm_is_far(long_station):
    """The bound is not vacuous: at the awaiting posture (the arm 0.32 m from the long table)
    the gap is within 0.1 m of the exact distance."""
    clearance = long_station.referee.table_clearances[0]
    q = np.array(AWAITING)
    exact = _true_distance(long_station, long_station.world.robot, q)
    assert 0.2 < clearance.gap(q) <= exact
    assert not clearance.may_touch(q)
    assert exact - clearance.gap(q) < 0.1


def test_the_shipped_world_is_spared_every_contact_query_at_the_awaiting_posture():
    """The shipped station's referee carries the bound, and the posture the arm waits in is
    0.61 m clear of the table by it (0.64 m by the exact distance)."""
    station = _station()
    clearance = station.referee.table_clearance
    q = np.array(AWAITING)
    assert clearance is not None and 0.6 < clearance.gap(q) <= _true_distance(
        station, station.world.robot, q) < 0.65
    assert clearance.gap(q) > MARGIN


def test_no_bound_for_an_arm_that_is_not_the_dh_chain(tmp_path):
    """A model whose upper arm is 1 cm longer than the DH table's: the chain's blade centre is not
    the plant's, and no bound is built (the referee then queries the contacts every sample)."""
    head, joint4 = model_file().read_text(encoding="utf-8").split('<joint name="wam_joint4"', 1)
    old = '<origin xyz="0.045 0 0.55"'
    assert joint4.index(old) < joint4.index("</joint>")  # the joint's own origin
    path = tmp_path / "long_forearm.urdf"
    path.write_text(head + '<joint name="wam_joint4"' + joint4.replace(old, old.replace(
        "0.55", "0.56"), 1), encoding="utf-8")
    station = _station(urdf=str(path))
    world = station.world
    table, inspector = table_top_geometries(world), world.scene_graph.model_inspector()
    assert TableClearance.of(world.plant, world.robot, table, inspector) is None
    assert station.referee.table_clearance is None


def test_no_bound_without_a_box_for_the_table():
    """A table geometry that is not a box (here the ball's sphere) gives no bound; no table
    geometry gives none either."""
    station = _station()
    world = station.world
    plant, inspector = world.plant, world.scene_graph.model_inspector()
    ball = [g for i in plant.GetBodyIndices(world.ball)
            for g in plant.GetCollisionGeometriesForBody(plant.get_body(i))]
    assert TableClearance.of(plant, world.robot, ball, inspector) is None
    assert TableClearance.of(plant, world.robot, [], inspector) is None
    table = table_top_geometries(world)
    assert TableClearance.of(plant, world.robot, table, inspector) is not None


@pytest.mark.parametrize("shape, radius", [
    (Sphere(0.04), 0.04),
    (Cylinder(0.076, 0.01), math.hypot(0.076, 0.005)),
    (Capsule(0.042, 0.19), 0.042 + 0.095),
    (Box(0.2, 0.3, 0.6), 0.5 * math.sqrt(0.04 + 0.09 + 0.36)),
])
def test_bounding_radius_holds_the_shape(shape, radius):
    assert bounding_radius(shape) == pytest.approx(radius, rel=1e-15)


def test_bounding_radius_of_an_unbounded_shape_is_unknown():
    assert bounding_radius(HalfSpace()) is None
