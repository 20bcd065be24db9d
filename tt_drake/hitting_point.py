"""Predicting the virtual hitting point (paper section II-C.1): features, labels, GPR, physics.

**Features.** The ball's estimated position and velocity at four consecutive camera frames after
it passes the virtual plane s (y = ``PLANES.observation_y``, the net plane) toward the robot:
``x = (p_1, v_1, p_2, v_2, p_3, v_3, p_4, v_4)`` (24 numbers), where frame 1 is the first frame
whose filtered estimate has ``p_y < observation_y``. They come from the ball-flight estimator
(:mod:`tt_drake.estimation`) fed by the camera (:mod:`tt_drake.camera_model`). That is the
feature set ``states`` (the paper's, the shipped predictor's); ``states+spin`` appends the
estimator's spin omega (rad/s, world frame) at the fourth observation (27 numbers): what the
filter has learnt about the spin from the flight so far and, for a ball that bounced on the
server's half, from that bounce (docs/spin.md). A saved predictor names its feature set.

**Outputs** (seven): the ball's position ``p_hit`` (3) and velocity ``v_hit`` (3) when its centre
reaches the virtual hitting plane y = ``PLANES.hitting_y``, and ``t_hit``, the time from the fourth
observation's capture time to that crossing (time to go, s). The plane fixes ``p_hit[1] =
hitting_y`` exactly: that output is reported as exact, not learnt (its variance is zero).

**GPR.** One scikit-learn ``GaussianProcessRegressor`` per learnt output, kernel

    k(x, x') = c^2 exp(-1/2 sum_d (x_d - x'_d)^2 / l_d^2) + s_n^2 [x = x']

(a Gaussian/RBF kernel on the standardised inputs, by default with one shared length scale
``l_d = l``, optionally one per input (ARD), plus white noise), the
hyperparameters ``c, l, s_n`` maximising the log marginal likelihood (L-BFGS with restarts) and
``normalize_y``. Prediction at a query ``x`` is the posterior mean

    y(x) = mu_y + sigma_y k_*(x)^T alpha,   alpha = (K + s_n^2 I)^-1 (Y - mu_y) / sigma_y

which after loading needs only numpy: the saved file holds the standardised training inputs, the
length scales, ``c^2``, ``alpha`` and the input/output scaling of each output.

**Physical model.** The paper's "manually programmed" reference: from the estimator's state at the
fourth observation, integrate the ball model to the hitting plane
(:meth:`~tt_drake.ball_model.BallModel.predict_plane`).

**Metrics.** Per output on held-out serves: ``MSE = mean (y - y_hat)^2``, ``RMSE = sqrt(MSE)`` and
``nMSE = MSE / Var(y)`` (paper section III-B).
"""

from __future__ import annotations

import math
import time
import warnings

import numpy as np

from tt_drake.artefacts import ArtefactError, load_artefact, save_artefact
from tt_drake.ball_model import BallModel, CompliantBounceBallModel
from tt_drake.camera_model import CameraConfig, camera_from_dict
from tt_drake.constants import PLANES
from tt_drake.errors import BadInputError
from tt_drake.estimation import EstimatorConfig, config_from_dict

N_OBSERVATIONS = 4
FEATURE_SIZE = 6 * N_OBSERVATIONS
#: The GPR's feature sets and their sizes (module docstring).
FEATURE_SETS = {"states": FEATURE_SIZE, "states+spin": FEATURE_SIZE + 3}
OUTPUT_NAMES = ("p_x", "p_y", "p_z", "v_x", "v_y", "v_z", "t_hit")
OUTPUT_UNITS = ("mm", "mm", "mm", "mm/s", "mm/s", "mm/s", "ms")  # for RMSE in reports
EXACT_OUTPUT = 1  # p_y: fixed by the hitting plane's definition
ARTEFACT_KIND = "hitting-point-gpr"
ARTEFACT_VERSION = 1


class PredictorFileError(ArtefactError, BadInputError):
    """A saved predictor is corrupt, of another kind or does not match this code."""


# -- labels and features -------------------------------------------------------------------------

