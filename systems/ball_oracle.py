"""BallOracle LeafSystem: the simulator's true ball state, at the camera's frames, with no noise.

The ``oracle`` perception (``Scenario.perception``) stands where the camera and the
ball-flight estimator stand, with the estimator's output ports, so a player cannot tell them
apart except by the quality of what it sees. It defines what is physically returnable from the
robot's mount: the oracle analytical player's legal returns (docs/serves.md, "Returnable
ceiling").

Timing is the camera's and the estimator's: frame k is captured at ``t_k = k / rate`` (the
camera's 60 Hz periodic update) and delivered at the first planning tick (250 Hz) after it,
where the estimator would have processed it. Both are periodic discrete updates; an update reads
the state from before the updates of that instant, so a frame captured at a tick is delivered at
the next one, as a camera frame reaches the estimator.

Ports:

- input ``ball_state`` (13): the plant's state output for the ball, (quaternion wxyz, p, omega, v),
  omega in the world frame;
- output ``state`` (6): the true (p, v) at the delivered frame's capture time ``status[1]``
  (zeros before the first frame);
- output ``spin`` (3): the true angular velocity omega (rad/s, world frame) at that time;
- output ``covariance`` (36): zeros (the state is exact);
- output ``status`` (2): ``(valid, t_state)``; valid = 1 from the first delivered frame on.

Discrete state: ``[captured (11), delivered (11)]``, each ``(valid, t, p, v, omega)``.
"""

import numpy as np
from pydrake.systems.framework import LeafSystem

from tt_drake.camera_model import CameraConfig
from tt_drake.wam_params import PLANNING_RATE

#: What a player may see: ``Scenario.perception``.
PERCEPTIONS = ("camera", "oracle")

_FRAME = 11  # valid, t, p (3), v (3), omega (3)


class BallOracle(LeafSystem):
    def __init__(self, rate: float = CameraConfig().rate, planning_rate: float = PLANNING_RATE):
        super().__init__()
        self._ball = self.DeclareVectorInputPort("ball_state", 13)
        self._xd = self.DeclareDiscreteState(np.zeros(2 * _FRAME))
        self.DeclarePeriodicDiscreteUpdateEvent(1.0 / rate, 0.0, self._capture)
        self.DeclarePeriodicDiscreteUpdateEvent(1.0 / planning_rate, 0.0, self._deliver)
        deps = {self.xd_ticket()}
        self.DeclareVectorOutputPort("state", 6, self._calc_state, prerequisites_of_calc=deps)
        self.DeclareVectorOutputPort("spin", 3, self._calc_spin, prerequisites_of_calc=deps)
        self.DeclareVectorOutputPort("covariance", 36, lambda _c, out: out.SetFromVector(
            np.zeros(36)), prerequisites_of_calc={self.nothing_ticket()})
        self.DeclareVectorOutputPort("status", 2, self._calc_status, prerequisites_of_calc=deps)

    def _capture(self, context, discrete_state):
        s = self._ball.Eval(context)
        frame = np.r_[1.0, context.get_time(), s[4:7], s[10:13], s[7:10]]
        x = discrete_state.get_mutable_value(self._xd)
        x[:_FRAME] = frame

    def _deliver(self, context, discrete_state):
        captured = context.get_discrete_state(self._xd).get_value()[:_FRAME]
        x = discrete_state.get_mutable_value(self._xd)
        x[_FRAME:] = captured

    def _delivered(self, context) -> np.ndarray:
        return context.get_discrete_state(self._xd).get_value()[_FRAME:]

    def _calc_state(self, context, output):
        output.SetFromVector(self._delivered(context)[2:8])

    def _calc_spin(self, context, output):
        output.SetFromVector(self._delivered(context)[8:11])

    def _calc_status(self, context, output):
        output.SetFromVector(self._delivered(context)[0:2])
