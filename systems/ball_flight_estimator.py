"""BallFlightEstimator LeafSystem: the EKF of :mod:`tt_drake.estimation` at the camera's rate.

At every planning tick (250 Hz, :data:`tt_drake.wam_params.PLANNING_RATE`) it reads the camera's
``measurement`` (x, y, z, t_capture, valid) and, if the frame is newer than the last one
processed (so once per 60 Hz frame, at the first tick after it), runs one filter step at
``t_capture``:
predict with the ball model (bounce included) and, unless the frame was dropped, gate and fuse the
position. A tick without a new frame returns "did nothing" (``EventStatus.DidNothing``): the
simulator then leaves the state, and the caches of everything reading the outputs, as they are.
The complete filter state is the system's discrete state
(:meth:`BallFlightEKF.to_vector`, group 0), so contexts clone and replay exactly.

Every output is a discrete-state group of its own that the update writes beside the filter's
vector, and a Drake state output port: a read (the predictor's at every planning tick, the
players', a logger's) is served in C++ from the context and never calls Python
(docs/performance.md). The groups are a function of the filter's vector (:func:`published`).

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
#: The outputs, in their order: each a discrete-state group (:func:`published`).
OUTPUTS = ("state", "spin", "covariance", "spin_covariance", "status")


def published(x: np.ndarray) -> tuple[np.ndarray, ...]:
    """The outputs (:data:`OUTPUTS`) of the filter's vector ``x``: (p, v) and the spin while
    tracking (zeros otherwise), the covariances of (p, v) and of the spin (row-major), and
    ``(valid, t_state)``."""
    tracking = x[0] == 1.0
    state = x[_X]
    cov = x[_P].reshape(N_STATE, N_STATE)
    return (state[0:6] if tracking else np.zeros(6), state[6:9] if tracking else np.zeros(3),
            cov[0:6, 0:6].ravel(), cov[6:9, 6:9].ravel(),
            np.array([1.0 if tracking else 0.0, x[1]]))


class BallFlightEstimator(LeafSystem):
    def __init__(self, config: EstimatorConfig | None = None, rate: float = PLANNING_RATE):
        super().__init__()
        self.config = config or EstimatorConfig()
        self._ekf = BallFlightEKF(self.config)  # scratch: loaded from / stored to the state
        self._u = self.DeclareVectorInputPort("measurement", 5)
        x0 = self._ekf.to_vector()
        self._xd = self.DeclareDiscreteState(x0)
        self._published = [self.DeclareDiscreteState(value) for value in published(x0)]
        self.DeclarePeriodicDiscreteUpdateEvent(1.0 / rate, 0.0, self._update)
        for name, group in zip(OUTPUTS, self._published, strict=True):
            self.DeclareStateOutputPort(name, group)

    def _update(self, context, discrete_state):
        u = self._u.Eval(context)
        t = float(u[3])
        x = context.get_discrete_state(self._xd).get_value()
        if math.isnan(t) or not t > x[-1]:  # no frame yet, or processed (last_frame_t)
            return _NOTHING  # the state is not written: nothing downstream is recomputed
        ekf = self._ekf
        ekf.load_vector(x)
        ekf.step(t, np.array(u[0:3]) if u[4] > 0.5 else None)
        x = ekf.to_vector()
        discrete_state.set_value(self._xd, x)
        for group, value in zip(self._published, published(x), strict=True):
            discrete_state.set_value(group, value)