def plane_crossing_from_samples(t, p, v, plane_y: float):
    """First crossing of y = ``plane_y`` (from above) in sampled states, by cubic Hermite
    interpolation of the position between the two samples that bracket it (Newton on
    y(s) = plane_y) and linear interpolation of the velocity. Returns (t_c, p_c, v_c) or None."""
    y = p[:, 1]
    below = np.nonzero((y[:-1] > plane_y) & (y[1:] <= plane_y))[0]
    if len(below) == 0:
        return None
    i = int(below[0])
    h = float(t[i + 1] - t[i])
    p0, p1, m0, m1 = p[i], p[i + 1], v[i] * h, v[i + 1] * h

    def herm(s):
        s2, s3 = s * s, s * s * s
        return ((2 * s3 - 3 * s2 + 1) * p0 + (s3 - 2 * s2 + s) * m0 + (-2 * s3 + 3 * s2) * p1
                + (s3 - s2) * m1)

    def dherm(s):
        s2 = s * s
        return ((6 * s2 - 6 * s) * p0 + (3 * s2 - 4 * s + 1) * m0 + (-6 * s2 + 6 * s) * p1
                + (3 * s2 - 2 * s) * m1)

    s = (y[i] - plane_y) / (y[i] - y[i + 1])
    for _ in range(20):
        ds = (herm(s)[1] - plane_y) / dherm(s)[1]
        s = min(max(s - ds, 0.0), 1.0)
        if abs(ds) < 1e-13:
            break
    pc = herm(s)
    pc[1] = plane_y
    vc = (1 - s) * v[i] + s * v[i + 1]
    return float(t[i] + s * h), pc, vc


def observation_frames(states: np.ndarray, tracking: np.ndarray,
                       plane_y: float = PLANES.observation_y) -> np.ndarray | None:
    """Indices of the four consecutive frames after the estimate passes y = ``plane_y`` moving
    toward the robot (-y), or None if the filter is not tracking on all four."""
    cand = np.nonzero(tracking & (np.nan_to_num(states[:, 1], nan=np.inf) < plane_y)
                      & (np.nan_to_num(states[:, 4], nan=0.0) < 0.0))[0]
    if len(cand) == 0:
        return None
    idx = np.arange(cand[0], cand[0] + N_OBSERVATIONS)
    if idx[-1] >= len(states) or not tracking[idx].all():
        return None
    return idx


def make_features(observed_states: np.ndarray, spin=None,
                  feature_set: str = "states") -> np.ndarray:
    """The features of ``feature_set`` (module docstring) from the estimator's states (4, 6) at
    the four observation frames and, for ``states+spin``, its spin (3) at the fourth."""
    s = np.asarray(observed_states, dtype=float)
    if s.shape != (N_OBSERVATIONS, 6):
        raise ValueError(f"expected ({N_OBSERVATIONS}, 6) observed states, got {s.shape}")
    if feature_set == "states":
        return s.reshape(-1)
    if feature_set == "states+spin":
        w = np.zeros(3) if spin is None else np.asarray(spin, dtype=float).reshape(3)
        return np.r_[s.reshape(-1), w]
    raise ValueError(f"unknown feature set {feature_set!r}; choose one of "
                     f"{', '.join(FEATURE_SETS)}")


def make_label(p_hit, v_hit, t_cross: float, t_obs: float) -> np.ndarray:
    """The 7 outputs: p_hit, v_hit and t_hit = t_cross - t_obs (time to go from the fourth
    observation)."""
    return np.concatenate([p_hit, v_hit, [t_cross - t_obs]])


class PhysicalPredictor:
    """The physical-model predictor: ball model from the estimated state to the hitting plane."""

    def __init__(self, model: BallModel | None = None, plane_y: float = PLANES.hitting_y):
        self.model = model or CompliantBounceBallModel(dt=2e-3)
        self.plane_y = plane_y

    def predict(self, state6) -> np.ndarray | None:
        """(p_hit, v_hit, t_hit) from the state (p, v) at the fourth observation; None if the
        model's ball never reaches the plane."""
        hit = self.model.predict_plane(np.asarray(state6, dtype=float), self.plane_y)
        if hit is None:
            return None
        return np.concatenate([hit.position, hit.velocity, [hit.t]])


