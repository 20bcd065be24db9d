"""The returnable bound: which serves the robot's mount can legally return (docs/rules.md).

A serve is **returnable** when at least one *oracle strategy* returns it legally. A strategy is
the analytical player (the teacher, docs/analytical_player.md), or the learned player with a
shipped set, with ``oracle`` perception: the simulator's true ball state and spin at the
camera's frames, no noise. The strategies differ in what a player may choose: where along the
ball's path it hits (the hitting plane, the height band of
:class:`tt_drake.hitting_time.HittingBand`) and where on the opponent's court it aims (a legal
return need not land on the target); each also has the teacher's fallbacks for a stroke the arm
cannot make (a racket compensating half or none of the spin, the ball met off the blade's
centre: :class:`PlannerConfig`). The last strategies are the teacher and the learned player with
the hard set seeing the serve through the camera, with noise streams the evaluated players never
draw: a stroke at the edge of the arm's reach can succeed when it is planned for a point a
centimetre or two from the true one and the blade's face still meets the ball, and these draws
search that neighbourhood of the noiseless plan. They are tried in order, each only on the
serves no earlier strategy returned, so the bound costs one oracle episode per serve plus one
per strategy for each serve the earlier ones missed.

The bound is empirical: it bounds a player only if that player returns no serve it calls
unreturnable. Every ``--ceiling`` summary therefore reports ``returns_outside_ceiling``, the
player's legal returns of serves outside it, beside the plain legal return rate.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from tt_drake.ball_model import CompliantBounceBallModel
from tt_drake.constants import BALL, PLANES, TABLE, TARGET
from tt_drake.diagrams.episodes import (
    add_analytical_player,
    add_learned_player,
    teacher_planner_config,
)
from tt_drake.diagrams.scenario import LearnedPlayerConfig, Scenario
from tt_drake.hitting_time import HittingBand, closest_approach
from tt_drake.models import use_artefact_set
from tt_drake.seeds import episode_seed
from tt_drake.serves import serve_sampler
from tt_drake.systems.analytical_player import PlannerConfig, planner_ball_model
from tt_drake.systems.hitting_ik import SHOULDER
from tt_drake.systems.momp_player import MOVING_GOAL_TORQUE_FRACTION
from tt_drake.wam_params import reach_bound


@dataclass(frozen=True)
class OracleStrategy:
    """One way the oracle teacher may play a serve: ``target`` (x, y on the opponent's half,
    m; None: the scenario's referee target), ``band`` (None: the hitting plane only), the
    hitting plane ``plane_y`` (m) and the spin shares its strokes may compensate
    (``PlannerConfig.stroke_spins``; None: the teacher's). With ``artefacts`` (a shipped set's
    name, :data:`tt_drake.models.ARTEFACT_SETS`) the strategy is instead the learned ``momp``
    player with that set and ``band`` (its target, plane and spin shares unused).
    ``perception``: what the player sees (``oracle``, or ``camera`` with the camera's
    ``noise_stream``, which must then not be 0, the evaluated players' own stream)."""

    name: str
    target: tuple[float, float] | None = None
    band: HittingBand | None = HittingBand()
    plane_y: float = PLANES.hitting_y
    stroke_spins: tuple[float, ...] | None = None
    artefacts: str | None = None
    perception: str = "oracle"
    noise_stream: int = 0
    reach_in: tuple[float, ...] = ()

    def __post_init__(self):
        if self.perception not in ("oracle", "camera"):
            raise ValueError(f"strategy {self.name}: perception must be oracle or camera, "
                             f"not {self.perception!r}")
        if (self.perception == "camera") != (self.noise_stream > 0):
            raise ValueError(f"strategy {self.name}: a camera strategy needs a noise stream "
                             "> 0 (stream 0 is the evaluated players' own), an oracle none")

    def planner_config(self, scenario: Scenario) -> PlannerConfig:
        """The scenario's teacher (:func:`teacher_planner_config`: its drives and ``teacher``
        settings) with this strategy's target, band, plane and fallbacks."""
        x, y = self.target or (scenario.referee.target_x, scenario.referee.target_y)
        config = dataclasses.replace(teacher_planner_config(scenario), target_x=x, target_y=y,
                                     band=self.band, plane_y=self.plane_y)
        if self.stroke_spins is not None:
            config = dataclasses.replace(config, stroke_spins=self.stroke_spins)
        if self.reach_in:
            config = dataclasses.replace(config, reach_in=self.reach_in)
        return config


#: The reach-in strategies' fallback (m; ``PlannerConfig.reach_in``): a ball just beyond every
#: stroke the arm makes is met with the blade planned for a point this much nearer the shoulder.
REACH_IN = (0.03, 0.06, 0.09)
#: Where on the opponent's court they aim (x, y; m): a blade meeting the ball off its centre
#: sends it off the planned line, so each aim is a draw of its own.
REACH_AIMS = (("centre", (TARGET.x, TARGET.y)), ("left", (-0.45, 0.7)), ("right", (0.45, 0.7)),
              ("short", (0.0, 0.35)), ("deep", (0.0, 1.1)))

#: The strategies of the bound, in the order they are tried (module docstring): the teacher as
#: it plays (its fallbacks included: strokes compensating half or none of the spin, the ball off
#: the blade's centre), then hitting higher or lower along the path (the height band) and on
#: hitting planes 0.17 m nearer and farther; strokes that ignore the spin from the start (the
#: teacher's fallbacks reach a spin-blind stroke only after every full-spin one fails); and the
#: learned player with the hard set, whose primitives reach balls the teacher's IK does not,
#: hitting off the plane up to 0.08 m (not 0.18 m) behind the table's edge; and the teacher and
#: the hard set's player (as it ships) through the camera, each with two noise streams of their
#: own (module docstring).
STRATEGIES: tuple[OracleStrategy, ...] = (
    OracleStrategy("teacher"),
    OracleStrategy("high-band", band=HittingBand(plane_z_min=0.6, z_min=0.8)),
    OracleStrategy("low-band", band=HittingBand(plane_z_min=0.4, z_min=0.55)),
    OracleStrategy("near-plane", plane_y=PLANES.hitting_y + 0.17),
    OracleStrategy("far-plane", plane_y=PLANES.hitting_y - 0.17),
    OracleStrategy("spin-blind", stroke_spins=(0.0,)),
    OracleStrategy("low-band-blind", band=HittingBand(plane_z_min=0.4, z_min=0.55),
                   stroke_spins=(0.0,)),
    OracleStrategy("hard-set-near", artefacts="hard",
                   band=HittingBand(y_max=TABLE.robot_edge_y - 0.08)),
    OracleStrategy("teacher-camera-1", perception="camera", noise_stream=1),
    OracleStrategy("teacher-camera-2", perception="camera", noise_stream=2),
    OracleStrategy("hard-set-camera-1", artefacts="hard", band=None, perception="camera",
                   noise_stream=1),
    OracleStrategy("hard-set-camera-2", artefacts="hard", band=None, perception="camera",
                   noise_stream=2),
    *(OracleStrategy(f"reach-{name}", target=target, reach_in=REACH_IN)
      for name, target in REACH_AIMS),
)


def strategy_scenario(strategy: OracleStrategy, scenario: Scenario) -> Scenario:
    """The scenario ``strategy`` plays: a copy of ``scenario`` with the strategy's perception
    (and camera noise stream) and, for a learned strategy, its shipped artefact set, played
    without the stock robot's ``learned`` fallbacks and early refresh (the caller's are left as
    they were)."""
    oracle = copy.deepcopy(scenario)
    oracle.perception = strategy.perception
    oracle.camera = dataclasses.replace(oracle.camera, noise_stream=strategy.noise_stream)
    if strategy.artefacts is not None:
        # The set as it was trained and shipped: without the stock robot's fallbacks and early
        # refresh, its plans asking the drives' supply the moving goal's multiple of the effort
        # limits, so that the bound does not move with the learned player's settings (a
        # learned return outside it is reported as such).
        oracle.learned = LearnedPlayerConfig(correction_fallback=False, stroke_fallbacks=False,
                                             refresh_before_bounce=False,
                                             supply_fraction=MOVING_GOAL_TORQUE_FRACTION)
        use_artefact_set(oracle.learned, strategy.artefacts)
    return oracle


def strategy_player(strategy: OracleStrategy) -> Callable:
    """A player function for :class:`tt_drake.diagrams.episodes.ServeDiagram`: the analytical
    player planning with ``strategy``'s settings, or for a learned strategy the ``momp`` player
    with its band (its artefacts come with :func:`strategy_scenario`)."""
    if strategy.artefacts is not None:
        return functools.partial(add_learned_player, band=strategy.band)

    def add(builder, world, controller, scenario):
        return add_analytical_player(builder, world, controller, scenario,
                                     config=strategy.planner_config(scenario))

    return add


#: How much farther (m) than the racket reaches a serve's path must stay to be beyond reach: room
#: for the ball model's path against the simulator's (aerodynamics, the compliant contact).
REACH_MARGIN = 0.05


def beyond_reach(launch_state) -> bool:
    """Whether no point of the serve's path in play on the robot's half comes within the
    racket's reach: the ball's centre stays farther from the shoulder than
    :func:`tt_drake.wam_params.reach_bound` + the ball's radius + :data:`REACH_MARGIN`
    (:func:`tt_drake.hitting_time.closest_approach`, the least of the ball model with the true
    table and with the planner's larger one, spin included). No arm configuration touches such
    a ball with the blade, so no strategy need play it and no player can return it."""
    far = reach_bound() + BALL.radius + REACH_MARGIN
    state = np.asarray(launch_state, dtype=float)
    return all(closest_approach(model, state, SHOULDER) > far
               for model in (CompliantBounceBallModel(dt=2e-3), planner_ball_model(2e-3)))


def within_reach(scenario: Scenario, serves: int, seed: int) -> list[bool]:
    """For each serve i < ``serves`` of a run (episode ``episode_seed(seed, i)``, served as
    ``scenario.launcher`` serves it), whether its ball comes within the racket's reach (not
    :func:`beyond_reach`): the ``within_reach`` flags of :func:`returnable_by`."""
    sampler = serve_sampler(scenario.launcher)
    return [not beyond_reach(sampler.sample(episode_seed(seed, i)).launch_state)
            for i in range(serves)]


def returnable_by(play: Callable[[OracleStrategy, list[int]], Sequence[bool]], serves: int,
                  strategies: Sequence[OracleStrategy] = STRATEGIES,
                  within_reach: Sequence[bool] | None = None) -> list[str | None]:
    """For each serve i < ``serves``, the name of the first strategy that returns it legally,
    or None. ``play(strategy, indices)`` plays the serves ``indices`` (the run's serve indices,
    ascending) with the oracle teacher under ``strategy`` and says which it returned legally.
    ``within_reach`` (one per serve; None: all): serves outside it (:func:`beyond_reach`) are
    not played and are unreturnable."""
    if within_reach is not None and len(within_reach) != serves:
        raise ValueError(f"{len(within_reach)} reach flags for {serves} serves")
    found: list[str | None] = [None] * serves
    for strategy in strategies:
        todo = [i for i in range(serves)
                if found[i] is None and (within_reach is None or within_reach[i])]
        if not todo:
            break
        returned = list(play(strategy, todo))
        if len(returned) != len(todo):
            raise ValueError(f"strategy {strategy.name}: {len(returned)} results for "
                             f"{len(todo)} serves")
        for i, ok in zip(todo, returned, strict=True):
            if ok:
                found[i] = strategy.name
    return found


def ceiling_summary(returned: Sequence[bool], returnable: Sequence[str | None]) -> dict:
    """A player's figures against the bound on the same serves: ``returnable_rate`` (share of
    serves the bound calls returnable), ``returnable_serves``, ``returns_of_returnable`` (the
    player's legal returns among them), ``return_rate_of_returnable`` (their ratio; None if no
    serve is returnable) and ``returns_outside_ceiling`` (legal returns of the others: not 0
    means the bound is wrong for this player)."""
    if len(returned) != len(returnable):
        raise ValueError(f"{len(returned)} episodes but {len(returnable)} ceiling entries")
    n = sum(r is not None for r in returnable)
    inside = sum(bool(ok) and r is not None for ok, r in zip(returned, returnable, strict=True))
    outside = sum(bool(ok) and r is None for ok, r in zip(returned, returnable, strict=True))
    serves = len(returned)
    return {"returnable_rate": n / serves if serves else 0.0, "returnable_serves": n,
            "returns_of_returnable": inside,
            "return_rate_of_returnable": inside / n if n else None,
            "returns_outside_ceiling": outside}
