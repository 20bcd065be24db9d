"""Serve distributions: reproducibility, validity and coverage of the hitting region."""

import json
import time

import numpy as np
import pytest

from tt_drake.ball_model import BallModel
from tt_drake.constants import HITTING_REGION, PLANES
from tt_drake.seeds import episode_seed
from tt_drake.serves import (
    LAUNCHER_Y,
    SPIN_DEFAULT,
    TEST_PERCENT,
    ServeError,
    ServeSampler,
    load_real_states,
    reaches_robot_half,
    split_of,
)


def test_same_seed_gives_the_same_serve_and_different_seeds_differ():
    sampler = ServeSampler("default")
    a, b, c = sampler.sample(7), ServeSampler("default").sample(7), sampler.sample(8)
    np.testing.assert_array_equal(a.launch_state, b.launch_state)
    assert not np.allclose(a.launch_state, c.launch_state)


def test_default_serves_bounce_once_on_the_robot_half_and_cover_the_region():
    sampler = ServeSampler("default")
    serves = [sampler.sample(seed) for seed in range(1000)]
    crossings = np.array([s.crossing.position for s in serves])
    for s in serves:
        assert len(s.crossing.bounces) == 1
        assert -1.37 <= s.bounce_y <= 0.0
    assert np.allclose(crossings[:, 1], PLANES.hitting_y)
    r = HITTING_REGION
    assert np.all((crossings[:, 0] >= r.x_min) & (crossings[:, 0] <= r.x_max))
    assert np.all((crossings[:, 2] >= r.z_min) & (crossings[:, 2] <= r.z_max))
    # Coverage: every cell of a 4 x 3 grid over the region is reached.
    ix = np.minimum(((crossings[:, 0] - r.x_min) / (r.x_max - r.x_min) * 4).astype(int), 3)
    iz = np.minimum(((crossings[:, 2] - r.z_min) / (r.z_max - r.z_min) * 3).astype(int), 2)
    assert len(set(zip(ix, iz, strict=True))) == 12


def test_spin_is_optional_and_bounded():
    serve = ServeSampler("default", spin_max=50.0).sample(3)
    assert np.all(np.abs(serve.launch_state[6:9]) <= 50.0)
    assert np.any(serve.launch_state[6:9] != 0.0)
    assert np.all(ServeSampler("default").sample(3).launch_state[6:9] == 0.0)


def test_fixed_serve_is_always_the_same():
    sampler = ServeSampler("fixed")
    np.testing.assert_array_equal(sampler.sample(1).launch_state, sampler.sample(2).launch_state)


def test_real_serves_load_in_the_world_frame():
    states = load_real_states()
    assert states.shape == (2704, 9)
    # Serves travel toward the robot (-y) and start above the table surface (z shifted by 0.76).
    assert np.median(states[:, 4]) < -3.0
    assert np.all(states[:, 2] > 0.76)


def test_unknown_distribution_and_bad_files_fail_clearly(tmp_path):
    with pytest.raises(ServeError, match="unknown serve distribution 'lob'"):
        ServeSampler("lob")
    with pytest.raises(ServeError, match="not found"):
        load_real_states(tmp_path / "missing.json")
    bad = tmp_path / "bad.json"
    bad.write_text("[{\"pos_x\": 1}]")
    with pytest.raises(ServeError, match="malformed"):
        load_real_states(bad)
    bad.write_text("{not json")
    with pytest.raises(ServeError, match="cannot read"):
        load_real_states(bad)
    (tmp_path / "ok.json").write_text(json.dumps([]))
    with pytest.raises(ServeError):
        ServeSampler("real", real_path=tmp_path / "ok.json").sample(0)


# -- distributions with spin, the real-ball pools and their splits ---------------------------------

def test_episode_seeds_are_the_runners():
    from tt_drake.diagrams.episodes import episode_seed as runner_seed
    from tt_drake.seeds import episode_seed

    assert runner_seed is episode_seed
    assert episode_seed(3, 4) == int(np.random.SeedSequence([3, 4]).generate_state(1)[0])


def test_spin_distribution_is_the_default_launcher_with_spin_up_to_spin_max():
    spin = ServeSampler("spin")
    assert spin.spin_max == SPIN_DEFAULT == 100.0  # spin_max 0: the distribution's default
    serves = [spin.sample(seed) for seed in range(40)]
    w = np.array([s.launch_state[6:9] for s in serves])
    assert np.all(np.abs(w) <= 100.0) and np.abs(w).max() > 60.0
    # Spin is drawn per axis, every sign: each component takes both signs over 40 serves.
    assert np.all((w > 0).any(axis=0)) and np.all((w < 0).any(axis=0))
    # The launcher's position and validity are the default's: one bounce on the robot's half,
    # crossing the hitting region.
    for s in serves:
        assert s.launch_state[1] == pytest.approx(LAUNCHER_Y)
        assert len(s.crossing.bounces) == 1 and HITTING_REGION.contains(
            s.crossing.position[0], s.crossing.position[2])
    narrow = ServeSampler("spin", spin_max=20.0).sample(3).launch_state[6:9]
    assert np.all(np.abs(narrow) <= 20.0) and np.any(narrow != 0.0)


def test_negative_or_nan_spin_max_is_refused():
    for bad in (-1.0, float("nan")):
        with pytest.raises(ServeError, match="spin_max must be >= 0"):
            ServeSampler("spin", spin_max=bad)


