"""Serve distributions: reproducibility, validity and coverage of the hitting region."""

import json

import numpy as np
import pytest

from tt_drake.constants import HITTING_REGION, PLANES
from tt_drake.serves import ServeError, ServeSampler, load_real_states


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
