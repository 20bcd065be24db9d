"""Gymnasium environments of tt-drake, registered on import (``pip install tt-drake[gym]``)::

    import gymnasium
    import tt_drake.gym  # noqa: F401

    env = gymnasium.make("tt_drake/ReturnBall-v0", distribution="default")

- ``tt_drake/ReturnBall-v0``: episodic, one serve and one stroke per episode: the offset to the
  analytical player's hitting configuration, or with ``action="absolute"`` the hitting
  configuration and time from scratch (no teacher);
- ``tt_drake/ReturnBallStep-v0``: step-based on ``pydrake.gym.DrakeGymEnv``, joint set-point
  increments at 100 Hz.

The environments live in :mod:`tt_drake.diagrams.gym_envs` (spaces, reward and options are
documented there and in docs/gym.md); this module only registers them, by name, so that it
imports no pydrake (docs/design.md, "Layout and layering").
"""

from gymnasium.envs.registration import register, registry

ENVIRONMENTS = {
    "tt_drake/ReturnBall-v0": "tt_drake.diagrams.gym_envs:ReturnBallEnv",
    "tt_drake/ReturnBallStep-v0": "tt_drake.diagrams.gym_envs:ReturnBallStepEnv",
}

for _env_id, _entry_point in ENVIRONMENTS.items():
    if _env_id not in registry:
        register(id=_env_id, entry_point=_entry_point)
