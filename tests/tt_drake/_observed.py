"""A launcher serve flown by the ball model and seen by the 60 Hz camera through the EKF: what
the GPR tests learn from (the ball model as the truth)."""

import numpy as np

from tt_drake.camera_model import CameraConfig, CameraModel
from tt_drake.constants import PLANES
from tt_drake.estimation import propagate_exact, run_filter
from tt_drake.hitting_point import observation_frames
from tt_drake.serves import ServeSampler

RATE = 60.0


def observed_serve(distribution: str, seed: int, model, state_size: int | None = None):
    """(filter run, the four observation frames' indices, the true crossing of the hitting
    plane, the frame times) of serve ``seed`` of ``distribution``; ``state_size`` (e.g. 6 for
    (p, v) only) truncates the launch state the model flies."""
    serve = ServeSampler(distribution).sample(seed)
    hit = model.predict_plane(serve.launch_state, PLANES.hitting_y)
    n = int(hit.t * RATE) + 1
    x = serve.launch_state[:state_size].copy()
    xs = [x]
    for _ in range(n - 1):
        x, _ = propagate_exact(model, x, 1.0 / RATE)
        xs.append(x)
    xs = np.array(xs)
    z = CameraModel(CameraConfig()).measure_sequence(seed, xs[:, :3])
    times = np.arange(n) / RATE
    run = run_filter(times, z)
    return run, observation_frames(run.states, run.tracking), hit, times
