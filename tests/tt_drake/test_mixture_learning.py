"""Algorithm 3 over a library (tt_drake.mixture_learning): pruning with the referee's reward, PoWER
(Eq. 9) weighted by the gating share, and a learning state that resumes exactly."""

from __future__ import annotations

import numpy as np
import pytest

from tt_drake.mixture_learning import MixtureLearner, PowerParams, exploration_sigma
from tt_drake.momp import gating_weights
from tt_drake.referee_rules import RefereeConfig, return_reward
from tt_drake.responsibility import ResponsibilityParams

STIMULI = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
BANDWIDTHS = np.array([0.5, 0.5])


def _stroke(learner: MixtureLearner, x) -> tuple[np.ndarray, np.ndarray]:
    """The primitives of a stroke and their gating weights (Eq. 6 with gamma), as the player
    reports them."""
    nu = gating_weights(x, learner.stimuli, learner.bandwidths, learner.gamma)
    idx = np.flatnonzero(nu >= 1e-6)
    return idx, nu[idx] / nu[idx].sum()


def _learn_with_a_bad_primitive(config: RefereeConfig, rollouts: int = 600):
    """Primitive 0's strokes land 0.75 m from the target (legal returns), 1's and 2's 0.05 m; a
    mixed stroke lands at the mixture of their distances. The reward is the referee's."""
    learner = MixtureLearner(np.zeros((3, 2, 4)), STIMULI, np.full(2, 0.35))
    rng = np.random.default_rng(3)
    distance = np.array([0.75, 0.05, 0.05])
    credited = np.zeros(3)
    for _ in range(rollouts):
        x = STIMULI[rng.integers(3)] + rng.normal(0.0, 0.15, 2)  # serves near each primitive
        idx, nu = _stroke(learner, x)
        credited[idx] += nu
        learner.credit(x, idx, nu, return_reward(nu @ distance[idx], config))
    return learner, credited


def test_a_primitive_that_returns_far_off_target_is_pruned_and_good_ones_are_kept():
    learner, credited = _learn_with_a_bad_primitive(RefereeConfig())
    np.testing.assert_array_equal(learner.pruned, [True, False, False])
    assert credited[0] > 5.0  # it was used (every one of its strokes a legal return) before
    assert learner.gamma[1] > 0.5 and learner.gamma[2] > 0.5
    # Why the reward's floor had to come down: with the former 0.6, a legal return is worth more
    # than the pruning level (0.42) wherever it lands, and nothing is pruned.
    old, _ = _learn_with_a_bad_primitive(RefereeConfig(return_floor=0.6))
    assert not old.pruned.any()
    assert return_reward(10.0, RefereeConfig(return_floor=0.6)) > (
        ResponsibilityParams().prune_below_reward)


def _toy_learner(seed: int = 0):
    """Every primitive's stroke is best with weights W_STAR[i]: a stroke with explored weights
    theta lands sum_i nu_i |mean(theta_i - W_STAR_i)| metres off; start 0.5 m off."""
    w_star = np.random.default_rng(seed).normal(0.0, 1.0, (3, 2, 4))
    start = w_star + 0.5
    learner = MixtureLearner(start, STIMULI, BANDWIDTHS,
                             power=PowerParams(relative_sigma=0.0, n_best=8),
                             sigma=np.full((2, 1), 0.3))

    def landing(theta, idx, nu):
        return float(sum(n * abs(np.mean(theta[i] - w_star[i])) for i, n in zip(idx, nu,
                                                                               strict=True)))
    return learner, w_star, landing


def test_power_in_algorithm_3_moves_the_weights_of_the_primitives_that_took_part():
    learner, w_star, landing = _toy_learner()
    rng = np.random.default_rng(1)
    xs = np.array([[0.1, 0.0], [0.9, 0.05], [2.1, -0.05], [1.2, 0.0]])

    def mean_reward(weights):
        out = []
        for x in xs:
            idx, nu = _stroke(learner, x)
            out.append(return_reward(landing(weights, idx, nu)))
        return float(np.mean(out))

    before = mean_reward(learner.weights)
    error0 = np.abs((learner.weights - w_star).mean(axis=(1, 2)))
    for _ in range(25):  # batches of 8 rollouts
        for _ in range(8):
            x = xs[rng.integers(len(xs))] + rng.normal(0.0, 0.05, 2)
            idx, nu = _stroke(learner, x)
            theta = learner.explore(rng)
            learner.credit(x, idx, nu, return_reward(landing(theta, idx, nu)), theta)
        learner.update_weights()
    after = mean_reward(learner.weights)
    error1 = np.abs((learner.weights - w_star).mean(axis=(1, 2)))
    assert before < 0.5 and after > before + 0.3
    assert np.all(error1 < error0) and error1.sum() < 0.5 * error0.sum()
    assert not learner.pruned.any()


