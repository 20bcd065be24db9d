"""HittingConfiguration LeafSystem: the hitting configuration (theta_hit, theta_dot_hit) for the
predicted stimulus (paper section II-C.2).

Two sources, chosen at construction:

- ``"crkr"`` (default): the cost-regularised kernel regression mean
  ``y(s) = y_mean + k(s)^T (K + lambda C)^-1 (Y - y_mean)`` of
  :class:`tt_drake.learned_player.ConfigurationModel`, with s = (p_hit, v_hit), trained by
  ``tt-drake train crkr`` on the teacher's successful strokes;
- ``"analytical"``: the teacher's aim + racket law + IK
  (:meth:`tt_drake.systems.analytical_player.StrokePlanner.stroke`) on the same predicted stimulus.
  By default the ball is taken as spinless here, so that the paper profile's row is unchanged.
  With ``use_spin`` (the hard protocol's player, ``LearnedPlayerConfig.moving_goal``) the
  predictor's ``spin_hit`` is given to the aim (the Magnus force of the return flight) and to the
  racket law (the racket's tangential velocity matches the spinning ball's contact point), as the
  teacher does: a spinless aim on `spin` serves scattered the learned player's landings by 28 cm
  laterally (docs/learned_player.md, "Why the hard player's returns scatter"). Matching a
  spinning ball's contact point can ask the racket for 2-3 m/s more, which a late move of the
  moving goal may not fit into the effort budget: ``theta_dot_hit_spinless`` is then the same
  racket without that tangential term (the joint velocities at theta_hit for the racket velocity
  minus the tangential part of omega x (-R n)), which the player tries when the move to
  (theta_hit, theta_dot_hit) is refused: a return that lands off target rather than a miss.
  When no spin-aware stroke is within the arm's reach and joint speeds, the configuration is the
  spinless one (both velocity outputs equal). ``fallback_strokes`` offers the teacher's other
  strokes for the same prediction (:meth:`StrokePlanner.strokes`: less of the spin compensated,
  the ball met off the blade's centre), solved only as far as a player reads them.

With ``aims`` (the rally's competitive aim, ``analytical`` source only) each ball's stroke plays
its drawn aim as the analytical player does (:class:`tt_drake.systems.analytical_player.
StrokeAims`): the ball's index is the predictor's ``balls`` input and the draws' seed the rally
seed (:meth:`HittingConfiguration.set_seed`); when no drawn aim serves, the planner's own aim.

The CrKR stimulus is the model's layout (:mod:`tt_drake.stimulus`, recorded in its artefact):
(p_hit, v_hit), or with the predicted spin at impact ``spin_hit`` appended.

Ports: inputs ``p_hit`` (3), ``v_hit`` (3), ``t_hit`` (1, absolute), ``valid`` (1),
``spin_hit`` (3, read only by a CrKR model whose stimulus has the spin) and ``balls`` (1, read
only with ``aims``) from
:class:`tt_drake.systems.hitting_point_predictor.HittingPointPredictor`; outputs ``theta_hit``
(7), ``theta_dot_hit`` (7), ``valid`` (1) and ``theta_dot_hit_spinless`` (7: ``theta_dot_hit``
unless ``use_spin``) and ``fallback_strokes`` (abstract: a :class:`FallbackStrokes`, empty for
the ``crkr`` source). It has no state: the outputs are a function of the inputs (and, with
``aims``, of the seed parameter), cached by Drake until the predictor publishes another
prediction, and solved once per prediction (the three ports share one solution), so a player
reads the configuration of the prediction it reads, at the same tick.
"""

from collections.abc import Iterator

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import LeafSystem

from tt_drake.learned_player import ConfigurationModel
from tt_drake.racket_law import racket_for_return
from tt_drake.rally_aim import CompetitiveAim
from tt_drake.stimulus import PAPER_STIMULUS, compose_stimulus
from tt_drake.systems.analytical_player import StrokeAims, StrokePlanner
from tt_drake.systems.seed_parameter import SeedParameter

SOURCES = ("crkr", "analytical")
_NO_ANSWER = np.zeros(22)


