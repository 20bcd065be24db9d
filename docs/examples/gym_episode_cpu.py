"""CPU time of a Gymnasium episode of tt-drake (docs/gym.md, docs/performance.md): reset and
steps with the zero action (ReturnBall-v0, offset mode: the teacher's stroke) until the episode
ends, on serves of seeds ``seed`` .. ``seed + episodes - 1`` after one untimed warm-up episode.

    OPENBLAS_NUM_THREADS=1 python docs/examples/gym_episode_cpu.py --episodes 20 [--seed 100]
        [--env tt_drake/ReturnBall-v0] [--action offset|absolute] [--scenario S] [--json FILE]

prints the mean, median and quartiles of the episodes' CPU time (``time.process_time``) and
their simulated durations.
"""

from __future__ import annotations

import argparse
import sys
import time

import gymnasium
import numpy as np

import tt_drake.gym  # noqa: F401  (registers the environments)
from tt_drake.outputs import write_json_atomic


def episode_cpu(env_id: str, episodes: int, seed: int, action: str | None,
                scenario: str | None = None) -> dict:
    kwargs = {"action": action} if action is not None else {}
    if scenario is not None:
        kwargs["scenario"] = scenario
    env = gymnasium.make(env_id, **kwargs)
    zero = np.zeros(env.action_space.shape, dtype=env.action_space.dtype)

    def play(episode_seed: int) -> None:
        env.reset(seed=episode_seed)
        done = False
        while not done:
            _, _, terminated, truncated, _ = env.step(zero)
            done = terminated or truncated

    play(seed - 1)  # warm-up: first calls, compiled code loaded
    cpu = []
    for k in range(episodes):
        c0 = time.process_time()
        play(seed + k)
        cpu.append(time.process_time() - c0)
    env.close()
    q1, median, q3 = np.percentile(cpu, [25, 50, 75])
    return {"env": env_id, "action": action, "scenario": scenario or "default",
            "episodes": episodes, "seed": seed,
            "cpu_per_episode": float(np.mean(cpu)), "median": float(median),
            "q1": float(q1), "q3": float(q3), "cpu": cpu}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--env", default="tt_drake/ReturnBall-v0")
    ap.add_argument("--action", choices=("offset", "absolute"), default=None,
                    help="ReturnBall-v0's action mode (default: the environment's, offset)")
    ap.add_argument("--episodes", type=int, default=20)
    ap.add_argument("--seed", type=int, default=100)
    ap.add_argument("--scenario", default=None,
                    help="a scenario name or YAML path (default: the environment's, default)")
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    if args.episodes < 1:
        ap.error("--episodes must be >= 1")
    r = episode_cpu(args.env, args.episodes, args.seed, args.action, args.scenario)
    print(f"{r['env']} ({r['action'] or 'default action'}, scenario {r['scenario']}): "
          f"{r['cpu_per_episode']:.3f} s CPU per "
          f"episode (median {r['median']:.3f}, quartiles {r['q1']:.3f}-{r['q3']:.3f}; "
          f"{r['episodes']} episodes, seeds {r['seed']}..{r['seed'] + r['episodes'] - 1})")
    if args.json:
        write_json_atomic(args.json, r)
    return 0


if __name__ == "__main__":
    sys.exit(main())