def test_eq9_share_weights_the_step_and_a_far_primitive_is_left_alone():
    learner = MixtureLearner(np.zeros((3, 1, 2)), STIMULI, BANDWIDTHS,
                             power=PowerParams(n_best=5, min_share=0.01), sigma=np.ones((1, 1)))
    x = np.array([0.2, 0.0])
    explored = np.ones((3, 1, 2))
    share = learner.power_shares(x)
    assert share[2] < 0.01 < share[1] < share[0]
    learner.credit(x, [0, 1, 2], share, 0.8, explored)
    np.testing.assert_array_equal(learner.update_weights(), [0, 1])
    # one rollout: w_i + eps share_i r / r = share_i (eps = 1)
    np.testing.assert_allclose(learner.weights[0], share[0])
    np.testing.assert_allclose(learner.weights[1], share[1])
    np.testing.assert_array_equal(learner.weights[2], 0.0)
    assert learner.update_weights().size == 0  # nothing new since


def test_pruned_primitives_are_neither_explored_nor_updated():
    learner = MixtureLearner(np.zeros((3, 2, 4)), STIMULI, BANDWIDTHS, gamma=[0.0, 1.0, 1.0])
    theta = learner.explore(np.random.default_rng(0))
    assert np.all(theta[0] == 0.0) and np.all(theta[1:] != 0.0)
    assert learner.power_shares([0.0, 0.0])[0] == 0.0
    learner.credit([0.0, 0.0], [0, 1], [0.5, 0.5], 1.0, theta)
    assert 0 not in learner.samplers and learner.gamma[0] == 0.0


def test_exploration_sigma_is_relative_to_each_joints_spread():
    w = np.zeros((4, 2, 3))
    w[:, 0] = np.arange(12).reshape(4, 3)
    w[:, 1] = 10.0 * np.arange(12).reshape(4, 3)
    sigma = exploration_sigma(w, 0.1)
    assert sigma.shape == (2, 1)
    np.testing.assert_allclose(sigma[:, 0], [0.1 * np.std(np.arange(12)),
                                             0.1 * np.std(10.0 * np.arange(12))])


def test_the_state_resumes_with_the_same_updates():
    a, _, landing = _toy_learner(seed=2)
    rng = np.random.default_rng(5)
    plan = [(np.array([rng.uniform(0, 2), 0.0]), np.random.default_rng(k)) for k in range(24)]

    def step(learner, k):
        x, r = plan[k]
        idx, nu = _stroke(learner, x)
        theta = learner.explore(np.random.default_rng(k))
        learner.credit(x, idx, nu, return_reward(landing(theta, idx, nu)), theta)
        if k % 4 == 3:
            learner.update_weights()

    for k in range(10):
        step(a, k)
    b = MixtureLearner.from_state(a.state(), STIMULI, BANDWIDTHS, power=a.power)
    for k in range(10, 24):
        step(a, k)
        step(b, k)
    for key, value in a.state().items():
        np.testing.assert_array_equal(b.state()[key], value, err_msg=key)


def test_bad_inputs_are_refused():
    with pytest.raises(ValueError, match="shape"):
        MixtureLearner(np.zeros((3, 2)), STIMULI, BANDWIDTHS)
    with pytest.raises(ValueError, match="stimuli"):
        MixtureLearner(np.zeros((2, 2, 4)), STIMULI, BANDWIDTHS)
    with pytest.raises(ValueError):
        PowerParams(n_best=0)
    learner = MixtureLearner(np.zeros((3, 2, 4)), STIMULI, BANDWIDTHS)
    with pytest.raises(ValueError, match="explored"):
        learner.credit([0.0, 0.0], [0], [1.0], 1.0, np.zeros((3, 2, 3)))