class FallbackStrokes:
    """The teacher's strokes for one prediction, in its fallbacks' order
    (:meth:`StrokePlanner.strokes`: each share of the predicted spin compensated with each
    blade offset, then the reach points), as (theta_hit, theta_dot_hit) pairs. Solved lazily:
    iterating solves each stroke once, the first time any iteration reaches it, and a caller
    that stops at the first stroke it accepts solves no more. Empty without a planner."""

    def __init__(self, planner: StrokePlanner | None = None, p_hit=None, v_hit=None,
                 t_hit: float = 0.0, spin_hit=None):
        self._solved: list[tuple[np.ndarray, np.ndarray]] = []
        self._pending = (None if planner is None
                         else planner.strokes(p_hit, v_hit, t_hit, spin_hit, None))

    def __iter__(self) -> Iterator[tuple[np.ndarray, np.ndarray]]:
        i = 0
        while True:
            if i == len(self._solved):
                stroke = None if self._pending is None else next(self._pending, None)
                if stroke is None:
                    self._pending = None
                    return
                self._solved.append((stroke.q_hit, stroke.qd_hit))
            yield self._solved[i]
            i += 1

    def __deepcopy__(self, memo) -> "FallbackStrokes":
        # A pure function of one prediction, and a generator cannot be copied: a cloned context
        # shares it.
        return self


