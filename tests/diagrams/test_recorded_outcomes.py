"""Fixed serves and rallies of every player give the recorded outcomes bit for bit.

The records (tests/data/recorded_outcomes.json, written by tests/data/make_recorded_outcomes.py)
hold each episode's launch, the referee's verdict, the landing and hit time as exact floats and
when the episode ended: any change to the physics, the seeds, the players or how a diagram is
built and reset that moves a landing by one bit fails here.

They were made with OpenBLAS's Haswell kernels, which the package pins on every x86-64 machine
(tt_drake/blas.py): with the kernels OpenBLAS picks for an Intel AVX-512 CPU the same serves land
~1e-10 m elsewhere.
"""

import os
import platform

import pytest

from tests.data.make_recorded_outcomes import (
    RALLY_PLAYERS,
    SERVE_PLAYERS,
    SERVES,
    load_recorded,
    play_rally,
    play_serves,
    rally_case_key,
    serve_case_key,
)
from tt_drake.blas import BLAS_CORE_TYPE

RECORDED = load_recorded()


def test_the_process_runs_the_blas_kernels_the_records_were_made_with():
    """On x86-64 importing tt_drake (the root conftest.py does, before numpy loads) asked
    OpenBLAS for the Haswell kernels, and numpy's and scipy's OpenBLAS run them; elsewhere the
    package leaves the variable to the environment (OpenBLAS has no such family there:
    tests/tt_drake/test_blas.py)."""
    import numpy as np
    import scipy.linalg
    from threadpoolctl import threadpool_info

    np.linalg.solve(np.eye(3), np.ones(3))
    scipy.linalg.solve(np.eye(3), np.ones(3))  # both libraries loaded
    kernels = {info.get("architecture") for info in threadpool_info()
               if info.get("internal_api") == "openblas"}
    assert kernels  # numpy's and scipy's OpenBLAS
    if platform.machine().lower() in ("x86_64", "amd64"):
        assert os.environ.get("OPENBLAS_CORETYPE") == BLAS_CORE_TYPE
        assert kernels == {BLAS_CORE_TYPE}


def test_the_records_cover_every_case_and_pin_returns_and_faults():
    serves = RECORDED["serves"]
    assert set(serves) == {serve_case_key(label, d) for label, _, _ in SERVE_PLAYERS
                           for d in SERVES}
    assert set(RECORDED["rallies"]) == {rally_case_key(p) for p in RALLY_PLAYERS}
    outcomes = {e["outcome"] for episodes in serves.values() for e in episodes}
    assert outcomes == {"returned", "missed", "fault"}
    for rally in RECORDED["rallies"].values():  # each side returned at least once
        assert {e["player"] for e in rally["exchanges"]} == {0, 1}


@pytest.mark.parametrize("distribution", list(SERVES))
@pytest.mark.parametrize("label", [label for label, _, _ in SERVE_PLAYERS])
def test_fixed_serves_give_the_recorded_outcomes_bit_for_bit(label, distribution):
    assert play_serves(label, distribution) == RECORDED["serves"][
        serve_case_key(label, distribution)]


@pytest.mark.parametrize("players", RALLY_PLAYERS, ids=rally_case_key)
def test_fixed_rallies_give_the_recorded_exchanges_bit_for_bit(players):
    assert play_rally(players) == RECORDED["rallies"][rally_case_key(players)]
