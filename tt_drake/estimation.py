"""Ball-flight estimation: an extended Kalman filter on the ball model, through the table bounce.

State ``x = (p, v)`` (6, world frame; spin is taken as zero, as the ``default`` serves have none).
The dynamics are the numpy :class:`~tt_drake.ball_model.CompliantBounceBallModel` (gravity, drag,
Magnus and the Hunt-Crossley table bounce, calibrated to the Drake world), which is non-smooth at
the bounce, so the filter is
"model-based":

Prediction over ``dt`` (frame to frame)::

    x-  = f(x+, dt)                        f = BallModel.predict_time (bounce included)
    F   = df/dx                            in flight: the variational equation, integrated
                                           with the RK4 steps of f (its exact derivative):
                                           F = [[I, dp/dv0], [0, dv/dv0]],
                                           (dv/dv0)' = J(v) dv/dv0,  (dp/dv0)' = dv/dv0,
                                           J = -k (|v| I + v v^T / |v|)   (omega = 0);
                                           across a bounce: finite differences, column j:
                                           (f(x + eps e_j, dt) - f(x, dt)) / eps
    P-  = F P+ F^T + Q(dt) [+ Q_bounce]
    Q(dt) = q [[dt^3/3 I, dt^2/2 I], [dt^2/2 I, dt I]]       white-acceleration noise, density q
    Q_bounce = diag(0, 0, 0, s_b^2, s_b^2, s_b^2)             when a bounce falls inside dt

Update with a position measurement ``z`` (``H = [I_3 0]``, ``R = sigma^2 I_3``)::

    y = z - H x-,   S = H P- H^T + R,   d^2 = y^T S^-1 y
    gate: reject z if d^2 > chi2_3^-1(gate_probability)        (outliers)
    K = P- H^T S^-1,   x+ = x- + K y,   P+ = (I - K H) P- (I - K H)^T + K R K^T   (Joseph form)

Dropouts are predictions without update. After ``max_rejections`` consecutive rejected
measurements the track is declared lost and the filter re-initialises, so a burst of outliers or
a bad start cannot make it diverge for good.

Initialisation from the first ``init_frames`` measurements ``z_i`` at ``t_i``: per axis, least
squares on ``z_i = p + v tau_i + a tau_i^2 / 2`` with ``tau_i = t_i - t_last`` and the
acceleration ``a`` known: first gravity alone, then gravity plus drag and Magnus at the first
velocity estimate. The fit is accepted if its normalised residual sum is within the chi-square
gate; otherwise the oldest measurement is dropped and the filter waits for the next. The initial
covariance is the least-squares covariance ``sigma^2 (A^T A)^-1`` (per axis), inflated by
``init_inflation``.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from scipy.stats import chi2

from tt_drake.ball_model import BallModel, BallModelParams, CompliantBounceBallModel

UNINITIALISED = 0.0
TRACKING = 1.0


@dataclass(frozen=True)
class EstimatorConfig:
    """Filter parameters (SI units)."""

    meas_sigma: float = 0.003  # camera noise per axis (m)
    accel_noise: float = 0.002  # q, white-acceleration noise density (m^2/s^3)
    bounce_velocity_sigma: float = 0.05  # extra velocity uncertainty per bounce (m/s)
    gate_probability: float = 0.999  # chi-square gate of the innovation (3 dof)
    init_frames: int = 3
    init_inflation: float = 2.0
    max_rejections: int = 4
    model_dt: float = 4e-3  # RK4 step of the propagation model (s)
    fd_eps: float = 1e-6  # finite-difference step of the Jacobian across a bounce (m, m/s)

    def __post_init__(self):
        if self.init_frames < 3:
            raise ValueError("init_frames must be >= 3")
        if not 0.0 < self.gate_probability < 1.0:
            raise ValueError("gate_probability must be in (0, 1)")

    def as_dict(self) -> dict:
        return asdict(self)


def propagate_exact(model: BallModel, x, duration: float) -> tuple[np.ndarray, bool]:
    """The state (p, v) exactly ``duration`` seconds after ``x`` (spin zero), with the model's
    RK4 flight steps (at most ``model.dt``, the last one shortened to land on ``duration``) and
    its table bounce at the impact (``BallModel.table_impact``). Returns (state, bounced).

    (``BallModel.predict_time`` ends on the first step boundary at or after ``duration``, up to
    one ``dt`` late, which is too coarse for a 60 Hz filter.)"""
    pos, vel = tuple(float(c) for c in x[0:3]), tuple(float(c) for c in x[3:6])
    w = (0.0, 0.0, 0.0)
    t, bounced = 0.0, False
    while duration - t > 1e-12:
        h = min(model.dt, duration - t)
        new_p, new_v = model.flight_step(pos, vel, w, h)
        impact = model.table_impact(pos, vel, w, h, new_p, new_v)
        if impact is not None:
            th, hp, hv = impact
            hv, w = model.bounce(hv, w)
            pos, vel, t, bounced = hp, hv, t + th, True
            continue
        pos, vel, t = new_p, new_v, t + h
    return np.array(pos + vel), bounced


_IDENTITY3 = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)


def propagate_flight_jacobian(model: BallModel, x, duration: float
                              ) -> tuple[np.ndarray, np.ndarray] | None:
    """``propagate_exact``'s state (the same steps, so the same numbers) and its Jacobian
    F = df/dx from the variational equation (``BallModel.flight_step_variational``), or None
    if the table bounce happens within ``duration``.

    Without a bounce the acceleration does not depend on the position, so
    F = [[I, dp/dv0], [0, dv/dv0]], and the two 3 x 3 blocks start at 0 and I."""
    pos, vel = tuple(float(c) for c in x[0:3]), tuple(float(c) for c in x[3:6])
    w = (0.0, 0.0, 0.0)
    dp, dv = (0.0,) * 9, _IDENTITY3
    t = 0.0
    while duration - t > 1e-12:
        h = min(model.dt, duration - t)
        new_p, new_v, new_dp, new_dv = model.flight_step_variational(pos, vel, w, h, dp, dv)
        if model.table_impact(pos, vel, w, h, new_p, new_v) is not None:
            return None
        pos, vel, dp, dv, t = new_p, new_v, new_dp, new_dv, t + h
    F = np.eye(6)
    F[0:3, 3:6] = np.reshape(dp, (3, 3))
    F[3:6, 3:6] = np.reshape(dv, (3, 3))
    return np.array(pos + vel), F


class BallFlightEKF:
    """The filter of the module docstring. ``step`` once per camera frame.

    The whole filter state packs into a flat vector (:meth:`to_vector` / :meth:`load_vector`), the
    layout the Drake ``BallFlightEstimator`` keeps as its discrete state::

        [status, t, x(6), P(36), rejections, n_init, init buffer (init_frames x 4: t, z), nis,
         last_frame_t]
    """

    def __init__(self, config: EstimatorConfig | None = None,
                 model_params: BallModelParams | None = None):
        self.config = config or EstimatorConfig()
        self.model = CompliantBounceBallModel(model_params, dt=self.config.model_dt)
        c = self.config
        self.gate = float(chi2.ppf(c.gate_probability, 3))
        self.R = np.eye(3) * c.meas_sigma**2
        self.reset()

    # -- state handling -------------------------------------------------------------------------
    def reset(self) -> None:
        self.status = UNINITIALISED
        self.t = math.nan
        self.x = np.zeros(6)
        self.P = np.eye(6)
        self.rejections = 0
        self.buffer: list[tuple[float, np.ndarray]] = []
        self.nis = math.nan
        self.last_frame_t = -math.inf

    @property
    def tracking(self) -> bool:
        return self.status == TRACKING

    @property
    def vector_size(self) -> int:
        return 2 + 6 + 36 + 2 + 4 * self.config.init_frames + 2

    def to_vector(self) -> np.ndarray:
        buf = np.full((self.config.init_frames, 4), np.nan)
        for i, (t, z) in enumerate(self.buffer):
            buf[i, 0] = t
            buf[i, 1:] = z
        return np.concatenate([[self.status, self.t], self.x, self.P.ravel(),
                               [self.rejections, len(self.buffer)], buf.ravel(),
                               [self.nis, self.last_frame_t]])

    def load_vector(self, v) -> None:
        v = np.asarray(v, dtype=float)
        n = self.config.init_frames
        self.status, self.t = float(v[0]), float(v[1])
        self.x = v[2:8].copy()
        self.P = v[8:44].reshape(6, 6).copy()
        self.rejections = int(v[44])
        nbuf = int(v[45])
        buf = v[46:46 + 4 * n].reshape(n, 4)
        self.buffer = [(float(buf[i, 0]), buf[i, 1:].copy()) for i in range(nbuf)]
        self.nis, self.last_frame_t = float(v[46 + 4 * n]), float(v[47 + 4 * n])

    # -- propagation ----------------------------------------------------------------------------
    def propagate(self, x: np.ndarray, dt: float) -> tuple[np.ndarray, bool]:
        """f(x, dt) with the ball model; also whether the table bounce happened inside dt."""
        return propagate_exact(self.model, x, dt)

    def propagate_with_jacobian(self, x: np.ndarray, dt: float
                                ) -> tuple[np.ndarray, bool, np.ndarray]:
        """(f(x, dt), bounced, F): F from the variational equation in flight, from finite
        differences (:meth:`numerical_jacobian`) when the table bounce happens inside dt."""
        flight = propagate_flight_jacobian(self.model, x, dt)
        if flight is not None:
            return flight[0], False, flight[1]
        fx, bounced = self.propagate(x, dt)
        return fx, bounced, self.numerical_jacobian(x, dt, fx)

    def jacobian(self, x: np.ndarray, dt: float) -> np.ndarray:
        """F = df/dx of the propagation map (see :meth:`propagate_with_jacobian`)."""
        return self.propagate_with_jacobian(x, dt)[2]

    def numerical_jacobian(self, x: np.ndarray, dt: float,
                           fx: np.ndarray | None = None) -> np.ndarray:
        """Forward-difference Jacobian F = df/dx of the propagation map, column j
        (f(x + eps e_j, dt) - f(x, dt)) / eps."""
        if fx is None:
            fx, _ = self.propagate(x, dt)
        eps = self.config.fd_eps
        F = np.empty((6, 6))
        for j in range(6):
            xp = x.copy()
            xp[j] += eps
            F[:, j] = (self.propagate(xp, dt)[0] - fx) / eps
        return F

    def process_noise(self, dt: float, bounced: bool) -> np.ndarray:
        q = self.config.accel_noise
        Q = np.zeros((6, 6))
        i3 = np.eye(3)
        Q[:3, :3] = q * dt**3 / 3.0 * i3
        Q[:3, 3:] = Q[3:, :3] = q * dt**2 / 2.0 * i3
        Q[3:, 3:] = q * dt * i3
        if bounced:
            Q[3:, 3:] += self.config.bounce_velocity_sigma**2 * i3
        return Q

    def predict(self, t: float) -> None:
        dt = t - self.t
        if dt <= 0.0:
            return
        fx, bounced, F = self.propagate_with_jacobian(self.x, dt)
        self.x = fx
        self.P = F @ self.P @ F.T + self.process_noise(dt, bounced)
        self.P = 0.5 * (self.P + self.P.T)
        self.t = t

    # -- measurement update ---------------------------------------------------------------------
    def update(self, z) -> bool:
        """Gate and fuse one position measurement; returns whether it was accepted."""
        z = np.asarray(z, dtype=float)
        y = z - self.x[:3]
        S = self.P[:3, :3] + self.R
        Sinv = np.linalg.inv(S)
        d2 = float(y @ Sinv @ y)
        self.nis = d2
        if d2 > self.gate:
            self.rejections += 1
            if self.rejections >= self.config.max_rejections:
                self.reset_track()
            return False
        self.rejections = 0
        K = self.P[:, :3] @ Sinv
        self.x = self.x + K @ y
        IKH = np.eye(6)
        IKH[:, :3] -= K
        self.P = IKH @ self.P @ IKH.T + K @ self.R @ K.T
        return True

    def reset_track(self) -> None:
        """Declare the track lost; keep the frame clock."""
        last = self.last_frame_t
        self.reset()
        self.last_frame_t = last

    # -- initialisation -------------------------------------------------------------------------
    def _try_initialise(self) -> bool:
        c = self.config
        while len(self.buffer) >= c.init_frames:
            ts = np.array([b[0] for b in self.buffer])
            zs = np.array([b[1] for b in self.buffer])
            tau = ts - ts[-1]
            A = np.column_stack([np.ones_like(tau), tau])
            AtA_inv = np.linalg.inv(A.T @ A)
            a = np.array([0.0, 0.0, -self.model.params.gravity])
            for _ in range(2):
                rhs = zs - 0.5 * np.outer(tau**2, a)
                coef = AtA_inv @ A.T @ rhs  # (2, 3): rows p, v
                a = np.array(self.model.acceleration(tuple(coef[1]), (0.0, 0.0, 0.0)))
            resid = rhs - A @ coef
            dof = 3 * (len(tau) - 2)
            stat = float(np.sum(resid**2)) / c.meas_sigma**2
            speed = float(np.linalg.norm(coef[1]))
            if stat <= chi2.ppf(c.gate_probability, dof) and speed < 40.0:
                self.x = np.concatenate([coef[0], coef[1]])
                cov = c.init_inflation * c.meas_sigma**2 * AtA_inv
                P = np.zeros((6, 6))
                for k in range(3):
                    P[np.ix_([k, k + 3], [k, k + 3])] = cov
                self.P = P
                self.t = float(ts[-1])
                self.status = TRACKING
                self.rejections = 0
                self.buffer = []
                return True
            self.buffer.pop(0)
        return False

    # -- one frame --------------------------------------------------------------------------------
    def step(self, t: float, z=None) -> bool:
        """Process camera frame captured at ``t`` with measurement ``z`` (3) or None (dropped).
        Frames not newer than the last processed one are ignored. Returns whether the filter
        is tracking afterwards."""
        if not t > self.last_frame_t:
            return self.tracking
        self.last_frame_t = t
        if self.tracking:
            self.predict(t)
            if z is not None:
                self.update(z)
            return self.tracking
        if z is not None:
            self.buffer.append((float(t), np.asarray(z, dtype=float).copy()))
            if len(self.buffer) > self.config.init_frames:
                self.buffer.pop(0)
            self._try_initialise()
        return self.tracking


@dataclass
class FilterRun:
    """Offline filter output at every frame: state (F, 6), covariance (F, 6, 6), tracking (F,)."""

    times: np.ndarray
    states: np.ndarray
    covariances: np.ndarray
    tracking: np.ndarray


def run_filter(times, measurements, config: EstimatorConfig | None = None,
               model_params: BallModelParams | None = None, stop=None) -> FilterRun:
    """Run the filter over frames (``times`` (F,), ``measurements`` (F, 3) with NaN rows for
    dropped frames) exactly as the Drake system does. ``stop(i, ekf)`` may end the run early
    (returning True after frame i is processed); unprocessed rows are NaN."""
    ekf = BallFlightEKF(config, model_params)
    n = len(times)
    states = np.full((n, 6), np.nan)
    covs = np.full((n, 6, 6), np.nan)
    tracking = np.zeros(n, dtype=bool)
    for i in range(n):
        z = measurements[i]
        ekf.step(float(times[i]), None if np.isnan(z[0]) else z)
        if ekf.tracking:
            states[i] = ekf.x
            covs[i] = ekf.P
            tracking[i] = True
        if stop is not None and stop(i, ekf):
            break
    return FilterRun(np.asarray(times, dtype=float), states, covs, tracking)


def nees(errors: np.ndarray, covariances: np.ndarray) -> np.ndarray:
    """Normalised estimation error squared e^T P^-1 e per row (chi-square, 6 dof if consistent)."""
    return np.einsum("ni,ni->n", errors, np.linalg.solve(covariances, errors[..., None])[..., 0])
