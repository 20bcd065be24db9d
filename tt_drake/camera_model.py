"""A 60 Hz ball camera in numpy: what it reports for a true ball position, frame by frame.

The camera captures frame k at ``t_k = t_0 + k / rate``. For each frame it draws, from one seeded
generator per episode (so any episode replays exactly):

- a dropout (probability ``dropout``): the frame reports nothing;
- otherwise a measurement ``z_k = p(t_k) + n_k`` with ``n_k ~ N(0, sigma^2 I_3)``;
- with probability ``outlier`` the measurement is a gross outlier instead:
  ``z_k = p(t_k) + r_k u_k`` with ``u_k`` uniform on the unit sphere and
  ``r_k ~ U(outlier_min, outlier_max)`` (a mis-detection, e.g. a reflection).

Latency: a frame captured at ``t_k`` is delivered ``latency_frames = ceil(latency * rate)`` frames
later, carrying its capture time so the estimator can put it where it belongs.

The draws of all frames of an episode are made at once (:meth:`CameraModel.episode_draws`) and
indexed by frame number, so the Drake ``BallCamera`` and the offline pipeline in
``diagrams/predictor.py`` produce identical measurements from the same seed.
"""

import math
from dataclasses import asdict, dataclass

import numpy as np


@dataclass
class CameraConfig:
    """Camera parameters (SI units). Defaults: 60 Hz, sigma = 3 mm per axis, no latency, no
    dropouts, no outliers. The scenario's ``camera:`` section (a plain dataclass so that
    ``yaml_load_typed`` can fill it; :meth:`problems` checks it after loading)."""

    rate: float = 60.0
    sigma: float = 0.003
    latency: float = 0.0
    dropout: float = 0.0
    outlier: float = 0.0
    outlier_min: float = 0.1
    outlier_max: float = 0.5
    max_frames: int = 600  # frames drawn per episode (10 s at 60 Hz)

    def __post_init__(self):
        problems = self.problems()
        if problems:
            raise ValueError("; ".join(problems))

    def problems(self, prefix: str = "camera.") -> list[str]:
        """What is wrong with the values (one phrase per field, named with ``prefix``): every
        value finite, rate > 0, sigma and latency >= 0, probabilities in [0, 1],
        0 <= outlier_min <= outlier_max, max_frames >= 1."""
        out = []
        for name in ("rate", "sigma", "latency", "dropout", "outlier", "outlier_min",
                     "outlier_max"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or not math.isfinite(value):
                out.append(f"{prefix}{name} must be a finite number, got {value!r}")
        if out:
            return out
        if not self.rate > 0.0:
            out.append(f"{prefix}rate must be > 0, got {self.rate}")
        for name in ("sigma", "latency"):
            if getattr(self, name) < 0.0:
                out.append(f"{prefix}{name} must be >= 0, got {getattr(self, name)}")
        for name in ("dropout", "outlier"):
            p = getattr(self, name)
            if not 0.0 <= p <= 1.0:
                out.append(f"{prefix}{name} probability must be in [0, 1], got {p}")
        if not 0.0 <= self.outlier_min <= self.outlier_max:
            out.append(f"{prefix}outlier_min and outlier_max must satisfy 0 <= outlier_min <= "
                       f"outlier_max, got {self.outlier_min}, {self.outlier_max}")
        if not isinstance(self.max_frames, int) or self.max_frames < 1:
            out.append(f"{prefix}max_frames must be an integer >= 1, got {self.max_frames!r}")
        return out

    @property
    def period(self) -> float:
        return 1.0 / self.rate

    @property
    def latency_frames(self) -> int:
        """Whole frames between capture and delivery: ceil(latency * rate), where a latency
        within 0.1 % of a frame above a whole number of frames counts as that number (so the
        0.016667 s of a YAML file is one frame at 60 Hz, not two)."""
        return int(math.ceil(self.latency * self.rate - 1e-3))

    def as_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class EpisodeDraws:
    """Random draws of one episode, one row per frame."""

    dropped: np.ndarray  # (F,) bool
    noise: np.ndarray  # (F, 3) measurement error added to the true position (m)


class CameraModel:
    """Turns true ball positions into camera measurements (see the module docstring)."""

    def __init__(self, config: CameraConfig | None = None):
        self.config = config or CameraConfig()

    def episode_draws(self, seed: int) -> EpisodeDraws:
        """All random draws of the episode with ``seed`` (a pure function of the seed)."""
        c = self.config
        n = c.max_frames
        rng = np.random.default_rng(np.random.SeedSequence([int(seed) & 0xFFFFFFFFFFFF, 60]))
        dropped = rng.random(n) < c.dropout
        noise = rng.normal(0.0, c.sigma, (n, 3))
        is_outlier = rng.random(n) < c.outlier
        direction = rng.normal(size=(n, 3))
        direction /= np.linalg.norm(direction, axis=1, keepdims=True)
        radius = rng.uniform(c.outlier_min, c.outlier_max, n)
        noise[is_outlier] = direction[is_outlier] * radius[is_outlier, None]
        return EpisodeDraws(dropped=dropped, noise=noise)

    def measure(self, draws: EpisodeDraws, frame: int, true_position) -> tuple | None:
        """Measurement of frame ``frame`` as a tuple (x, y, z), or None if dropped (or past the
        drawn frames)."""
        if frame < 0 or frame >= len(draws.dropped) or draws.dropped[frame]:
            return None
        n = draws.noise[frame]
        return (float(true_position[0] + n[0]), float(true_position[1] + n[1]),
                float(true_position[2] + n[2]))

    def measure_sequence(self, seed: int, true_positions: np.ndarray) -> np.ndarray:
        """Measurements of frames 0..F-1 for true positions (F, 3): an (F, 3) array with NaN rows
        for dropped frames (delivery delay is not applied; rows are indexed by capture frame)."""
        draws = self.episode_draws(seed)
        p = np.asarray(true_positions, dtype=float)
        f = min(len(p), len(draws.dropped))
        z = np.full((len(p), 3), np.nan)
        z[:f] = p[:f] + draws.noise[:f]
        z[:f][draws.dropped[:f]] = np.nan
        return z
