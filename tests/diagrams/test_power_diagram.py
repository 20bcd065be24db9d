"""PoWER (Eq. 9, through tt_drake.mixture_learning) improves a stroke in the serve diagram.

With the library's default gains (alpha_y = 35) a hitting DMP reaches the hitting configuration
whatever its weights, so PoWER has nothing to improve there. This test builds a primitive whose
weights do move the impact: one hitting primitive imitated from the teacher's stroke with a
low-gain DMP (alpha_y = 10), which no longer pulls the arm to the goal and so arrives off the
hitting configuration on other serves. Each rollout runs the explored weights on a fixed pair of
serves and earns their mean reward; three PoWER updates of six rollouts must raise the mean
reward of the mean weights on those serves. On the ideal robot, the robot of the learning
figures in docs/reproducing.md.
"""

from __future__ import annotations

import numpy as np
import pytest

from tt_drake.diagrams.collect import collect
from tt_drake.diagrams.episodes import ServeDiagram, episode_seed
from tt_drake.diagrams.reproduce import credited_reward
from tt_drake.diagrams.scenario import load_scenario
from tt_drake.diagrams.train import train_library
from tt_drake.dmp import HittingDMP
from tt_drake.mixture_learning import MixtureLearner, PowerParams

SERVES = [episode_seed(11, i) for i in range(2)]


@pytest.mark.slow
def test_power_raises_the_reward_of_a_low_gain_primitive_in_the_diagram(tmp_path):
    from importlib.resources import files

    models = files("tt_drake.models") / "learned"
    data, library = tmp_path / "teacher", tmp_path / "library.npz"
    collect(load_scenario("ideal_robot"), "analytical", 2, 11, str(data), progress=False)
    train_library(data, library, primitives=1, dmp=HittingDMP(alpha_y=10.0))
    scenario = load_scenario("ideal_robot")
    scenario.learned.library = str(library)
    scenario.learned.crkr = str(models / "crkr.npz")
    scenario.learned.predictor = str(models / "predictor.npz")
    diagram = ServeDiagram(scenario, "momp")
    lib = diagram.library
    imitated = lib.weights.copy()
    learner = MixtureLearner(lib.weights, lib.stimuli, lib.bandwidths,
                             power=PowerParams(relative_sigma=0.5, n_best=6))

    def rollout(weights):
        episodes = [diagram.run(seed, weights=weights) for seed in SERVES]
        return episodes, float(np.mean([credited_reward(e.as_dict()) for e in episodes]))

    _, before = rollout(learner.weights)
    explored_rewards = []
    for batch in range(3):
        for k in range(6):
            theta = learner.explore(np.random.default_rng([0, batch, k]))
            episodes, reward = rollout(theta)
            explored_rewards.append(reward)
            stroke = episodes[0].stroke
            learner.credit(stroke["stimulus"], stroke["primitives"], stroke["mixture"], reward,
                           theta)
        assert learner.update_weights().tolist() == [0]
    _, after = rollout(learner.weights)
    # the premise: here the weights move the outcome (explored rewards spread widely)
    assert np.ptp(explored_rewards) > 0.2
    assert after > before + 0.1
    assert not np.allclose(learner.weights, imitated)
