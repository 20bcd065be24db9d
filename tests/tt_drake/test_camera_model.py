"""Camera model: per-seed determinism and the statistics of noise, dropouts and outliers."""

import numpy as np
import pytest

from tt_drake.camera_model import CameraConfig, CameraModel


def test_draws_are_a_pure_function_of_the_seed():
    cam = CameraModel(CameraConfig(dropout=0.2, outlier=0.05))
    a, b, c = cam.episode_draws(5), cam.episode_draws(5), cam.episode_draws(6)
    assert np.array_equal(a.noise, b.noise) and np.array_equal(a.dropped, b.dropped)
    assert not np.array_equal(a.noise, c.noise)


def test_noise_dropout_and_outlier_statistics():
    cfg = CameraConfig(sigma=0.003, dropout=0.2, outlier=0.02, max_frames=20000)
    d = CameraModel(cfg).episode_draws(1)
    assert d.dropped.mean() == pytest.approx(0.2, abs=0.01)
    big = np.linalg.norm(d.noise, axis=1) > 0.05
    assert big.mean() == pytest.approx(0.02, abs=0.004)
    assert np.all(np.linalg.norm(d.noise[big], axis=1) >= cfg.outlier_min - 1e-12)
    assert d.noise[~big].std(axis=0) == pytest.approx([0.003] * 3, rel=0.05)


def test_measure_sequence_and_latency():
    cfg = CameraConfig(sigma=0.0, dropout=0.5, latency=0.02)
    assert cfg.latency_frames == 2
    p = np.arange(30.0).reshape(10, 3)
    z = CameraModel(cfg).measure_sequence(3, p)
    d = CameraModel(cfg).episode_draws(3)
    assert np.all(np.isnan(z[d.dropped[:10]]))
    assert np.array_equal(z[~d.dropped[:10]], p[~d.dropped[:10]])


def test_bad_config_is_refused():
    with pytest.raises(ValueError):
        CameraConfig(dropout=1.5)
    with pytest.raises(ValueError):
        CameraConfig(rate=0.0)


def test_a_noise_stream_is_an_independent_draw_of_the_same_seed_and_stream_0_is_unchanged():
    """Stream 0 keys its generator by (seed, 60[, block]) as always; streams 1 and 2 give other
    noise of the same distribution, each a pure function of (seed, block, stream)."""
    seed = 12345
    own = CameraModel(CameraConfig()).block_draws(seed, 0)
    rng = np.random.default_rng(np.random.SeedSequence([seed, 60]))
    rng.random(600)  # the dropout draws come first
    assert np.array_equal(own.noise, rng.normal(0.0, 0.003, (600, 3)))
    draws = [CameraModel(CameraConfig(noise_stream=s)).block_draws(seed, b).noise
             for s in (1, 2) for b in (0, 1)]
    for i, a in enumerate([own.noise, *draws]):
        for b in [own.noise, *draws][i + 1:]:
            assert not np.allclose(a, b)
    again = CameraModel(CameraConfig(noise_stream=1)).block_draws(seed, 0).noise
    assert np.array_equal(again, draws[0])
    pooled = np.concatenate(draws)
    assert abs(pooled.std() - 0.003) < 0.0002  # sigma = 3 mm, 7,200 draws


def test_a_noise_stream_must_be_a_whole_number_of_at_least_zero():
    for bad in (-1, 1.5, True):
        with pytest.raises(ValueError, match="noise_stream"):
            CameraConfig(noise_stream=bad)
