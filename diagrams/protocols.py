"""What a ``tt-drake reproduce`` run is made of: its stages in order, its protocols (which
serves it learns from and is judged on) and the rates every stage reports. The run
(:mod:`tt_drake.diagrams.reproduce`) and its report (:mod:`tt_drake.diagrams.report`) share them.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from types import SimpleNamespace

from tt_drake.diagrams.train import HARD_PROFILE, STIFF_HARD_PROFILE

#: The stages, in the order a run plays them (the module docstring of
#: :mod:`tt_drake.diagrams.reproduce` says what each does).
STAGES = ("teacher", "predictor", "library", "crkr", "single", "gamma1", "responsibility",
          "power", "final")


@dataclass(frozen=True)
class Protocol:
    """Which serves a run learns from and is judged on.

    ``train``: the distributions of the teacher's demonstrations and of every learning stage's
    rollouts (their serves split evenly among them); ``evaluate``: (label, distribution) of the
    ``final`` stage's two serve sets, with ``final_serves`` / ``final_seed`` and ``real_serves``
    / ``real_seed``; ``ceiling``: also play every evaluation serve with the oracle teacher
    (``serve --ceiling``) and give each figure relative to its returnable serves; ``gamma1`` on
    the evaluation serves instead of its own, so that before and after learning are compared on
    the same serves; ``ceiling_sets``: the evaluation sets (labels) the ``final`` stage also
    plays with the oracle teacher when ``ceiling`` is off (the paper profile's real serves: a
    real-serve rate comes with what could be returned from our mount)."""

    name: str
    train: tuple[str, ...]
    evaluate: tuple[tuple[str, str], tuple[str, str]]
    ceiling: bool = False
    ceiling_sets: tuple[str, ...] = ()
    # The library's settings (``tt_drake.diagrams.train.library_options``); empty: the paper's.
    library: tuple[tuple[str, object], ...] = ()
    # The GPR's feature set (``tt_drake.hitting_point``), trained on the ``train`` mix when not
    # the paper's ``states`` (the paper's predictor learns from default serves only).
    predictor_features: str = "states"
    # The momp player's hitting DMP follows each new prediction until the cut-off (the moving
    # goal, ``LearnedPlayerConfig.moving_goal``); the paper profile commits at the swing start.
    moving_goal: bool = False
    # The hitting configuration the momp player of the ``single``, ``gamma1``, ``responsibility``,
    # ``power`` and ``final`` stages uses (``LearnedPlayerConfig.configuration``): ``crkr`` (the
    # paper's) or ``analytical`` (the teacher's IK). The ``crkr`` stage trains and judges CrKR
    # either way; the paper profile's ``gamma1`` plays both.
    configuration: str = "crkr"
    # What the teacher sees while it demonstrates (``Scenario.perception``). Through the camera
    # the spin-aware EKF's spin at impact is noisy (median 13.7 rad/s between nearest-neighbour
    # stimuli vs 4.4 for the oracle), the teacher's racket law turns it into hitting velocities
    # that the paper's 6-D stimulus cannot explain, and CrKR and the library learn that noise
    # (docs/reproducing.md, "The teacher's perception"). The players always see the camera.
    teacher_perception: str = "camera"

    def library_settings(self, config):
        """The settings the library and CrKR stages read: the protocol's, else ``config``'s."""
        return SimpleNamespace(**{**config.to_dict(), **dict(self.library)}) if self.library \
            else config


PROTOCOLS = {
    # The paper's experiments, on the default launcher (the earlier runs' settings).
    # Its teacher demonstrates with the oracle's perception, as a human teacher sees the ball.
    "paper": Protocol("paper", ("default",), (("default", "default"), ("real", "real")),
                      ceiling_sets=("real",), teacher_perception="oracle"),
    # Learning has to do something: spinning launcher serves and recorded real serves and rally
    # balls to learn from, unseen spin seeds and the real serves' test split to be judged on.
    # Its library imitates the arm's recorded strokes with softer DMPs (the weights decide the
    # impact), gates and configures on the spin too; its GPR reads the estimated spin. Its player
    # takes the teacher's IK as the hitting configuration, as the shipped hard set does
    # (tt_drake.models.ARTEFACT_SETS): with the spin stimulus its CrKR returned 11 of 20 real
    # serves where the IK returned 20 (docs/learned_player.md); CrKR is still trained and
    # reported.
    "hard": Protocol("hard", ("spin", "real-train", "rally-train"),
                     (("spin", "spin"), ("real-test", "real-test")), ceiling=True,
                     library=tuple(HARD_PROFILE.items()), predictor_features="states+spin",
                     moving_goal=True, configuration="analytical"),
}
# The hard protocol with the stiffer hitting DMP that made the shipped hard set
# (``--protocol hard-stiff --sizes artefacts --until crkr``): the same serves, stages and player.
PROTOCOLS["hard-stiff"] = replace(PROTOCOLS["hard"], name="hard-stiff",
                                  library=tuple(STIFF_HARD_PROFILE.items()))


def rates(episodes: list[dict]) -> dict:
    """Hit, legal-return and on-target rates and the mean reward of episode dicts."""
    n = len(episodes)
    if n == 0:
        return {"serves": 0}
    out = {"serves": n}
    for key, field in (("hit_rate", "hit"), ("return_rate", "returned"),
                       ("target_rate", "on_target")):
        out[key] = sum(bool(e[field]) for e in episodes) / n
    out["mean_reward"] = sum(e["reward"] for e in episodes) / n
    strokes = [e["stroke"] for e in episodes if "stroke" in e]
    if strokes:
        out["fallback_strokes"] = sum(s["fallback"] for s in strokes)
        # A stroke the teacher's quintics carried (the primitives' plan left the joint or effort
        # limits) is no success of the motor primitives.
        carried = [not e.get("stroke", {}).get("fallback", False) for e in episodes]
        out["momp_return_rate"] = sum(bool(e["returned"]) and c
                                      for e, c in zip(episodes, carried, strict=True)) / n
        out["momp_target_rate"] = sum(bool(e["on_target"]) and c
                                      for e, c in zip(episodes, carried, strict=True)) / n
        # Strokes whose hitting stage began on an early physical-model prediction, before the
        # learned predictor's (GPR) final one.
        out["early_strokes"] = sum(bool(s.get("early_prediction")) for s in strokes)
    return out