def test_split_is_a_fixed_function_of_the_id_with_about_30_percent_test():
    ids = np.arange(20000)
    test = np.array([split_of(i) == "test" for i in ids])
    assert abs(test.mean() - TEST_PERCENT / 100) < 0.015  # binomial sd 0.0032
    # Fixed: the definition in the docstring, recomputed here.
    import hashlib

    for i in (0, 1, 2704, 15791):
        digest = int.from_bytes(hashlib.sha256(str(i).encode()).digest(), "big")
        assert split_of(i) == ("test" if digest % 100 < 30 else "train")


def _write_balls(path, states, ids=True):
    keys = ("pos_x", "pos_y", "pos_z", "vel_x", "vel_y", "vel_z", "w_vel_x", "w_vel_y", "w_vel_z")
    records = []
    for k, s in enumerate(states):
        r = dict(zip(keys, map(float, s), strict=True))
        r["pos_z"] -= 0.76  # the file's frame: origin at the table surface
        if ids:
            r["id"] = 1000 + k
        records.append(r)
    path.write_text(json.dumps(records))
    return path


def _real_like(n, seed=0):
    """n real serves (world frame) from the shipped file, a seeded choice."""
    states = load_real_states()
    return states[np.random.default_rng(seed).choice(len(states), n, replace=False)]


def test_pool_keeps_every_ball_reaching_the_robot_half_and_splits_by_id(tmp_path):
    states = _real_like(40)
    states[0, 4] = -15.0  # far too fast: lands beyond the robot's end
    states[1, 4] = 3.0  # moving away from the robot
    path = _write_balls(tmp_path / "balls.json", states)
    pool = ServeSampler("real", real_path=path).pool()
    ids = [b.id for b in pool]
    assert 1000 not in ids and 1001 not in ids and len(pool) >= 25
    model = ServeSampler("real").model
    for b in pool:
        bounce = next(x for x in b.crossing.bounces if x.position[1] < 0.0)
        assert abs(bounce.position[1]) <= 1.37 - 0.02 and abs(bounce.position[0]) <= 0.7425
        assert reaches_robot_half(model, b.state) is not None
    test = ServeSampler("real-test", real_path=path).pool()
    train = ServeSampler("real-train", real_path=path).pool()
    assert sorted([b.id for b in test] + [b.id for b in train]) == sorted(ids)
    assert all(split_of(b.id) == "test" for b in test)
    assert all(split_of(b.id) == "train" for b in train)


def test_shipped_real_pool_includes_serves_crossing_below_the_hitting_region():
    pool = ServeSampler("real-test").pool()
    z = np.array([b.crossing.position[2] for b in pool])
    assert np.sum(z < HITTING_REGION.z_min) > 0.3 * len(pool)
    assert all(split_of(b.id) == "test" for b in pool)


def test_a_run_deals_the_pool_without_repeats_and_replays(tmp_path):
    path = _write_balls(tmp_path / "balls.json", _real_like(25, seed=1))
    sampler = ServeSampler("real", real_path=path, run_seed=11)
    n = len(sampler.pool())
    dealt = [sampler.sample(episode_seed(11, i)).source_id for i in range(n)]
    assert sorted(dealt) == sorted(b.id for b in sampler.pool())  # a permutation of the pool
    again = ServeSampler("real", real_path=path, run_seed=11)
    assert [again.sample(episode_seed(11, i)).source_id for i in (4, 0, 7)] == [
        dealt[4], dealt[0], dealt[7]]  # pure: any episode replays alone, in any order
    other = [ServeSampler("real", real_path=path, run_seed=12).sample(episode_seed(12, i))
             .source_id for i in range(n)]
    assert other != dealt and sorted(other) == sorted(dealt)
    # Outside a run (or past the pool's size) a seed draws from the pool, reproducibly.
    free = ServeSampler("real", real_path=path)
    assert free.sample(5).source_id == ServeSampler("real", real_path=path).sample(5).source_id


def test_a_split_of_a_file_without_ids_is_refused(tmp_path):
    path = _write_balls(tmp_path / "noids.json", _real_like(10), ids=False)
    assert len(ServeSampler("real", real_path=path).pool()) > 0  # unsplit: numbered 0..N-1
    for name in ("real-test", "real-train"):
        with pytest.raises(ServeError, match="has no record ids, so it has no"):
            ServeSampler(name, real_path=path).check()
    with pytest.raises(ServeError, match="has no record ids"):
        ServeSampler("rally-test", rally_path=path).check()


def test_a_pool_is_flown_once_per_process_and_again_when_its_file_changes(tmp_path,
                                                                         monkeypatch):
    import tt_drake.serves as serves

    path = _write_balls(tmp_path / "balls.json", _real_like(6, seed=2))
    flown = []
    original = serves.reaches_robot_half
    monkeypatch.setattr(serves, "reaches_robot_half",
                        lambda model, state: flown.append(1) or original(model, state))
    first = ServeSampler("real", real_path=path).pool()
    assert len(flown) == 6
    again = ServeSampler("real", real_path=path, run_seed=3).pool()
    assert again is first and len(flown) == 6  # a new sampler (a new diagram) reuses it
    assert ServeSampler("real", real_path=path, model=BallModel(dt=4e-3)).pool() is not first
    assert len(flown) == 12  # another flight model flies the balls again
    time.sleep(0.05)
    _write_balls(path, _real_like(5, seed=3))
    ServeSampler("real", real_path=path).pool()
    assert len(flown) == 17  # a changed file's five balls are flown
