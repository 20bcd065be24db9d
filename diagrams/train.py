"""``tt-drake train library|crkr``: the learned player's artefacts from a teacher dataset.

    tt-drake train library --data DIR --out FILE [--primitives 300] [--stimulus paper|spin]
                           [--demonstrations planned|recorded] [--alpha-y 35]
                           [--hitting-borrow 0.5] [--stage-borrow 0.5]
                           [--kappa 1] [--zeta 0.25] [--threshold 0.1]
    tt-drake train crkr    --data DIR --out FILE [--samples 2500] [--stimulus paper|spin]

DIR is a dataset written by ``tt-drake collect`` (:func:`tt_drake.diagrams.collect.load_dataset`).
Only the teacher's successful strokes (legal returns) are used.

library (paper section III-C): one hitting primitive per successful stroke, imitated from its
hitting-stage samples (Eqs. 7-8, Algorithm 2), up to ``--primitives`` of them (the first ones in
the dataset's serve order; serves are independent draws). Its stimulus x_i is the teacher's
prediction (p_hit, v_hit) at the hitting plane (6-D, the dataset's ``stimulus[:6]``): what the
player sees at run time is a prediction too, not the true crossing. Gating bandwidths by Scott's
rule (:func:`tt_drake.momp.scott_bandwidths`); 1 for p_hit's y, constant on the plane. Plus one DMP
per other stage (section III-A), each imitated from one representative demonstration: among the
successful serves, the one whose stage duration is the median (preparation: the swing-back, from
rest to rest; follow-through: from (theta_hit, theta_dot_hit) to rest; awaiting: the return to the
awaiting posture after the follow-through). In every primitive, the joints that barely moved in the
demonstration take the normalised shape of the joint that moved most
(:func:`tt_drake.imitation.borrow_weak_shapes`: DMP amplitude scaling is ill-conditioned there).

The defaults are the paper profile's. The options (docs/motor_primitives.md section 10): the
demonstrations are the executed plan or the arm's recorded joint state; the DMP gain alpha_y; the
borrowing ratio of the hitting primitives and of the stage DMPs (0: none); the stimulus layout
(:mod:`tt_drake.stimulus`: ``spin`` appends the teacher's predicted spin at impact, ``spin_hit``);
the responsibility learning's kappa, zeta and pruning threshold (Eq. 10, Algorithm 3;
:class:`tt_drake.responsibility.ResponsibilityParams`). All are recorded in the artefact.

crkr (paper section II-C.2): the map from the stimulus s = (p_hit, v_hit) to the hitting
configuration (theta_hit, theta_dot_hit), 14 outputs sharing one kernel (one model per output, as
in the paper), with the cost of each sample the squared distance of theta_hit from the hitting
comfort posture (:data:`tt_drake.systems.hitting_ik.HITTING_COMFORT`, the teacher's IK uses the
same one) plus a floor of :data:`COST_FLOOR`, around the targets' mean as prior mean
(:class:`tt_drake.learned_player.ConfigurationModel`). Kernel bandwidth per input
``CRKR_BANDWIDTH_SCALE n^(-1/9)`` times its standard deviation (Scott-style shrinking with the
sample count n for 5 varying inputs; the constant 3 = 2 sd at n = 35 was the best of 0.5/1/2 sd on
a 35/15 split of 50 teacher strokes: held-out mean error 0.04 rad in theta_hit, 0.16 rad/s in
theta_dot_hit, against 0.32 for the mean alone); ``lambda`` :data:`CRKR_LAMBDA` (0.01 and 0.1
were equal there).

Both files carry the scenario's name and the hitting plane's y, and a format version; the player
refuses a file trained for another scenario (:class:`LearnedArtefactError`).
"""

from pathlib import Path

import numpy as np

from tt_drake.constants import PLANES
from tt_drake.crkr import comfort_cost
from tt_drake.diagrams.collect import DatasetError, load_dataset
from tt_drake.dmp import HittingDMP
from tt_drake.errors import BadInputError
from tt_drake.imitation import WEAK_AMPLITUDE_RATIO, Demonstration, borrow_weak_shapes
from tt_drake.learned_player import (
    ConfigurationModel,
    StagePrimitive,
    save_configuration_model,
    save_player_library,
)
from tt_drake.momp import MotorPrimitiveLibrary, scott_bandwidths
from tt_drake.outputs import check_writable, portable_path
from tt_drake.responsibility import ResponsibilityParams
from tt_drake.stages import AWAITING, FOLLOW_THROUGH, HITTING, PREPARATION, STAGES
from tt_drake.stimulus import (
    PAPER_STIMULUS,
    STIMULI,
    compose_stimulus,
    describe_stimulus,
    stimulus_layout,
    stimulus_size,
)
from tt_drake.systems.hitting_ik import HITTING_COMFORT

