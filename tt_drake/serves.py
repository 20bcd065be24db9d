"""Serve distributions of the ball launcher: ``default``, ``real`` and ``fixed``.

A serve is the ball's launch state ``(p, v, omega)`` (9 floats, world frame). Every serve is drawn
from a ``numpy.random.Generator`` seeded per episode, so any episode can be replayed.

- ``default``: a launcher 0.2 m behind the opponent's table edge and 0.15 m above the surface (the
  MPI lab's ball gun, facts.md section 2). Its lateral position x0 and launch velocity are drawn
  uniformly from a band that contains every valid serve (:func:`default_proposal`), and a draw is
  kept only if the ball model predicts one bounce on the robot's half, net clearance, and a
  crossing of the virtual hitting plane inside :data:`HITTING_REGION`.
- ``real``: real serves measured right after a human or robot hit, from
  google-deepmind/competitive_robot_table_tennis (``serves.json``, CC-BY 4.0, Copyright 2025 Google
  LLC; D'Ambrosio et al., "Achieving Human Level Competitive Robot Table Tennis", ICRA 2025), kept
  when the ball model predicts that the ball bounces once on the robot's half and crosses the
  hitting plane inside the (slightly enlarged) hitting region. Their frame's origin is the table
  surface centre, so z is shifted by the table height.
- ``fixed``: one repeatable serve for debugging.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tt_drake.ball_model import BallModel, PlaneCrossing
from tt_drake.constants import BALL, HITTING_REGION, PLANES, TABLE

DISTRIBUTIONS = ("default", "real", "fixed")

#: Launch position of the ``fixed`` serve and the centre of the ``default`` launcher (m).
LAUNCHER_Y = TABLE.opponent_edge_y + 0.2
LAUNCHER_Z = TABLE.surface_z + 0.15
FIXED_SERVE = (0.1, LAUNCHER_Y, LAUNCHER_Z, 0.25, -5.2, 3.0, 0.0, 0.0, 0.0)

#: The ``default`` launcher's lateral range (m) and forward launch speed range (m/s).
DEFAULT_X_RANGE = (-0.4, 0.6)
DEFAULT_VY_RANGE = (-8.0, -3.2)


def default_proposal(rng: np.random.Generator, x_range=DEFAULT_X_RANGE,
                     vy_range=DEFAULT_VY_RANGE) -> tuple[float, float, float, float]:
    """Draw (x0, vx, vy, vz) for a ``default`` serve candidate; x0 uniform in ``x_range``, vy
    uniform in ``vy_range`` (a scenario's ``launcher.x_range`` and ``vy_range`` may narrow the
    defaults: the band below was measured inside them), vz and vx in the band at (x0, vy).

    The band was measured by rejection sampling a wide box (x0 in [-0.4, 0.6], v in
    [-1.5, 1.5] x [-8, -3] x [1, 6] m/s; 9.5 % kept): valid serves have v_z between two quadratics
    in v_y and v_x within 1 m/s of 0.44 - 1.46 x0. The band adds 0.2 m/s margins, so it keeps every
    valid serve of the box while about half of its draws are kept.
    """
    x0 = rng.uniform(*x_range)
    vy = rng.uniform(*vy_range)
    vz_low = 0.1789 * vy * vy + 2.7767 * vy + 12.0666 - 0.2
    vz_high = 0.1311 * vy * vy + 2.3208 * vy + 12.2732 + 0.2
    vz = rng.uniform(vz_low, vz_high)
    vx_mid = 0.44 - 1.46 * x0
    vx = rng.uniform(max(-1.5, vx_mid - 1.1), min(1.5, vx_mid + 1.1))
    return x0, vx, vy, vz


class ServeError(ValueError):
    """A serve distribution cannot be used (unknown name, missing or malformed data file)."""


@dataclass(frozen=True)
class Serve:
    """One serve: the launch state and the model's prediction of its flight."""

    launch_state: np.ndarray  # (9,) p, v, omega
    crossing: PlaneCrossing  # at the virtual hitting plane
    source_id: int = -1  # index into serves.json for ``real`` serves

    @property
    def bounce_y(self) -> float:
        return float(self.crossing.bounces[-1].position[1])


#: Net clearance (m) a served ball must have in the model: the net's collision box is 20 mm
#: thick and the model sees a plane, so a ball grazing within a centimetre touches it in Drake.
NET_MARGIN = 0.01
#: A served ball must bounce at least this far inside the table's edges: nearer, it meets the
#: edge of the table top (an "edge ball", contact normal not vertical) and bounces otherwise.
EDGE_MARGIN = BALL.radius


