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
