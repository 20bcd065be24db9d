"""Serve distributions of the ball launcher; the pools of real balls and their splits.

A serve is the ball's launch state ``(p, v, omega)`` (9 floats, world frame). Every serve is drawn
from a ``numpy.random.Generator`` seeded per episode, so any episode can be replayed
(docs/serves.md).

- ``default``: a launcher 0.2 m behind the opponent's table edge and 0.15 m above the surface (the
  MPI lab's ball gun, docs/constants.md). Its lateral position x0 and launch velocity are drawn
  uniformly from a band that contains every valid serve (:func:`default_proposal`), and a draw is
  kept only if the ball model predicts one bounce on the robot's half, net clearance, and a
  crossing of the virtual hitting plane inside :data:`HITTING_REGION`. With ``spin_max`` > 0 each
  spin component is drawn uniformly from [-spin_max, spin_max] rad/s.
- ``spin``: the ``default`` launcher with spin drawn per axis uniformly from
  [-spin_max, spin_max]; ``spin_max`` = 0 (the launcher's default) means
  :data:`SPIN_DEFAULT` = 100 rad/s.
- ``real``: real serves measured right after a human or robot hit, from
  google-deepmind/competitive_robot_table_tennis (``serves.json``, CC-BY 4.0, Copyright 2025 Google
  LLC; D'Ambrosio et al., "Achieving Human Level Competitive Robot Table Tennis", ICRA 2025):
  every serve that the ball model predicts to reach the robot's half (:func:`reaches_robot_half`),
  wherever it then crosses the hitting plane. Their frame's origin is the table surface centre,
  so z is shifted by the table height. ``real-train`` / ``real-test``: the split by serve id
  (:func:`split_of`, test about 30 %).
- ``rally``, ``rally-train``, ``rally-test``: the same for ``rallies.json`` (ball states right after
  a hit in a real rally), keeping the balls hit toward the robot.
- ``fixed``: one repeatable serve for debugging.

The pool distributions draw uniformly from their pool, except within a run: serve i of a run with
base seed ``run_seed`` (episode seed ``episode_seed(run_seed, i)``) takes element i of a
permutation of the pool keyed by ``run_seed``, so a run of fewer serves than the pool never
repeats one.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tt_drake.ball_model import BallModel, PlaneCrossing
from tt_drake.constants import BALL, HITTING_REGION, PLANES, TABLE
from tt_drake.data import ball_states_path
from tt_drake.errors import BadInputError
from tt_drake.seeds import episode_seed

#: The real-ball pools: distribution prefix -> the ball-state file (:mod:`tt_drake.data`).
POOLS = {"real": "serves", "rally": "rallies"}
SPLITS = ("train", "test")
DISTRIBUTIONS = ("default", "spin",
                 *(f"{pool}{suffix}" for pool in POOLS for suffix in ("", "-train", "-test")),
                 "fixed")

#: Pools already simulated in this process, by file, split and flight model: a diagram built
#: for each batch of rollouts (``tt-drake reproduce``) would otherwise fly every ball of the file
#: again (measured under load: 60 s for ``rally-train``, 19 s for ``real-train``). Forked worker
#: processes inherit the parent's.
_POOL_CACHE: dict[tuple, list] = {}

#: Spin per axis (rad/s) of the ``spin`` distribution when the launcher's ``spin_max`` is 0.
SPIN_DEFAULT = 100.0
#: Percentage of the records in the ``-test`` split (:func:`split_of`).
TEST_PERCENT = 30

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



class ServeError(ValueError, BadInputError):
    """A serve distribution cannot be used (unknown name, missing or malformed data file)."""


@dataclass(frozen=True)
class Serve:
    """One serve: the launch state and the model's prediction of its flight."""

    launch_state: np.ndarray  # (9,) p, v, omega
    #: At the virtual hitting plane; for a pool serve that does not reach the plane, where its
    #: approach ends instead (:func:`reaches_robot_half`).
    crossing: PlaneCrossing
    source_id: int = -1  # the record's id in its ball-state file, for pool serves

    @property
    def bounce_y(self) -> float:
        return float(self.crossing.bounces[-1].position[1])


