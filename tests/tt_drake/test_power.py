"""PoWER (Eq. 9) with Gaussian exploration and an importance sampler."""

from __future__ import annotations

import numpy as np
import pytest

from tests.tt_drake._demos import monotone_demo
from tt_drake.dmp import HittingDMP
from tt_drake.imitation import imitate
from tt_drake.power import PoWER, explore

DMP = HittingDMP()


def _toy_task():
    """Toy hitting task: reach p* = 1 rad with v* = 2 rad/s at the hitting time T = 0.5 s.

    The primitive is imitated from a demonstration that does this and then perturbed; the reward
    exp(-((q(T) - p*)/0.03)^2 / 2 - ((qd(T) - v*)/0.3)^2 / 2) lies in [0, 1].
    """
    res = imitate(DMP, monotone_demo(tau=0.5, p0=0.0, p1=1.0, v1=2.0))

    def reward(w):
        tr = DMP.rollout(w, res.y0, res.g_f, res.g_dot, 0.5, amplitude=res.amplitude, n_steps=50)
        e = (tr.q[-1, 0] - 1.0) / 0.03
        v = (tr.qd[-1, 0] - 2.0) / 0.3
        return float(np.exp(-0.5 * (e * e + v * v)))

    return res.weights, reward


@pytest.mark.parametrize("seed", [0, 1, 2, 3, 4])
def test_power_improves_toy_hitting_task(seed):
    w_demo, reward = _toy_task()
    rng = np.random.default_rng(seed)
    w = w_demo + 1000.0 * rng.standard_normal(w_demo.shape)  # perturbed primitive
    r0 = reward(w)
    assert r0 < 0.5
    learner = PoWER(n_best=10)
    best_greedy = r0
    for _ in range(200):
        theta = explore(w, 300.0, rng)
        learner.add(theta, reward(theta))
        w = learner.update(w)
        best_greedy = reward(w)
        if best_greedy >= 0.9:
            break
    assert best_greedy >= 0.9 > r0


def test_single_policy_update_is_reward_weighted_mean_of_kept_rollouts():
    rng = np.random.default_rng(0)
    w = rng.normal(size=(2, 4))
    learner = PoWER(n_best=3)
    thetas, rewards = [], [0.1, 0.9, 0.5, 0.7, 0.05]
    for r in rewards:
        thetas.append(explore(w, 1.0, rng))
        learner.add(thetas[-1], r)
    kept = [1, 3, 2]  # the three best
    np.testing.assert_allclose(learner.rewards, [0.9, 0.7, 0.5])
    r = np.array([rewards[k] for k in kept])
    expected = w + sum(r_j * (thetas[k] - w) for r_j, k in zip(r, kept, strict=True)) / r.sum()
    np.testing.assert_allclose(learner.update(w), expected)


def test_library_form_eq9_paper_default_and_weighted_variant():
    rng = np.random.default_rng(1)
    w = rng.normal(size=(3, 2, 5))  # 3 primitives
    rollouts = [(explore(w, 0.5, rng), r, rng.dirichlet(np.ones(3))) for r in (0.2, 0.8, 0.6)]
    paper, weighted = PoWER(n_best=10), PoWER(n_best=10, responsibility_weighted=True)
    for theta, r, nu in rollouts:
        paper.add(theta, r, nu)
        weighted.add(theta, r, nu)
    num = sum(nu[:, None, None] * r * (theta - w) for theta, r, nu in rollouts)
    den_paper = sum(r for _, r, _ in rollouts)
    den_w = sum(nu * r for _, r, nu in rollouts)
    np.testing.assert_allclose(paper.update(w), w + num / den_paper)
    np.testing.assert_allclose(weighted.update(w), w + num / den_w[:, None, None])
    # a primitive with no responsibility in any rollout does not move
    zero = PoWER()
    for theta, r, nu in rollouts:
        nu = nu.copy()
        nu[2] = 0.0
        zero.add(theta, r, nu)
    np.testing.assert_allclose(zero.update(w)[2], w[2])


def test_rewards_must_be_non_negative_and_zero_rewards_do_nothing():
    learner = PoWER()
    with pytest.raises(ValueError):
        learner.add(np.zeros(3), -0.1)
    learner.add(np.ones(3), 0.0)
    np.testing.assert_array_equal(learner.update(np.zeros(3)), np.zeros(3))
    with pytest.raises(ValueError):
        learner.add(np.ones(3), 0.5, nu=np.ones(3))  # mixing with / without nu
    with pytest.raises(ValueError):
        PoWER(n_best=0)


def test_exploration_statistics_and_reproducibility():
    w = np.zeros((200, 50))
    a = explore(w, np.linspace(0.5, 2.0, 50), np.random.default_rng(3))
    b = explore(w, np.linspace(0.5, 2.0, 50), np.random.default_rng(3))
    np.testing.assert_array_equal(a, b)
    np.testing.assert_allclose(a.std(0), np.linspace(0.5, 2.0, 50), rtol=0.25)
