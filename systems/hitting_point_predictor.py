"""HittingPointPredictor LeafSystem: p_hit, v_hit and t_hit from four observations after plane s.

Every camera period (two thirds of a period after the camera's update) it reads the estimator's
``state`` and ``status``. Each new valid estimate with ``p_y < observation_y`` and ``v_y < 0``
(past the virtual plane s, moving toward the robot) is collected; a non-qualifying one restarts the
count. At the fourth consecutive one it predicts once, with the GPR
(:class:`tt_drake.hitting_point.HittingPointGPR`, features = the four states) or the physical
model (:class:`tt_drake.hitting_point.PhysicalPredictor`, from the fourth state), and holds it.

Ports:

- inputs ``state`` (6) and ``status`` (2: valid, t_state) from ``BallFlightEstimator``;
- outputs ``p_hit`` (3), ``v_hit`` (3), ``t_hit`` (1) and ``valid`` (1). ``t_hit`` is an
  **absolute** simulation time: the fourth observation's capture time plus the predicted time to
  go (the regressors learn the time to go, which does not depend on the episode's clock).

Discrete state: ``[n_collected, last_t, observations (4 x 6), p_hit (3), v_hit (3), t_hit,
valid]``; outputs copy slices of it.
"""

import math

import numpy as np
from pydrake.systems.framework import LeafSystem

from tt_drake.constants import PLANES
from tt_drake.hitting_point import N_OBSERVATIONS, HittingPointGPR, PhysicalPredictor

_OBS = 2
_OUT = 2 + 6 * N_OBSERVATIONS


class HittingPointPredictor(LeafSystem):
    def __init__(self, gpr: HittingPointGPR | None = None,
                 physical: PhysicalPredictor | None = None, rate: float = 60.0,
                 observation_y: float = PLANES.observation_y):
        super().__init__()
        if gpr is None and physical is None:
            physical = PhysicalPredictor()
        self.gpr, self.physical = gpr, physical
        self.observation_y = observation_y
        self._state = self.DeclareVectorInputPort("state", 6)
        self._status = self.DeclareVectorInputPort("status", 2)
        initial = np.zeros(_OUT + 8)
        initial[1] = -math.inf
        self._xd = self.DeclareDiscreteState(initial)
        period = 1.0 / rate
        self.DeclarePeriodicDiscreteUpdateEvent(period, 2.0 * period / 3.0, self._update)
        deps = {self.xd_ticket()}
        self.DeclareVectorOutputPort("p_hit", 3, self._calc(_OUT, _OUT + 3),
                                     prerequisites_of_calc=deps)
        self.DeclareVectorOutputPort("v_hit", 3, self._calc(_OUT + 3, _OUT + 6),
                                     prerequisites_of_calc=deps)
        self.DeclareVectorOutputPort("t_hit", 1, self._calc(_OUT + 6, _OUT + 7),
                                     prerequisites_of_calc=deps)
        self.DeclareVectorOutputPort("valid", 1, self._calc(_OUT + 7, _OUT + 8),
                                     prerequisites_of_calc=deps)

    def _calc(self, lo, hi):
        def calc(context, output):
            output.SetFromVector(context.get_discrete_state(self._xd).get_value()[lo:hi])

        return calc

    def predict(self, observations: np.ndarray) -> np.ndarray | None:
        """(p_hit, v_hit, time to go) from the four observed states (4, 6)."""
        if self.gpr is not None:
            return self.gpr.predict(observations.reshape(-1))
        return self.physical.predict(observations[-1])

    def _update(self, context, discrete_state):
        status = self._status.Eval(context)
        x = context.get_discrete_state(self._xd).get_value()
        t = float(status[1])
        if status[0] < 0.5 or not t > x[1] or x[_OUT + 7] == 1.0:
            return
        new = x.copy()
        new[1] = t
        s = self._state.Eval(context)
        n = int(x[0])
        if s[1] < self.observation_y and s[4] < 0.0:
            new[_OBS + 6 * n:_OBS + 6 * n + 6] = s
            n += 1
        else:
            n = 0
        new[0] = n
        if n == N_OBSERVATIONS:
            pred = self.predict(new[_OBS:_OUT].reshape(N_OBSERVATIONS, 6))
            if pred is None:
                new[0] = 0
            else:
                new[_OUT:_OUT + 6] = pred[:6]
                new[_OUT + 6] = t + pred[6]
                new[_OUT + 7] = 1.0
        discrete_state.set_value(self._xd, new)
