"""Referee rules: detect the ball's contacts from sampled states and judge an episode.

Contacts with the ball last about a millisecond, shorter than any sensible sampling period, so
they are detected from the samples themselves: between two samples the flight law
(:class:`tt_drake.ball_model.BallModel`) predicts the velocity change; a larger change means a
contact happened, and where the ball was tells which surface it touched.

Outcome classes (one per episode):

- ``missed``: the racket never touched the ball;
- ``returned``: a legal return: after the racket hit, the ball cleared the net without touching it
  and first landed on the opponent's half;
- ``fault``: hit but not returned, with the fault named: ``net`` (touched the net or a post after
  the hit), ``own_half`` (first landed on the robot's half), ``out`` (reached the floor without
  landing on the table), ``double_hit``, ``no_landing`` (still in the air at the end).

Independently of the class, ``double_bounce`` (the serve bounced twice on the robot's half before
any hit) and ``robot_table`` (the robot touched the table) are recorded as faults.

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

    def as_dict(self) -> dict:
        return {
            "outcome": self.outcome, "hit": self.hit, "returned": self.returned,
            "on_target": self.on_target, "faults": list(self.faults),
            "landing": None if self.landing is None else [round(c, 4) for c in self.landing],
            "target_distance": None if self.target_distance is None
            else round(self.target_distance, 4),
            "hit_time": None if self.hit_time is None else round(self.hit_time, 4),
            "reward": round(self.reward, 4),
        }


def decides_return(events, event: ContactEvent) -> bool:
    """Whether ``event``, following ``events``, settles the episode's outcome: a contact with
    the table, the net or the floor after the racket's hit (:func:`judge` reads no further). A
    second racket event does not: one contact straddling two samples shows as two."""
    return (event.kind in (TABLE_CONTACT, NET_CONTACT, FLOOR_CONTACT)
            and any(e.kind == RACKET_CONTACT for e in events))


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
    before = events if hit_index is None else events[:hit_index]
    robot_bounces = [e for e in before if e.kind == TABLE_CONTACT and e.position[1] < 0.0]
    if len(robot_bounces) >= 2:
        faults.append("double_bounce")
    if robot_touched_table:
        faults.append("robot_table")
    if hit_index is None:
        return _scored(Outcome("missed", False, False, False, faults), config)
    hit_time = events[hit_index].t
    after = events[hit_index + 1:]
    landing = None
    fault = "no_landing"
    for e in after:
        if e.kind == TABLE_CONTACT:
            landing = (e.position[0], e.position[1])
            fault = None if e.position[1] > 0.0 else "own_half"
            break
        if e.kind == NET_CONTACT:
            fault = "net"
            break
        if e.kind == FLOOR_CONTACT:
            fault = "out"
            break
        if e.kind in (RACKET_CONTACT, ROBOT_CONTACT):
            fault = "double_hit"
            break
    if fault is not None:
        faults.append(fault)
        outcome = Outcome("fault", True, False, False, faults, landing, hit_time=hit_time)
        return _scored(outcome, config)
    d = math.hypot(landing[0] - config.target_x, landing[1] - config.target_y)
    outcome = Outcome("returned", True, True, d <= config.target_radius, faults, landing, d,
                      hit_time)
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
    if "robot_table" in outcome.faults:
        reward = min(reward, 0.1)
    outcome.reward = reward
    return outcome
