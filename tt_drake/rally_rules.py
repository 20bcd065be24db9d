"""Rally rules: two robots, one ball; who receives, what counts as an exchange, how a rally ends.

The second robot (``B``) stands at the other end of the table, **mirrored through the net**: its
mount is the first robot's (``A``) turned a half-turn about the vertical axis through the table
centre, M = Rz(pi): (x, y, z) -> (-x, -y, z). A proper rotation, so B is the same right-handed
forehand robot seen from its own end, and everything side-specific (camera, estimator, player,
the single-stroke :func:`tt_drake.referee_rules.judge`) runs unchanged in a side's own frame:
A's frame is the world frame, B's is the world seen through M (M is its own inverse). The spin,
an axial vector, turns with the same rotation.

An **exchange** is one legal return: the receiver hits the ball and it first lands on the
opponent's half, touching the net on the way or not (``judge`` in the receiver's frame says
``returned``). Then the opponent receives; its events start with that landing, a bounce on
its own half. The rally ends at the first fault of the receiver (:func:`decide`):

- ``missed``: the ball reached the floor without the receiver's racket touching it;
- ``double_bounce``: it bounced twice on the receiver's half before the hit;
- ``net``, ``own_half`` (it never reached the other side), ``out``, ``table_side`` (it struck a
  side or end face of the table), ``double_hit``: after the hit,
  as :func:`tt_drake.referee_rules.after_hit` names them (a return that touches the net and
  lands on the opponent's half is an exchange);
- ``no_landing``: nothing decided ``exchange_timeout`` seconds after the exchange began (the ball
  rests or rolls somewhere; ``missed`` if the receiver never hit it);

or when a robot, either of them, touches the table with its arm or racket
(:data:`tt_drake.referee_rules.ROBOT_TABLE`, the serve's rule:
:func:`tt_drake.referee_rules.table_toucher`): that robot loses the point (Law 2.10.1), whether
it was receiving or not; or when ``max_exchanges`` exchanges have been played (``capped``).
"""


from dataclasses import dataclass, field

import numpy as np

from tt_drake.rally_aim import CompetitiveAim
from tt_drake.referee_rules import (
    FLOOR_CONTACT,
    RACKET_CONTACT,
    ROBOT_TABLE,
    TABLE_CONTACT,
    ContactEvent,
    after_hit,
    merge_contacts,
    receiver_bounces,
)

SIDES = ("A", "B")


def to_side(side: int, x, y, z) -> tuple[float, float, float]:
    """A world-frame point or vector (position, velocity or spin) in side ``side``'s frame
    (0: A, the world; 1: B, through M = Rz(pi)); M is its own inverse, so this also maps back."""
    if side == 0:
        return float(x), float(y), float(z)
    return -float(x), -float(y), float(z)


def mirror_state13(state) -> list[float]:
    """The plant's 13-float ball state (quaternion wxyz, p, omega, v) seen from B's frame: the
    orientation composed with M (quaternion (0, 0, 0, 1) times it), p, omega and v rotated."""
    w, qx, qy, qz = state[0:4]
    # (0, 0, 0, 1) x (w, qx, qy, qz) = (-qz, -qy, qx, w)
    return [-qz, -qy, qx, w, *to_side(1, *state[4:7]), *to_side(1, *state[7:10]),
            *to_side(1, *state[10:13])]


def mirror_matrix13():
    """:func:`mirror_state13` as a 13 x 13 matrix (it is linear), for a C++ ``MatrixGain``."""
    m = np.zeros((13, 13))
    m[0, 3], m[1, 2], m[2, 1], m[3, 0] = -1.0, -1.0, 1.0, 1.0
    for i in (4, 7, 10):
        m[i, i], m[i + 1, i + 1], m[i + 2, i + 2] = -1.0, -1.0, 1.0
    return m


def _rally_flight_times() -> list[float]:
    return [0.5, 0.6]


@dataclass
class RallyConfig:
    """The rally's settings (scenario field ``rally``). The players' aim, as in a cooperative
    training rally, is a ball the opponent can play (docs/rally.md): ``target_x``, ``target_y``
    is where each aims, in its own frame (on the opponent's half, y > 0): by default 0.3 m to
    the striker's left of the centre line, towards the opponent's forehand (its +x is the
    striker's -x), and 0.9 m past the net, 0.47 m before the end line; ``flight_times`` (s) are
    the return's candidate flight times to it (the single stroke tries 0.5 to 0.9 s and takes
    the least racket speed: a slow, high ball that, returned by a robot with its spin, stops
    dead at the bounce and drops before the opponent's hitting plane). ``max_exchanges``: the
    rally stops there (counted as that many). ``exchange_timeout`` (s): see the module
    docstring. ``aim`` and ``competitive``: each stroke's aim (:mod:`tt_drake.rally_aim`)."""

    target_x: float = -0.3
    target_y: float = 0.9
    flight_times: list[float] = field(default_factory=_rally_flight_times)
    max_exchanges: int = 50
    exchange_timeout: float = 3.0
    # Each stroke's aim (tt_drake.rally_aim): ``cooperative`` (the target above, flat strokes)
    # or ``competitive`` (drawn per stroke from ``competitive``).
    aim: str = "cooperative"
    competitive: CompetitiveAim = field(default_factory=CompetitiveAim)


