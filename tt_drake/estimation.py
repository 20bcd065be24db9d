"""Ball-flight estimation: an extended Kalman filter on the ball model, spin included, through
the table bounces.

State ``x = (p, v, omega)`` (9, world frame; omega in rad/s). The dynamics are the numpy
:class:`~tt_drake.ball_model.CompliantBounceBallModel` (gravity, drag, Magnus and the
Hunt-Crossley table bounce, calibrated to the Drake world; docs/world.md, "Physics"), which is
non-smooth at the bounce, so the filter is "model-based":

Prediction over ``dt`` (frame to frame)::

    x-  = f(x+, dt)                        flight: p' = v, v' = g - k |v| v + C_L omega x v,
                                           omega' = 0; at every table impact the bounce map
                                           (v, omega) -> (v', omega') of the ball model
                                           (spin and velocity change together)
    F   = df/dx                            in flight: the variational equation, integrated
                                           with the RK4 steps of f (its exact derivative):
                                           F = [[I, dp/dv0, dp/dw0], [0, dv/dv0, dv/dw0],
                                                [0, 0, I]],
                                           (dv/dv0)' = J(v) dv/dv0,
                                           (dv/dw0)' = J(v) dv/dw0 - C_L [v]x,
                                           (dp/d.)' = dv/d.,
                                           J = -k (|v| I + v v^T / |v|) + C_L [omega]x;
                                           across a bounce: finite differences, column j:
                                           (f(x + eps e_j, dt) - f(x, dt)) / eps
    P-  = F P+ F^T + Q(dt) [+ Q_bounce]
    Q(dt) = blkdiag(q [[dt^3/3 I, dt^2/2 I], [dt^2/2 I, dt I]], q_w dt I)
            white-acceleration noise (density q) and a spin random walk (density q_w)
    Q_bounce = diag(0, s_b^2 I, s_w^2 I)   when a bounce falls inside dt

Spin is observed mainly through the bounces: the velocity change at contact depends on the slip
of the contact point, v_t - R omega x n, so the post-bounce velocity measurements correct the
spin through the cross-covariance the bounce Jacobian creates (the Magnus drift between 60 Hz
frames is well below the camera noise). The spin about the table normal (omega_z) is not changed
by a bounce and is seen only through the Magnus curvature of the flight.

Update with a position measurement ``z`` (``H = [I_3 0 0]``, ``R = sigma^2 I_3``)::

    y = z - H x-,   S = H P- H^T + R,   d^2 = y^T S^-1 y
    gate: accept z if d^2 <= chi2_3^-1(gate_probability)
    bounce hypothesis: if z fails the gate while the ball is near a bounce (a predicted impact
    inside this interval or the one before, or the predicted ball descending within one frame's
    travel plus three standard deviations of the contact height over the table), the bounce may
    have happened otherwise than predicted (its time, the table edge, the spin): test z again
    with P- + Q_hyp, Q_hyp = sigma_h^2 [[tau^2 I, tau I, 0], [tau I, I, 0], [0, 0, (s_h/sigma_h)^2
    I]] (tau = dt), and fuse it with that covariance if it passes; otherwise reject it (outlier)
    K = P- H^T S^-1,   x+ = x- + K y,   P+ = (I - K H) P- (I - K H)^T + K R K^T   (Joseph form)

Dropouts are predictions without update. After ``max_rejections`` consecutive rejected
measurements the track is declared lost and the filter re-initialises, so a burst of outliers or
a bad start cannot make it diverge for good.

Initialisation from the first ``init_frames`` measurements ``z_i`` at ``t_i``: per axis, least
squares on ``z_i = p + v tau_i + a tau_i^2 / 2`` with ``tau_i = t_i - t_last`` and the
acceleration ``a`` known: first gravity alone, then gravity plus drag at the first velocity
estimate. The fit is accepted if its normalised residual sum is within the chi-square gate;
otherwise the oldest measurement is dropped and the filter waits for the next. The initial
covariance is the least-squares covariance ``sigma^2 (A^T A)^-1`` (per axis), inflated by
``init_inflation``; the spin starts at zero with standard deviation ``spin_sigma0`` per axis.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from scipy.stats import chi2

from tt_drake.ball_model import BallModel, BallModelParams, CompliantBounceBallModel
from tt_drake.filter_kernel import add_process_noise
from tt_drake.flight_kernel import UNTIL_CONTACT, variational_flight

UNINITIALISED = 0.0
TRACKING = 1.0

#: The filter state's dimension: (p, v, omega).
N_STATE = 9


@dataclass(frozen=True)
class EstimatorConfig:
    """Filter parameters (SI units)."""

    meas_sigma: float = 0.003  # camera noise per axis (m)
    accel_noise: float = 0.002  # q, white-acceleration noise density (m^2/s^3)
    spin_noise: float = 4.0  # q_w, spin random-walk density ((rad/s)^2/s)
    spin_sigma0: float = 50.0  # prior standard deviation of each spin component (rad/s)
    bounce_velocity_sigma: float = 0.05  # s_b, extra velocity uncertainty per bounce (m/s)
    bounce_spin_sigma: float = 5.0  # s_w, extra spin uncertainty per bounce (rad/s)
    hypothesis_velocity_sigma: float = 1.0  # sigma_h of the bounce hypothesis (m/s)
    hypothesis_spin_sigma: float = 30.0  # s_h of the bounce hypothesis (rad/s)
    gate_probability: float = 0.999  # chi-square gate of the innovation (3 dof)
    init_frames: int = 3
    init_inflation: float = 2.0
    max_rejections: int = 4
    model_dt: float = 1.0 / 120.0  # RK4 step of the propagation model (s): two per 60 Hz frame
    fd_eps: float = 1e-6  # finite-difference step of the Jacobian across a bounce (m, m/s, rad/s)

    def __post_init__(self):
        problems = self.problems()
        if problems:
            raise ValueError("; ".join(problems))

    def problems(self) -> list[str]:
        """What is wrong with the values: noise densities, standard deviations and steps finite
        and > 0 (the filter divides by them or takes their logarithm), gate_probability in
        (0, 1), init_inflation finite and >= 1, init_frames a whole number in [3, 60] (a
        second at 60 Hz) and max_rejections one in [0, 60]."""
        out = []
        for name, value in asdict(self).items():
            if isinstance(value, bool) or not isinstance(value, (int, float)) \
                    or not math.isfinite(value):
                out.append(f"{name} must be a finite number, got {value!r}")
        if out:
            return out
        for name in ("meas_sigma", "accel_noise", "spin_noise", "spin_sigma0",
                     "bounce_velocity_sigma", "bounce_spin_sigma", "hypothesis_velocity_sigma",
                     "hypothesis_spin_sigma", "model_dt", "fd_eps"):
            if not getattr(self, name) > 0.0:
                out.append(f"{name} must be > 0, got {getattr(self, name)}")
        if not 0.0 < self.gate_probability < 1.0:
            out.append(f"gate_probability must be in (0, 1), got {self.gate_probability}")
        if not self.init_inflation >= 1.0:
            out.append(f"init_inflation must be >= 1, got {self.init_inflation}")
        for name, low in (("init_frames", 3), ("max_rejections", 0)):
            value = getattr(self, name)
            if not (isinstance(value, int) and low <= value <= 60):
                out.append(f"{name} must be a whole number in [{low}, 60], got {value!r}")
        return out

    def as_dict(self) -> dict:
        return asdict(self)


#: The spin prior (rad/s) that makes this filter the spinless (p, v) filter (its NEES and
#: estimates agree with it to the last digit shown by eval-predictor on 150 serves).
SPINLESS_PRIOR = 1e-3


def config_from_dict(d: dict) -> EstimatorConfig:
    """The estimator configuration saved with an artefact (``EstimatorConfig.as_dict``). One saved
    before the filter carried spin has no ``spin_sigma0``: it gets :data:`SPINLESS_PRIOR`, so that
    an artefact learnt on the spinless filter's (p, v) estimates (the shipped GPR predictor) is
    fed the same estimates. The numerical settings ``model_dt`` and ``fd_eps`` (which change the
    estimates by ~1e-9) are this code's. Unknown keys, values that are no numbers and values out
    of range (:meth:`EstimatorConfig.problems`) raise ValueError."""
    if not isinstance(d, dict):
        raise ValueError(f"estimator settings must be a mapping, got {type(d).__name__}")
    fields = set(EstimatorConfig.__dataclass_fields__)
    unknown = set(d) - fields
    if unknown:
        raise ValueError(f"unknown estimator settings {sorted(unknown)}")
    kept = {k: v for k, v in d.items() if k not in ("model_dt", "fd_eps")}
    return EstimatorConfig(**{"spin_sigma0": SPINLESS_PRIOR, **kept})


def _as_state9(x) -> tuple[tuple, tuple, tuple]:
    s = [float(c) for c in x]
    w = tuple(s[6:9]) if len(s) >= 9 else (0.0, 0.0, 0.0)
    return tuple(s[0:3]), tuple(s[3:6]), w


def propagate_exact(model: BallModel, x, duration: float, with_bounce_time: bool = False):
    """The state exactly ``duration`` seconds after ``x`` (``(p, v)``: spin zero, or
    ``(p, v, omega)``; the result has the same length), with the model's RK4 flight steps (at
    most ``model.dt``, the last one shortened to land on ``duration``) and its table bounce
    (velocity and spin together) at every impact (``BallModel.table_impact``).
    Returns (state, bounced), or (state, bounced, time of the last impact from the start, NaN if
    none) with ``with_bounce_time``.

    (``BallModel.predict_time`` ends on the first step boundary at or after ``duration``, up to
    one ``dt`` late, which is too coarse for a 60 Hz filter.)"""
    pos, vel, w = _as_state9(x)
    t, t_bounce = 0.0, math.nan
    if starts_in_contact(model, pos, vel):
        vel, w = model.bounce(vel, w)
        t_bounce = 0.0
    while duration - t > 1e-12:
        h = min(model.dt, duration - t)
        new_p, new_v = model.flight_step(pos, vel, w, h)
        impact = model.table_impact(pos, vel, w, h, new_p, new_v)
        if impact is not None:
            th, hp, hv = impact
            hv, w = model.bounce(hv, w)
            pos, vel, t = hp, hv, t + th
            t_bounce = t
            continue
        pos, vel, t = new_p, new_v, t + h
    out = np.array(pos + vel + w) if len(x) >= 9 else np.array(pos + vel)
    if with_bounce_time:
        return out, not math.isnan(t_bounce), t_bounce
    return out, not math.isnan(t_bounce)


def starts_in_contact(model: BallModel, pos: tuple, vel: tuple) -> bool:
    """Whether a state (typically a filter update's) has the ball's centre below the contact
    height ``table_z + R`` but above the surface, over the table and descending: the impact is
    then due at once (``BallModel.table_impact`` only sees a step that starts above the contact
    height, so such a state would otherwise fly through the table)."""
    p = model.params
    contact_z = p.table_z + p.radius
    return (vel[2] < 0.0 and p.table_z < pos[2] < contact_z
            and model.over_table(pos[0], pos[1]))


def propagate_flight_jacobian(model: BallModel, x, duration: float
                              ) -> tuple[np.ndarray, np.ndarray] | None:
    """``propagate_exact``'s state of the 9-state ``x`` (the same steps, so the same numbers) and
    its Jacobian F = df/dx from the variational equation
    (:func:`tt_drake.flight_kernel.variational_flight`, compiled), or None if a table bounce
    happens within ``duration``.

    Without a bounce the acceleration does not depend on the position and the spin is constant,
    so F = [[I, dp/dv0, dp/dw0], [0, dv/dv0, dv/dw0], [0, 0, I]]; dp/dv0 and the spin blocks
    start at 0, dv/dv0 at I."""
    pos, vel, w = _as_state9(x)
    if starts_in_contact(model, pos, vel):
        return None
    p = model.params
    position, velocity, spin = np.array(pos), np.array(vel), np.array(w)
    dp = np.zeros(18)
    dv = np.zeros(18)
    dv[0] = dv[7] = dv[14] = 1.0
    pending = np.empty(42)
    t, contact_z = 0.0, p.table_z + p.radius
    while True:
        status, t, h = variational_flight(position, velocity, spin, dp, dv, t, duration,
                                          model.dt, p.drag_k, p.magnus_cl, p.gravity,
                                          contact_z, pending)
        if status != UNTIL_CONTACT:
            break
        # The step goes down through the contact height: a bounce if it meets the table.
        new_p, new_v = tuple(pending[0:3].tolist()), tuple(pending[3:6].tolist())
        if model.table_impact(tuple(position.tolist()), tuple(velocity.tolist()), w, h,
                              new_p, new_v) is not None:
            return None
        position[:], velocity[:] = pending[0:3], pending[3:6]
        dp[:], dv[:] = pending[6:24], pending[24:42]
        t = t + h
    F = np.eye(N_STATE)
    F[0:3, 3:9] = dp.reshape(3, 6)
    F[3:6, 3:9] = dv.reshape(3, 6)
    return np.concatenate((position, velocity, spin)), F


class BallFlightEKF:
    """The filter of the module docstring. ``step`` once per camera frame.

    The whole filter state packs into a flat vector (:meth:`to_vector` / :meth:`load_vector`), the
    layout the Drake ``BallFlightEstimator`` keeps as its discrete state::

        [status, t, x(9), P(81), rejections, n_init, init buffer (init_frames x 4: t, z),
         last_bounce_t, nis, last_frame_t]

    (``STATE_SLICE`` and ``COVARIANCE_SLICE`` locate x and P; ``last_frame_t`` is last.)
    """

    STATE_SLICE = slice(2, 2 + N_STATE)
    COVARIANCE_SLICE = slice(2 + N_STATE, 2 + N_STATE + N_STATE * N_STATE)

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
        self.x = np.zeros(N_STATE)
        self.P = np.eye(N_STATE)
        self.rejections = 0
        self.buffer: list[tuple[float, np.ndarray]] = []
        self.last_bounce_t = -math.inf
        self.nis = math.nan
        self.last_frame_t = -math.inf

    @property
    def tracking(self) -> bool:
        return self.status == TRACKING

    @property
    def vector_size(self) -> int:
        return 2 + N_STATE + N_STATE**2 + 2 + 4 * self.config.init_frames + 3

    def to_vector(self) -> np.ndarray:
        buf = np.full((self.config.init_frames, 4), np.nan)
        for i, (t, z) in enumerate(self.buffer):
            buf[i, 0] = t
            buf[i, 1:] = z
        return np.concatenate([[self.status, self.t], self.x, self.P.ravel(),
                               [self.rejections, len(self.buffer)], buf.ravel(),
                               [self.last_bounce_t, self.nis, self.last_frame_t]])

    def load_vector(self, v) -> None:
        v = np.asarray(v, dtype=float)
        n = self.config.init_frames
        self.status, self.t = float(v[0]), float(v[1])
        self.x = v[self.STATE_SLICE].copy()
        self.P = v[self.COVARIANCE_SLICE].reshape(N_STATE, N_STATE).copy()
        k = self.COVARIANCE_SLICE.stop
        self.rejections = int(v[k])
        nbuf = int(v[k + 1])
        buf = v[k + 2:k + 2 + 4 * n].reshape(n, 4)
        self.buffer = [(float(buf[i, 0]), buf[i, 1:].copy()) for i in range(nbuf)]
        k += 2 + 4 * n
        self.last_bounce_t, self.nis, self.last_frame_t = (float(v[k]), float(v[k + 1]),
                                                            float(v[k + 2]))

    # -- propagation ----------------------------------------------------------------------------
    def propagate(self, x: np.ndarray, dt: float) -> tuple[np.ndarray, bool]:
        """f(x, dt) with the ball model; also whether a table bounce happened inside dt."""
        return propagate_exact(self.model, x, dt)

    def propagate_with_jacobian(self, x: np.ndarray, dt: float
                                ) -> tuple[np.ndarray, bool, np.ndarray]:
        """(f(x, dt), bounced, F): F from the variational equation in flight, from finite
        differences (:meth:`numerical_jacobian`) when a table bounce happens inside dt."""
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
        n = len(x)
        F = np.empty((n, n))
        for j in range(n):
            xp = x.copy()
            xp[j] += eps
            F[:, j] = (self.propagate(xp, dt)[0] - fx) / eps
        return F

    def noise_terms(self, dt: float, bounced: bool) -> tuple[float, float, float, float]:
        """Q(dt) [+ Q_bounce]'s four values (module docstring): (q dt^3 / 3, q dt^2 / 2,
        q dt [+ s_b^2], q_w dt [+ s_w^2]) on its blocks pp, pv, vv and ww, each times I_3
        (:func:`tt_drake.filter_kernel.add_process_noise` adds them to P)."""
        c = self.config
        q = c.accel_noise
        vv, ww = q * dt, c.spin_noise * dt
        if bounced:
            vv += c.bounce_velocity_sigma**2
            ww += c.bounce_spin_sigma**2
        return q * dt**3 / 3.0, q * dt**2 / 2.0, vv, ww

    def hypothesis_noise(self, dt: float) -> np.ndarray:
        """Q_hyp of the bounce hypothesis (module docstring): a velocity error sigma_h taken at
        most dt ago, and a spin error s_h."""
        c = self.config
        s2 = c.hypothesis_velocity_sigma**2
        Q = np.zeros((N_STATE, N_STATE))
        i3 = np.eye(3)
        Q[:3, :3] = s2 * dt * dt * i3
        Q[:3, 3:6] = Q[3:6, :3] = s2 * dt * i3
        Q[3:6, 3:6] = s2 * i3
        Q[6:9, 6:9] = c.hypothesis_spin_sigma**2 * i3
        return Q

    def near_bounce(self, t: float, dt: float) -> bool:
        """Whether the bounce hypothesis applies at ``t`` (after :meth:`predict`): a predicted
        impact in this interval or the one before, or the ball descending over the table within
        one frame's travel plus three standard deviations of the contact height."""
        if t - self.last_bounce_t <= 2.0 * dt + 1e-9:
            return True
        p = self.model.params
        x = self.x
        if x[5] >= 0.0:
            return False
        margin = 0.1
        if abs(x[0]) > p.table_half_width + margin or abs(x[1]) > p.table_half_length + margin:
            return False
        height = x[2] - (p.table_z + p.radius)
        return height < -x[5] * dt + 3.0 * (math.sqrt(self.P[2, 2]) + self.config.meas_sigma)

    def unscented_propagate(self, x: np.ndarray, P: np.ndarray, dt: float
                            ) -> tuple[np.ndarray, np.ndarray, bool, float]:
        """The unscented transform of (x, P) through f(., dt): sigma points
        chi_(+-j) = x +- (sqrt(n P))_j (n = 9, the columns of a Cholesky factor, equal weights
        1 / 2n), x- = sum w f(chi), P_f = sum w (f(chi) - x-)(f(chi) - x-)^T. Returns
        (x-, P_f, whether f(x) bounces, the impact time after the start or NaN).

        Used across the table bounce, where f switches between sliding and rolling contact and
        between bouncing before or after the frame: a Jacobian at the mean (finite differences)
        is blind to a switch the uncertainty allows, and the spin learnt from the rebound was
        then overconfident (e.g. a serve whose mean spin predicted rolling while the true one
        slid kept a 70 rad/s error with a 6 rad/s standard deviation)."""
        n = len(x)
        try:
            L = np.linalg.cholesky(n * P)
        except np.linalg.LinAlgError:
            vals, vecs = np.linalg.eigh(0.5 * (P + P.T))
            L = vecs * np.sqrt(np.clip(n * vals, 0.0, None))
        _, bounced, t_bounce = propagate_exact(self.model, x, dt, with_bounce_time=True)
        ys = np.empty((2 * n, n))
        for j in range(n):
            ys[2 * j] = propagate_exact(self.model, x + L[:, j], dt)[0]
            ys[2 * j + 1] = propagate_exact(self.model, x - L[:, j], dt)[0]
        mean = ys.mean(axis=0)
        d = ys - mean
        return mean, d.T @ d / (2 * n), bounced, t_bounce

    def predict(self, t: float) -> None:
        """x-, P- at ``t``: the variational Jacobian in flight; the unscented transform
        (:meth:`unscented_propagate`) when the bounce falls within dt, or may (the ball
        descending over the table and predicted within three standard deviations of the
        contact height at ``t``)."""
        dt = t - self.t
        if dt <= 0.0:
            return
        flight = propagate_flight_jacobian(self.model, self.x, dt)
        bounced = False
        if flight is not None:
            fx, F = flight
            P = F @ self.P @ F.T
            if self._may_bounce(fx, P):
                flight = None
        if flight is None:
            fx, P, bounced, t_bounce = self.unscented_propagate(self.x, self.P, dt)
            if bounced:
                self.last_bounce_t = self.t + t_bounce
        self.x = fx
        self.P = np.empty((N_STATE, N_STATE))
        add_process_noise(np.ascontiguousarray(P), *self.noise_terms(dt, bounced), self.P)
        self.t = t

    def _may_bounce(self, x: np.ndarray, P: np.ndarray) -> bool:
        p = self.model.params
        return (x[5] < 0.0 and self.model.over_table(x[0], x[1])
                and x[2] - 3.0 * math.sqrt(P[2, 2]) < p.table_z + p.radius)

    # -- measurement update ---------------------------------------------------------------------
    def update(self, z, dt: float | None = None) -> bool:
        """Gate and fuse one position measurement; returns whether it was accepted. ``dt``: the
        prediction interval just before (enables the bounce hypothesis; None: plain gate)."""
        z = np.asarray(z, dtype=float)
        y = z - self.x[:3]
        S = self.P[:3, :3] + self.R
        Sinv = np.linalg.inv(S)
        d2 = float(y @ Sinv @ y)
        self.nis = d2
        if d2 > self.gate and dt is not None and (self.rejections > 0
                                                   or self.near_bounce(self.t, dt)):
            P_hyp = self.P + self.hypothesis_noise(dt)
            S_hyp = P_hyp[:3, :3] + self.R
            Sinv_hyp = np.linalg.inv(S_hyp)
            d2_hyp = float(y @ Sinv_hyp @ y)
            if d2_hyp <= self.gate:
                self.P, Sinv, d2 = P_hyp, Sinv_hyp, d2_hyp
        if d2 > self.gate:
            self.rejections += 1
            if self.rejections >= self.config.max_rejections:
                self.reset_track()
            return False
        self.rejections = 0
        K = self.P[:, :3] @ Sinv
        self.x = self.x + K @ y
        IKH = np.eye(N_STATE)
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
                self.x = np.concatenate([coef[0], coef[1], np.zeros(3)])
                cov = c.init_inflation * c.meas_sigma**2 * AtA_inv
                P = np.zeros((N_STATE, N_STATE))
                for k in range(3):
                    P[np.ix_([k, k + 3], [k, k + 3])] = cov
                P[6:9, 6:9] = c.spin_sigma0**2 * np.eye(3)
                self.P = P
                self.t = float(ts[-1])
                self.status = TRACKING
                self.rejections = 0
                self.buffer = []
                self.last_bounce_t = -math.inf
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
            dt = t - self.t
            self.predict(t)
            if z is not None:
                self.update(z, dt)
            return self.tracking
        if z is not None:
            self.buffer.append((float(t), np.asarray(z, dtype=float).copy()))
            if len(self.buffer) > self.config.init_frames:
                self.buffer.pop(0)
            self._try_initialise()
        return self.tracking


