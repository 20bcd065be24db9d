"""Referee rules: detect the ball's contacts from sampled states and judge an episode.

Contacts with the ball last about a millisecond, shorter than any sensible sampling period, so
they are detected from the samples themselves: between two samples the flight law
(:class:`tt_drake.ball_model.BallModel`) predicts the velocity change; a larger change means a
contact happened, and where the ball was tells which surface it touched.

Outcome classes (one per episode), by the ITTF Laws 2.5-2.10 (docs/rules.md):

- ``missed``: the racket never touched the ball;
- ``returned``: a legal return: after the racket hit, the ball first landed on the opponent's
  half (it may touch the net assembly on the way: Law 2.7.1, a "let" only for a serve), and
  before the hit it had bounced at most once on the robot's half;
- ``fault``: hit but not returned, with the fault named: ``double_bounce`` (the ball had bounced
  twice on the robot's half before the hit: the point was lost there, whatever the stroke
  did), ``net`` (touched the net or a post after the hit and then did not reach the opponent's
  court), ``own_half`` (first landed on the robot's half), ``out`` (reached the floor without
  landing on the table), ``table_side`` (struck a side or end face of the table: the playing
  surface does not include the vertical sides of the tabletop, Law 2.1.2),
  ``double_hit``, ``no_landing`` (still in the air at the end).

Independently of the class, ``double_bounce`` is also recorded for a missed ball that bounced
twice on the robot's half and ``robot_table`` (:data:`ROBOT_TABLE`) when the robot touched the
table; ``net_touch`` (not a fault) says that the return touched the net assembly.
:func:`receiver_bounces` and :func:`after_hit` are the two rules every referee reads (this
module's :func:`judge`, and the rally's :func:`tt_drake.rally_rules.decide`), and
:func:`table_toucher` says, for both, which of the plant's contacts is a robot touching the
table.

Reward in [0, 1] (the paper's r of Eq. 10 and Algorithm 3, which it does not define further): 0
when missed; 0.2 for a hit that is not returned; a legal return earns
``r_0 + (1 - r_0) exp(-d^2 / (2 sigma^2))`` with d the landing distance from the target, sigma =
``reward_sigma`` (0.3 m) and the floor ``r_0 = return_floor`` (0.3). Any robot-table contact caps
the reward at 0.1.

Why the floor is 0.3 (it was 0.6): responsibility learning (Eq. 10) eventually prunes a primitive
whose mean credited reward stays below ``1 + zeta ln(threshold) / kappa`` (0.42 with the defaults
of :class:`tt_drake.responsibility.ResponsibilityParams`). With a floor of 0.6 no primitive that
returns the ball could ever be pruned, however far off it aims. With 0.3, a return on target
(d <= 0.2 m) earns at least 0.86 and one landing 0.5 m off 0.47, and returns landing more than
0.56 m off earn less than the pruning level. The floor only changes the reward: which strokes
count as legal returns, hits or misses is decided as before.
"""


import math
from dataclasses import dataclass, field

from tt_drake.ball_model import BallModel
from tt_drake.constants import NET, TABLE, TARGET

# Contact kinds.
TABLE_CONTACT, NET_CONTACT, FLOOR_CONTACT, RACKET_CONTACT, ROBOT_CONTACT = (
    "table", "net", "floor", "racket", "robot")
#: A contact with a side or end face of the table, below its playing surface.
TABLE_SIDE_CONTACT = "table_side"
#: The fault of a robot touching the table (the serve's outcome, the rally's fault kind).
ROBOT_TABLE = "robot_table"


@dataclass(frozen=True)
class ContactEvent:
    t: float
    kind: str
    position: tuple[float, float, float]


@dataclass
class RefereeConfig:
    target_x: float = TARGET.x
    target_y: float = TARGET.y
    target_radius: float = 0.2  # a landing within this distance counts as "on target" (m)
    reward_sigma: float = 0.3  # m
    return_floor: float = 0.3  # reward of a legal return landing far from the target
    velocity_jump: float = 0.25  # m/s of unexplained velocity change that signals a contact
    racket_reach: float = 0.15  # contact within this distance of the racket centre is a hit (m)


