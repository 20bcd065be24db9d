"""The stimulus the learned player's gating network (Eq. 6) and CrKR (section II-C.2) see.

The paper's stimulus is the predicted ball state at the virtual hitting plane, ``x = (p_hit,
v_hit)`` (6-D). A layout names the parts of ``x`` in order; a learned artefact records its layout
(old artefacts, which record none, are the paper's 6-D one), so that the player builds the vector
the artefact was trained on and a mismatch fails at load time:

- ``p_hit`` (3, m), ``v_hit`` (3, m/s): the predicted hitting point and ball velocity there;
- ``spin_hit`` (3, rad/s, world frame): the ball's predicted spin at the hitting plane, i.e. the
  estimator's spin carried through the bounces still ahead by the ball model (what the teacher's
  stroke assumes, and the ``spin_hit`` output of
  :class:`tt_drake.systems.hitting_point_predictor.HittingPointPredictor`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["STIMULUS_PARTS", "PAPER_STIMULUS", "SPIN_STIMULUS", "STIMULI", "stimulus_layout",
           "stimulus_size", "compose_stimulus", "describe_stimulus"]

STIMULUS_PARTS = {"p_hit": 3, "v_hit": 3, "spin_hit": 3}
PAPER_STIMULUS = ("p_hit", "v_hit")
SPIN_STIMULUS = ("p_hit", "v_hit", "spin_hit")
# Named layouts (the command line's --stimulus).
STIMULI = {"paper": PAPER_STIMULUS, "spin": SPIN_STIMULUS}


def stimulus_layout(names) -> tuple[str, ...]:
    """``names`` checked as a layout (distinct known parts, beginning with the paper's p_hit,
    v_hit: players read p_hit as the stimulus' first three values); ValueError naming the
    problem otherwise."""
    if isinstance(names, str) or not isinstance(names, list | tuple) or not names:
        raise ValueError(f"a stimulus layout is a non-empty list of parts, got {names!r}")
    layout = tuple(names)
    unknown = [n for n in layout if n not in STIMULUS_PARTS]
    if unknown or len(set(layout)) != len(layout) or layout[:2] != PAPER_STIMULUS:
        raise ValueError(f"stimulus layout {list(layout)}: parts must be distinct, among "
                         f"{', '.join(STIMULUS_PARTS)}, and begin with p_hit, v_hit")
    return layout


def stimulus_size(layout) -> int:
    return sum(STIMULUS_PARTS[n] for n in stimulus_layout(layout))


def describe_stimulus(layout) -> str:
    """E.g. ``"p_hit, v_hit (6)"``."""
    return f"{', '.join(stimulus_layout(layout))} ({stimulus_size(layout)})"


def compose_stimulus(layout, p_hit, v_hit, spin_hit=None) -> np.ndarray:
    """The stimulus vector of ``layout`` from its parts; ValueError if the layout needs the spin
    and none is given."""
    parts = {"p_hit": p_hit, "v_hit": v_hit, "spin_hit": spin_hit}
    out = []
    for name in stimulus_layout(layout):
        if parts[name] is None:
            raise ValueError(f"the stimulus needs {name}, which is not available")
        value = np.asarray(parts[name], dtype=float).reshape(-1)
        if value.shape != (STIMULUS_PARTS[name],):
            raise ValueError(f"{name} must have {STIMULUS_PARTS[name]} values, got {value.shape}")
        out.append(value)
    return np.concatenate(out)
