"""BallCamera LeafSystem: the ball seen by a 60 Hz camera with noise, dropouts, outliers, latency.

The math is :class:`tt_drake.camera_model.CameraModel`: frame k, captured at the k-th periodic
update after the episode's reset, reports ``z_k = p(t_k) + n_k`` (Gaussian, sigma per axis), or
nothing (dropout), or a gross outlier; it is delivered ``latency_frames`` updates later.

Ports:

- input ``ball_state`` (13): the plant's state output for the ball, (quaternion wxyz, p, omega, v);
- output ``measurement`` (5): ``(x, y, z, t_capture, valid)`` of the frame delivered at the last
  update; ``valid = 0`` for a dropped frame (then x, y, z are NaN) and ``t_capture = NaN`` before
  the first delivery.

Discrete state: group 0 ``[frame counter, frames in flight (latency_frames x 5)]``, group 1 the
delivered frame (5), which the ``measurement`` output is: a Drake state output port, so the
estimator's reads are served in C++ and never call Python (docs/performance.md). The per-episode
seed is a numeric parameter (:meth:`set_seed`), as in ``BallLauncher``; all random draws of an
episode are a pure function of it.
"""

import math

import numpy as np
from pydrake.systems.framework import LeafSystem

from tt_drake.camera_model import CameraConfig, CameraModel
from tt_drake.systems.seed_parameter import SeedParameter

_NO_FRAME = (math.nan, math.nan, math.nan, math.nan, 0.0)


class BallCamera(SeedParameter, LeafSystem):
    def __init__(self, config: CameraConfig | None = None):
        super().__init__()
        self.config = config or CameraConfig()
        self.model = CameraModel(self.config)
        self._lat = self.config.latency_frames
        self._draws_cache: tuple[tuple[int, int], object] | None = None
        self._ball = self.DeclareVectorInputPort("ball_state", 13)
        self.declare_seed()
        self._xd = self.DeclareDiscreteState(np.array([0.0, *(_NO_FRAME * self._lat)]))
        self._delivered = self.DeclareDiscreteState(np.array(_NO_FRAME))
        self.DeclarePeriodicDiscreteUpdateEvent(self.config.period, 0.0, self._update)
        self.DeclareStateOutputPort("measurement", self._delivered)

    def _draws(self, seed: int, block: int):
        if self._draws_cache is None or self._draws_cache[0] != (seed, block):
            self._draws_cache = ((seed, block), self.model.block_draws(seed, block))
        return self._draws_cache[1]

    def _update(self, context, discrete_state):
        x = context.get_discrete_state(self._xd).get_value()
        k = int(x[0])
        s = self._ball.Eval(context)
        block, row = self.model.block_of(k)
        z = self.model.measure(self._draws(self.seed(context), block), row, (s[4], s[5], s[6]))
        t = context.get_time()
        frame = (*z, t, 1.0) if z is not None else (math.nan, math.nan, math.nan, t, 0.0)
        new = np.empty_like(x)
        new[0] = k + 1
        if self._lat == 0:
            delivered = frame
        else:
            delivered = x[1:6]  # the oldest frame in flight is delivered
            new[1:-5] = x[6:]
            new[-5:] = frame
        discrete_state.set_value(self._xd, new)
        discrete_state.set_value(self._delivered, delivered)
