"""HittingPointPredictor LeafSystem: p_hit, v_hit and t_hit from four observations after plane s.

At every planning tick (250 Hz) it reads the estimator's ``state`` and ``status``; a new estimate
(once per camera frame) is acted on at the first tick after the estimator's update. Each new
valid estimate with ``p_y < observation_y`` and ``v_y < 0`` (past the virtual plane s, moving
toward the robot) is collected; a non-qualifying one restarts the count. At the fourth
consecutive one it makes the **final** prediction, with the GPR
(:class:`tt_drake.hitting_point.HittingPointGPR`, features = the four states) or the physical
model (:class:`tt_drake.hitting_point.PhysicalPredictor`, from the fourth state), and holds it.

With an ``early`` physical predictor, every valid estimate of a ball moving toward the robot
(``v_y < 0``) before the final prediction gives an **early** one from that state: the paper
starts the preparation stage as soon as "the system detects a ping pong ball that is moving
towards the robot" and re-estimates the goal as the ball flies (section III-C). An early
prediction is published (``valid`` = 1, ``final`` = 0) when it is the first, or moved more than
``early_tolerance`` = (metres, seconds) from the published one, so that a player re-plans only on
a real change; the final prediction replaces it (``final`` = 1).

With a ``refresh`` physical predictor the final prediction is not held for good: every new
estimate taken after the robot-side bounce (the model sees no bounce left before the hitting
plane) gives a physical prediction from the estimated state and spin, published when it moved
more than ``refresh_tolerance`` from the published one. After that bounce the estimator knows the
spin (docs/spin.md), which the GPR's features (four states before the bounce) cannot show.
With ``refresh_ahead`` the refresh starts at the final prediction: every new estimate, before
the bounce too, gives a physical prediction from the estimated state and the spin the filter
has seen so far (the Magnus force's curvature shows every component but the one about the
ball's direction of travel), as the teacher predicts at every frame. A moving goal then follows
the ball's estimate in small steps as the filter's spin converges, rather than in one step of
10-30 cm after the bounce, which the stock robot's slow base joint cannot make.

Ports:

- inputs ``state`` (6) and ``status`` (2: valid, t_state) from ``BallFlightEstimator``, and
  ``spin`` (3, rad/s) from it too; an unconnected ``spin`` is taken as zero (the physical
  predictions then assume a spinless ball, as before spin was estimated);
- outputs ``p_hit`` (3), ``v_hit`` (3), ``t_hit`` (1), ``valid`` (1), ``final`` (1) and
  ``spin_hit`` (3, rad/s): the ball's spin at the hitting plane as the ball model carries the
  estimator's spin there through the bounces ahead (the teacher's stroke assumes the same; a
  GPR prediction takes it from the physical model started at the fourth observation). It is the
  spin part of a learned player's stimulus when its artefacts say so (:mod:`tt_drake.stimulus`).
  ``balls`` (1) counts the balls let go with ``play_again``.
  ``t_hit`` is an **absolute** simulation time: the capture time of the state predicted from
  plus the predicted time to go (the regressors learn the time to go, which does not depend on
  the episode's clock).

The update works on the layout ``[n_collected, last_t, observations (4 x 6), p_hit (3), v_hit
(3), t_hit, valid, final, spin_hit (3), first_bounce, bounces, balls]``; ``first_bounce`` and
``bounces`` count the ball's bounces on the robot's half, from every estimate
(:class:`tt_drake.hitting_time.BounceCount`, -1: none yet), and ``balls`` the balls dropped so far
with ``play_again`` (the rally's stroke index, by which a competitive player draws its aim). The
discrete state holds it in eight groups: group 0 the memory (``n_collected``, ``last_t``, the
observations and the bounce count) and one group per output (``p_hit`` ... ``spin_hit``,
``balls``), which the outputs are: Drake's state output ports, served in C++
from the context, so that reading a prediction (the player's and the configuration's reads, a
logger's samples) never calls Python (docs/performance.md). A tick without a new estimate reads
only the memory's ``last_t``.

**The rules.** No prediction is published for a point after the ball's second bounce on the
robot's half (Law 2.10.1.3, a lost point): an early or final prediction whose plane crossing the
ball model, from the current estimate and the bounces counted, puts after that bounce is
replaced, with a ``band``, by the band's point before it
(:func:`tt_drake.hitting_time.choose_hitting_point`), and otherwise withdrawn; a refreshed one
likewise. A withdrawn prediction sets ``valid`` to 0, and a learned player not yet in its
hitting stage lets the ball go; the next legal prediction (a later estimate may show the ball
flying higher) is published again.
"""

import math

import numpy as np
from pydrake.systems.framework import EventStatus, LeafSystem