@dataclass
class FilterRun:
    """Offline filter output at every frame: state (F, 6: p, v), its covariance (F, 6, 6), the
    spin (F, 3), the full 9-state covariance (F, 9, 9) and tracking (F,)."""

    times: np.ndarray
    states: np.ndarray
    covariances: np.ndarray
    tracking: np.ndarray
    spins: np.ndarray | None = None
    full_covariances: np.ndarray | None = None


def run_filter(times, measurements, config: EstimatorConfig | None = None,
               model_params: BallModelParams | None = None, stop=None) -> FilterRun:
    """Run the filter over frames (``times`` (F,), ``measurements`` (F, 3) with NaN rows for
    dropped frames) exactly as the Drake system does. ``stop(i, ekf)`` may end the run early
    (returning True after frame i is processed); unprocessed rows are NaN."""
    ekf = BallFlightEKF(config, model_params)
    n = len(times)
    states = np.full((n, 6), np.nan)
    spins = np.full((n, 3), np.nan)
    covs = np.full((n, N_STATE, N_STATE), np.nan)
    tracking = np.zeros(n, dtype=bool)
    for i in range(n):
        z = measurements[i]
        ekf.step(float(times[i]), None if np.isnan(z[0]) else z)
        if ekf.tracking:
            states[i] = ekf.x[:6]
            spins[i] = ekf.x[6:9]
            covs[i] = ekf.P
            tracking[i] = True
        if stop is not None and stop(i, ekf):
            break
    return FilterRun(np.asarray(times, dtype=float), states, covs[:, :6, :6].copy(), tracking,
                     spins, covs)


def nees(errors: np.ndarray, covariances: np.ndarray) -> np.ndarray:
    """Normalised estimation error squared e^T P^-1 e per row (chi-square with as many dof as
    the state has entries, if the filter is consistent)."""
    return np.einsum("ni,ni->n", errors, np.linalg.solve(covariances, errors[..., None])[..., 0])