def serve_is_valid(model: BallModel, state: np.ndarray, region_margin: float = 0.0):
    """The model's crossing if the serve bounces exactly once on the robot's half (after any
    bounces on the opponent's half) at least :data:`EDGE_MARGIN` inside the table's edges, clears
    the net by :data:`NET_MARGIN` and crosses the hitting plane inside the region (grown by
    ``region_margin``); otherwise None."""
    crossing = model.predict_plane(state, PLANES.hitting_y)
    if crossing is None:
        return None
    robot_half = [b for b in crossing.bounces if b.position[1] < 0.0]
    if len(robot_half) != 1 or crossing.bounces[-1] is not robot_half[0]:
        return None
    x_b, y_b = robot_half[0].position[0], robot_half[0].position[1]
    if (abs(x_b) > 0.5 * TABLE.width - EDGE_MARGIN
            or abs(y_b) > 0.5 * TABLE.length - EDGE_MARGIN):
        return None
    if state[1] > 0.0:
        clearance = model.net_clearance(state)
        if clearance is None or clearance < NET_MARGIN:
            return None
    x, z = crossing.position[0], crossing.position[2]
    r = HITTING_REGION
    m = region_margin
    if not (r.x_min - m <= x <= r.x_max + m and r.z_min - m <= z <= r.z_max + m):
        return None
    return crossing


def real_serves_path() -> Path:
    """Where ``serves.json`` is read from: $TT_DRAKE_SERVES, else the copy shipped in
    ``tt_drake/data`` (:func:`tt_drake.data.ball_states_path`)."""
    from tt_drake.data import ball_states_path

    return ball_states_path("serves")


def load_real_states(path: Path | None = None) -> np.ndarray:
    """All real serve states from ``serves.json`` as an (N, 9) array in the world frame."""
    path = Path(path) if path is not None else real_serves_path()
    try:
        records = json.loads(path.read_text())
    except FileNotFoundError:
        raise ServeError(f"real serves file not found: {path} (set TT_DRAKE_SERVES)") from None
    except (OSError, json.JSONDecodeError) as err:
        raise ServeError(f"cannot read real serves file {path}: {err}") from None
    keys = ("pos_x", "pos_y", "pos_z", "vel_x", "vel_y", "vel_z", "w_vel_x", "w_vel_y", "w_vel_z")
    try:
        states = np.array([[float(r[k]) for k in keys] for r in records])
    except (KeyError, TypeError, ValueError) as err:
        raise ServeError(f"malformed real serves file {path}: {err}") from None
    if states.shape[0] == 0:
        raise ServeError(f"real serves file {path} holds no serves")
    states[:, 2] += TABLE.surface_z
    return states


class ServeSampler:
    """Draws serves of one distribution; ``sample(seed)`` is a pure function of the seed."""

    def __init__(self, distribution: str = "default", spin_max: float = 0.0,
                 real_path: Path | None = None, model: BallModel | None = None,
                 x_range=DEFAULT_X_RANGE, vy_range=DEFAULT_VY_RANGE):
        if distribution not in DISTRIBUTIONS:
            raise ServeError(
                f"unknown serve distribution {distribution!r}; choose one of {DISTRIBUTIONS}")
        if spin_max < 0.0:
            raise ServeError(f"spin_max must be >= 0, got {spin_max}")
        self.distribution = distribution
        self.spin_max = spin_max
        self.x_range = (float(x_range[0]), float(x_range[1]))
        self.vy_range = (float(vy_range[0]), float(vy_range[1]))
        self.model = model or BallModel(dt=8e-3)  # RK4: 8 ms steps agree with 1 ms to 1e-8 m
        self._real: list[tuple[int, np.ndarray, PlaneCrossing]] | None = None
        self._real_path = real_path

    def real_pool(self) -> list[tuple[int, np.ndarray, PlaneCrossing]]:
        """The real serves that qualify (computed once): (id, state, crossing)."""
        if self._real is None:
            pool = []
            for i, state in enumerate(load_real_states(self._real_path)):
                crossing = serve_is_valid(self.model, state, region_margin=0.1)
                if crossing is not None:
                    pool.append((i, state, crossing))
            if not pool:
                raise ServeError("no real serve reaches the robot's hitting region")
            self._real = pool
        return self._real

    def sample(self, seed: int) -> Serve:
        rng = np.random.default_rng(seed)
        if self.distribution == "fixed":
            state = np.array(FIXED_SERVE, dtype=float)
            crossing = self.model.predict_plane(state, PLANES.hitting_y)
            return Serve(state, crossing)
        if self.distribution == "real":
            pool = self.real_pool()
            i, state, crossing = pool[int(rng.integers(len(pool)))]
            return Serve(state.copy(), crossing, source_id=i)
        for _ in range(1000):
            x0, vx, vy, vz = default_proposal(rng, self.x_range, self.vy_range)
            w = rng.uniform(-self.spin_max, self.spin_max, 3) if self.spin_max > 0 else np.zeros(3)
            state = np.array([x0, LAUNCHER_Y, LAUNCHER_Z, vx, vy, vz, *w])
            crossing = serve_is_valid(self.model, state)
            if crossing is not None:
                return Serve(state, crossing)
        raise ServeError("no valid serve found in 1000 draws; check the serve configuration")