from tt_drake.constants import PLANES
from tt_drake.hitting_point import N_OBSERVATIONS, HittingPointGPR, PhysicalPredictor
from tt_drake.hitting_time import (
    BounceCount,
    choose_hitting_point,
    count_bounces,
    robot_bounces_by,
)
from tt_drake.wam_params import PLANNING_RATE

_OBS = 2
_OUT = 2 + 6 * N_OBSERVATIONS
#: The outputs: each a discrete-state group, the layout's slice [_OUT + lo, _OUT + hi).
_PUBLISHED = (("p_hit", 0, 3), ("v_hit", 3, 6), ("t_hit", 6, 7), ("valid", 7, 8),
              ("final", 8, 9), ("spin_hit", 9, 12))
_BALLS = _OUT + 14  # the layout's ball counter, its own group and output port
_LAYOUT = _OUT + 15
#: What the refresh returns when the rules leave the ball no hitting point.
WITHDRAW = object()

#: The state's "no bounce seen yet" (the refresh's bounce count: first bounce time, count).
_NO_BOUNCE = -1.0
# A tick that finds no new estimate changes nothing: "did nothing" tells the simulator not to
# write the unchanged state back, so the outputs' caches (and everything reading them) stay valid.
_NOTHING = EventStatus.DidNothing()