#: Net clearance (m) a served ball must have in the model: the net's collision box is 20 mm
#: thick and the model sees a plane, so a ball grazing within a centimetre touches it in Drake.
NET_MARGIN = 0.01
#: A served ball must bounce at least this far inside the table's edges: nearer, it meets the
#: edge of the table top (an "edge ball", contact normal not vertical) and bounces otherwise.
EDGE_MARGIN = BALL.radius
#: A pool ball's approach ends where it crosses the hitting plane, or where its centre falls to
#: this height (m) first (below the table top, beyond the robot's reach).
FLOOR_STOP_Z = 0.1


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
    if not _inside_edges(robot_half[0].position):
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


def _inside_edges(position) -> bool:
    return (abs(position[0]) <= 0.5 * TABLE.width - EDGE_MARGIN
            and abs(position[1]) <= 0.5 * TABLE.length - EDGE_MARGIN)


def approach_end(model: BallModel, state, max_time: float = 3.0) -> PlaneCrossing | None:
    """The ball's state where it crosses the virtual hitting plane or, if it falls first, where
    its centre drops to :data:`FLOOR_STOP_Z`; with every table bounce on the way. None if neither
    happens within ``max_time``."""
    s = np.asarray(state, dtype=float).reshape(-1)
    side = 1.0 if s[1] > PLANES.hitting_y else -1.0

    def stop(_t, q, _v):
        return min(side * (q[1] - PLANES.hitting_y), q[2] - FLOOR_STOP_Z)

    return model.advance(s, stop, max_time)  # the event-located integration of predict_plane


def reaches_robot_half(model: BallModel, state) -> PlaneCrossing | None:
    """Where a real ball's approach ends (:func:`approach_end`) if the model predicts that it
    reaches the robot's half: it starts on the opponent's half moving toward the robot, clears
    the net by :data:`NET_MARGIN` and its first bounce on the robot's half is at least
    :data:`EDGE_MARGIN` inside the table's edges (it may bounce there again: a short ball);
    otherwise None. It need not cross the hitting plane, nor inside the hitting region."""
    s = np.asarray(state, dtype=float)
    if not (s[1] > 0.0 and s[4] < 0.0):
        return None
    end = approach_end(model, s)
    if end is None:
        return None
    robot_half = [b for b in end.bounces if b.position[1] < 0.0]
    if not robot_half or not _inside_edges(robot_half[0].position):
        return None
    clearance = model.net_clearance(s)
    if clearance is None or clearance < NET_MARGIN:
        return None
    return end


def split_of(record_id: int) -> str:
    """The split of a real ball by its id: ``test`` when the SHA-256 digest of the id's decimal
    string, read as a big-endian integer, is below :data:`TEST_PERCENT` modulo 100, else
    ``train``. Fixed forever: it depends on the id alone, not on the file's order or size."""
    digest = hashlib.sha256(str(int(record_id)).encode()).digest()
    return "test" if int.from_bytes(digest, "big") % 100 < TEST_PERCENT else "train"


def real_serves_path() -> Path:
    """Where ``serves.json`` is read from: $TT_DRAKE_SERVES, else the copy shipped in
    ``tt_drake/data`` (:func:`tt_drake.data.ball_states_path`)."""
    return ball_states_path("serves")


_STATE_KEYS = ("pos_x", "pos_y", "pos_z", "vel_x", "vel_y", "vel_z",
               "w_vel_x", "w_vel_y", "w_vel_z")


#: The largest ball-state file read (bytes): the shipped ones hold 0.8 and 3.7 MB (about 200
#: bytes a ball); reading stops past this, so a huge or endless file ($TT_DRAKE_SERVES=/dev/zero)
#: is one line, not an exhausted memory.
MAX_BALL_STATE_BYTES = 64 << 20


