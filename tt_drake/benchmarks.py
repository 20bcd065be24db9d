"""Micro-benchmarks of the learning core (called by ``tt-drake bench`` and docs/examples).

Timings are wall-clock on the calling process; pin BLAS to one thread for "one core" numbers
(:func:`bench_momp_planning` does so through ``threadpoolctl`` when it is installed, which it is
as a dependency of scikit-learn).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from threadpoolctl import threadpool_limits

from tt_drake.dmp import HittingDMP
from tt_drake.momp import MotorPrimitiveLibrary, scott_bandwidths

__all__ = ["synthetic_library", "bench_momp_planning", "compare_serve_records"]


def synthetic_library(
    n_primitives: int = 300,
    n_dof: int = 7,
    n_stimulus: int = 6,
    dmp: HittingDMP | None = None,
    seed: int = 0,
) -> MotorPrimitiveLibrary:
    """A random library of the paper's size (300 primitives, 7 DoF, 6-D stimuli) for timing.

    Stimuli resemble the project's (hitting point within ~0.3 m, ball velocity within ~0.5 m/s);
    weights and amplitudes are random; bandwidths by Scott's rule.
    """
    dmp = HittingDMP() if dmp is None else dmp
    rng = np.random.default_rng(seed)
    centre = np.array([0.3, -1.0, 1.0, -0.5, 4.0, 1.0])[:n_stimulus]
    spread = np.array([0.3, 0.1, 0.15, 0.5, 0.5, 0.5])[:n_stimulus]
    if n_stimulus > 6:
        centre = np.concatenate([centre, np.zeros(n_stimulus - 6)])
        spread = np.concatenate([spread, np.ones(n_stimulus - 6)])
    stimuli = centre + spread * rng.standard_normal((n_primitives, n_stimulus))
    weights = 100.0 * rng.standard_normal((n_primitives, n_dof, dmp.n_basis))
    amplitude = rng.uniform(0.3, 1.5, (n_primitives, n_dof)) * rng.choice([-1, 1], (1, n_dof))

    return MotorPrimitiveLibrary(dmp, weights, amplitude, stimuli, scott_bandwidths(stimuli))


def bench_momp_planning(
    n_primitives: int = 300,
    n_dof: int = 7,
    rate: float = 500.0,
    duration: float = 0.5,
    repeats: int = 200,
    method: str = "weights",
    seed: int = 0,
) -> dict[str, Any]:
    """Time planning one hitting movement (gating + mixture + rollout) from a library.

    Each repetition draws a new stimulus and task (start, ``g_f``, ``g_dot``) and calls
    :meth:`MotorPrimitiveLibrary.plan`; the hitting time is ``duration`` so the integrator's
    cached sensitivity map is reused after the first (cold) call, as in a running system where
    the hitting stage has a fixed number of samples. The cold first call is reported separately.
    Returns milliseconds: ``cold_ms``, ``mean_ms``, ``median_ms``, ``p95_ms``, ``min_ms`` and the
    mean number of primitives kept by the gating.
    """
    lib = synthetic_library(n_primitives, n_dof, seed=seed)
    rng = np.random.default_rng(seed + 1)
    tasks = [
        (
            lib.stimuli[rng.integers(n_primitives)] + 0.5 * lib.bandwidths
            * rng.standard_normal(lib.stimuli.shape[1]),
            rng.uniform(-1, 1, n_dof),
            rng.uniform(-1, 1, n_dof),
            rng.uniform(-2, 2, n_dof),
        )
        for _ in range(repeats + 1)
    ]
    times = []
    kept = []
    with threadpool_limits(limits=1):
        for i, (x, y0, g_f, g_dot) in enumerate(tasks):
            t0 = time.perf_counter()
            traj = lib.plan(x, y0, g_f, g_dot, duration, rate=rate, method=method)
            times.append(time.perf_counter() - t0)
            if i:
                kept.append(lib.active(x)[0].size)
    ms = 1e3 * np.array(times)
    warm = ms[1:]
    return {
        "n_primitives": n_primitives,
        "n_dof": n_dof,
        "rate_hz": rate,
        "duration_s": duration,
        "samples": int(traj.t.size),
        "method": method,
        "repeats": repeats,
        "cold_ms": float(ms[0]),
        "mean_ms": float(warm.mean()),
        "median_ms": float(np.median(warm)),
        "p95_ms": float(np.percentile(warm, 95)),
        "min_ms": float(warm.min()),
        "mean_kept_primitives": float(np.mean(kept)),
    }


# Fields of a serve record (``tt-drake serve --json``) that must match exactly for two runs to
# have the same per-serve outcome; the landing point is compared within a tolerance.
OUTCOME_FIELDS = ("outcome", "hit", "returned", "on_target", "faults")


def compare_serve_records(a: dict, b: dict, landing_tol: float = 1e-3) -> dict[str, Any]:
    """Compare two ``tt-drake serve --json`` outputs serve by serve.

    Both must hold the same serves (the same seeds in the same order). A serve *differs* when any
    of :data:`OUTCOME_FIELDS` differ, when one has a landing point and the other not, or when
    the landing points are more than ``landing_tol`` metres apart. Returns the number of serves,
    the indices of those that differ (with the two records' outcome and landing), the largest
    landing shift (m) over serves that land in both, and ``same`` (no serve differs).
    """
    ea, eb = a["episodes"], b["episodes"]
    if [e["seed"] for e in ea] != [e["seed"] for e in eb]:
        raise ValueError("the two runs do not hold the same serves (seeds differ)")
    differ = []
    shift = 0.0
    for i, (x, y) in enumerate(zip(ea, eb, strict=True)):
        bad = [f for f in OUTCOME_FIELDS if x.get(f) != y.get(f)]
        la, lb = x.get("landing"), y.get("landing")
        if (la is None) != (lb is None):
            bad.append("landing")
        elif la is not None:
            d = float(np.linalg.norm(np.subtract(la, lb)))
            shift = max(shift, d)
            if d > landing_tol:
                bad.append("landing")
        if bad:
            differ.append({"index": i, "seed": x["seed"], "fields": bad,
                           "a": [x.get("outcome"), la], "b": [y.get("outcome"), lb]})
    return {"serves": len(ea), "differ": differ, "max_landing_shift": shift,
            "same": not differ}