class ContactDetector:
    """Turns sampled ball states (and the racket centre) into contact events."""

    def __init__(self, config: RefereeConfig | None = None, model: BallModel | None = None):
        self.config = config or RefereeConfig()
        self.model = model or BallModel()
        self.reset()

    def reset(self) -> None:
        self._prev: tuple | None = None

    @staticmethod
    def sample(t: float, p, v, w=(0.0, 0.0, 0.0), racket=None) -> tuple:
        """One sample as plain floats: (t, p, v, omega, racket centre or None)."""
        return (float(t), tuple(float(c) for c in p[:3]), tuple(float(c) for c in v[:3]),
                tuple(float(c) for c in w[:3]),
                None if racket is None else tuple(float(c) for c in racket[:3]))

    def update(self, t: float, p, v, w=(0.0, 0.0, 0.0), racket=None) -> ContactEvent | None:
        """Feed one sample; returns the contact that happened since the previous one, if any."""
        cur = self.sample(t, p, v, w, racket)
        prev, self._prev = self._prev, cur
        return None if prev is None else self.detect(prev, cur)

    def detect(self, prev: tuple, cur: tuple) -> ContactEvent | None:
        """The contact between two samples (see :meth:`sample`), if the velocity jumped."""
        t0, p0, v0, w0, racket0 = prev
        t, p, v, w, racket = cur
        dt = t - t0
        if dt <= 0.0:
            return None
        # Flight-law prediction over the interval (midpoint acceleration).
        a0 = self.model.acceleration(v0, w0)
        a1 = self.model.acceleration(v, w)
        jump = math.sqrt(sum((v[i] - v0[i] - 0.5 * dt * (a0[i] + a1[i])) ** 2 for i in range(3)))
        if jump < self.config.velocity_jump:
            return None
        kind, position = self._classify(p0, v0, p, v, racket0, racket)
        return None if kind is None else ContactEvent(t, kind, position)

    def _classify(self, p0, v0, p1, v1, racket0, racket1):
        r = self.model.params.radius
        contact_z = TABLE.surface_z + r
        near = 0.03
        lo_z = min(p0[2], p1[2])
        # Table: the ball was at the surface over the table (a contact may straddle two samples,
        # so the vertical velocity need not have turned yet).
        if (v0[2] < 0.0 and lo_z < contact_z + near and lo_z > TABLE.surface_z - near
                and self._over_table(p0, p1)):
            # Where it touched: extrapolate the incoming segment to the contact height.
            drop = p0[2] - lo_z + 1e-12
            s = 0.0 if v0[2] >= 0 else min(1.0, max(0.0, (p0[2] - contact_z) / drop))
            pos = tuple(p0[i] + s * (p1[i] - p0[i]) for i in range(2)) + (contact_z,)
            return TABLE_CONTACT, pos
        mid = tuple(0.5 * (p0[i] + p1[i]) for i in range(3))
        if lo_z < r + near:
            return FLOOR_CONTACT, mid
        if any(self._at_table_side(p, r, near) for p in (p0, p1)):
            return TABLE_SIDE_CONTACT, mid
        net_top = TABLE.surface_z + NET.height + r
        if (min(abs(p0[1]), abs(p1[1])) < 0.5 * NET.thickness + r + 0.05 and lo_z < net_top + near
                and abs(mid[0]) < NET.half_span + 0.05):
            return NET_CONTACT, mid
        for rk in (racket0, racket1):
            if rk is not None:
                d = math.dist(mid, rk)
                if d < self.config.racket_reach:
                    return RACKET_CONTACT, mid
        if racket0 is None and racket1 is None:
            # No robot information (scripted tests): any other contact is the racket.
            return RACKET_CONTACT, mid
        if mid[1] < TABLE.robot_edge_y + 0.3:
            return ROBOT_CONTACT, mid
        return None, mid  # nothing is there to touch: not a contact

    @staticmethod
    def _at_table_side(p, r: float, near: float) -> bool:
        """The ball (centre ``p``, radius ``r``) at a side or end face of the table: within
        ``r + near`` outside the top's outline, between its underside and its top."""
        hx, hy = 0.5 * TABLE.width, 0.5 * TABLE.length
        dx, dy = abs(p[0]) - hx, abs(p[1]) - hy
        outside = max(dx, dy)
        return (-near < outside < r + near and dx < r + near and dy < r + near
                and TABLE.surface_z - TABLE.collision_thickness - near < p[2] < TABLE.surface_z)

    @staticmethod
    def _over_table(p0, p1) -> bool:
        hx = 0.5 * TABLE.width + 0.02
        hy = 0.5 * TABLE.length + 0.02
        return any(abs(p[0]) <= hx and abs(p[1]) <= hy for p in (p0, p1))