def load_ball_states(path: Path) -> tuple[np.ndarray | None, np.ndarray]:
    """The records of a ball-state file (``serves.json`` or ``rallies.json``, at most
    :data:`MAX_BALL_STATE_BYTES`): their ids (None if the file has none) and their states as an
    (N, 9) array in the world frame."""
    path = Path(path)
    try:
        with open(path, "rb") as f:
            data = f.read(MAX_BALL_STATE_BYTES + 1)
        if len(data) > MAX_BALL_STATE_BYTES:
            raise ServeError(f"ball-state file {path} is larger than {MAX_BALL_STATE_BYTES} "
                             "bytes")
        records = json.loads(data.decode("utf-8"))
    except FileNotFoundError:
        raise ServeError(f"ball-state file not found: {path} (set TT_DRAKE_SERVES or "
                         "TT_DRAKE_RALLIES)") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise ServeError(f"cannot read ball-state file {path}: {err}") from None
    try:
        states = np.array([[float(r[k]) for k in _STATE_KEYS] for r in records], dtype=float)
    except (KeyError, TypeError, ValueError) as err:
        raise ServeError(f"malformed ball-state file {path}: {err}") from None
    if states.shape[0] == 0:
        raise ServeError(f"ball-state file {path} holds no balls")
    if not np.all(np.isfinite(states)):
        raise ServeError(f"malformed ball-state file {path}: a state is not finite")
    with_id = sum(isinstance(r, dict) and "id" in r for r in records)
    ids = None
    if with_id:
        if with_id != len(records):
            raise ServeError(f"malformed ball-state file {path}: {len(records) - with_id} of "
                             f"{len(records)} records have no id")
        try:
            ids = np.array([int(r["id"]) for r in records])
        except (TypeError, ValueError) as err:
            raise ServeError(f"malformed ball-state file {path}: an id is not a whole number: "
                             f"{err}") from None
        if len(set(ids.tolist())) != len(ids):
            raise ServeError(f"malformed ball-state file {path}: ids repeat")
    states[:, 2] += TABLE.surface_z
    return ids, states


def load_real_states(path: Path | None = None) -> np.ndarray:
    """All real serve states from ``serves.json`` as an (N, 9) array in the world frame."""
    return load_ball_states(Path(path) if path is not None else real_serves_path())[1]


@dataclass(frozen=True)
class PoolBall:
    """A real ball of a pool: its record's id, launch state and approach (:class:`Serve`)."""

    id: int
    state: np.ndarray
    crossing: PlaneCrossing


def parse_distribution(distribution: str) -> tuple[str, str | None]:
    """(pool or distribution name, split or None): ``real-test`` -> (``real``, ``test``)."""
    if distribution not in DISTRIBUTIONS:
        raise ServeError(f"unknown serve distribution {distribution!r}; choose one of "
                         f"{', '.join(DISTRIBUTIONS)}")
    name, _, split = distribution.partition("-")
    return name, split or None


