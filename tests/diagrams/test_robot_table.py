"""A robot that drives its racket into the table loses the point: the rally referee ends the
rally with that robot's ``robot_table`` fault, whichever side receives, and the serve referee
records the same fault; both read the contacts with ``referee_rules.table_toucher``.

On the shipped mount the arm cannot reach the table top: a search over its joint range (40
local searches of the signed distance from random configurations) found no configuration
touching it (at full stretch over the end line the nearest robot geometry stays about 8 mm
clear). So these tests play on a table whose collision box is 0.33 m longer at each
end (a scenario's own table model); the rules' table (``tt_drake.constants.TABLE``) and the
serve are unchanged.
"""

import numpy as np
import pytest
from pydrake.systems.framework import BasicVector, LeafSystem

from tt_drake.diagrams.episodes import ServeDiagram
from tt_drake.diagrams.players import drive_controller, register_player, unregister_player
from tt_drake.diagrams.rally import (
    RallyDiagram,
    RallyResult,
    rally_scenario,
    summarize_rallies,
)
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.rally_rules import Exchange, RallyFault
from tt_drake.referee_rules import ROBOT_TABLE
from tt_drake.stages import Quintic
from tt_drake.wam_params import AWAITING

Q_AWAIT = np.asarray(AWAITING, dtype=float)
#: The racket centre 4 cm under the table's surface, 0.18 m inside the end line (A's frame:
#: (0.2, -1.55, 0.72) m, over the longer table).
Q_TOUCH = np.array([-0.20, 0.91, 1.43, 0.62, -2.89, 0.01, -1.06])
REACH_TIME = 0.4  # s: the quintic from the awaiting posture to Q_TOUCH


class TableToucher(LeafSystem):
    """Lowers the racket onto the table: a rest-to-rest quintic from the awaiting posture to
    ``Q_TOUCH`` in ``REACH_TIME``, then holds it (the controller presses the racket down)."""

    def __init__(self):
        super().__init__()
        zero = np.zeros(7)
        self._path = Quintic.fit(0.0, REACH_TIME, Q_AWAIT, zero, zero, Q_TOUCH, zero, zero)
        self.DeclareVectorInputPort("ball_state", 13)
        self.DeclareVectorOutputPort("desired_state", BasicVector(14), self._state)
        self.DeclareVectorOutputPort("desired_acceleration", BasicVector(7), self._acceleration)

    def _state(self, context, output):
        q, qd, _ = self._path.evaluate(context.get_time())
        output.SetFromVector(np.r_[q, qd])

    def _acceleration(self, context, output):
        output.SetFromVector(self._path.evaluate(context.get_time())[2])


def add_table_toucher(builder, world, controller, scenario) -> list:
    toucher = builder.AddNamedSystem("table_toucher", TableToucher())
    drive_controller(builder, world, controller, toucher)
    return []


@pytest.fixture(scope="module", autouse=True)
def registered():
    register_player("table_toucher", add_table_toucher)
    yield
    unregister_player("table_toucher")


def _scenario(table: str):
    scenario = load_scenario()
    scenario.world.models.table = table
    return scenario


@pytest.mark.parametrize("side", [0, 1], ids=["A, receiving", "B, not receiving"])
def test_a_robot_touching_the_table_loses_the_rally(long_table, side):
    players = ["idle", "idle"]
    players[side] = "table_toucher"
    diagram = RallyDiagram(rally_scenario(_scenario(long_table)), tuple(players))
    # The referee reads the contacts only where the arms' bound lets them reach the table.
    assert all(c is not None for c in diagram.station.referee.table_clearances)
    result = diagram.run(3)
    assert result.exchanges == [] and not result.capped
    assert (result.fault.player, result.fault.kind) == (side, ROBOT_TABLE)
    # Ended at the touch, near the end of the reach, long before the idle receiver's miss.
    assert 0.2 < result.fault.t < REACH_TIME + 0.1 and result.duration == result.fault.t
    assert result.fault.incoming_speed is None  # no ball had come near the toucher
    summary = summarize_rallies([result])
    assert summary["faults"] == {f"{'AB'[side]}:{ROBOT_TABLE}": 1}
    # B had no ball to return: the fault is not one of its balls.
    assert summary["players"]["B"]["balls"] == 0
    assert summary["players"]["A"]["balls"] == (1 if side == 0 else 0)


def test_the_same_touch_is_the_serve_referees_robot_table(long_table):
    diagram = ServeDiagram(_scenario(long_table), "table_toucher")
    assert diagram.station.referee.table_clearance is not None
    result = diagram.run(3)
    assert ROBOT_TABLE in result.outcome.faults and result.outcome.reward <= 0.1


def test_the_idle_rally_on_the_long_table_has_no_touch(long_table):
    """The control: the same world without the toucher ends with A's miss."""
    result = RallyDiagram(rally_scenario(_scenario(long_table)), ("idle", "idle")).run(3)
    assert (result.fault.player, result.fault.kind) == (0, "missed")


def test_a_touch_by_the_player_not_receiving_is_its_fault_but_not_one_of_its_balls():
    a_returned = Exchange(0, 0.7, (0.0, 0.9), 5.0, (30.0, 40.0, 0.0))
    results = [  # A touches while B receives; B touches while B receives
        RallyResult(1, [0.0] * 9, [a_returned], RallyFault(0, ROBOT_TABLE, 1.0), False, 1.0, 1.0),
        RallyResult(2, [0.0] * 9, [a_returned], RallyFault(1, ROBOT_TABLE, 1.2, 6.0,
                                                           (0.0, 0.0, 0.0)), False, 1.2, 1.0),
    ]
    s = summarize_rallies(results)
    assert s["faults"] == {"A:robot_table": 1, "B:robot_table": 1}
    a, b = s["players"]["A"], s["players"]["B"]
    assert (a["returns"], a["balls"], a["success_rate"]) == (2, 2, 1.0)
    assert (b["returns"], b["balls"], b["robot_balls"]) == (0, 1, 1)