@dataclass(frozen=True)
class Exchange:
    """One legal return: who returned, when it hit, where the ball landed (the returner's frame),
    the ball it had to return: its speed (m/s) and spin (rad/s, the returner's frame) at the
    last sample before the hit, and the ball it sent: ``outgoing`` (p, v, omega; 9 floats in the
    returner's frame) at the referee's first sample after the hit (None if not recorded)."""

    player: int
    hit_time: float
    landing: tuple[float, float]
    incoming_speed: float
    incoming_spin: tuple[float, float, float]
    outgoing: tuple[float, ...] | None = None

    def as_dict(self) -> dict:
        out = {"player": SIDES[self.player], "hit_time": round(self.hit_time, 4),
               "landing": [round(c, 4) for c in self.landing],
               "incoming_speed": round(self.incoming_speed, 4),
               "incoming_spin": [round(c, 3) for c in self.incoming_spin]}
        if self.outgoing is not None:
            out["outgoing"] = [round(c, 4) for c in self.outgoing]
        return out


@dataclass(frozen=True)
class RallyFault:
    """The fault that ended a rally: whose (the receiver; for ``robot_table`` the robot that
    touched the table, which may be the other), which kind, when, and the ball it had to return
    (None if it never came near, or if it was not receiving: speed and spin as in
    :class:`Exchange`)."""

    player: int
    kind: str
    t: float
    incoming_speed: float | None = None
    incoming_spin: tuple[float, float, float] | None = None

    def as_dict(self) -> dict:
        return {"player": SIDES[self.player], "kind": self.kind, "t": round(self.t, 4),
                "incoming_speed": None if self.incoming_speed is None
                else round(self.incoming_speed, 4),
                "incoming_spin": None if self.incoming_spin is None
                else [round(c, 3) for c in self.incoming_spin]}


def table_fault(toucher: int, receiver: int, t: float, incoming=None) -> RallyFault:
    """The fault of robot ``toucher`` touching the table at ``t`` while ``receiver`` receives:
    ``robot_table``, that robot's; ``incoming`` ((speed, spin, ...) of the ball the receiver
    has to return, or None) is recorded only if the toucher was receiving."""
    speed, spin = incoming[:2] if incoming is not None and toucher == receiver else (None, None)
    return RallyFault(toucher, ROBOT_TABLE, t, speed, spin)


def receiver_after(exchanges) -> int:
    """Who receives after ``exchanges`` (:class:`Exchange`, in order): A (0) the launcher's
    ball, then the opponent of the last returner."""
    return 0 if not exchanges else 1 - exchanges[-1].player


def decide(events: list[ContactEvent], t: float, started: float,
           timeout: float) -> tuple[str, object] | None:
    """The receiver's exchange so far, from its contact events in its own frame (the first is
    the bounce that began it): ``("returned", landing)``, ``("fault", kind)`` or None (not
    decided yet) at time ``t``; ``started``: when the exchange began (see the module
    docstring). The rules are the serve's (:func:`tt_drake.referee_rules.receiver_bounces` before
    the hit, :func:`tt_drake.referee_rules.after_hit` after it)."""
    merged = merge_contacts(events)
    if receiver_bounces(merged) >= 2:
        return "fault", "double_bounce"
    hit = next((i for i, e in enumerate(merged) if e.kind == RACKET_CONTACT), None)
    if hit is None:
        if any(e.kind == FLOOR_CONTACT for e in merged) or t - started > timeout:
            return "fault", "missed"
        return None
    ret = after_hit(merged[hit + 1:])
    if ret.decided:
        return ("returned", ret.landing) if ret.fault is None else ("fault", ret.fault)
    if t - started > timeout:
        return "fault", ret.fault
    return None


def opening_event(landing: tuple[float, float], t: float, z: float) -> ContactEvent:
    """A return's landing (returner's frame) as the first event of the opponent's exchange, in
    the opponent's frame: a bounce on its own half."""
    x, y, _ = to_side(1, landing[0], landing[1], z)
    return ContactEvent(t, TABLE_CONTACT, (x, y, z))
