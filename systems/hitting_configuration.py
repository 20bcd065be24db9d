"""HittingConfiguration LeafSystem: the hitting configuration (theta_hit, theta_dot_hit) for the
predicted stimulus (paper section II-C.2).

Two sources, chosen at construction:

- ``"crkr"`` (default): the cost-regularised kernel regression mean
  ``y(s) = y_mean + k(s)^T (K + lambda C)^-1 (Y - y_mean)`` of
  :class:`tt_drake.learned_player.ConfigurationModel`, with s = (p_hit, v_hit), trained by
  ``tt-drake train crkr`` on the teacher's successful strokes;
- ``"analytical"``: the teacher's aim + racket law + IK
  (:meth:`tt_drake.systems.analytical_player.StrokePlanner.stroke`) on the same predicted stimulus.
  The ball is taken as spinless here (the teacher itself uses the spin its physical model gives
  the bounce; this is a documented difference, kept so that the paper profile's row is unchanged,
  although the predictor's ``spin_hit`` would now give it).

The CrKR stimulus is the model's layout (:mod:`tt_drake.stimulus`, recorded in its artefact):
(p_hit, v_hit), or with the predicted spin at impact ``spin_hit`` appended.

Ports: inputs ``p_hit`` (3), ``v_hit`` (3), ``t_hit`` (1, absolute), ``valid`` (1) and
``spin_hit`` (3, read only by a CrKR model whose stimulus has the spin) from
:class:`tt_drake.systems.hitting_point_predictor.HittingPointPredictor`; outputs ``theta_hit``
(7), ``theta_dot_hit`` (7) and ``valid`` (1). It has no state: the outputs are a function of the
inputs, cached by Drake until the predictor publishes another prediction, and solved once per
prediction (the three ports share one solution), so a player reads the configuration of the
prediction it reads, at the same tick.
"""

import numpy as np
from pydrake.systems.framework import LeafSystem

from tt_drake.learned_player import ConfigurationModel
from tt_drake.stimulus import PAPER_STIMULUS, compose_stimulus

SOURCES = ("crkr", "analytical")
_NO_ANSWER = np.zeros(15)


class HittingConfiguration(LeafSystem):
    def __init__(self, source: str = "crkr", model: ConfigurationModel | None = None,
                 planner=None):
        super().__init__()
        if source not in SOURCES:
            raise ValueError(f"unknown hitting-configuration source {source!r}; "
                             f"choose one of {', '.join(SOURCES)}")
        if source == "crkr" and model is None:
            raise ValueError("the crkr source needs a trained ConfigurationModel")
        if source == "analytical" and planner is None:
            from tt_drake.systems.analytical_player import StrokePlanner

            planner = StrokePlanner()
        self.source, self.model, self.planner = source, model, planner
        self._p = self.DeclareVectorInputPort("p_hit", 3)
        self._v = self.DeclareVectorInputPort("v_hit", 3)
        self._t = self.DeclareVectorInputPort("t_hit", 1)
        self._valid = self.DeclareVectorInputPort("valid", 1)
        self._spin = self.DeclareVectorInputPort("spin_hit", 3)
        self._layout = getattr(model, "stimulus", PAPER_STIMULUS)
        self._uses_spin = source == "crkr" and "spin_hit" in self._layout
        self._memo: tuple = (None, _NO_ANSWER)  # (stimulus, answer): a pure function's cache
        deps = {self.all_input_ports_ticket()}
        for name, lo, hi in (("theta_hit", 0, 7), ("theta_dot_hit", 7, 14), ("valid", 14, 15)):
            self.DeclareVectorOutputPort(name, hi - lo, self._copy(lo, hi),
                                         prerequisites_of_calc=deps)

    def _copy(self, lo, hi):
        def calc(context, output):
            output.SetFromVector(self._answer(context)[lo:hi])

        return calc

    def solve(self, p_hit, v_hit, t_hit, spin_hit=None):
        """(theta_hit, theta_dot_hit) or None if the source has no answer (IK failed)."""
        if self.source == "crkr":
            s = compose_stimulus(self._layout, p_hit, v_hit, spin_hit)
            q, qd, _ = self.model.predict(s, variance=False)
            return q, qd
        stroke = self.planner.stroke(p_hit, v_hit, t_hit, np.zeros(3), None)
        return None if stroke is None else (stroke.q_hit, stroke.qd_hit)

    def _answer(self, context) -> np.ndarray:
        """``[theta_hit (7), theta_dot_hit (7), valid]`` for the inputs' prediction."""
        if self._valid.Eval(context)[0] < 0.5:
            return _NO_ANSWER
        stimulus = (*self._p.Eval(context), *self._v.Eval(context), self._t.Eval(context)[0])
        if self._uses_spin:
            stimulus += tuple(self._spin.Eval(context)) if self._spin.HasValue(context) else ()
        if stimulus == self._memo[0]:
            return self._memo[1]
        solved = self.solve(np.array(stimulus[:3]), np.array(stimulus[3:6]), stimulus[6],
                            np.array(stimulus[7:10]) if len(stimulus) == 10 else None)
        answer = _NO_ANSWER if solved is None else np.r_[solved[0], solved[1], 1.0]
        self._memo = (stimulus, answer)
        return answer