COST_FLOOR = 0.05  # rad^2
CRKR_BANDWIDTH_SCALE = 3.0
CRKR_LAMBDA = 0.01
MIN_SAMPLES = 20  # a stage with fewer samples (< 40 ms at 500 Hz) is not used as a demonstration


class TrainError(ValueError, BadInputError):
    """A dataset that cannot train the requested artefact."""


def stage_runs(rows: np.ndarray) -> list[tuple[int, np.ndarray]]:
    """Consecutive rows (in time order) of one serve's trajectory with the same stage index:
    [(stage, rows)]."""
    rows = rows[np.argsort(rows[:, 0], kind="stable")]
    stage = rows[:, 1].astype(int)
    cuts = np.flatnonzero(np.diff(stage)) + 1
    return [(int(part[0, 1]), part) for part in np.split(rows, cuts) if len(part)]


def _spread(x: np.ndarray) -> np.ndarray:
    """Standard deviation per stimulus dimension, 0 for a constant one (p_hit's y is the hitting
    plane's: its round-off spread must not become a kernel bandwidth of 1e-12 m)."""
    sd = x.std(axis=0) if len(x) > 1 else np.zeros(x.shape[1])
    return np.where(sd > 1e-6, sd, 0.0)


DEMONSTRATIONS = {"planned": "trajectory", "recorded": "recorded"}


def _demo(rows: np.ndarray) -> Demonstration:
    return Demonstration(rows[:, 0] - rows[0, 0], rows[:, 2:9], rows[:, 9:16], rows[:, 16:23])


def _successful(data: dict) -> np.ndarray:
    ok = np.flatnonzero(data["returned"] > 0.5)
    if ok.size == 0:
        raise TrainError("the dataset has no successful (returned) teacher stroke")
    return ok


def _load(folder) -> dict:
    data = load_dataset(folder)
    if "trajectory" not in data or len(data["returned"]) == 0:
        raise DatasetError(f"{folder}: no serves")
    return data


def _meta(data: dict, folder, used: int) -> dict:
    m = data["manifest"]
    return {"scenario": m["scenario"], "distribution": m["distribution"],
            "hitting_y": PLANES.hitting_y, "dataset": portable_path(folder),
            "dataset_seed": m["seed"], "dataset_serves": m["serves"], "teacher": m["player"],
            "samples": int(used)}


def stimuli_of(data: dict, layout=PAPER_STIMULUS) -> np.ndarray:
    """Every serve's stimulus of ``layout`` (:mod:`tt_drake.stimulus`) from the teacher's
    prediction (``stimulus``: p_hit, v_hit, t_hit; ``spin_hit``: its spin at impact)."""
    layout = stimulus_layout(layout)
    if "spin_hit" in layout and "spin_hit" not in data:
        raise TrainError("the dataset has no spin_hit (collected before it was recorded); "
                         "collect it again for a stimulus with spin")
    n = len(data["returned"])
    spin = data["spin_hit"] if "spin_hit" in data else np.full((n, 3), np.nan)
    return np.array([compose_stimulus(layout, data["stimulus"][i, :3], data["stimulus"][i, 3:6],
                                      spin[i]) for i in range(n)]).reshape(n, -1)


def extract_strokes(data: dict, limit: int | None = None, demonstrations: str = "planned",
                    stimulus=PAPER_STIMULUS) -> dict:
    """Per successful serve (up to ``limit`` hitting demonstrations): the hitting demonstrations
    with their stimuli (of the layout ``stimulus``), and the candidate demonstrations of the
    other stages. ``demonstrations``: ``"planned"``, the teacher's executed plan, or
    ``"recorded"``, the arm's measured joint state during it (with the tracking error)."""
    if demonstrations not in DEMONSTRATIONS:
        raise TrainError(f"unknown demonstrations {demonstrations!r}; choose one of "
                         f"{', '.join(DEMONSTRATIONS)}")
    key = DEMONSTRATIONS[demonstrations]
    if key not in data:
        raise TrainError(f"the dataset has no {demonstrations} demonstrations (collected before "
                         f"the arm's state was recorded); collect it again")
    x = stimuli_of(data, stimulus)
    by_serve = data[f"{key}_serve"]
    hit_idx = STAGES.index(HITTING)
    follow_idx, await_idx = STAGES.index(FOLLOW_THROUGH), STAGES.index(AWAITING)
    prep_idx = STAGES.index(PREPARATION)
    out = {"hitting": [], "stimuli": [], PREPARATION: [], FOLLOW_THROUGH: [], AWAITING: []}
    for i in _successful(data):
        runs = stage_runs(data[key][by_serve == i])
        for k, (stage, rows) in enumerate(runs):
            if len(rows) < MIN_SAMPLES:
                continue
            if stage == hit_idx and (limit is None or len(out["hitting"]) < limit):
                out["hitting"].append(_demo(rows))
                out["stimuli"].append(x[i])
            elif stage == prep_idx:
                out[PREPARATION].append(_demo(rows))
            elif stage == follow_idx:
                out[FOLLOW_THROUGH].append(_demo(rows))
            elif stage == await_idx and k > 0 and runs[k - 1][0] == follow_idx:
                out[AWAITING].append(_demo(rows))
    return out