class HittingPointPredictor(LeafSystem):
    def __init__(self, gpr: HittingPointGPR | None = None,
                 physical: PhysicalPredictor | None = None, rate: float = PLANNING_RATE,
                 observation_y: float = PLANES.observation_y,
                 early: PhysicalPredictor | None = None,
                 early_tolerance: tuple[float, float] = (0.02, 0.01),
                 refresh: PhysicalPredictor | None = None,
                 refresh_tolerance: tuple[float, float] = (0.02, 0.01), play_again: bool = False,
                 band=None, refresh_ahead: bool = False):
        """``play_again`` (the rally): a valid estimate of a ball flying away (v_y > 0) drops
        the prediction and the observations (``valid`` = 0), ready for the next ball. ``band``
        (a :class:`tt_drake.hitting_time.HittingBand`): the refreshed predictions choose the
        hitting point along the path as the teacher does (:func:`tt_drake.hitting_time.
        choose_hitting_point`: the plane when it serves, else where the ball falls through the
        band's height); None: the plane crossing. ``refresh_ahead``: the ``refresh`` starts at
        the final prediction, not after the robot-side bounce (module docstring)."""
        super().__init__()
        self.band = band
        self.play_again = play_again
        self.refresh_ahead = refresh_ahead
        if gpr is None and physical is None:
            physical = PhysicalPredictor()
        self.gpr, self.physical, self.early, self.refresh = gpr, physical, early, refresh
        self.observation_y = observation_y
        self.early_tolerance = tuple(float(x) for x in early_tolerance)
        self.refresh_tolerance = tuple(float(x) for x in refresh_tolerance)
        self._state = self.DeclareVectorInputPort("state", 6)
        self._spin = self.DeclareVectorInputPort("spin", 3)
        self._status = self.DeclareVectorInputPort("status", 2)
        initial = np.zeros(_LAYOUT)
        initial[1] = -math.inf
        initial[_OUT + 12] = _NO_BOUNCE
        self._xd = self.DeclareDiscreteState(np.r_[initial[:_OUT], initial[_OUT + 12:_BALLS]])
        self._published = [self.DeclareDiscreteState(initial[_OUT + lo:_OUT + hi])
                           for _, lo, hi in _PUBLISHED]
        self._balls = self.DeclareDiscreteState(initial[_BALLS:])
        self.DeclarePeriodicDiscreteUpdateEvent(1.0 / rate, 0.0, self._update)
        for (name, _, _), group in zip(_PUBLISHED, self._published, strict=True):
            self.DeclareStateOutputPort(name, group)
        self.DeclareStateOutputPort("balls", self._balls)
        # The ball model that carries the spin to the plane when a GPR predicts.
        self._spin_model = (physical or early or refresh or PhysicalPredictor()).model
        self._plane_y = (physical or early or refresh or PhysicalPredictor()).plane_y
        self._plane_memo = None  # (model, (plane_y, state), crossing): :meth:`_plane`

    def layout(self, context) -> np.ndarray:
        """The state as one vector in the update's layout (the module's docstring)."""
        memory = context.get_discrete_state(self._xd).get_value()
        return np.concatenate([memory[:_OUT],
                               *(context.get_discrete_state(g).get_value()
                                 for g in self._published),
                               memory[_OUT:],
                               context.get_discrete_state(self._balls).get_value()])

    def _store(self, discrete_state, new: np.ndarray) -> None:
        """Write the layout ``new`` into the state's groups."""
        discrete_state.set_value(self._xd, np.r_[new[:_OUT], new[_OUT + 12:_BALLS]])
        for (_, lo, hi), group in zip(_PUBLISHED, self._published, strict=True):
            discrete_state.set_value(group, new[_OUT + lo:_OUT + hi])
        discrete_state.set_value(self._balls, new[_BALLS:])

    def _plane(self, model, state9: np.ndarray, plane_y: float):
        """``model.predict_plane(state9, plane_y)``, kept for the last (model, state, plane):
        at a tick's new estimate the early or final prediction and its check under the rules
        (:meth:`_legal`) ask for the same crossing, from the same estimate with the learned
        player's one physical model, and it is a pure function of them."""
        key = (plane_y, tuple(state9.tolist()))
        memo = self._plane_memo
        if memo is not None and memo[0] is model and memo[1] == key:
            return memo[2]
        hit = model.predict_plane(state9, plane_y)
        self._plane_memo = (model, key, hit)
        return hit

    def _crossing(self, physical: PhysicalPredictor, state9) -> np.ndarray | None:
        """``physical``'s prediction (p_hit, v_hit, time to go) with the spin at the plane
        appended; None if the model's ball never reaches the plane."""
        hit = self._plane(physical.model, state9, physical.plane_y)
        return None if hit is None else _prediction(hit)

    def predict(self, observations: np.ndarray, spin=None) -> np.ndarray | None:
        """(p_hit, v_hit, time to go) from the four observed states (4, 6); the physical model
        starts from the fourth with ``spin`` (zero if None). The GPR's features are those of
        its feature set: the states (the shipped predictor's), or the states and ``spin``."""
        if self.gpr is not None:
            return self.gpr.predict(self.gpr.features(observations, spin))
        return self.physical.predict(_with_spin(observations[-1], spin))

    def _final(self, observations: np.ndarray, spin) -> np.ndarray | None:
        """:meth:`predict` and the spin at the plane: (p_hit, v_hit, time to go, spin_hit)."""
        start = _with_spin(observations[-1], spin)
        if self.gpr is None:
            return self._crossing(self.physical, start)
        pred = self.gpr.predict(self.gpr.features(observations, spin))
        if pred is None:
            return None
        hit = self._plane(self._spin_model, start, self._plane_y)
        return np.r_[pred[:7], start[6:9] if hit is None else hit.spin]

    def _spin_value(self, context) -> np.ndarray | None:
        return self._spin.Eval(context) if self._spin.HasValue(context) else None

    def _refreshed(self, s, spin, x, t: float, bounces: int):
        """The physical prediction from an estimate after the robot-side bounce, if it moved
        more than ``refresh_tolerance`` from the published one; else None. ``bounces``: the
        ball's bounces on the robot's half so far. Returns ``WITHDRAW`` when the rules leave no
        hitting point: the ball has bounced twice on the robot's half (Law 2.10.1.3: the point
        is lost, and a player should let the ball go), or, hitting at the plane only, the model
        predicts the second bounce before the plane. A band that finds no point for one
        estimate withdraws nothing: near the band's edges that flickers with the estimate's
        noise, and the stroke planned on the last point may still return the ball."""
        if s[4] >= 0.0 or s[1] >= self.observation_y:
            return None
        if bounces >= 2:
            return WITHDRAW
        if self.band is None:
            hit = self._plane(self.refresh.model, _with_spin(s, spin), self.refresh.plane_y)
            if hit is not None and robot_bounces_by(hit, bounces) >= 2:
                return WITHDRAW
        else:
            hit = choose_hitting_point(self.refresh.model, _with_spin(s, spin),
                                       self.refresh.plane_y, self.band, bounces_behind=bounces)
        if hit is None or (hit.bounces and not self.refresh_ahead):
            return None  # the robot-side bounce is still ahead
        pred = _prediction(hit)
        # A withdrawn prediction (valid = 0) is replaced by the first legal one.
        moved = (x[_OUT + 7] == 0.0
                 or float(np.linalg.norm(pred[:3] - x[_OUT:_OUT + 3])) > self.refresh_tolerance[0]
                 or abs(t + pred[6] - x[_OUT + 6]) > self.refresh_tolerance[1])
        return pred if moved else None

    def _update(self, context, discrete_state):
        status = self._status.Eval(context)
        t = float(status[1])
        if status[0] < 0.5 or not t > context.get_discrete_state(self._xd).get_value()[1]:
            return _NOTHING
        x = self.layout(context)
        if self.play_again and self._state.Eval(context)[4] > 0.0 and (x[0] > 0 or x[_OUT + 7]):
            new = np.zeros_like(x)
            new[1] = t
            new[_OUT + 12] = _NO_BOUNCE
            new[_BALLS] = x[_BALLS] + 1.0
            self._store(discrete_state, new)
            return
        if x[_OUT + 8] == 1.0 and self.refresh is None:
            return _NOTHING  # a held final prediction: nothing to read
        s, spin = self._state.Eval(context), self._spin_value(context)
        state9 = _with_spin(s, spin)
        new = x.copy()
        new[1] = t
        if x[_OUT + 8] == 1.0:
            bounces = self._count_bounces(x, new, state9, t)
            pred = self._refreshed(s, spin, x, t, bounces)
            if pred is WITHDRAW:
                new[_OUT + 7] = 0.0  # no legal hitting point: the prediction is withdrawn
            elif pred is not None:
                _publish(new, pred, t)
            self._store(discrete_state, new)
            return
        bounces = self._count_bounces(x, new, state9, t)
        n = int(x[0])
        if s[1] < self.observation_y and s[4] < 0.0:
            new[_OBS + 6 * n:_OBS + 6 * n + 6] = s
            n += 1
        else:
            n = 0
        new[0] = n
        pred = None
        if n == N_OBSERVATIONS:
            pred = self._final(new[_OBS:_OUT].reshape(N_OBSERVATIONS, 6), spin)
            if pred is None:
                new[0] = 0
            else:
                new[_OUT + 8] = 1.0
                pred = self._legal(pred, state9, bounces)
        if pred is None and self.early is not None and s[4] < 0.0:
            pred = self._crossing(self.early, state9)
            if pred is not None:
                pred = self._legal(pred, state9, bounces)
            if (pred is not None and pred is not WITHDRAW and x[_OUT + 7] == 1.0
                    and not self._moved(x, pred, t)):
                pred = None
        if pred is WITHDRAW:
            new[_OUT + 7] = 0.0
        elif pred is not None:
            _publish(new, pred, t)
        self._store(discrete_state, new)

    def _count_bounces(self, x, new, state9, t: float) -> int:
        """The ball's bounces on the robot's half so far, counted from every estimate
        (:func:`tt_drake.hitting_time.count_bounces`) and recorded in ``new``."""
        first = x[_OUT + 12]
        count = count_bounces(self._spin_model,
                              BounceCount(None if first == _NO_BOUNCE else first,
                                          int(x[_OUT + 13])), state9, t)
        new[_OUT + 12] = _NO_BOUNCE if count.first is None else count.first
        new[_OUT + 13] = count.count
        return count.count

    def _legal(self, pred: np.ndarray, state9, bounces: int):
        """An early or final prediction under the rules (Law 2.10.1.3): ``pred`` itself when the
        ball model, from the estimate ``state9``, reaches the hitting plane before the ball's
        second bounce on the robot's half (``bounces``: those it has made); otherwise, with a
        band, the point :func:`tt_drake.hitting_time.choose_hitting_point` finds before that
        bounce, and ``WITHDRAW`` when there is none (the ball is let go)."""
        if bounces < 2:
            hit = self._plane(self._spin_model, state9, self._plane_y)
            if hit is None or robot_bounces_by(hit, bounces) < 2:
                return pred
            if self.band is not None:
                chosen = choose_hitting_point(self._spin_model, state9, self._plane_y, self.band,
                                              bounces_behind=bounces)
                if chosen is not None:
                    return _prediction(chosen)
        return WITHDRAW

    def _moved(self, x, pred, t: float) -> bool:
        """An early prediction farther than ``early_tolerance`` from the published one."""
        return (float(np.linalg.norm(pred[:3] - x[_OUT:_OUT + 3])) > self.early_tolerance[0]
                or abs(t + pred[6] - x[_OUT + 6]) > self.early_tolerance[1])


def _with_spin(state6, spin) -> np.ndarray:
    """(p, v) and the spin (zero if None) as the ball model's 9-state."""
    return np.r_[np.asarray(state6, dtype=float), np.zeros(3) if spin is None else spin]


def _prediction(hit) -> np.ndarray:
    """A crossing of the ball model as a prediction: (p_hit, v_hit, time to go, spin_hit)."""
    return np.concatenate([hit.position, hit.velocity, [hit.t], hit.spin])


def _publish(new: np.ndarray, pred: np.ndarray, t: float) -> None:
    """Write the prediction ``pred`` (time to go from the estimate's time ``t``) into the
    state ``new`` as the published one (``valid`` = 1)."""
    new[_OUT:_OUT + 6] = pred[:6]
    new[_OUT + 6] = t + pred[6]
    new[_OUT + 7] = 1.0
    new[_OUT + 9:_OUT + 12] = pred[7:10]
