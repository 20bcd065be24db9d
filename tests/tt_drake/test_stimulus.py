"""Stimulus layouts: recorded in the learned artefacts; the shipped 6-D ones load and gate as the
paper's stimulus; a mismatched stimulus fails clearly."""

import numpy as np
import pytest

from tt_drake.artefacts import load_artefact, save_artefact
from tt_drake.dmp import HittingDMP
from tt_drake.learned_player import (
    LIBRARY_FILE_KIND,
    ConfigurationModel,
    LearnedArtefactError,
    StagePrimitive,
    load_configuration_model,
    load_player_library,
    save_configuration_model,
    save_player_library,
)
from tt_drake.momp import MotorPrimitiveLibrary, gating_weights
from tt_drake.stages import AWAITING, FOLLOW_THROUGH, PREPARATION
from tt_drake.stimulus import (
    PAPER_STIMULUS,
    SPIN_STIMULUS,
    compose_stimulus,
    stimulus_layout,
    stimulus_size,
)

SHIPPED = "models/learned"


def test_layouts_compose_in_order():
    p, v, w = [1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, 9.0]
    np.testing.assert_array_equal(compose_stimulus(PAPER_STIMULUS, p, v, w), p + v)
    np.testing.assert_array_equal(compose_stimulus(SPIN_STIMULUS, p, v, w), p + v + w)
    assert stimulus_size(PAPER_STIMULUS) == 6 and stimulus_size(SPIN_STIMULUS) == 9
    with pytest.raises(ValueError, match="needs spin_hit"):
        compose_stimulus(SPIN_STIMULUS, p, v, None)
    for bad in ([], ["p_hit", "p_hit"], ["q_hit"], "p_hit", ["v_hit", "p_hit"], ["p_hit"]):
        with pytest.raises(ValueError, match="stimulus layout"):
            stimulus_layout(bad)


def test_shipped_artefacts_keep_the_papers_stimulus_and_gating():
    library, _, meta = load_player_library(f"{SHIPPED}/library.npz")
    assert "stimulus" not in meta and library.stimulus_layout == PAPER_STIMULUS
    x = library.stimuli[3] + 0.01
    np.testing.assert_array_equal(library.gating(x), gating_weights(
        x, library.stimuli, library.bandwidths, library.gamma))
    with pytest.raises(ValueError, match=r"shape \(9,\).*6 values \(p_hit, v_hit\)"):
        library.gating(np.r_[x, 0.0, 0.0, 0.0])
    model, _ = load_configuration_model(f"{SHIPPED}/crkr.npz")
    assert model.stimulus == PAPER_STIMULUS
    with pytest.raises(ValueError, match="9 values for a CrKR model of 6"):
        model.predict(np.zeros(9))


def _spin_library(n=5, seed=0):
    rng = np.random.default_rng(seed)
    dmp = HittingDMP()
    w = rng.normal(0, 50, (n, 7, dmp.n_basis))
    x = rng.normal(size=(n, 9))
    lib = MotorPrimitiveLibrary(dmp, w, rng.uniform(0.2, 1.0, (n, 7)), x, np.ones(9),
                                stimulus_layout=SPIN_STIMULUS)
    stage = StagePrimitive(w[0], np.ones(7), 0.5)
    return lib, {PREPARATION: stage, FOLLOW_THROUGH: stage, AWAITING: stage}


def test_a_spin_library_round_trips_and_a_mismatched_one_is_refused(tmp_path):
    lib, stages = _spin_library()
    path = tmp_path / "lib.npz"
    save_player_library(path, lib, stages, {"scenario": "default", "hitting_y": -1.0})
    loaded, _, meta = load_player_library(path, "default")
    assert meta["stimulus"] == list(SPIN_STIMULUS) and loaded.stimulus_layout == SPIN_STIMULUS
    np.testing.assert_array_equal(loaded.gating(lib.stimuli[1]), lib.gating(lib.stimuli[1]))
    # The layout says 9 values, the stored stimuli have 6: refused at load, naming both.
    arrays, meta = load_artefact(path, LIBRARY_FILE_KIND)
    arrays["stimuli"], arrays["bandwidths"] = arrays["stimuli"][:, :6], arrays["bandwidths"][:6]
    save_artefact(tmp_path / "bad.npz", LIBRARY_FILE_KIND, arrays, meta)
    with pytest.raises(LearnedArtefactError, match="stimulus layout p_hit, v_hit, spin_hit has "
                                                   "9 values, its stimuli 6"):
        load_player_library(tmp_path / "bad.npz")
    with pytest.raises(ValueError, match="has 9 values, the stimuli 6"):
        MotorPrimitiveLibrary(lib.dmp, lib.weights, lib.amplitude, lib.stimuli[:, :6],
                              np.ones(6), stimulus_layout=SPIN_STIMULUS)


def test_crkr_with_spin_in_its_stimulus(tmp_path):
    """The spin is an input of the kernel: two samples at the same (p, v) with opposite spins
    keep apart instead of averaging."""
    rng = np.random.default_rng(1)
    pv = rng.normal(size=6)
    x = np.array([np.r_[pv, 50.0, 0.0, 0.0], np.r_[pv, -50.0, 0.0, 0.0]])
    y = np.array([np.full(14, 0.5), np.full(14, -0.5)])
    model = ConfigurationModel.fit(x, y, np.ones(2), np.r_[np.ones(6), 20.0, 1.0, 1.0], 1e-3,
                                   SPIN_STIMULUS)
    q0, _, _ = model.predict(x[0])
    q1, _, _ = model.predict(x[1])
    assert q0[0] > 0.4 and q1[0] < -0.4
    save_configuration_model(tmp_path / "c.npz", model, {"scenario": "default", "hitting_y": 0})
    loaded, meta = load_configuration_model(tmp_path / "c.npz")
    assert loaded.stimulus == SPIN_STIMULUS and meta["stimulus"] == list(SPIN_STIMULUS)
    np.testing.assert_allclose(loaded.predict(x[0])[0], q0, atol=1e-12)
    with pytest.raises(ValueError, match="stimuli of 6 values for the layout"):
        ConfigurationModel.fit(x[:, :6], y, np.ones(2), np.ones(6), 1e-3, SPIN_STIMULUS)