def _representative(demos: list[Demonstration], stage: str) -> Demonstration:
    if not demos:
        raise TrainError(f"no usable {stage} demonstration in the successful strokes")
    taus = np.array([d.tau for d in demos])
    return demos[int(np.argsort(taus)[len(taus) // 2])]


# The ``hard-stiff`` profile, which trained the shipped hard set (models/learned-hard/): the
# library imitates the arm's recorded strokes with no borrowing in the hitting primitives and
# gates on the spin (docs/motor_primitives.md section 10); its stiff hitting DMP (alpha_y 15)
# reaches the teacher's hitting configuration whatever its weights, so the library plays best
# without learning and learning has nothing to select; Eq. 10 with the defaults (kappa 1).
STIFF_HARD_PROFILE = {"demonstrations": "recorded", "alpha_y": 15.0, "stimulus": "spin",
                      "hitting_borrow": 0.0, "stage_borrow": WEAK_AMPLITUDE_RATIO}
# The hard reproduce profile: alpha_y 11 leaves part of the impact to the primitives, so that
# responsibility learning and PoWER have something to select and adapt; kappa 4 and zeta 0.5
# let Eq. 10 prune a primitive after the ~3 rollouts' worth of gating weight it gets (kappa 1
# cannot): docs/reproducing.md, "Choosing the hard profile's gain". The paper profile keeps
# train_library's defaults.
HARD_PROFILE = {**STIFF_HARD_PROFILE, "alpha_y": 11.0, "kappa": 4.0, "zeta": 0.5}


def library_options(config) -> dict:
    """train_library's keyword arguments from a reproduce profile's config: its attributes
    ``demonstrations``, ``alpha_y``, ``stimulus``, ``hitting_borrow`` and ``stage_borrow``, and
    the responsibility learning's ``kappa``, ``zeta`` and ``threshold`` (Eq. 10, Algorithm 3;
    the others keep :class:`ResponsibilityParams`' defaults) if it has them (else the paper
    profile's: train_library's defaults)."""
    out = {}
    for name in ("demonstrations", "hitting_borrow", "stage_borrow"):
        if getattr(config, name, None) is not None:
            out[name] = getattr(config, name)
    if getattr(config, "alpha_y", None) is not None:
        out["dmp"] = HittingDMP(alpha_y=float(config.alpha_y))
    learning = {name: float(getattr(config, name)) for name in ("kappa", "zeta", "threshold")
                if getattr(config, name, None) is not None}
    if learning:
        out["responsibility"] = ResponsibilityParams(**learning)
    out["stimulus"] = stimulus_of(config)
    return out


def stimulus_of(config) -> tuple[str, ...]:
    """The stimulus layout of a reproduce profile's config (attribute ``stimulus``: a layout or
    a name of :data:`tt_drake.stimulus.STIMULI`; absent: the paper's)."""
    value = getattr(config, "stimulus", None)
    if value is None:
        return PAPER_STIMULUS
    return stimulus_layout(STIMULI[value] if isinstance(value, str) else value)


def train_library(data_dir, out, primitives: int = 300, dmp: HittingDMP | None = None,
                  demonstrations: str = "planned", stimulus=PAPER_STIMULUS,
                  hitting_borrow: float = WEAK_AMPLITUDE_RATIO,
                  stage_borrow: float = WEAK_AMPLITUDE_RATIO,
                  responsibility: ResponsibilityParams | None = None) -> dict:
    """Write the primitive library (hitting primitives + stage DMPs); returns a summary.

    ``demonstrations``: the teacher's executed plan (``"planned"``) or the arm's recorded joint
    state (``"recorded"``); ``stimulus``: the gating network's stimulus layout
    (:mod:`tt_drake.stimulus`); ``dmp``: the DMP's hyperparameters (gains, basis), recorded in
    the artefact; ``hitting_borrow`` and ``stage_borrow``: the amplitude ratio below which a
    joint of a hitting primitive / of a stage DMP takes the dominant joint's shape
    (:func:`tt_drake.imitation.borrow_weak_shapes`; 0 keeps every joint's own shape);
    ``responsibility``: the library's responsibility-learning parameters (kappa, zeta and the
    pruning threshold of Eq. 10 and Algorithm 3, recorded in the artefact; default
    :class:`ResponsibilityParams`' defaults)."""
    check_writable(out)
    dmp = dmp or HittingDMP()
    layout = stimulus_layout(stimulus)
    for name, ratio in (("hitting_borrow", hitting_borrow), ("stage_borrow", stage_borrow)):
        if not 0.0 <= ratio <= 1.0:
            raise TrainError(f"{name} must lie in [0, 1], got {ratio}")
    data = _load(data_dir)
    strokes = extract_strokes(data, primitives, demonstrations, layout)
    if not strokes["hitting"]:
        raise TrainError(f"{data_dir}: no usable hitting demonstration")
    x = np.array(strokes["stimuli"])
    h = np.where(_spread(x) > 0, scott_bandwidths(x), 1.0)
    library = MotorPrimitiveLibrary.from_demonstrations(
        dmp, strokes["hitting"], x, h, stimulus_layout=layout,
        responsibility=responsibility or ResponsibilityParams())
    borrowed = 0
    for p in range(library.n_primitives):
        before = library.weights[p].copy()
        library.weights[p], library.amplitude[p] = borrow_weak_shapes(
            library.weights[p], library.amplitude[p], hitting_borrow)
        borrowed += int(np.any(library.weights[p] != before, axis=1).sum())
    stages = {}
    for stage in (PREPARATION, FOLLOW_THROUGH, AWAITING):
        prim = StagePrimitive.imitate(dmp, _representative(strokes[stage], stage))
        stages[stage] = StagePrimitive(*borrow_weak_shapes(prim.weights, prim.amplitude,
                                                           stage_borrow), prim.tau)
    meta = {**_meta(data, data_dir, library.n_primitives), "demonstrations": demonstrations,
            "hitting_borrow": hitting_borrow, "stage_borrow": stage_borrow,
            "borrowed_dofs": borrowed}
    save_player_library(out, library, stages, meta)
    return {"artefact": "library", "out": str(out), "primitives": library.n_primitives,
            "bandwidths": library.bandwidths.round(4).tolist(),
            "borrowed_share": borrowed / library.weights[:, :, 0].size, **meta}


def train_crkr(data_dir, out, samples: int = 2500, stimulus=PAPER_STIMULUS) -> dict:
    """Write the CrKR hitting-configuration model from a teacher dataset (stimulus of the layout
    ``stimulus``); returns a summary."""
    check_writable(out)
    data = _load(data_dir)
    ok = _successful(data)[:samples]
    return fit_crkr(stimuli_of(data, stimulus)[ok], data["q_hit"][ok], data["qd_hit"][ok], out,
                    _meta(data, data_dir, len(ok)), stimulus)


def fit_crkr(x, q_hit, qd_hit, out, meta: dict, stimulus=PAPER_STIMULUS) -> dict:
    """Fit the CrKR map on pairs (stimulus (n, 6) -> theta_hit, theta_dot_hit (n, 7) each) and
    write it to ``out`` with ``meta`` (scenario, hitting_y, data provenance); returns a summary.
    Used on the teacher's pairs (``train crkr``) and on a learned player's own successful
    strokes (policy iteration, ``tt-drake reproduce``)."""
    check_writable(out)
    x, q_hit, qd_hit = (np.asarray(a, dtype=float) for a in (x, q_hit, qd_hit))
    layout = stimulus_layout(stimulus)
    size = stimulus_size(layout)
    if (len(x) < 2 or x.shape[1:] != (size,) or q_hit.shape != (len(x), 7)
            or qd_hit.shape != q_hit.shape):
        raise TrainError(f"CrKR needs at least 2 pairs of a {size}-D stimulus "
                         f"({', '.join(layout)}) and 7 + 7 joint values, "
                         f"got {x.shape}, {q_hit.shape}, {qd_hit.shape}")
    y = np.hstack([q_hit, qd_hit])
    costs = comfort_cost(q_hit, HITTING_COMFORT) + COST_FLOOR
    sd = _spread(x)
    h = CRKR_BANDWIDTH_SCALE * len(x) ** (-1.0 / 9.0) * np.where(sd > 0, sd, 1.0)
    model = ConfigurationModel.fit(x, y, costs, h, CRKR_LAMBDA, layout)
    meta = {**meta, "samples": int(len(x)), "inputs": describe_stimulus(layout),
            "outputs": "theta_hit (7), theta_dot_hit (7)",
            "comfort_posture": list(HITTING_COMFORT), "cost_floor": COST_FLOOR}
    save_configuration_model(out, model, meta)
    return {"artefact": "crkr", "out": str(out), "bandwidths": h.round(4).tolist(), **meta}


def format_train(summary: dict) -> str:
    what = (f"{summary['primitives']} hitting primitives + 3 stage DMPs"
            if summary["artefact"] == "library" else f"CrKR on {summary['samples']} samples")
    return (f"{what} from {summary['dataset']} (scenario {summary['scenario']}, "
            f"{summary['dataset_serves']} serves) -> {Path(summary['out'])}")
