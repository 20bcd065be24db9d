"""The GPR's ``states+spin`` feature set: the estimator's spin as an input, the artefact field
that names it, and that it makes the GPR right on spinning serves where the states alone are not
(the ball model as the truth: fast)."""

import json

import numpy as np
import pytest

from tests.tt_drake._observed import observed_serve
from tt_drake.ball_model import CompliantBounceBallModel
from tt_drake.constants import PLANES
from tt_drake.hitting_point import (
    FEATURE_SETS,
    HittingPointGPR,
    PredictorFileError,
    make_features,
    make_label,
    regression_metrics,
)

MODEL = CompliantBounceBallModel(dt=2e-3)


def spin_serve(seed):
    """The four observed states, the spin estimate at the fourth and the label of one ``spin``
    serve (+-100 rad/s per axis), the ball model (spin, Magnus, bounce) as the truth."""
    run, idx, hit, times = observed_serve("spin", seed, MODEL)
    return (run.states[idx], run.spins[idx[-1]],
            make_label(hit.position, hit.velocity, hit.t, times[idx[-1]]))


@pytest.fixture(scope="module")
def spin_data():
    return [spin_serve(s) for s in range(1000, 1200)]


def _fit_and_score(rows, feature_set):
    X = np.array([make_features(s, w, feature_set) for s, w, _ in rows])
    Y = np.array([y for _, _, y in rows])
    gpr = HittingPointGPR.fit(X[:150], Y[:150], n_restarts=0, feature_set=feature_set)
    return gpr, {r["output"]: r["nmse"] for r in regression_metrics(Y[150:],
                                                                    gpr.predict_many(X[150:]))}


def test_the_spin_features_beat_the_states_alone_on_spinning_serves(spin_data):
    """Before the robot-side bounce the four (p, v) states hardly show a spin of up to
    100 rad/s, yet it decides the bounce: the estimator's spin (from the Magnus curvature over
    the whole flight) tells the GPR more. Held-out nMSE, 150 training / 50 test serves."""
    _, plain = _fit_and_score(spin_data, "states")
    _, spun = _fit_and_score(spin_data, "states+spin")
    learnt = [k for k, v in plain.items() if v is not None]
    assert np.mean([spun[k] for k in learnt]) < 0.8 * np.mean([plain[k] for k in learnt])
    assert spun["t_hit"] < 0.6 * plain["t_hit"], (plain, spun)
    assert spun["v_z"] < 0.6 * plain["v_z"], (plain, spun)


def test_features_of_each_set():
    s = np.arange(24.0).reshape(4, 6)
    w = np.array([10.0, -20.0, 30.0])
    assert np.array_equal(make_features(s), s.reshape(-1))
    assert np.array_equal(make_features(s, w), s.reshape(-1))  # the paper's set ignores spin
    assert np.array_equal(make_features(s, w, "states+spin"), np.r_[s.reshape(-1), w])
    assert len(make_features(s, w, "states+spin")) == FEATURE_SETS["states+spin"] == 27
    with pytest.raises(ValueError, match="unknown feature set"):
        make_features(s, w, "states+colour")


def _small_spin_gpr():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(40, 27))
    Y = np.c_[X[:, 24], np.full(40, PLANES.hitting_y), X[:, 25], X[:, :3], X[:, 26]]
    return HittingPointGPR.fit(X, Y, n_restarts=0, feature_set="states+spin"), X


def test_spin_predictor_round_trip_names_its_feature_set(tmp_path):
    gpr, X = _small_spin_gpr()
    path = tmp_path / "spin.npz"
    gpr.save(path, {"distribution": "spin"})
    loaded = HittingPointGPR.load(path)
    assert loaded.feature_set == "states+spin"
    assert loaded.meta["feature_set"] == "states+spin" and loaded.meta["feature_size"] == 27
    assert np.array_equal(loaded.predict_many(X), gpr.predict_many(X))
    s, w = X[3, :24].reshape(4, 6), X[3, 24:]
    assert np.array_equal(loaded.features(s, w), X[3])
    with pytest.raises(ValueError, match="feature set"):
        HittingPointGPR.fit(X[:, :24], np.zeros((40, 7)), feature_set="states+spin")


def test_mismatched_feature_sets_are_refused(tmp_path):
    from tt_drake.artefacts import load_artefact, save_artefact
    from tt_drake.hitting_point import ARTEFACT_KIND

    gpr, _ = _small_spin_gpr()
    path = tmp_path / "spin.npz"
    gpr.save(path)
    arrays, meta = load_artefact(path, ARTEFACT_KIND)
    cases = {"unknown": ({**meta, "feature_set": "states+colour"}, arrays, "unknown feature set"),
             "absent": ({k: v for k, v in meta.items() if k != "feature_set"}, arrays,
                        "do not match"),  # 27 features read as the paper's 24
             "truncated": (meta, {**arrays, "train_x": arrays["train_x"][:, :24],
                                  "x_mean": arrays["x_mean"][:24],
                                  "x_scale": arrays["x_scale"][:24],
                                  "length_scales": arrays["length_scales"][:, :24]},
                           "24 features")}
    for name, (m, a, message) in cases.items():
        bad = tmp_path / f"{name}.npz"
        doc = {k: v for k, v in m.items() if k != "kind"}
        save_artefact(bad, ARTEFACT_KIND, a, json.loads(json.dumps(doc)))
        with pytest.raises(PredictorFileError, match=message):
            HittingPointGPR.load(bad)


def test_the_shipped_predictor_reads_as_the_papers_feature_set():
    from tt_drake.models import shipped_artefact

    gpr = HittingPointGPR.load(shipped_artefact("predictor"))
    assert gpr.feature_set == "states" and "feature_set" not in gpr.meta
    s = gpr.train_x[0] * gpr.x_scale + gpr.x_mean
    obs = s.reshape(4, 6)
    # The spin does not reach the paper's features: the prediction is the one from the states.
    assert np.array_equal(gpr.predict(gpr.features(obs, np.array([50.0, 0.0, -80.0]))),
                          gpr.predict(s))
