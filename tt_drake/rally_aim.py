"""Where each stroke of a rally aims, with what pace and spin: the players' per-stroke decision.

An :class:`Aim` is the landing target (x, y on the opponent's half, in the striker's own frame),
the return's flight time (None: the player's candidate times, least racket speed first) and its
topspin (rad/s, negative for backspin; None: the flat stroke, the ball keeping the spin it came
with; :mod:`tt_drake.spin_stroke`).

- ``cooperative``: every stroke aims at the rally's one target with the flat stroke, a ball the
  opponent can play.
- ``competitive``: each stroke draws its aim (:class:`CompetitiveAim`): the target uniform over
  a box of the opponent's half, the flight time uniform over a range (pace: 0.45 s is a drive at
  ~6 m/s, 0.8 s a slow ball), and the stroke's kind, a topspin drive, a backspin push or a block
  that takes the spin off the ball, with the given probabilities. Stroke k of a rally with seed
  s draws from its own generator, keyed by (s, k), so a rally replays exactly and its strokes
  are independent.

  A competitive stroke keeps the ball in play for a robot whose base does not move: it takes
  the first of ``draws`` aims drawn in turn whose return the opponent can play
  (:func:`opponent_hitting_point`: the opponent, the same robot mirrored through the net,
  chooses its hitting point on the return's predicted path by its own rule, and that point lies
  in the ``playable_x`` and ``playable_z`` ranges the arm reaches, and whose return, struck
  from behind the striker's own end line, passes over it: :func:`passes_own_end`); if none,
  the cooperative aim.
"""

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from tt_drake.ball_model import BallModel, BallModelParams, PlaneCrossing
from tt_drake.constants import BALL, TABLE
from tt_drake.hitting_time import HittingBand, choose_hitting_point

AIMS = ("cooperative", "competitive")
STROKE_KINDS = ("drive", "push", "block")


def _pair(low: float, high: float):
    return field(default_factory=lambda: [low, high])


@dataclass
class CompetitiveAim:
    """The competitive aim's draws (scenario field ``rally.competitive``): target ``x`` and
    ``y`` ranges (m, the striker's frame: y > 0 is the opponent's half, the end line at 1.37 m),
    ``flight_time`` range (s), the probabilities of a drive, a push and a block (``kinds``), a
    drive's topspin range (rad/s), a push's (negative: backspin) and a block's; how many aims a
    stroke may draw (``draws``) to find one whose return lands in the opponent's reach: its
    hitting point across (``playable_x``, m, the opponent's frame) and in height
    (``playable_z``, m; ``learned_playable_z`` when the opponent is a learned player, whose
    motor primitives meet low balls less well: :meth:`against`); and how high a return struck
    from behind the striker's own end line passes over it (``end_clearance``, m,
    :func:`passes_own_end`)."""

    x: list[float] = _pair(-0.55, 0.55)
    y: list[float] = _pair(0.45, 1.3)
    flight_time: list[float] = _pair(0.42, 0.85)
    kinds: list[float] = field(default_factory=lambda: [0.7, 0.15, 0.15])
    drive_topspin: list[float] = _pair(20.0, 70.0)
    push_topspin: float = -30.0
    block_topspin: float = 0.0
    draws: int = 8
    # Where the arm meets a ball (the opponent's hitting point, its frame); chosen on
    # validation rallies (docs/rally.md, "Competitive play"). The stock robot meets a ball
    # falling through the hitting band's 0.65 m floor behind the table less well than the
    # ideal robot (whose scenario keeps [0.65, 1.15] m), so its box starts at 0.7 m; a deep
    # return crosses the opponent's hitting plane high, and the box reaching 1.25 m keeps
    # more of them.
    playable_x: list[float] = _pair(-0.6, 0.5)
    playable_z: list[float] = _pair(0.7, 1.25)
    learned_playable_z: list[float] = _pair(0.7, 1.15)
    # A return struck from behind the striker's own end line passes over it with the ball's
    # bottom at least this high above the playing surface (m; :func:`passes_own_end`).
    end_clearance: float = 0.02

    def against(self, learned: bool) -> "CompetitiveAim":
        """These settings for a stroke whose opponent is a learned player (``learned``: its
        reach ``learned_playable_z``) or not (``playable_z``)."""
        return dataclasses.replace(self, playable_z=list(self.learned_playable_z)) if learned \
            else dataclasses.replace(self)

    def playable(self, point: PlaneCrossing | None) -> bool:
        """Whether the opponent's hitting point (its frame; None: it has none) lies in reach."""
        return (point is not None
                and self.playable_x[0] <= point.position[0] <= self.playable_x[1]
                and self.playable_z[0] <= point.position[2] <= self.playable_z[1])

    def problems(self, prefix: str = "rally.competitive.") -> list[str]:
        """What is wrong with the values, one phrase per field."""
        out = []
        for name in ("x", "y", "flight_time", "drive_topspin", "playable_x", "playable_z",
                     "learned_playable_z"):
            pair = getattr(self, name)
            if (len(pair) != 2 or not all(np.isfinite(pair)) or pair[0] > pair[1]):
                out.append(f"{prefix}{name} must be [low, high] with low <= high, got {pair}")
        if len(self.y) == 2 and not 0.0 < self.y[0]:
            out.append(f"{prefix}y must lie on the opponent's half (> 0), got {self.y}")
        if len(self.flight_time) == 2 and not 0.0 < self.flight_time[0]:
            out.append(f"{prefix}flight_time must be > 0, got {self.flight_time}")
        kinds = np.asarray(self.kinds, dtype=float)
        if kinds.shape != (3,) or np.any(kinds < 0.0) or abs(kinds.sum() - 1.0) > 1e-9:
            out.append(f"{prefix}kinds must be 3 probabilities (drive, push, block) summing to "
                       f"1, got {self.kinds}")
        if not (isinstance(self.draws, int) and 1 <= self.draws <= 100):
            out.append(f"{prefix}draws must be an integer from 1 to 100, got {self.draws}")
        for name in ("push_topspin", "block_topspin"):
            if not np.isfinite(getattr(self, name)):
                out.append(f"{prefix}{name} must be finite, got {getattr(self, name)}")
        if not (np.isfinite(self.end_clearance) and self.end_clearance >= 0.0):
            out.append(f"{prefix}end_clearance must be a finite number >= 0, got "
                       f"{self.end_clearance}")
        return out