# -- the GPR -------------------------------------------------------------------------------------

class HittingPointGPR:
    """Seven outputs: six independent GPs and the exact p_y (module docstring)."""

    def __init__(self, x_mean, x_scale, train_x, length_scales, signal_var, alpha, y_mean, y_scale,
                 exact_value: float = PLANES.hitting_y, info: dict | None = None,
                 feature_set: str = "states"):
        self.x_mean = np.asarray(x_mean, dtype=float)
        self.x_scale = np.asarray(x_scale, dtype=float)
        self.train_x = np.asarray(train_x, dtype=float)  # standardised (n, d)
        self.length_scales = np.asarray(length_scales, dtype=float)  # (6, d)
        self.signal_var = np.asarray(signal_var, dtype=float)  # (6,)
        self.alpha = np.asarray(alpha, dtype=float)  # (6, n)
        self.y_mean = np.asarray(y_mean, dtype=float)  # (6,)
        self.y_scale = np.asarray(y_scale, dtype=float)  # (6,)
        self.exact_value = float(exact_value)
        self.info = info or {}
        self.feature_set = feature_set
        # The perception it was trained on, when saved with it (checked by :meth:`load`).
        self.camera: CameraConfig | None = None
        self.estimator: EstimatorConfig | None = None
        # Pre-scaled training inputs per output: X / l, and their squared norms.
        self._xs = self.train_x[None, :, :] / self.length_scales[:, None, :]  # (6, n, d)
        self._xs2 = np.einsum("knd,knd->kn", self._xs, self._xs)
        self._coef = self.alpha * (self.signal_var * self.y_scale)[:, None]  # (6, n)
        self._sklearn = None

    @staticmethod
    def learnt_outputs() -> list[int]:
        return [i for i in range(len(OUTPUT_NAMES)) if i != EXACT_OUTPUT]

    def features(self, observed_states, spin=None) -> np.ndarray:
        """This predictor's features from the four observed states and the spin at the fourth
        (:func:`make_features` with its feature set)."""
        return make_features(observed_states, spin, self.feature_set)

    @classmethod
    def fit(cls, X, Y, n_restarts: int = 1, seed: int = 0, progress=None,
            ard: bool = False, feature_set: str = "states") -> HittingPointGPR:
        """Train on features X (n, 24 or 27: ``feature_set``) and labels Y (n, 7). ``ard``: one
        length scale per input (slow: ~80 s for 200 serves); default one shared length scale on
        the standardised inputs (the paper's Gaussian kernel)."""
        # scikit-learn's GP adds about a second to every import of this module; only fitting
        # needs it (a saved predictor predicts with numpy).
        from sklearn.exceptions import ConvergenceWarning
        from sklearn.gaussian_process import GaussianProcessRegressor
        from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

        X = np.asarray(X, dtype=float)
        Y = np.asarray(Y, dtype=float)
        if feature_set not in FEATURE_SETS or X.shape[1] != FEATURE_SETS[feature_set]:
            raise ValueError(f"{X.shape[1]} features do not make the feature set "
                             f"{feature_set!r}")
        x_mean = X.mean(axis=0)
        x_scale = X.std(axis=0)
        x_scale[x_scale < 1e-12] = 1.0
        Xs = (X - x_mean) / x_scale
        d = X.shape[1]
        lengths, svars, alphas, ymeans, yscales, models, lml = [], [], [], [], [], [], []
        wall = time.perf_counter()
        for k in cls.learnt_outputs():
            length = np.full(d, 3.0) if ard else 3.0
            kernel = (ConstantKernel(1.0, (1e-3, 1e4))
                      * RBF(length, (1e-2, 1e4))
                      + WhiteKernel(1e-4, (1e-10, 1e-1)))
            gp = GaussianProcessRegressor(kernel, normalize_y=True, n_restarts_optimizer=n_restarts,
                                          random_state=seed + k)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", ConvergenceWarning)
                gp.fit(Xs, Y[:, k])
            kf = gp.kernel_
            lengths.append(np.broadcast_to(kf.k1.k2.length_scale, (d,)).astype(float))
            svars.append(float(kf.k1.k1.constant_value))
            alphas.append(gp.alpha_.ravel())
            ymeans.append(float(np.ravel(gp._y_train_mean)[0]))
            yscales.append(float(np.ravel(gp._y_train_std)[0]))
            lml.append(float(gp.log_marginal_likelihood_value_))
            models.append(gp)
            if progress is not None:
                progress(OUTPUT_NAMES[k])
        info = {
            "n_train": int(X.shape[0]),
            "kernels": [str(m.kernel_) for m in models],
            "log_marginal_likelihood": lml,
            "noise_var": [float(m.kernel_.k2.noise_level) for m in models],
            "fit_seconds": round(time.perf_counter() - wall, 2),
        }
        gpr = cls(x_mean, x_scale, Xs, np.array(lengths), np.array(svars), np.array(alphas),
                  np.array(ymeans), np.array(yscales), info=info, feature_set=feature_set)
        gpr._sklearn = (models, Xs)
        return gpr

    def predict(self, x) -> np.ndarray:
        """The 7 outputs for one feature vector (24 or 27: :meth:`features`), numpy only."""
        xs = (np.asarray(x, dtype=float) - self.x_mean) / self.x_scale
        q = xs[None, :] / self.length_scales  # (6, d)
        d2 = self._xs2 - 2.0 * np.einsum("knd,kd->kn", self._xs, q) + np.einsum("kd,kd->k", q, q)[
            :, None]
        learnt = self.y_mean + np.einsum("kn,kn->k", np.exp(-0.5 * np.maximum(d2, 0.0)),
                                         self._coef)
        out = np.empty(len(OUTPUT_NAMES))
        out[self.learnt_outputs()] = learnt
        out[EXACT_OUTPUT] = self.exact_value
        return out

    def predict_many(self, X) -> np.ndarray:
        X = np.atleast_2d(np.asarray(X, dtype=float))
        return np.array([self.predict(x) for x in X])

    def predict_sklearn(self, X) -> np.ndarray:
        """The same prediction through the fitted scikit-learn models (only after ``fit``)."""
        if self._sklearn is None:
            raise RuntimeError("no scikit-learn models: this predictor was loaded from a file")
        models, _ = self._sklearn
        Xs = (np.atleast_2d(X) - self.x_mean) / self.x_scale
        out = np.empty((len(Xs), len(OUTPUT_NAMES)))
        for gp, k in zip(models, self.learnt_outputs(), strict=True):
            out[:, k] = gp.predict(Xs)
        out[:, EXACT_OUTPUT] = self.exact_value
        return out

    # -- files -------------------------------------------------------------------------------
    def save(self, path, meta: dict | None = None):
        arrays = {
            "x_mean": self.x_mean, "x_scale": self.x_scale, "train_x": self.train_x,
            "length_scales": self.length_scales, "signal_var": self.signal_var,
            "alpha": self.alpha, "y_mean": self.y_mean, "y_scale": self.y_scale,
        }
        doc = {"version": ARTEFACT_VERSION, "outputs": list(OUTPUT_NAMES),
               "exact_output": OUTPUT_NAMES[EXACT_OUTPUT], "exact_value": self.exact_value,
               "feature_size": FEATURE_SETS[self.feature_set], "info": self.info,
               **(meta or {})}
        if self.feature_set != "states":  # a file without the field is the paper's set
            doc["feature_set"] = self.feature_set
        return save_artefact(path, ARTEFACT_KIND, arrays, doc)

    @classmethod
    def load(cls, path) -> HittingPointGPR:
        """Load a saved predictor (no pickle); raises :class:`PredictorFileError` when the file is
        missing, corrupt, of another kind or inconsistent with this code."""
        try:
            arrays, meta = load_artefact(path, ARTEFACT_KIND)
        except ArtefactError as err:
            raise PredictorFileError(str(err)) from None
        feature_set = meta.get("feature_set", "states")
        if not isinstance(feature_set, str) or feature_set not in FEATURE_SETS:
            raise PredictorFileError(f"{path}: unknown feature set {feature_set!r}; this code "
                                     f"knows {', '.join(FEATURE_SETS)}")
        size = FEATURE_SETS[feature_set]
        if meta.get("version") != ARTEFACT_VERSION or list(meta.get("outputs", [])) != list(
                OUTPUT_NAMES) or meta.get("feature_size") != size:
            raise PredictorFileError(f"{path}: predictor version/outputs/features do not match "
                                     f"this code (version {meta.get('version')!r})")
        n_out = len(OUTPUT_NAMES) - 1
        try:
            n, d = arrays["train_x"].shape
            shapes = {"x_mean": (d,), "x_scale": (d,), "length_scales": (n_out, d),
                      "signal_var": (n_out,), "alpha": (n_out, n), "y_mean": (n_out,),
                      "y_scale": (n_out,)}
            for name, shape in shapes.items():
                if arrays[name].shape != shape:
                    raise PredictorFileError(f"{path}: array {name!r} has shape "
                                             f"{arrays[name].shape}, expected {shape}")
        except (KeyError, ValueError) as err:
            raise PredictorFileError(f"{path}: malformed predictor ({err})") from None
        if d != size:
            raise PredictorFileError(f"{path}: {d} features, its feature set {feature_set!r} "
                                     f"has {size}")
        # Scales and kernel parameters divide or weigh every prediction: strictly positive.
        for name in ("x_scale", "length_scales", "signal_var", "y_scale"):
            if not np.all(arrays[name] > 0):
                raise PredictorFileError(f"{path}: array {name!r} must be > 0 everywhere")
        exact = meta.get("exact_value")
        if isinstance(exact, bool) or not isinstance(exact, (int, float)) or not np.isfinite(exact):
            raise PredictorFileError(f"{path}: exact_value must be a finite number")
        camera, estimator = _perception_from_meta(path, meta)
        gpr = cls(arrays["x_mean"], arrays["x_scale"], arrays["train_x"],
                  arrays["length_scales"], arrays["signal_var"], arrays["alpha"],
                  arrays["y_mean"], arrays["y_scale"], exact_value=meta.get("exact_value"),
                  info=meta.get("info", {}), feature_set=feature_set)
        gpr.meta = meta
        gpr.camera, gpr.estimator = camera, estimator
        return gpr


