"""``tt-drake train-predictor`` / ``eval-predictor``: labelled serves, the GPR and its evaluation.

One sample per serve (seed ``episode_seed(base_seed, i)``; the ``default`` distribution unless
asked otherwise; a pool distribution deals serve i of the run as ``tt-drake serve --seed
base_seed`` does). A training set may mix distributions (``--distribution
default,spin,real-train``): the serves are split evenly between them (the first ones get one more
when they do not divide evenly), each distribution's serves being the first ones of its own run
with seed base_seed.

1. Drake: the serve flies in a ball-only world (table, net, floor, ball, aerodynamics); the ball
   state is logged ten times per camera frame (600 Hz, so every 10th sample is a camera frame).
2. Label: the true state where the ball's centre crosses the virtual hitting plane, by Hermite
   interpolation of the log (:func:`tt_drake.hitting_point.plane_crossing_from_samples`).
3. Features, offline in numpy with the same code the Drake systems run: camera draws
   (:class:`~tt_drake.camera_model.CameraModel`, seeded per serve) on the true frame positions,
   the EKF (:func:`~tt_drake.estimation.run_filter`), its states at the four frames after the
   plane y = 0 (:func:`~tt_drake.hitting_point.observation_frames`) and, for the feature set
   ``states+spin``, its spin at the fourth.

The Drake part is the slow one (~0.1-0.2 s a serve); its results are cached in chunks of
``CHUNK`` serves in ``<output>.cache/`` so an interrupted run resumes where it stopped. Workers are
forked processes (two by default), each building its diagram once.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import os
import sys
import time
import zipfile
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.stats import chi2
from tqdm import tqdm

from tt_drake.artefacts import ArtefactError, check_npz_sizes
from tt_drake.ball_model import BallModel, CompliantBounceBallModel
from tt_drake.camera_model import CameraConfig, CameraModel
from tt_drake.constants import PLANES
from tt_drake.diagrams.ball_world import BallOnlyWorld
from tt_drake.diagrams.episodes import check_run, episode_seed
from tt_drake.diagrams.workers import fork_context
from tt_drake.errors import BadInputError
from tt_drake.estimation import EstimatorConfig, nees, run_filter
from tt_drake.hitting_point import (
    FEATURE_SETS,
    OUTPUT_NAMES,
    HittingPointGPR,
    PhysicalPredictor,
    make_features,
    make_label,
    observation_frames,
    plane_crossing_from_samples,
    regression_metrics,
)
from tt_drake.outputs import FolderLock, atomic_file, check_writable, write_json_atomic
from tt_drake.serves import ServeError, ServeSampler

FRAME_RATE = 60.0
SUBSAMPLES = 10  # log samples per camera frame
MAX_FRAMES = 120  # 2 s of frames per serve
CHUNK = 50
SIM_VERSION = 2
AFTER_CROSSING = 0.05  # simulate this long past the model's predicted crossing (s)


class PredictorError(ValueError, BadInputError):
    """A user error of the predictor commands (bad option values, unusable data)."""


# -- Drake: one serve in a ball-only world ---------------------------------------------------------

class BallOnlySimulation(BallOnlyWorld):
    """The ball-only world logged at ``FRAME_RATE * SUBSAMPLES``; ``run`` gives (t, p, v)."""

    def __init__(self):
        super().__init__(log_period=1.0 / (FRAME_RATE * SUBSAMPLES))

    def run(self, launch_state, duration: float):
        return super().run(launch_state, duration)[:3]


@dataclass
class SimSample:
    """What Drake tells about one serve (fixed-size arrays, NaN-padded)."""

    seed: int
    launch: np.ndarray  # (9,)
    frames_p: np.ndarray  # (MAX_FRAMES, 3) true positions at t_k = k / FRAME_RATE
    frames_v: np.ndarray  # (MAX_FRAMES, 3)
    crossing: np.ndarray  # (7,) true p, v at the hitting plane and its time (NaN if none)
    model_crossing: np.ndarray  # (7,) CompliantBounceBallModel's prediction from the launch
    rigid_crossing: np.ndarray  # (7,) the rigid-bounce BallModel's prediction


def _crossing(model: BallModel, state) -> np.ndarray:
    c = model.predict_plane(state, PLANES.hitting_y)
    return np.r_[c.position, c.velocity, c.t] if c is not None else np.full(7, np.nan)


def simulate_serve(sim: BallOnlySimulation, sampler, models, seed: int) -> SimSample:
    serve = sampler.sample(seed)
    model_crossing = _crossing(models[0], serve.launch_state)
    rigid_crossing = _crossing(models[1], serve.launch_state)
    duration = float(serve.crossing.t) + AFTER_CROSSING
    t, p, v = sim.run(serve.launch_state, duration)
    c = plane_crossing_from_samples(t, p, v, PLANES.hitting_y)
    crossing = np.r_[c[1], c[2], c[0]] if c is not None else np.full(7, np.nan)
    frames_p = np.full((MAX_FRAMES, 3), np.nan)
    frames_v = np.full((MAX_FRAMES, 3), np.nan)
    idx = np.arange(0, len(t), SUBSAMPLES)[:MAX_FRAMES]
    # The logger samples at multiples of 1/600 s; every SUBSAMPLES-th one is a camera frame.
    assert np.allclose(t[idx], np.arange(len(idx)) / FRAME_RATE, atol=1e-9)
    frames_p[: len(idx)] = p[idx]
    frames_v[: len(idx)] = v[idx]
    return SimSample(seed, serve.launch_state.copy(), frames_p, frames_v, crossing, model_crossing,
                     rigid_crossing)


# -- parallel generation with a chunk cache ------------------------------------------------------

_WORKER: dict = {}


def _worker_chunk(args) -> dict:
    seeds, distribution, base_seed = args

    if "sim" not in _WORKER:
        _WORKER["sim"] = BallOnlySimulation()
        _WORKER["model"] = (CompliantBounceBallModel(), BallModel())
    key = (distribution, base_seed)
    if _WORKER.get("sampler_key") != key:  # the pools deal serve i of run base_seed
        _WORKER["sampler"] = ServeSampler(distribution, run_seed=base_seed)
        _WORKER["sampler_key"] = key
    samples = [simulate_serve(_WORKER["sim"], _WORKER["sampler"], _WORKER["model"], s)
               for s in seeds]
    return _stack(samples)


def parse_distributions(text: str | None) -> list[str]:
    """The serve distributions of a comma-separated list (default: ``default``); ServeError
    naming an unknown one or an unusable data file (a split asked of a file without ids); each
    distribution once."""
    names = [n.strip() for n in (text or "default").split(",")]
    for name in names:
        ServeSampler(name).check()
    if len(set(names)) != len(names):
        raise ServeError(f"a serve distribution is listed twice: {text!r}")
    return names


def share(serves: int, distributions: list[str]) -> list[int]:
    """How many of ``serves`` each distribution gets (module docstring)."""
    k = len(distributions)
    return [serves // k + (1 if i < serves % k else 0) for i in range(k)]


def generate_mix(serves: int, base_seed: int, distributions: list[str], cache_dir,
                 workers: int = 2, progress: bool = True) -> dict:
    """:func:`generate_samples` for each distribution's share, stacked; ``distribution`` holds
    each serve's index into ``distributions``."""
    parts = []
    for j, (name, n) in enumerate(zip(distributions, share(serves, distributions), strict=True)):
        if n == 0:
            continue
        part = generate_samples(n, base_seed, cache_dir, workers, progress,
                                desc=f"simulating {name}", distribution=name)
        part["distribution"] = np.full(n, j, dtype=np.int64)
        parts.append(part)
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