@dataclass
class Outcome:
    """The referee's verdict on one episode."""

    outcome: str  # "missed", "returned" or "fault"
    hit: bool
    returned: bool
    on_target: bool
    faults: list[str] = field(default_factory=list)
    landing: tuple[float, float] | None = None
    target_distance: float | None = None
    hit_time: float | None = None
    reward: float = 0.0
    net_touch: bool = False  # the return touched the net assembly (legal if it then landed)

    def as_dict(self) -> dict:
        return {
            "outcome": self.outcome, "hit": self.hit, "returned": self.returned,
            "on_target": self.on_target, "faults": list(self.faults),
            "landing": None if self.landing is None else [round(c, 4) for c in self.landing],
            "target_distance": None if self.target_distance is None
            else round(self.target_distance, 4),
            "hit_time": None if self.hit_time is None else round(self.hit_time, 4),
            "reward": round(self.reward, 4), "net_touch": self.net_touch,
        }


def receiver_bounces(events) -> int:
    """How many times the ball bounced on the receiver's half (y < 0 in its frame) before the
    receiver's first racket contact (or in all of ``events`` if there is none). Two or more is a
    lost point for the receiver (ITTF Law 2.10.1.3): the ball is out of play at the second."""
    n = 0
    for e in events:
        if e.kind == RACKET_CONTACT:
            break
        n += e.kind == TABLE_CONTACT and e.position[1] < 0.0
    return n


@dataclass(frozen=True)
class Return:
    """What the ball did after the racket's hit (:func:`after_hit`): ``fault`` (None for a legal
    return, else its name), ``landing`` (x, y of the first table contact, or None),
    ``net_touch`` (it touched the net assembly) and ``decided`` (a contact settled it; if not,
    ``fault`` is what the ball's state so far makes it: ``net`` after a net touch, else
    ``no_landing``)."""

    fault: str | None
    landing: tuple[float, float] | None
    net_touch: bool
    decided: bool


def after_hit(events) -> Return:
    """The return's verdict from the contacts after the racket's hit, in the striker's frame.

    The first table contact decides: on the opponent's half (y > 0) a legal return, whether or
    not the ball touched the net on the way (Law 2.7.1); on the striker's half ``net`` after a
    net touch, else ``own_half``. The floor before any table contact is ``out`` (``net`` if the
    ball touched the net and fell on the striker's side, y < 0); a side or end face of the table
    is ``table_side``; another racket or robot contact is ``double_hit``. A net contact alone
    decides nothing: the ball may still drop over."""
    net_touch = False
    for e in events:
        if e.kind == TABLE_CONTACT:
            landing = (e.position[0], e.position[1])
            if e.position[1] > 0.0:
                return Return(None, landing, net_touch, True)
            return Return("net" if net_touch else "own_half", landing, net_touch, True)
        if e.kind == NET_CONTACT:
            net_touch = True
        elif e.kind == FLOOR_CONTACT:
            fault = "net" if net_touch and e.position[1] < 0.0 else "out"
            return Return(fault, None, net_touch, True)
        elif e.kind == TABLE_SIDE_CONTACT:
            return Return("table_side", None, net_touch, True)
        elif e.kind in (RACKET_CONTACT, ROBOT_CONTACT):
            return Return("double_hit", None, net_touch, True)
    return Return("net" if net_touch else "no_landing", None, net_touch, False)