def _perception_from_meta(path, meta: dict) -> tuple[CameraConfig | None, EstimatorConfig | None]:
    """The saved camera and estimator settings (None where not saved), checked as a scenario's
    are, and the metadata that names the training run: ``train_seed`` a whole number >= 0,
    ``distribution`` a string. Raises PredictorFileError with one line."""
    seed = meta.get("train_seed")
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int) or seed < 0):
        raise PredictorFileError(f"{path}: train_seed must be a whole number >= 0 (got {seed!r})")
    if not isinstance(meta.get("distribution", ""), str):
        raise PredictorFileError(f"{path}: distribution must be a string (got "
                                 f"{meta['distribution']!r})")
    out = []
    for key, parse in (("camera", camera_from_dict), ("estimator", config_from_dict)):
        try:
            out.append(parse(meta[key]) if key in meta else None)
        except (TypeError, ValueError) as err:
            raise PredictorFileError(f"{path}: its saved {key} settings are invalid: "
                                     f"{' '.join(str(err).split())}") from None
    return out[0], out[1]


# -- metrics -------------------------------------------------------------------------------------

def regression_metrics(Y_true, Y_pred) -> list[dict]:
    """Per output: MSE, RMSE (SI and report units), nMSE = MSE / Var(y); an output whose target
    variance is zero (p_y on the plane) is marked exact, with nMSE None."""
    Y_true = np.asarray(Y_true, dtype=float)
    Y_pred = np.asarray(Y_pred, dtype=float)
    rows = []
    for k, name in enumerate(OUTPUT_NAMES):
        err = Y_pred[:, k] - Y_true[:, k]
        mse = float(np.mean(err**2))
        var = float(np.var(Y_true[:, k]))
        exact = var < 1e-18
        rows.append({
            "output": name, "mse": mse, "rmse": math.sqrt(mse),
            "rmse_report": math.sqrt(mse) * 1000.0, "report_unit": OUTPUT_UNITS[k],
            "target_var": var, "nmse": None if exact else mse / var, "exact": exact,
        })
    return rows