class HittingConfiguration(SeedParameter, LeafSystem):
    def __init__(self, source: str = "crkr", model: ConfigurationModel | None = None,
                 planner=None, use_spin: bool = False):
        super().__init__()
        if source not in SOURCES:
            raise ValueError(f"unknown hitting-configuration source {source!r}; "
                             f"choose one of {', '.join(SOURCES)}")
        if source == "crkr" and model is None:
            raise ValueError("the crkr source needs a trained ConfigurationModel")
        if source == "analytical" and planner is None:
            planner = StrokePlanner()
        self.source, self.model, self.planner = source, model, planner
        self._p = self.DeclareVectorInputPort("p_hit", 3)
        self._v = self.DeclareVectorInputPort("v_hit", 3)
        self._t = self.DeclareVectorInputPort("t_hit", 1)
        self._valid = self.DeclareVectorInputPort("valid", 1)
        self._spin = self.DeclareVectorInputPort("spin_hit", 3)
        self._balls = self.DeclareVectorInputPort("balls", 1)
        self.declare_seed()  # the rally's seed, from which the per-stroke aims are drawn
        self._aims: StrokeAims | None = None
        self._layout = getattr(model, "stimulus", PAPER_STIMULUS)
        self._uses_spin = (source == "crkr" and "spin_hit" in self._layout) or (
            source == "analytical" and use_spin)
        # ((stimulus, ball), answer): a pure function's cache
        self._memo: tuple = (None, _NO_ANSWER)
        # The seed is a parameter: a competitive stroke's aim depends on it.
        deps = {self.all_input_ports_ticket(), self.all_parameters_ticket()}
        for name, lo, hi in (("theta_hit", 0, 7), ("theta_dot_hit", 7, 14), ("valid", 14, 15),
                             ("theta_dot_hit_spinless", 15, 22)):
            self.DeclareVectorOutputPort(name, hi - lo, self._copy(lo, hi),
                                         prerequisites_of_calc=deps)
        self.DeclareAbstractOutputPort("fallback_strokes",
                                       lambda: AbstractValue.Make(FallbackStrokes()),
                                       self._fallbacks, prerequisites_of_calc=deps)

    def _copy(self, lo, hi):
        def calc(context, output):
            output.SetFromVector(self._answer(context)[lo:hi])

        return calc

    def _fallbacks(self, context, output) -> None:
        """``fallback_strokes``: the planner's strokes for the inputs' prediction, unsolved until
        read (none for the ``crkr`` source or without a valid prediction)."""
        stimulus = None if self.source != "analytical" else self._stimulus(context)
        if stimulus is None:
            output.set_value(FallbackStrokes())
            return
        spin = np.array(stimulus[7:10]) if len(stimulus) == 10 else np.zeros(3)
        output.set_value(FallbackStrokes(self.planner, np.array(stimulus[:3]),
                                         np.array(stimulus[3:6]), float(stimulus[6]), spin))

    @property
    def aims(self) -> CompetitiveAim | None:
        """The competitive aim's settings (module docstring); None: the planner's aim."""
        return None if self._aims is None else self._aims.aims

    @aims.setter
    def aims(self, aims: CompetitiveAim | None) -> None:
        if aims is not None and not self.takes_aims:
            raise ValueError("per-stroke aims need the analytical hitting configuration")
        self._aims = None if aims is None else StrokeAims(self.planner, aims)

    @property
    def takes_aims(self) -> bool:
        """Whether the source can play per-stroke aims (the analytical one; a CrKR model
        answers for the aim it learned)."""
        return self.source == "analytical"

    @property
    def uses_spin(self) -> bool:
        """Whether the answer depends on the ``spin_hit`` input."""
        return self._uses_spin

    def solve(self, p_hit, v_hit, t_hit, spin_hit=None, ball: tuple[int, int] | None = None):
        """(theta_hit, theta_dot_hit, theta_dot_hit_spinless) or None if the source has no
        answer (IK failed). ``ball``: (seed, ball index) of a competitive stroke, whose aim
        is tried first (module docstring)."""
        if self.source == "crkr":
            s = compose_stimulus(self._layout, p_hit, v_hit, spin_hit)
            q, qd, _ = self.model.predict(s, variance=False)
            return q, qd, qd
        spin = np.zeros(3) if spin_hit is None else np.asarray(spin_hit, dtype=float)
        if self._aims is not None and ball is not None:
            found = self._aims.stroke(*ball, p_hit, v_hit, t_hit, spin)
            if found is not None:  # a brushed stroke: no spinless variant
                return found.q_hit, found.qd_hit, found.qd_hit
        stroke = self.planner.stroke(p_hit, v_hit, t_hit, spin, None)
        if stroke is None and np.any(spin):
            # No racket that follows the spinning contact point is within the arm's reach or
            # joint speeds (low real serves with 100+ rad/s of topspin): the spinless one.
            spin = np.zeros(3)
            stroke = self.planner.stroke(p_hit, v_hit, t_hit, spin, None)
        if stroke is None:
            return None
        if not np.any(spin):
            return stroke.q_hit, stroke.qd_hit, stroke.qd_hit
        # The racket law for the same outgoing velocity without the spinning contact point's
        # tangential term (the normal does not depend on the spin).
        velocity = racket_for_return(v_hit, stroke.v_out).velocity
        return (stroke.q_hit, stroke.qd_hit,
                self.planner.hit_velocities(stroke.q_hit, velocity))

    def _stimulus(self, context) -> tuple | None:
        """The inputs' prediction ``(p_hit, v_hit, t_hit[, spin_hit])`` as a tuple (the spin
        when the source uses it and the input is connected); None without a valid one."""
        if self._valid.Eval(context)[0] < 0.5:
            return None
        stimulus = (*self._p.Eval(context), *self._v.Eval(context), self._t.Eval(context)[0])
        if self._uses_spin and self._spin.HasValue(context):
            stimulus += tuple(self._spin.Eval(context))
        return stimulus

    def _answer(self, context) -> np.ndarray:
        """``[theta_hit (7), theta_dot_hit (7), valid, theta_dot_hit_spinless (7)]`` for the
        inputs' prediction."""
        stimulus = self._stimulus(context)
        if stimulus is None:
            return _NO_ANSWER
        ball = None
        if self._aims is not None and self._balls.HasValue(context):
            ball = (self.seed(context), int(self._balls.Eval(context)[0]))
        if (stimulus, ball) == self._memo[0]:
            return self._memo[1]
        solved = self.solve(np.array(stimulus[:3]), np.array(stimulus[3:6]), stimulus[6],
                            np.array(stimulus[7:10]) if len(stimulus) == 10 else None, ball)
        answer = (_NO_ANSWER if solved is None
                  else np.r_[solved[0], solved[1], 1.0, solved[2]])
        self._memo = ((stimulus, ball), answer)
        return answer
