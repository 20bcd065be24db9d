"""RallyReferee LeafSystem: judges a rally of two robots with :mod:`tt_drake.rally_rules`.

Inputs: ``ball_state`` (13, the plant's state output for the ball, world frame),
``robot_a_state`` and ``robot_b_state`` (14 each, the arms' states: the racket centres are
computed from them by forward kinematics, and only for a contact to classify, as the single-stroke
:class:`tt_drake.systems.referee.Referee` does), ``contact_results`` (the plant's contact
results, optional: to see a robot touch the table).

A periodic unrestricted update at ``rate`` Hz samples them. Each sample is taken in the
receiver's frame (:func:`tt_drake.rally_rules.to_side`) and fed, with the previous one, to the
same :class:`tt_drake.referee_rules.ContactDetector` as the single-stroke referee, with the
receiver's racket centre; the receiver's events are judged by
:func:`tt_drake.rally_rules.decide`. A legal return adds an :class:`Exchange` and hands the ball
to the other side; the first fault, or ``max_exchanges`` exchanges, ends the rally and the
simulation (``EventStatus.ReachedTermination``), as does the ball reaching the floor. Each sample
first looks at the contacts: a robot body touching the table
(:func:`tt_drake.referee_rules.table_toucher`, the single-stroke referee's rule) ends the rally
with that robot's ``robot_table`` fault, whoever was receiving
(:func:`tt_drake.rally_rules.table_fault`); a ball contact detected in the same sample is not
judged (which came first is not known at the referee's rate: the touch decides).

Output ``rally``: the :class:`RallyRecord` so far.
"""

from __future__ import annotations

import math

from pydrake.common.value import AbstractValue
from pydrake.multibody.plant import ContactResults
from pydrake.systems.framework import EventStatus, LeafSystem

from tt_drake.constants import PLANES
from tt_drake.rally_rules import (
    Exchange,
    RallyConfig,
    RallyFault,
    decide,
    opening_event,
    table_fault,
    to_side,
)
from tt_drake.referee_rules import (
    FLOOR_CONTACT,
    RACKET_CONTACT,
    ContactDetector,
    ContactEvent,
    RefereeConfig,
    table_toucher,
)
from tt_drake.systems.immutable import Immutable
from tt_drake.systems.referee import RacketAt, contact_pairs


class RallyRecord(Immutable):
    """The rally so far: the exchanges (:class:`Exchange`), the fault that ended it (or None),
    whether it stopped at ``max_exchanges`` (``capped``), whether it is over, and who receives."""

    __slots__ = ("exchanges", "fault", "capped", "over", "receiver")

    def __init__(self, exchanges=(), fault=None, capped=False, over=False, receiver=0):
        self.exchanges, self.fault, self.capped = exchanges, fault, capped
        self.over, self.receiver = over, receiver


class _State(Immutable):
    """``sample``: the last sample in the receiver's frame (:meth:`ContactDetector.sample`) with
    both arms' joint positions; ``events``: the receiver's contact events (its frame);
    ``started``: when its exchange began; ``incoming``: (speed, spin) of the ball it had to
    return, and whether it was taken at the hit (else at the hitting plane)."""

    __slots__ = ("record", "sample", "q", "events", "started", "incoming", "outgoing")

    def __init__(self, record=None, sample=None, q=None, events=(), started=0.0,
                 incoming=None, outgoing=None):
        record = RallyRecord() if record is None else record
        self.record, self.sample, self.q, self.events = record, sample, q, events
        self.started, self.incoming, self.outgoing = started, incoming, outgoing


class _SideRacket(RacketAt):
    """The receiver's racket centre in its own frame, computed on first use (a 3-sequence)."""

    __slots__ = ("_side",)

    def __init__(self, q, centre, side: int):
        super().__init__(q, centre)
        self._side = side

    def _get(self):
        if self._point is None:
            self._point = to_side(self._side, *self._centre(self._q))
        return self._point


