"""The predictor system feeds a ``states+spin`` GPR its spin feature (the estimator's spin at the
fourth observation): the final prediction is the GPR's on the 27 features."""

import numpy as np

from tt_drake.systems.hitting_point_predictor import HittingPointPredictor

from ..tt_drake.test_gpr_spin_features import _small_spin_gpr


def test_final_prediction_reads_the_spin_feature():
    gpr, X = _small_spin_gpr()
    pred = HittingPointPredictor(gpr=gpr)
    obs = X[5, :24].reshape(4, 6)
    for spin in (X[5, 24:], X[5, 24:] + np.array([30.0, -20.0, 10.0])):
        out = pred._final(obs, spin)
        np.testing.assert_array_equal(out[:7], gpr.predict(np.r_[obs.reshape(-1), spin]))
    assert not np.allclose(pred._final(obs, X[5, 24:])[:7],
                           pred._final(obs, X[5, 24:] + 30.0)[:7])