def decides_return(events, event: ContactEvent) -> bool:
    """Whether ``event``, following ``events``, settles the episode's outcome: a contact with
    the table or the floor after the racket's hit (:func:`judge` reads no further). A net
    contact does not (the ball may still drop onto the opponent's court), nor does a second
    racket event: one contact straddling two samples shows as two."""
    return (event.kind in (TABLE_CONTACT, FLOOR_CONTACT, TABLE_SIDE_CONTACT)
            and any(e.kind == RACKET_CONTACT for e in events))


def table_toucher(contacts, robots, table) -> int | None:
    """Which robot touches the table: the index in ``robots`` of the first robot with a body in
    contact with a table geometry, or None.

    ``contacts``: the plant's contact pairs, each ``(body_A, body_B, geometry_A, geometry_B)``
    (body indices and geometry ids, as the plant's contact results give them); ``robots``: per
    robot, the set of its body indices (every arm link and the racket); ``table``: the set of
    the table top's geometry ids. A pair counts when one side is a table geometry and the other
    side's body is a robot's. Every such contact counts, the racket's as well as an arm link's:
    the Laws (2.10.1) lose the point for a player who moves the playing surface or whose free
    hand touches it; the simulated table is welded and cannot move, so the touch is the only
    sign a referee has."""
    for body_a, body_b, geometry_a, geometry_b in contacts:
        for body, other in ((body_a, geometry_b), (body_b, geometry_a)):
            if other in table:
                for k, bodies in enumerate(robots):
                    if body in bodies:
                        return k
    return None


def merge_contacts(events: list[ContactEvent], window: float = 0.012) -> list[ContactEvent]:
    """One event per contact: a contact that straddles samples shows as several events of the
    same kind within a few milliseconds; keep the first."""
    merged: list[ContactEvent] = []
    for e in events:
        if merged and merged[-1].kind == e.kind and e.t - merged[-1].t <= window:
            continue
        merged.append(e)
    return merged


def judge(events: list[ContactEvent], robot_touched_table: bool = False,
          config: RefereeConfig | None = None) -> Outcome:
    """Classify an episode from its contact events in time order (see the module docstring)."""
    config = config or RefereeConfig()
    events = merge_contacts(events)
    faults: list[str] = []
    hit_index = next((i for i, e in enumerate(events) if e.kind == RACKET_CONTACT), None)
    if receiver_bounces(events) >= 2:
        faults.append("double_bounce")
    if robot_touched_table:
        faults.append(ROBOT_TABLE)
    if hit_index is None:
        return _scored(Outcome("missed", False, False, False, faults), config)
    hit_time = events[hit_index].t
    if "double_bounce" in faults:  # the point was lost before the stroke
        return _scored(Outcome("fault", True, False, False, faults, hit_time=hit_time), config)
    ret = after_hit(events[hit_index + 1:])
    if ret.fault is not None:
        faults.append(ret.fault)
        outcome = Outcome("fault", True, False, False, faults, ret.landing, hit_time=hit_time,
                          net_touch=ret.net_touch)
        return _scored(outcome, config)
    landing = ret.landing
    d = math.hypot(landing[0] - config.target_x, landing[1] - config.target_y)
    outcome = Outcome("returned", True, True, d <= config.target_radius, faults, landing, d,
                      hit_time, net_touch=ret.net_touch)
    return _scored(outcome, config)


def return_reward(distance: float, config: RefereeConfig | None = None) -> float:
    """The reward of a legal return landing ``distance`` metres from the target:
    ``r_0 + (1 - r_0) exp(-d^2 / (2 sigma^2))`` (module docstring)."""
    config = config or RefereeConfig()
    floor, d = config.return_floor, float(distance)
    return floor + (1.0 - floor) * math.exp(-d * d / (2.0 * config.reward_sigma**2))


def _scored(outcome: Outcome, config: RefereeConfig) -> Outcome:
    if not outcome.hit:
        reward = 0.0
    elif not outcome.returned:
        reward = 0.2
    else:
        reward = return_reward(outcome.target_distance, config)
    if ROBOT_TABLE in outcome.faults:
        reward = min(reward, 0.1)
    outcome.reward = reward
    return outcome