@dataclass(frozen=True)
class Aim:
    """One stroke's aim (module docstring); ``kind`` names the stroke for the record."""

    target_x: float
    target_y: float
    flight_time: float | None = None
    topspin: float | None = None
    kind: str = "block"


def draw_aim(competitive: CompetitiveAim, seed: int, stroke: int) -> Aim:
    """Stroke ``stroke`` of the rally with ``seed``: the competitive aim's first draw (module
    docstring), a pure function of (seed, stroke)."""
    return draw_aims(competitive, seed, stroke)[0]


def draw_aims(competitive: CompetitiveAim, seed: int, stroke: int) -> list[Aim]:
    """Stroke ``stroke``'s ``competitive.draws`` aims, drawn in turn from the generator keyed by
    (seed, stroke): a pure function of them, the first the same for any number of draws."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed) & 0xFFFFFFFFFFFF,
                                                        int(stroke), 0xA1]))
    return [_draw(competitive, rng) for _ in range(competitive.draws)]


def _draw(competitive: CompetitiveAim, rng: np.random.Generator) -> Aim:
    x = float(rng.uniform(*competitive.x))
    y = float(rng.uniform(*competitive.y))
    flight_time = float(rng.uniform(*competitive.flight_time))
    kind = STROKE_KINDS[int(rng.choice(3, p=np.asarray(competitive.kinds, dtype=float)))]
    drive = float(rng.uniform(*competitive.drive_topspin))  # drawn for every kind alike
    topspin = {"drive": drive, "push": float(competitive.push_topspin),
               "block": float(competitive.block_topspin)}[kind]
    return Aim(x, y, flight_time, topspin, kind)


#: The flight model of :func:`passes_own_end`: the table as it is (the planners' model takes it
#: larger, which would let a ball below the surface bounce off the margin behind the end line).
_FLIGHT = BallModel(BallModelParams(), dt=0.01)


def passes_own_end(p_hit, v_out, spin_out, clearance: float) -> bool:
    """Whether a return leaving ``p_hit`` with ``v_out`` and ``spin_out`` (the striker's frame)
    passes over the striker's own end line: struck behind it (y < -L/2) the ball's centre
    crosses the end's vertical plane y = -L/2 at least R + ``clearance`` above the playing
    surface (a lower ball strikes the table's end, the ``table_side`` fault of Law 2.1.2:
    the playing surface excludes the sides of the tabletop). A return struck over the table
    passes."""
    end = TABLE.robot_edge_y
    p_hit = np.asarray(p_hit, dtype=float)
    if p_hit[1] >= end:
        return True
    state = np.concatenate([p_hit, np.asarray(v_out, dtype=float),
                            np.asarray(spin_out, dtype=float)])
    crossing = _FLIGHT.predict_plane(state, end, max_time=1.0)
    return (crossing is not None
            and crossing.position[2] >= TABLE.surface_z + BALL.radius + clearance)


def opponent_hitting_point(model: BallModel, p_hit, v_out, spin_out, plane_y: float,
                           band: HittingBand | None) -> PlaneCrossing | None:
    """Where the opponent, the striker's robot turned about the vertical axis through the table
    centre (M = Rz(pi): (x, y, z) -> (-x, -y, z)), hits the return that leaves ``p_hit`` with
    ``v_out`` and ``spin_out`` (the striker's frame), in the opponent's frame: the return's
    state (p, v, omega) mapped by M, then the robot's hitting-point rule
    (:func:`tt_drake.hitting_time.choose_hitting_point`) with its hitting plane ``plane_y`` and
    ``band`` (None: the default :class:`HittingBand`); None if it has none."""
    mirror = np.array([-1.0, -1.0, 1.0])
    state = np.concatenate([mirror * np.asarray(p_hit, dtype=float),
                            mirror * np.asarray(v_out, dtype=float),
                            mirror * np.asarray(spin_out, dtype=float)])
    return choose_hitting_point(model, state, plane_y, band, bounces_behind=0)