def _stack(samples: list[SimSample]) -> dict:
    return {
        "seed": np.array([s.seed for s in samples], dtype=np.int64),
        "launch": np.array([s.launch for s in samples]).reshape(-1, 9),
        "frames_p": np.array([s.frames_p for s in samples]).reshape(-1, MAX_FRAMES, 3),
        "frames_v": np.array([s.frames_v for s in samples]).reshape(-1, MAX_FRAMES, 3),
        "crossing": np.array([s.crossing for s in samples]).reshape(-1, 7),
        "model_crossing": np.array([s.model_crossing for s in samples]).reshape(-1, 7),
        "rigid_crossing": np.array([s.rigid_crossing for s in samples]).reshape(-1, 7),
    }


def _chunk_path(cache_dir: Path, base_seed: int, index: int,
                distribution: str = "default") -> Path:
    key = hashlib.sha256(json.dumps([SIM_VERSION, FRAME_RATE, SUBSAMPLES, MAX_FRAMES,
                                     AFTER_CROSSING, distribution]).encode()).hexdigest()[:10]
    return cache_dir / f"serves_s{base_seed}_c{index:05d}_{key}.npz"


def generate_samples(n: int, base_seed: int, cache_dir: str | os.PathLike | None,
                     workers: int = 2, progress: bool = True, desc: str = "simulating",
                     distribution: str = "default") -> dict:
    """Simulate serves 0..n-1 of ``base_seed`` (seeds ``episode_seed(base_seed, i)``) of
    ``distribution``, reusing cached chunks (a damaged one is reported and simulated again);
    returns the stacked arrays of :class:`SimSample`."""
    check_run(base_seed, n)
    cache = Path(cache_dir) if cache_dir is not None else None
    # The cache folder is locked while this run fills it: a concurrent run is refused.
    lock = FolderLock(cache, PredictorError, "predictor run") if cache is not None else None
    try:
        return _generate_samples(n, base_seed, cache, workers, progress, desc, distribution)
    finally:
        if lock is not None:
            lock.release()


