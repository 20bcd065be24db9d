"""Referee LeafSystem: watches the ball (and the robot's contacts with the table) and judges the
episode with :mod:`tt_drake.referee_rules`.

Inputs:
- ``ball_state``: the plant's state output for the ball (quaternion, p, omega, v; 13 floats);
- ``robot_state``: the plant's state output for the robot (optional): the racket centre is
  computed from its joint positions by ``racket_centre`` (:class:`RacketCentre`), and only for the
  samples that the contact detector needs it for (a velocity jump away from the table, the net and
  the floor), not at every sample (docs/performance.md);
- ``contact_results``: the plant's contact results, to see robot-table contact (optional;
  which contact counts: :func:`tt_drake.referee_rules.table_toucher`). With a
  ``table_clearance`` (:class:`tt_drake.systems.table_clearance.TableClearance`) they are read
  only at the samples where the arm's joint angles leave it within reach of the table top.

A periodic unrestricted update at ``rate`` Hz (default 250 Hz) samples them; its abstract state
holds the last sample, the contact events so far and whether the robot touched the table. Output
``outcome``: the :class:`tt_drake.referee_rules.Outcome` of the episode so far.

The referee ends the episode (``EventStatus.ReachedTermination``, which stops
``Simulator.AdvanceTo``) once the ball has fallen below ``stop_below`` metres: by then every
outcome is settled, and a ball sliding along the floor costs the integrator four times the steps
of a ball in flight. With ``stop_when_decided`` it ends the episode earlier, at the first contact
after the racket's hit on the table or the floor (the landing, or the fault; a net contact
decides nothing, the ball may still drop onto the opponent's court): it decides the outcome
(:func:`tt_drake.referee_rules.judge`), and the return flight after it is a third of a returned
ball's episode.
"""

from __future__ import annotations

from collections.abc import Callable

from pydrake.common.value import AbstractValue
from pydrake.multibody.plant import ContactResults
from pydrake.systems.framework import EventStatus, LeafSystem

from tt_drake.referee_rules import (
    FLOOR_CONTACT,
    ContactDetector,
    ContactEvent,
    Outcome,
    RefereeConfig,
    decides_return,
    judge,
    table_toucher,
)
from tt_drake.systems.immutable import Immutable
from tt_drake.systems.table_clearance import TableClearance


class _RefereeState(Immutable):
    """The referee's abstract state: the last sample, the contact events so far and whether the
    robot touched the table; every update makes a new one."""

    __slots__ = ("sample", "events", "touched")

    def __init__(self, sample=None, events=(), touched=False):
        self.sample, self.events, self.touched = sample, events, touched


def contact_pairs(results: ContactResults) -> list[tuple]:
    """The point-pair contacts of the plant's ``results`` as ``(body_A, body_B, geometry_A,
    geometry_B)`` (body indices, geometry ids): what
    :func:`tt_drake.referee_rules.table_toucher` reads."""
    pairs = []
    for i in range(results.num_point_pair_contacts()):
        info = results.point_pair_contact_info(i)
        pair = info.point_pair()
        pairs.append((info.bodyA_index(), info.bodyB_index(), pair.id_A, pair.id_B))
    return pairs


class RacketCentre:
    """The racket centre (world frame) from the arm's joint positions: forward kinematics of the
    racket-centre frame on a private context of ``plant``."""

    def __init__(self, plant, robot, frame):
        self._plant, self._robot, self._frame = plant, robot, frame
        self._context = plant.CreateDefaultContext()
        self.num_positions = plant.num_positions(robot)
        self.state_size = self.num_positions + plant.num_velocities(robot)

    def __call__(self, q) -> tuple[float, float, float]:
        self._plant.SetPositions(self._context, self._robot, q)
        p = self._frame.CalcPoseInWorld(self._context).translation()
        return float(p[0]), float(p[1]), float(p[2])


class RacketAt:
    """The racket centre at one sample, computed on first use from the joint positions stored
    with the sample (a 3-sequence for :class:`ContactDetector`). Never changed once computed."""

    __slots__ = ("_q", "_centre", "_point")

    def __init__(self, q: tuple, centre: Callable):
        self._q, self._centre, self._point = q, centre, None

    def _get(self) -> tuple:
        if self._point is None:
            self._point = self._centre(self._q)
        return self._point

    def __len__(self) -> int:
        return 3

    def __getitem__(self, i):
        return self._get()[i]

    def __iter__(self):
        return iter(self._get())

    def __deepcopy__(self, memo):
        return self


