"""BallFlightEstimator LeafSystem: the EKF of :mod:`tt_drake.estimation` at the camera's rate.

At every planning tick (250 Hz, :data:`tt_drake.wam_params.PLANNING_RATE`) it reads the camera's
``measurement`` (x, y, z, t_capture, valid) and, if the frame is newer than the last one
processed (so once per 60 Hz frame, at the first tick after it), runs one filter step at
``t_capture``:
predict with the ball model (bounce included) and, unless the frame was dropped, gate and fuse the
position. A tick without a new frame returns "did nothing" (``EventStatus.DidNothing``): the
simulator then leaves the state, and the caches of everything reading the outputs, as they are.
The complete filter state is the system's discrete state
(:meth:`BallFlightEKF.to_vector`), so contexts clone and replay exactly.

Ports:

- input ``measurement`` (5): from ``BallCamera``;
- output ``state`` (6): estimated (p, v) at ``status[1]`` (zeros while not tracking);
- output ``spin`` (3): estimated spin omega (rad/s, world frame) at the same time (zeros while
  not tracking);
- output ``covariance`` (36): the covariance of (p, v), row-major 6 x 6;
- output ``spin_covariance`` (9): the spin's covariance, row-major 3 x 3;
- output ``status`` (2): ``(valid, t_state)``; valid = 1 while the filter is tracking.
"""

import math

import numpy as np
from pydrake.systems.framework import EventStatus, LeafSystem

from tt_drake.estimation import N_STATE, BallFlightEKF, EstimatorConfig
from tt_drake.wam_params import PLANNING_RATE

_X = BallFlightEKF.STATE_SLICE
_P = BallFlightEKF.COVARIANCE_SLICE
# A tick without a new frame changes nothing: returning "did nothing" tells the simulator not to
# write the (unchanged) state back, so the caches of everything downstream stay valid.
_NOTHING = EventStatus.DidNothing()


class BallFlightEstimator(LeafSystem):
    def __init__(self, config: EstimatorConfig | None = None, rate: float = PLANNING_RATE):
        super().__init__()
        self.config = config or EstimatorConfig()
        self._ekf = BallFlightEKF(self.config)  # scratch: loaded from / stored to the state
        self._u = self.DeclareVectorInputPort("measurement", 5)
        self._xd = self.DeclareDiscreteState(self._ekf.to_vector())
        self.DeclarePeriodicDiscreteUpdateEvent(1.0 / rate, 0.0, self._update)
        deps = {self.xd_ticket()}
        self.DeclareVectorOutputPort("state", 6, self._calc_state, prerequisites_of_calc=deps)
        self.DeclareVectorOutputPort("spin", 3, self._calc_spin, prerequisites_of_calc=deps)
        self.DeclareVectorOutputPort("covariance", 36, self._calc_cov, prerequisites_of_calc=deps)
        self.DeclareVectorOutputPort("spin_covariance", 9, self._calc_spin_cov,
                                     prerequisites_of_calc=deps)
        self.DeclareVectorOutputPort("status", 2, self._calc_status, prerequisites_of_calc=deps)

    def _update(self, context, discrete_state):
        u = self._u.Eval(context)
        t = float(u[3])
        x = context.get_discrete_state(self._xd).get_value()
        if math.isnan(t) or not t > x[-1]:  # no frame yet, or processed (last_frame_t)
            return _NOTHING  # the state is not written: nothing downstream is recomputed
        ekf = self._ekf
        ekf.load_vector(x)
        ekf.step(t, np.array(u[0:3]) if u[4] > 0.5 else None)
        discrete_state.set_value(self._xd, ekf.to_vector())

    def _calc_state(self, context, output):
        x = context.get_discrete_state(self._xd).get_value()
        output.SetFromVector(x[_X][0:6] if x[0] == 1.0 else np.zeros(6))

    def _calc_spin(self, context, output):
        x = context.get_discrete_state(self._xd).get_value()
        output.SetFromVector(x[_X][6:9] if x[0] == 1.0 else np.zeros(3))

    def _covariance(self, context) -> np.ndarray:
        x = context.get_discrete_state(self._xd).get_value()
        return x[_P].reshape(N_STATE, N_STATE)

    def _calc_cov(self, context, output):
        output.SetFromVector(self._covariance(context)[0:6, 0:6].ravel())

    def _calc_spin_cov(self, context, output):
        output.SetFromVector(self._covariance(context)[6:9, 6:9].ravel())

    def _calc_status(self, context, output):
        x = context.get_discrete_state(self._xd).get_value()
        output.SetFromVector([1.0 if x[0] == 1.0 else 0.0, x[1]])