def _load_chunk(path: Path, seeds: list[int]) -> dict | None:
    """The cached chunk's first ``len(seeds)`` serves if it holds these serves, else None; a
    damaged file is reported (one line on stderr), removed and simulated again."""
    if not path.is_file():
        return None
    try:
        check_npz_sizes(path)
        with np.load(path, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
        m = len(data["seed"])
        expected = {"seed": (m,), "launch": (m, 9), "frames_p": (m, MAX_FRAMES, 3),
                    "frames_v": (m, MAX_FRAMES, 3), "crossing": (m, 7), "model_crossing": (m, 7),
                    "rigid_crossing": (m, 7)}
        shapes = {k: a.shape for k, a in data.items()}
        if shapes != expected:
            raise ValueError(f"arrays {shapes}, expected {expected}")
        if not np.all(np.isfinite(data["launch"])):
            raise ValueError("non-finite launch states")
    except (ArtefactError, zipfile.BadZipFile, zlib.error, EOFError, OSError, ValueError,
            KeyError, NotImplementedError) as err:
        print(f"tt-drake: damaged cache chunk {path}, simulating it again "
              f"({' '.join(str(err).split())[:200]})", file=sys.stderr)
        with contextlib.suppress(OSError):
            path.unlink()
        return None
    if m < len(seeds) or [int(s) for s in data["seed"][: len(seeds)]] != seeds:
        return None  # another run's serves (a shorter run): simulated and replaced
    return {k: a[: len(seeds)] for k, a in data.items()}


def _generate_samples(n: int, base_seed: int, cache: Path | None, workers: int, progress: bool,
                      desc: str, distribution: str = "default") -> dict:
    n_chunks = math.ceil(n / CHUNK)
    chunks: dict[int, dict] = {}
    todo = []
    for c in range(n_chunks):
        seeds = [episode_seed(base_seed, i) for i in range(c * CHUNK, min(n, (c + 1) * CHUNK))]
        path = _chunk_path(cache, base_seed, c, distribution) if cache is not None else None
        data = _load_chunk(path, seeds) if path is not None else None
        if data is not None:
            chunks[c] = data
            continue
        todo.append((c, seeds, path))
    bar = tqdm(total=n, desc=desc, unit="serve", file=sys.stderr, disable=not progress,
               initial=sum(len(ch["seed"]) for ch in chunks.values()))

    def store(c, path, data):
        chunks[c] = data
        if path is not None:  # atomically: a full disk leaves neither a chunk nor a temp file
            with atomic_file(path, binary=True, check=False) as f:
                np.savez(f, **data)
        bar.update(len(data["seed"]))

    try:
        if workers <= 1 or len(todo) <= 1:
            for c, seeds, path in todo:
                store(c, path, _worker_chunk((seeds, distribution, base_seed)))
        else:
            with fork_context().Pool(workers) as pool:
                results = pool.imap(_worker_chunk, [(seeds, distribution, base_seed)
                                                    for _, seeds, _ in todo])
                for (c, _, path), data in zip(todo, results, strict=True):
                    store(c, path, data)
    finally:
        bar.close()
    parts = [chunks[c] for c in range(n_chunks)]
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


# -- camera + estimator offline ------------------------------------------------------------------

def camera_seed(serve_seed: int) -> int:
    """The camera's seed of a serve (derived from the serve's seed: one seed per episode)."""
    return int(np.random.SeedSequence([int(serve_seed), 7]).generate_state(1)[0])


@dataclass
class PipelineResult:
    ok: bool
    reason: str = ""
    features: np.ndarray | None = None
    label: np.ndarray | None = None
    state4: np.ndarray | None = None  # estimator state at the fourth observation
    spin4: np.ndarray | None = None  # and its spin there
    run: object = None


def run_pipeline(frames_p, crossing, seed: int, camera: CameraConfig, estimator: EstimatorConfig,
                 full: bool = False, feature_set: str = "states") -> PipelineResult:
    """Camera and EKF on one serve's true frames; the features (of ``feature_set``), the label
    and the fourth observation's state and spin. ``full`` runs the filter over all frames (for
    estimator statistics) instead of stopping at the fourth observation."""
    if not np.all(np.isfinite(crossing)):
        return PipelineResult(False, "no crossing of the hitting plane in Drake")
    t_cross = float(crossing[6])
    n = int(np.sum(np.isfinite(frames_p[:, 0])))
    times = np.arange(n) / FRAME_RATE
    n = int(np.sum(times <= t_cross))
    times = times[:n]
    cam = CameraModel(camera)
    z = cam.measure_sequence(camera_seed(seed), frames_p[:n])
    lat = camera.latency_frames
    if lat:  # frame k is only known at frame k + lat: the last lat frames are not yet delivered
        z = z[: max(0, n - lat)]
        times = times[: len(z)]

    seen = {"after": 0}

    def stop(i, ekf):
        if full or not ekf.tracking:
            return False
        if ekf.x[1] < PLANES.observation_y and ekf.x[4] < 0.0:
            seen["after"] += 1
        else:
            seen["after"] = 0
        return seen["after"] >= 4

    run = run_filter(times, z, estimator, stop=stop)
    idx = observation_frames(run.states, run.tracking)
    if idx is None:
        return PipelineResult(False, "estimator not tracking at the observation frames", run=run)
    state4, spin4 = run.states[idx[-1]], run.spins[idx[-1]]
    feats = make_features(run.states[idx], spin4, feature_set)
    label = make_label(crossing[0:3], crossing[3:6], t_cross, float(times[idx[-1]]))
    return PipelineResult(True, "", feats, label, state4, spin4, run)


def build_dataset(samples: dict, camera: CameraConfig, estimator: EstimatorConfig,
                  physical: bool = False, progress: bool = False, desc: str = "filtering",
                  feature_set: str = "states"):
    """Features X (of ``feature_set``), labels Y, physical-model predictions (or None: from the
    estimated state and spin at the fourth observation) and skipped-serve reasons."""
    X, Y, P, used, skipped = [], [], [], [], {}
    phys = PhysicalPredictor() if physical else None
    for i in tqdm(range(len(samples["seed"])), desc=desc, unit="serve", file=sys.stderr,
                  disable=not progress):
        r = run_pipeline(samples["frames_p"][i], samples["crossing"][i], int(samples["seed"][i]),
                         camera, estimator, feature_set=feature_set)
        if not r.ok:
            skipped[r.reason] = skipped.get(r.reason, 0) + 1
            continue
        if phys is not None:
            pred = phys.predict(np.r_[r.state4, r.spin4])
            if pred is None:
                skipped["physical model misses the plane"] = skipped.get(
                    "physical model misses the plane", 0) + 1
                continue
            P.append(pred)
        X.append(r.features)
        Y.append(r.label)
        used.append(i)
    if not X:
        raise PredictorError("no usable serve: the estimator never produced the four observations")
    return (np.array(X), np.array(Y), np.array(P) if physical else None, np.array(used), skipped)


# -- model vs Drake, estimator statistics ---------------------------------------------------------

def model_vs_drake(samples: dict, key: str = "model_crossing") -> dict:
    """Ball model's predicted crossing from the true launch state vs Drake's (position, time);
    ``key``: ``model_crossing`` (compliant bounce) or ``rigid_crossing`` (BallModel)."""
    ok = np.all(np.isfinite(samples["crossing"]), axis=1) & np.all(
        np.isfinite(samples[key]), axis=1)
    dp = np.linalg.norm(samples[key][ok, :3] - samples["crossing"][ok, :3], axis=1)
    dt = np.abs(samples[key][ok, 6] - samples["crossing"][ok, 6])
    return {"serves": int(ok.sum()), "position_max_mm": float(dp.max() * 1e3),
            "position_mean_mm": float(dp.mean() * 1e3), "time_max_ms": float(dt.max() * 1e3),
            "time_mean_ms": float(dt.mean() * 1e3),
            "within_5mm_2ms": float(np.mean((dp <= 5e-3) & (dt <= 2e-3)))}


PHASES = ("to_net", "net_to_bounce", "after_bounce")


def estimator_statistics(samples: dict, camera: CameraConfig, estimator: EstimatorConfig,
                         max_serves: int = 200) -> dict:
    """Position / velocity RMSE of the filter against truth per flight phase (before the net,
    net to the robot-side bounce, bounce to the hitting plane), the fraction of steps whose NEES
    lies in the two-sided 95 % chi-square band (6 dof) and the mean NEES."""
    lo, hi = chi2.ppf(0.025, 6), chi2.ppf(0.975, 6)
    err_p = {k: [] for k in PHASES}
    err_v = {k: [] for k in PHASES}
    all_nees = []
    n = min(max_serves, len(samples["seed"]))
    for i in range(n):
        r = run_pipeline(samples["frames_p"][i], samples["crossing"][i], int(samples["seed"][i]),
                         camera, estimator, full=True)
        run = r.run
        if run is None:
            continue
        m = len(run.times)
        tp, tv = samples["frames_p"][i][:m], samples["frames_v"][i][:m]
        bounce = np.nonzero((tp[1:, 1] < 0) & (tv[:-1, 2] < 0) & (tv[1:, 2] > 0))[0]
        k_b = int(bounce[0]) + 1 if len(bounce) else m
        for k in np.nonzero(run.tracking)[0]:
            phase = PHASES[0] if tp[k, 1] > 0 else (PHASES[1] if k < k_b else PHASES[2])
            err_p[phase].append(run.states[k, :3] - tp[k])
            err_v[phase].append(run.states[k, 3:] - tv[k])
        ok = run.tracking
        e = np.concatenate([run.states[ok, :3] - tp[ok], run.states[ok, 3:] - tv[ok]], axis=1)
        all_nees.append(nees(e, run.covariances[ok]))
    out = {"serves": n}
    for k in PHASES:
        ep, ev = np.array(err_p[k]), np.array(err_v[k])
        out[k] = {"steps": len(ep),
                  "position_rmse_mm": float(np.sqrt(np.mean(np.sum(ep**2, 1))) * 1e3),
                  "velocity_rmse_mm_s": float(np.sqrt(np.mean(np.sum(ev**2, 1))) * 1e3)}
    a = np.concatenate(all_nees)
    out["nees_mean"] = float(a.mean())
    out["nees_in_95_band"] = float(np.mean((a >= lo) & (a <= hi)))
    return out


# -- train / eval commands -----------------------------------------------------------------------

def _cache_dir(out: str) -> Path:
    p = Path(out)
    return p.with_name(p.name + ".cache")


def train_predictor(serves: int, seed: int, out: str, camera: CameraConfig | None = None,
                    estimator: EstimatorConfig | None = None, restarts: int = 1,
                    workers: int = 2, progress: bool = True, distribution: str | None = None,
                    feature_set: str = "states") -> dict:
    """Train on ``serves`` serves of ``distribution`` (a comma-separated mix: module docstring)
    with the features of ``feature_set`` (:data:`tt_drake.hitting_point.FEATURE_SETS`)."""
    distributions = parse_distributions(distribution)
    if feature_set not in FEATURE_SETS:
        raise PredictorError(f"unknown feature set {feature_set!r}; choose one of "
                             f"{', '.join(FEATURE_SETS)}")
    check_writable(out)
    camera = camera or CameraConfig()
    estimator = estimator or EstimatorConfig()
    wall = time.perf_counter()
    samples = generate_mix(serves, seed, distributions, _cache_dir(out), workers, progress)
    X, Y, _, used, skipped = build_dataset(samples, camera, estimator, progress=progress,
                                           feature_set=feature_set)
    if len(X) < 20:
        raise PredictorError(f"only {len(X)} usable training serves; need at least 20")

    def tick(name):
        if progress:
            print(f"  fitted GP for {name}", file=sys.stderr)

    gpr = HittingPointGPR.fit(X, Y, n_restarts=restarts, seed=seed, progress=tick,
                              feature_set=feature_set)
    train_rows = regression_metrics(Y, gpr.predict_many(X))
    meta = {"train_seed": seed, "serves": serves, "used": int(len(X)), "skipped": skipped,
            "camera": camera.as_dict(), "estimator": estimator.as_dict(),
            "distribution": ",".join(distributions), "frame_rate": FRAME_RATE}
    gpr.save(out, meta)
    return {"out": out, "serves": serves, "used": int(len(X)), "skipped": skipped,
            "distribution": meta["distribution"], "feature_set": feature_set,
            "train_metrics": train_rows, "kernels": gpr.info["kernels"],
            "fit_seconds": gpr.info["fit_seconds"],
            "wall_seconds": round(time.perf_counter() - wall, 1)}


def query_time(gpr: HittingPointGPR, X: np.ndarray, repeats: int = 2000) -> dict:
    """Wall time of one 7-output GPR query (median and 99th percentile over ``repeats``)."""
    ts = []
    for j in range(repeats):
        x = X[j % len(X)]
        t0 = time.perf_counter()
        gpr.predict(x)
        ts.append(time.perf_counter() - t0)
    ts = np.array(ts) * 1e3
    return {"median_ms": float(np.median(ts)), "p99_ms": float(np.percentile(ts, 99)),
            "repeats": repeats}


def eval_predictor(model: str, serves: int, seed: int, json_path: str | None = None,
                   workers: int = 2, progress: bool = True, keep_errors: bool = False,
                   distribution: str | None = None) -> dict:
    """GPR and physical model against the true crossings of held-out serves of
    ``distribution`` (default ``default``; a comma-separated mix as in training). With
    ``keep_errors`` the result also holds ``errors``: the GPR's predicted-minus-true values
    (n, 7) in the report units (mm, mm/s, ms), not written to the JSON."""
    distributions = parse_distributions(distribution)
    gpr = HittingPointGPR.load(model)
    if json_path:
        check_writable(json_path)
    meta = gpr.meta
    if meta.get("train_seed") == seed:
        raise PredictorError(f"evaluation seed {seed} equals the training seed: use another "
                             "seed for held-out serves")
    camera, estimator = gpr.camera, gpr.estimator
    if camera is None or estimator is None:
        raise PredictorError(f"{model}: the predictor has no saved camera or estimator settings "
                             "(the perception it was trained on); train it again")
    wall = time.perf_counter()
    cache = _cache_dir(json_path) if json_path else None
    samples = generate_mix(serves, seed, distributions, cache, workers, progress)
    X, Y, P, used, skipped = build_dataset(samples, camera, estimator, physical=True,
                                           progress=progress, feature_set=gpr.feature_set)
    G = gpr.predict_many(X)
    data = {
        "model": str(model), "eval_seed": seed, "train_seed": meta.get("train_seed"),
        "distribution": ",".join(distributions),
        "train_distribution": meta.get("distribution", "default"),
        "feature_set": gpr.feature_set,
        "serves": serves, "used": int(len(X)), "skipped": skipped,
        "camera": camera.as_dict(), "estimator": estimator.as_dict(),
        "gpr": regression_metrics(Y, G),
        "physical": regression_metrics(Y, P),
        "query_time": query_time(gpr, X),
        "model_vs_drake": model_vs_drake(samples),
        "rigid_model_vs_drake": model_vs_drake(samples, "rigid_crossing"),
        "estimator_stats": estimator_statistics(samples, camera, estimator),
        "wall_seconds": round(time.perf_counter() - wall, 1),
    }
    if json_path:
        write_json_atomic(json_path, data)
    if keep_errors:
        data["errors"] = (G - Y) * 1000.0
    return data


def _fmt(v, spec):
    return "exact" if v is None else format(v, spec)


def format_eval(data: dict) -> str:
    """The side-by-side table of MSE, RMSE and nMSE per output."""
    lines = [f"held-out serves: {data['used']} of {data['serves']} "
             f"{data.get('distribution', 'default')} (eval seed {data['eval_seed']}, trained "
             f"with seed {data['train_seed']} on {data.get('train_distribution', 'default')}, "
             f"features {data.get('feature_set', 'states')})",
             f"{'output':8s} {'':5s} | {'GPR MSE':>10s} {'RMSE':>9s} {'nMSE':>9s} | "
             f"{'phys MSE':>10s} {'RMSE':>9s} {'nMSE':>9s}"]
    for g, p in zip(data["gpr"], data["physical"], strict=True):
        unit = g["report_unit"]
        if g["exact"]:
            lines.append(f"{g['output']:8s} {unit:5s} | exact: fixed by the hitting plane "
                         f"(y = {PLANES.hitting_y:.2f} m)")
            continue
        lines.append(
            f"{g['output']:8s} {unit:5s} | {g['mse']:10.3e} {g['rmse_report']:9.3f} "
            f"{_fmt(g['nmse'], '9.2e')} | {p['mse']:10.3e} {p['rmse_report']:9.3f} "
            f"{_fmt(p['nmse'], '9.2e')}")
    lines.append("MSE in SI units (m^2, m^2/s^2, s^2); RMSE in the unit column.")
    q = data.get("query_time")
    if q:
        lines.append(f"GPR query (7 outputs): median {q['median_ms']:.3f} ms, "
                     f"p99 {q['p99_ms']:.3f} ms")
    m = data.get("model_vs_drake")
    if m:
        lines.append(f"ball model vs Drake at the hitting plane over {m['serves']} serves: "
                     f"max {m['position_max_mm']:.2f} mm, {m['time_max_ms']:.2f} ms")
    return "\n".join(lines)


def format_train(data: dict) -> str:
    lines = [f"trained on {data['used']} of {data['serves']} {data.get('distribution', 'default')}"
             f" serves (features {data.get('feature_set', 'states')}) in {data['fit_seconds']} s "
             f"(GP fit); wrote {data['out']}"]
    for row, kern in zip([r for r in data["train_metrics"] if not r["exact"]], data["kernels"],
                         strict=True):
        lines.append(f"  {row['output']:6s} train RMSE {row['rmse_report']:8.3f} "
                     f"{row['report_unit']:5s} nMSE {row['nmse']:.2e}  kernel {kern[:60]}...")
    return "\n".join(lines)


__all__ = ["OUTPUT_NAMES", "train_predictor", "eval_predictor", "format_eval", "format_train",
           "generate_samples", "run_pipeline", "model_vs_drake", "estimator_statistics",
           "PredictorError"]