class ServeSampler:
    """Draws serves of one distribution; ``sample(seed)`` is a pure function of the seed and the
    sampler's configuration.

    ``spin_max``: rad/s per spin component; 0 means the distribution's default (none for
    ``default``, :data:`SPIN_DEFAULT` for ``spin``; pools and ``fixed`` ignore it). ``run_seed``:
    the base seed of the run being served (-1: none); a pool serve whose episode seed is
    ``episode_seed(run_seed, i)`` with i below the pool's size takes the pool's element
    ``permutation(run_seed)[i]`` (no serve twice in a run), any other seed a uniform draw."""

    def __init__(self, distribution: str = "default", spin_max: float = 0.0,
                 real_path: Path | None = None, model: BallModel | None = None,
                 rally_path: Path | None = None, run_seed: int = -1,
                 x_range=DEFAULT_X_RANGE, vy_range=DEFAULT_VY_RANGE):
        self.kind, self.split = parse_distribution(distribution)
        if not spin_max >= 0.0:
            raise ServeError(f"spin_max must be >= 0 rad/s, got {spin_max}")
        self.distribution = distribution
        self.spin_max = (SPIN_DEFAULT if self.kind == "spin" and spin_max == 0.0
                         else float(spin_max))
        self.x_range = (float(x_range[0]), float(x_range[1]))
        self.vy_range = (float(vy_range[0]), float(vy_range[1]))
        self.model = model or BallModel(dt=8e-3)  # RK4: 8 ms steps agree with 1 ms to 1e-8 m
        self.run_seed = int(run_seed)
        self._paths = {"real": real_path, "rally": rally_path}
        self._pool: list[PoolBall] | None = None
        self._deal: dict[int, int] | None = None

    def data_path(self) -> Path | None:
        """The ball-state file of a pool distribution (None for the others)."""
        if self.kind not in POOLS:
            return None
        if self._paths[self.kind]:
            return Path(self._paths[self.kind])

        return ball_states_path(POOLS[self.kind])

    def records(self) -> tuple[np.ndarray, np.ndarray]:
        """(ids, states) of the pool's file in its split, before the robot's-half filter; a
        file without ids numbers its records 0..N-1 and cannot be split."""
        path = self.data_path()
        ids, states = load_ball_states(path)
        if ids is None:
            if self.split is not None:
                raise ServeError(f"{path} has no record ids, so it has no {self.split} split: "
                                 f"use --distribution {self.kind}")
            ids = np.arange(len(states))
        if self.split is not None:
            keep = np.array([split_of(i) == self.split for i in ids], dtype=bool)
            ids, states = ids[keep], states[keep]
        return ids, states

    def check(self) -> None:
        """Fail now (ServeError, one line) if the distribution's data file is unusable; cheap:
        the file is read, the pool is not simulated."""
        if self.kind in POOLS:
            self.records()

    def pool(self) -> list[PoolBall]:
        """The pool's balls that reach the robot's half (computed once, in file order)."""
        if self.kind not in POOLS:
            raise ServeError(f"the {self.distribution} distribution has no pool")
        if self._pool is None:
            path = self.data_path()
            key = (str(path), path.stat().st_mtime_ns, self.split, type(self.model).__name__,
                   self.model.params, self.model.dt)
            if key not in _POOL_CACHE:
                ids, states = self.records()
                pool = []
                for i, state in zip(ids, states, strict=True):
                    crossing = reaches_robot_half(self.model, state)
                    if crossing is not None:
                        pool.append(PoolBall(int(i), state, crossing))
                if not pool:
                    raise ServeError(f"no ball of {path} ({self.distribution}) reaches the "
                                     "robot's half")
                _POOL_CACHE[key] = pool
            self._pool = _POOL_CACHE[key]
        return self._pool

    def real_pool(self) -> list[tuple[int, np.ndarray, PlaneCrossing]]:
        """The pool as (id, state, crossing) tuples."""
        return [(b.id, b.state, b.crossing) for b in self.pool()]

    def pool_index(self, seed: int) -> int:
        """Which element of the pool the episode ``seed`` serves (class docstring)."""
        n = len(self.pool())
        if self.run_seed >= 0:
            if self._deal is None:
                order = np.random.default_rng(self.run_seed).permutation(n)
                self._deal = {episode_seed(self.run_seed, i): int(order[i]) for i in range(n)}
            if seed in self._deal:
                return self._deal[seed]
        return int(np.random.default_rng(seed).integers(n))

    def sample(self, seed: int) -> Serve:
        if self.kind == "fixed":
            state = np.array(FIXED_SERVE, dtype=float)
            crossing = self.model.predict_plane(state, PLANES.hitting_y)
            return Serve(state, crossing)
        if self.kind in POOLS:
            ball = self.pool()[self.pool_index(seed)]
            return Serve(ball.state.copy(), ball.crossing, source_id=ball.id)
        rng = np.random.default_rng(seed)
        for _ in range(1000):
            x0, vx, vy, vz = default_proposal(rng, self.x_range, self.vy_range)
            w = rng.uniform(-self.spin_max, self.spin_max, 3) if self.spin_max > 0 else np.zeros(3)
            state = np.array([x0, LAUNCHER_Y, LAUNCHER_Z, vx, vy, vz, *w])
            crossing = serve_is_valid(self.model, state)
            if crossing is not None:
                return Serve(state, crossing)
        raise ServeError("no valid serve found in 1000 draws; check the serve configuration")


def serve_sampler(config) -> ServeSampler:
    """The sampler that draws the serves of a launcher configuration
    (:class:`tt_drake.systems.ball_launcher.LauncherConfig`: distribution, spin_max, data
    files, run_seed and the default launcher's ranges): episode seed -> launch state, as the
    launcher draws them."""
    return ServeSampler(config.distribution, config.spin_max, config.real_serves or None,
                        rally_path=config.rallies or None, run_seed=config.run_seed,
                        x_range=config.x_range, vy_range=config.vy_range)


def pool_counts(distribution: str, real_path: Path | None = None,
                rally_path: Path | None = None) -> dict:
    """How many balls a pool distribution's file holds, in its split, and in its pool (those
    that reach the robot's half); for ``tt-drake serves --info``."""
    sampler = ServeSampler(distribution, real_path=real_path, rally_path=rally_path)
    if sampler.kind not in POOLS:
        return {"distribution": distribution, "pool": None}
    ids, _ = sampler.records()
    _, all_states = load_ball_states(sampler.data_path())
    return {"distribution": distribution, "file": str(sampler.data_path()),
            "records": int(len(all_states)), "in_split": int(len(ids)),
            "pool": len(sampler.pool())}
