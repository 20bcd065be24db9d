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

The draws are made ``max_frames`` frames at a time (:meth:`CameraModel.block_draws`): block b
holds frames ``b n .. (b + 1) n - 1`` (``n = max_frames``) from its own generator, seeded by the
episode's seed and b (block 0 by the seed alone), so an episode has frames for as long as it lasts
whatever the rate, and frame k's draws depend on the seed, k and n only (not on how long the
episode runs). The Drake ``BallCamera`` and the offline pipeline in ``diagrams/predictor.py``
index them by frame number and produce identical measurements from the same seed.

Ranges (:meth:`CameraConfig.problems`): rate in (0, :data:`MAX_CAMERA_RATE`], latency in
[0, :data:`MAX_CAMERA_LATENCY`], max_frames in [1, :data:`MAX_CAMERA_FRAMES`].
"""

import math
from dataclasses import asdict, dataclass

import numpy as np

#: Fastest camera (Hz). Ball-tracking cameras of table-tennis robots run at 60-1,000 Hz; each frame
#: is a discrete update of the simulated camera and its filter, so a rate without a bound hangs.
MAX_CAMERA_RATE = 10_000.0
#: Longest latency (s): a frame delivered a second after its capture arrives after the ball has
#: crossed the table (a serve flies about 1 s); every frame in flight is held in the camera's state.
MAX_CAMERA_LATENCY = 1.0
#: Default frame rate (Hz): the paper's 60 Hz tracking.
DEFAULT_RATE = 60.0
#: Default latency (s): one frame at the default rate. A frame's position exists only
#: after its images are exposed, read out and triangulated, so it reaches the robot no earlier
#: than the next frame's capture (docs/constants.md, "Camera latency").
DEFAULT_LATENCY = 1.0 / DEFAULT_RATE
#: Most frames drawn per block (:meth:`CameraModel.block_draws`): about 100 bytes each, so a
#: block is at most ~20 MB (55 min at 60 Hz, 20 s at the fastest rate; then the next block).
MAX_CAMERA_FRAMES = 200_000


@dataclass
class CameraConfig:
    """Camera parameters (SI units). Defaults: 60 Hz, sigma = 3 mm per axis, a latency of one
    60 Hz frame (:data:`DEFAULT_LATENCY`), no dropouts, no outliers. The scenario's ``camera:``
    section (a plain dataclass so that ``yaml_load_typed`` can fill it; :meth:`problems` checks
    it after loading)."""

    rate: float = DEFAULT_RATE
    sigma: float = 0.003
    latency: float = DEFAULT_LATENCY
    dropout: float = 0.0
    outlier: float = 0.0
    outlier_min: float = 0.1
    outlier_max: float = 0.5
    max_frames: int = 600  # frames drawn per block (10 s at 60 Hz; see the module docstring)
    # Which of an episode's independent noise sequences the camera draws (0: the episode's
    # own). Another stream is the same serve seen through other noise: the returnable bound's
    # camera strategies (docs/rules.md) use streams 1 and 2.
    noise_stream: int = 0

    def __post_init__(self):
        problems = self.problems()
        if problems:
            raise ValueError("; ".join(problems))

    def problems(self, prefix: str = "camera.") -> list[str]:
        """What is wrong with the values (one phrase per field, named with ``prefix``): every
        value finite, rate in (0, MAX_CAMERA_RATE], sigma >= 0, latency in
        [0, MAX_CAMERA_LATENCY], probabilities in [0, 1], 0 <= outlier_min <= outlier_max,
        max_frames a whole number in [1, MAX_CAMERA_FRAMES], noise_stream a whole number >= 0."""
        out = []
        for name in ("rate", "sigma", "latency", "dropout", "outlier", "outlier_min",
                     "outlier_max"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or not math.isfinite(value):
                out.append(f"{prefix}{name} must be a finite number, got {value!r}")
        if out:
            return out
        if not 0.0 < self.rate <= MAX_CAMERA_RATE:
            out.append(f"{prefix}rate must be in (0, {MAX_CAMERA_RATE:g}] Hz, got {self.rate}")
        if self.sigma < 0.0:
            out.append(f"{prefix}sigma must be >= 0, got {self.sigma}")
        if not 0.0 <= self.latency <= MAX_CAMERA_LATENCY:
            out.append(f"{prefix}latency must be in [0, {MAX_CAMERA_LATENCY:g}] s, got "
                       f"{self.latency}")
        for name in ("dropout", "outlier"):
            p = getattr(self, name)
            if not 0.0 <= p <= 1.0:
                out.append(f"{prefix}{name} probability must be in [0, 1], got {p}")
        if not 0.0 <= self.outlier_min <= self.outlier_max:
            out.append(f"{prefix}outlier_min and outlier_max must satisfy 0 <= outlier_min <= "
                       f"outlier_max, got {self.outlier_min}, {self.outlier_max}")
        if (isinstance(self.max_frames, bool) or not isinstance(self.max_frames, int)
                or not 1 <= self.max_frames <= MAX_CAMERA_FRAMES):
            out.append(f"{prefix}max_frames must be a whole number in [1, {MAX_CAMERA_FRAMES}], "
                       f"got {self.max_frames!r}")
        if (isinstance(self.noise_stream, bool) or not isinstance(self.noise_stream, int)
                or self.noise_stream < 0):
            out.append(f"{prefix}noise_stream must be a whole number >= 0, got "
                       f"{self.noise_stream!r}")
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


def camera_from_dict(d) -> CameraConfig:
    """The camera settings saved with an artefact (:meth:`CameraConfig.as_dict`), checked as a
    scenario's are: known keys, numbers, ranges. Raises ValueError naming every problem."""
    if not isinstance(d, dict):
        raise ValueError(f"camera settings must be a mapping, got {type(d).__name__}")
    unknown = set(d) - set(CameraConfig.__dataclass_fields__)
    if unknown:
        raise ValueError(f"unknown camera settings {sorted(unknown)}")
    return CameraConfig(**d)  # __post_init__ raises ValueError with the problems


