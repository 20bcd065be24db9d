"""Referee LeafSystem: watches the ball (and the robot's contacts with the table) and judges the
episode with :mod:`tt_drake.referee_rules`.

Inputs:
- ``ball_state``: the plant's state output for the ball (quaternion, p, omega, v; 13 floats);
- ``robot_state``: the plant's state output for the robot (optional): the racket centre is
  computed from its joint positions by ``racket_centre`` (:class:`RacketCentre`), and only for the
  samples that the contact detector needs it for (a velocity jump away from the table, the net and
  the floor), not at every sample (docs/performance.md);
- ``contact_results``: the plant's contact results, to see robot-table contact (optional).

A periodic discrete update at ``rate`` Hz (default 250 Hz) samples them; its discrete state (a
vector, :class:`_RefereeVector`) holds the last sample (the racket centre as the joint positions
it is computed from), the contact events so far (at most :data:`MAX_EVENTS`) and whether the
robot touched the table. (An abstract state was deep-copied by the simulator twice per sample,
and kept the player's unrestricted updates that change nothing from skipping their write-back:
docs/performance.md, sixth pass.) Output ``outcome``: the
:class:`tt_drake.referee_rules.Outcome` of the episode so far.

The referee ends the episode (``EventStatus.ReachedTermination``, which stops
``Simulator.AdvanceTo``) once the ball has fallen below ``stop_below`` metres: by then every
outcome is settled, and a ball sliding along the floor costs the integrator four times the steps
of a ball in flight. With ``stop_when_decided`` it ends the episode earlier, at the first contact
after the racket's hit on the table, the net or the floor (the landing, or the fault): it decides
the outcome (:func:`tt_drake.referee_rules.judge`), and the return flight after it is a third
of a returned ball's episode.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.multibody.plant import ContactResults
from pydrake.systems.framework import EventStatus, LeafSystem

from tt_drake.referee_rules import (
    FLOOR_CONTACT,
    NET_CONTACT,
    RACKET_CONTACT,
    ROBOT_CONTACT,
    TABLE_CONTACT,
    ContactDetector,
    ContactEvent,
    Outcome,
    RefereeConfig,
    decides_return,
    judge,
)

# The most contact events one episode's state holds. A serve episode has a handful; a ball
# dribbling on the table until the time limit at most ~30 (bounces of the ball's velocity jump
# threshold or more); the referee fails loudly rather than drop one.
MAX_EVENTS = 64
_KINDS = (TABLE_CONTACT, NET_CONTACT, FLOOR_CONTACT, RACKET_CONTACT, ROBOT_CONTACT)
_KIND_CODE = {kind: float(i) for i, kind in enumerate(_KINDS)}


class _RefereeVector:
    """The layout of the referee's discrete state::

        [has_sample, t, p (3), v (3), omega (3), has_racket, q (num_positions), touched,
         n_events, events (MAX_EVENTS x 5: t, kind code, position (3))]

    Every value is stored as the float64 the abstract state held, so a sample and the events
    read back are the same numbers."""

    def __init__(self, num_positions: int):
        self.q = slice(12, 12 + num_positions)
        self.touched = 12 + num_positions
        self.n_events = self.touched + 1
        self.events = self.n_events + 1
        self.size = self.events + 5 * MAX_EVENTS

    def initial(self) -> np.ndarray:
        return np.zeros(self.size)

    def sample(self, x: list, centre) -> tuple | None:
        """The stored sample as :meth:`ContactDetector.sample`'s tuple (None before the first);
        the racket centre from the stored joint positions (``centre``), on first use."""
        if x[0] != 1.0:
            return None
        racket = RacketAt(tuple(x[self.q]), centre) if x[11] == 1.0 else None
        return (x[1], (x[2], x[3], x[4]), (x[5], x[6], x[7]), (x[8], x[9], x[10]), racket)

    def events_of(self, x) -> tuple:
        n = int(x[self.n_events])
        e = self.events
        return tuple(ContactEvent(x[k], _KINDS[int(x[k + 1])], (x[k + 2], x[k + 3], x[k + 4]))
                     for k in range(e, e + 5 * n, 5))

    def header(self, cur: tuple, q, touched: float, n_events: float) -> list:
        """The state's entries before the events for the sample ``cur`` (with the joint
        positions ``q`` of its racket centre, or None)."""
        t, p, v, w, _ = cur
        if q is None:
            return [1.0, t, *p, *v, *w, 0.0, touched, n_events]
        return [1.0, t, *p, *v, *w, 1.0, *q, touched, n_events]

    def append(self, new: np.ndarray, event: ContactEvent) -> None:
        n = int(new[self.n_events])
        if n == MAX_EVENTS:
            raise RuntimeError(f"the referee holds at most {MAX_EVENTS} contact events")
        k = self.events + 5 * n
        new[k:k + 5] = (event.t, _KIND_CODE[event.kind], *event.position)
        new[self.n_events] = n + 1


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
                 stop_when_decided: bool = False):
        super().__init__()
        self.config = config or RefereeConfig()
        self.detector = ContactDetector(self.config)
        self._racket_centre = racket_centre
        self._robot_bodies = set(robot_body_indices)
        self._table_geometries = set(table_geometry_ids)
        self._stop_below = stop_below
        self._stop_when_decided = stop_when_decided
        # The ports, kept: each 250 Hz sample reads them without looking them up (docs/
        # performance.md, fourth pass).
        self._ball = self.DeclareVectorInputPort("ball_state", 13)
        self._robot = self.DeclareVectorInputPort(
            "robot_state", 14 if racket_centre is None else racket_centre.state_size)
        self._contacts = self.DeclareAbstractInputPort("contact_results",
                                                       AbstractValue.Make(ContactResults()))
        self._succeeded = EventStatus.Succeeded()
        self._layout = _RefereeVector(0 if racket_centre is None else racket_centre.num_positions)
        self._xd = self.DeclareDiscreteState(self._layout.initial())
        self.DeclarePeriodicDiscreteUpdateEvent(1.0 / rate, 0.0, self._update)
        # The same update as a forced event, so that a sample can be taken on demand (tests).
        self.DeclareForcedDiscreteUpdateEvent(self._update)
        self.DeclareAbstractOutputPort(
            "outcome", lambda: AbstractValue.Make(Outcome("missed", False, False, False)),
            self._calc_outcome, prerequisites_of_calc={self.xd_ticket()})

    def _racket_q(self, context) -> tuple | None:
        """The joint positions the racket centre is computed from (None without a robot)."""
        if self._racket_centre is None or not self._robot.HasValue(context):
            return None
        return tuple(self._robot.Eval(context)[:self._racket_centre.num_positions].tolist())

    def _robot_touches_table(self, context) -> bool:
        if not self._table_geometries or not self._contacts.HasValue(context):
            return False
        results = self._contacts.Eval(context)
        for i in range(results.num_point_pair_contacts()):
            pair = results.point_pair_contact_info(i)
            bodies = (pair.bodyA_index(), pair.bodyB_index())
            if any(b in self._robot_bodies for b in bodies):
                ids = (pair.point_pair().id_A, pair.point_pair().id_B)
                if any(g in self._table_geometries for g in ids):
                    return True
        return False

    def _update(self, context, discrete_state):
        layout = self._layout
        x = context.get_discrete_state(self._xd).get_value()
        old = x[:layout.events].tolist()
        # ContactDetector.sample's tuple of plain floats, made at once (tolist) at 250 Hz.
        s = self._ball.Eval(context).tolist()
        q = self._racket_q(context)
        cur = (float(context.get_time()), (s[4], s[5], s[6]), (s[10], s[11], s[12]),
               (s[7], s[8], s[9]), None if q is None else RacketAt(q, self._racket_centre))
        touched = old[layout.touched]
        if touched != 1.0 and self._robot_touches_table(context):
            touched = 1.0
        event = None
        decided = False
        prev = layout.sample(old, self._racket_centre)
        if prev is not None:
            event = self.detector.detect(prev, cur)
            if event is not None:
                decided = self._stop_when_decided and decides_return(layout.events_of(x), event)
        new = x.copy()
        new[:layout.events] = layout.header(cur, q, touched, old[layout.n_events])
        if event is not None:
            layout.append(new, event)
        if decided:
            discrete_state.set_value(self._xd, new)
            return EventStatus.ReachedTermination(self, "the return's outcome is decided")
        if cur[1][2] < self._stop_below:
            # The ball is at the floor: that is its last contact, whether or not the floor
            # contact itself fell between samples.
            layout.append(new, ContactEvent(cur[0], FLOOR_CONTACT, cur[1]))
            discrete_state.set_value(self._xd, new)
            return EventStatus.ReachedTermination(self, "the ball reached the floor")
        discrete_state.set_value(self._xd, new)
        return self._succeeded

    def events(self, context):
        return list(self._layout.events_of(context.get_discrete_state(self._xd).get_value()))

    def touched(self, context) -> bool:
        """Whether the robot has touched the table so far."""
        return bool(context.get_discrete_state(self._xd).get_value()[self._layout.touched])

    def _calc_outcome(self, context, output):
        output.set_value(judge(self.events(context), self.touched(context), self.config))