class RallyReferee(LeafSystem):
    """``racket_centres``: for each side, a function of its joint positions (7) giving its racket
    centre in the world (:class:`tt_drake.systems.referee.RacketCentre`), or None (scripted
    tests: any unexplained velocity change away from table, net and floor is then the racket).
    ``robot_body_indices``: for each side, its bodies (arm links and racket);
    ``table_geometry_ids``: the table top's collision geometries (without them, or without the
    ``contact_results`` input, no touch of the table is seen). ``table_clearances``: for each
    side, its :class:`tt_drake.systems.table_clearance.TableClearance` or None; the contact
    results are read only at the samples where some side's arm may reach the table top."""

    def __init__(self, config: RallyConfig | None = None,
                 referee: RefereeConfig | None = None, rate: float = 250.0,
                 racket_centres=(None, None), stop_below: float = 0.1,
                 robot_body_indices=((), ()), table_geometry_ids=(),
                 table_clearances=(None, None)):
        super().__init__()
        self.config = config or RallyConfig()
        self.detector = ContactDetector(referee or RefereeConfig())
        self._centres = tuple(racket_centres)
        self._stop_below = stop_below
        self._robot_bodies = tuple(set(bodies) for bodies in robot_body_indices)
        self._table_geometries = set(table_geometry_ids)
        self._clearances = tuple(table_clearances)
        self._ball = self.DeclareVectorInputPort("ball_state", 13)
        self._arms = (self.DeclareVectorInputPort("robot_a_state", 14),
                      self.DeclareVectorInputPort("robot_b_state", 14))
        self._contacts = self.DeclareAbstractInputPort("contact_results",
                                                       AbstractValue.Make(ContactResults()))
        self._index = self.DeclareAbstractState(AbstractValue.Make(_State()))
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / rate, 0.0, self._update)
        self.DeclareForcedUnrestrictedUpdateEvent(self._update)
        self.DeclareAbstractOutputPort("rally", lambda: AbstractValue.Make(RallyRecord()),
                                       self._calc_rally)

    @property
    def table_clearances(self) -> tuple:
        """Each side's :class:`tt_drake.systems.table_clearance.TableClearance`, or None."""
        return self._clearances

    def _arm_q(self, context):
        return tuple(tuple(port.Eval(context)[:7]) if port.HasValue(context) else None
                     for port in self._arms)

    def _side_sample(self, t, p, v, w, q, side: int) -> tuple:
        centre = self._centres[side]
        racket = None if centre is None or q[side] is None else _SideRacket(q[side], centre, side)
        return (float(t), to_side(side, *p), to_side(side, *v), to_side(side, *w), racket)

    def _table_toucher(self, context, q) -> int | None:
        """The side whose robot touches the table now, or None (``q``: the sides' joint
        angles, :meth:`_arm_q`)."""
        if not self._table_geometries:
            return None
        if all(c is not None and x is not None and not c.may_touch(x)
               for c, x in zip(self._clearances, q, strict=True)):
            return None
        if not self._contacts.HasValue(context):
            return None
        return table_toucher(contact_pairs(self._contacts.Eval(context)), self._robot_bodies,
                             self._table_geometries)

    def _update(self, context, state):
        old = context.get_abstract_state(self._index).get_value()
        record = old.record
        out = state.get_mutable_abstract_state(self._index)
        if record.over:
            return EventStatus.ReachedTermination(self, "the rally is over")
        s = self._ball.Eval(context)
        t = context.get_time()
        q = self._arm_q(context)
        r = record.receiver
        cur = self._side_sample(t, s[4:7], s[10:13], s[7:10], q, r)
        toucher = self._table_toucher(context, q)
        if toucher is not None:
            record = RallyRecord(record.exchanges, table_fault(toucher, r, t, old.incoming),
                                 False, True, r)
            out.set_value(_State(record, cur, q, old.events, old.started, old.incoming,
                                 old.outgoing))
            return EventStatus.ReachedTermination(self, "a robot touched the table")
        if old.sample is None:
            out.set_value(_State(record, cur, q, (), t, None))
            return EventStatus.Succeeded()
        events, incoming, outgoing = old.events, old.incoming, old.outgoing
        event = self.detector.detect(old.sample, cur)
        if event is not None:
            events = (*events, event)
            if event.kind == RACKET_CONTACT and not (incoming and incoming[2]):
                incoming = _ball_seen(old.sample, at_hit=True)
            if event.kind == RACKET_CONTACT:  # the ball the racket sent (the last touch's)
                outgoing = (*cur[1], *cur[2], *cur[3])
        if incoming is None and old.sample[1][1] >= PLANES.hitting_y > cur[1][1]:
            incoming = _ball_seen(cur, at_hit=False)
        floor = cur[1][2] < self._stop_below
        if floor:
            events = (*events, ContactEvent(t, FLOOR_CONTACT, cur[1]))
        verdict = decide(list(events), t, old.started, self.config.exchange_timeout)
        started = old.started
        if verdict is not None and verdict[0] == "returned":
            hit_time = next(e.t for e in events if e.kind == RACKET_CONTACT)
            speed, spin = incoming[:2] if incoming else (math.nan, (math.nan,) * 3)
            exchanges = (*record.exchanges,
                         Exchange(r, hit_time, tuple(verdict[1]), speed, spin, outgoing))
            capped = len(exchanges) >= self.config.max_exchanges
            landing_t = events[-1].t
            r = 1 - r
            record = RallyRecord(exchanges, None, capped, capped, r)
            z = events[-1].position[2]
            events, started, incoming = (opening_event(verdict[1], landing_t, z),), landing_t, None
            outgoing = None
            cur = self._side_sample(t, s[4:7], s[10:13], s[7:10], q, r)
        elif verdict is not None:
            speed, spin = incoming[:2] if incoming else (None, None)
            record = RallyRecord(record.exchanges, RallyFault(r, verdict[1], t, speed, spin),
                                 False, True, r)
        elif floor:  # nothing left to judge (cannot happen: the floor decides)
            record = RallyRecord(record.exchanges, RallyFault(r, "out", t), False, True, r)
        out.set_value(_State(record, cur, q, events, started, incoming, outgoing))
        if record.over:
            return EventStatus.ReachedTermination(self, "the rally is over")
        return EventStatus.Succeeded()

    def record(self, context) -> RallyRecord:
        return context.get_abstract_state(self._index).get_value().record

    def _calc_rally(self, context, output):
        output.set_value(self.record(context))


def _ball_seen(sample, at_hit: bool) -> tuple:
    """(speed, spin, at_hit) of the ball in a side-frame sample."""
    v, w = sample[2], sample[3]
    return math.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2), tuple(w), at_hit