@dataclass(frozen=True)
class EpisodeDraws:
    """Random draws of one block of an episode's frames, one row per frame."""

    dropped: np.ndarray  # (F,) bool
    noise: np.ndarray  # (F, 3) measurement error added to the true position (m)


class CameraModel:
    """Turns true ball positions into camera measurements (see the module docstring)."""

    def __init__(self, config: CameraConfig | None = None):
        self.config = config or CameraConfig()

    def episode_draws(self, seed: int) -> EpisodeDraws:
        """The random draws of the first ``max_frames`` frames of the episode with ``seed``."""
        return self.block_draws(seed, 0)

    def block_draws(self, seed: int, block: int) -> EpisodeDraws:
        """The random draws of frames ``block n .. (block + 1) n - 1`` (``n = max_frames``) of
        the episode with ``seed``: a pure function of the seed, the block and the config's
        ``noise_stream`` (stream 0's keys have no stream entry, so they are the same as before
        streams existed; another stream's have four entries and so differ from all of them)."""
        c = self.config
        n = c.max_frames
        key = [int(seed) & 0xFFFFFFFFFFFF, 60]
        if c.noise_stream:
            key += [int(block), int(c.noise_stream)]
        elif block:
            key.append(int(block))
        rng = np.random.default_rng(np.random.SeedSequence(key))
        dropped = rng.random(n) < c.dropout
        noise = rng.normal(0.0, c.sigma, (n, 3))
        is_outlier = rng.random(n) < c.outlier
        direction = rng.normal(size=(n, 3))
        direction /= np.linalg.norm(direction, axis=1, keepdims=True)
        radius = rng.uniform(c.outlier_min, c.outlier_max, n)
        noise[is_outlier] = direction[is_outlier] * radius[is_outlier, None]
        return EpisodeDraws(dropped=dropped, noise=noise)

    def block_of(self, frame: int) -> tuple[int, int]:
        """(block, row): where frame ``frame``'s draws are (:meth:`block_draws`)."""
        return divmod(int(frame), self.config.max_frames)

    def measure(self, draws: EpisodeDraws, frame: int, true_position) -> tuple | None:
        """Measurement of row ``frame`` of a block of draws as a tuple (x, y, z), or None if
        dropped (or outside the block)."""
        if frame < 0 or frame >= len(draws.dropped) or draws.dropped[frame]:
            return None
        n = draws.noise[frame]
        return (float(true_position[0] + n[0]), float(true_position[1] + n[1]),
                float(true_position[2] + n[2]))

    def measure_sequence(self, seed: int, true_positions: np.ndarray) -> np.ndarray:
        """Measurements of frames 0..F-1 for true positions (F, 3): an (F, 3) array with NaN rows
        for dropped frames (delivery delay is not applied; rows are indexed by capture frame)."""
        p = np.asarray(true_positions, dtype=float)
        z = np.full((len(p), 3), np.nan)
        n = self.config.max_frames
        for start in range(0, len(p), n):
            draws = self.block_draws(seed, start // n)
            stop = min(len(p), start + n)
            rows = z[start:stop]  # a view: filled in place
            rows[:] = p[start:stop] + draws.noise[:stop - start]
            rows[draws.dropped[:stop - start]] = np.nan
        return z