class Referee(LeafSystem):
    def __init__(self, config: RefereeConfig | None = None, rate: float = 250.0,
                 racket_centre: RacketCentre | None = None,
                 robot_body_indices=(), table_geometry_ids=(), stop_below: float = 0.1,
                 stop_when_decided: bool = False, table_clearance: TableClearance | None = None):
        super().__init__()
        self.config = config or RefereeConfig()
        self.detector = ContactDetector(self.config)
        self._racket_centre = racket_centre
        self._robot_bodies = set(robot_body_indices)
        self._table_geometries = set(table_geometry_ids)
        self.table_clearance = table_clearance  # None without a racket centre
        self._stop_below = stop_below
        self._stop_when_decided = stop_when_decided
        # The ports, kept: each 250 Hz sample reads them without looking them up (docs/
        # performance.md).
        self._ball = self.DeclareVectorInputPort("ball_state", 13)
        self._robot = self.DeclareVectorInputPort(
            "robot_state", 14 if racket_centre is None else racket_centre.state_size)
        self._contacts = self.DeclareAbstractInputPort("contact_results",
                                                       AbstractValue.Make(ContactResults()))
        self._succeeded = EventStatus.Succeeded()
        self._state_index = self.DeclareAbstractState(AbstractValue.Make(_RefereeState()))
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / rate, 0.0, self._update)
        # The same update as a forced event, so that a sample can be taken on demand (tests).
        self.DeclareForcedUnrestrictedUpdateEvent(self._update)
        self.DeclareAbstractOutputPort(
            "outcome", lambda: AbstractValue.Make(Outcome("missed", False, False, False)),
            self._calc_outcome)

    @property
    def table_clearance(self) -> TableClearance | None:
        """The bound that spares the contact query while the arm cannot reach the table, or
        None (the contacts are read at every sample); settable (None turns it off)."""
        return self._clearance

    @table_clearance.setter
    def table_clearance(self, clearance: TableClearance | None) -> None:
        self._clearance = clearance if self._racket_centre is not None else None

    def _joint_positions(self, context):
        """The arm's joint angles (a numpy array), or None without a racket centre or a
        ``robot_state`` input."""
        if self._racket_centre is None or not self._robot.HasValue(context):
            return None
        return self._robot.Eval(context)[:self._racket_centre.num_positions]

    def _robot_touches_table(self, context, q) -> bool:
        if not self._table_geometries:
            return False
        if self._clearance is not None and q is not None and not self._clearance.may_touch(q):
            return False
        if not self._contacts.HasValue(context):
            return False
        pairs = contact_pairs(self._contacts.Eval(context))
        return table_toucher(pairs, (self._robot_bodies,), self._table_geometries) is not None

    def _update(self, context, state):
        old = context.get_abstract_state(self._state_index).get_value()
        # ContactDetector.sample's tuple of plain floats, made at once (tolist) at 250 Hz.
        s = self._ball.Eval(context).tolist()
        q = self._joint_positions(context)
        racket = None if q is None else RacketAt(tuple(q.tolist()), self._racket_centre)
        cur = (float(context.get_time()), (s[4], s[5], s[6]), (s[10], s[11], s[12]),
               (s[7], s[8], s[9]), racket)
        events = old.events
        decided = False
        if old.sample is not None:
            event = self.detector.detect(old.sample, cur)
            if event is not None:
                decided = self._stop_when_decided and decides_return(events, event)
                events = (*events, event)
        touched = old.touched or self._robot_touches_table(context, q)
        if decided:
            state.get_mutable_abstract_state(self._state_index).set_value(
                _RefereeState(cur, events, touched))
            return EventStatus.ReachedTermination(self, "the return's outcome is decided")
        if cur[1][2] < self._stop_below:
            # The ball is at the floor: that is its last contact, whether or not the floor
            # contact itself fell between samples.
            events = (*events, ContactEvent(cur[0], FLOOR_CONTACT, cur[1]))
            state.get_mutable_abstract_state(self._state_index).set_value(
                _RefereeState(cur, events, touched))
            return EventStatus.ReachedTermination(self, "the ball reached the floor")
        state.get_mutable_abstract_state(self._state_index).set_value(
            _RefereeState(cur, events, touched))
        return self._succeeded

    def events(self, context):
        return list(context.get_abstract_state(self._state_index).get_value().events)

    def _calc_outcome(self, context, output):
        state = context.get_abstract_state(self._state_index).get_value()
        output.set_value(judge(list(state.events), state.touched, self.config))
