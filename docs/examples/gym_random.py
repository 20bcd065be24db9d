"""A random policy on tt_drake/ReturnBall-v0: its success rate (on target: a legal return within
0.2 m of the target) over N episodes, beside the analytical player's (action = 0) on the same
serves.

The random policy samples every action from the action space (uniform offsets of at most
0.1 rad to theta_hit and 1 rad/s to theta_dot_hit per joint, the environment's defaults).

    python docs/examples/gym_random.py --episodes 30 --seed 0 --distribution fixed \
        --out docs/img/gym_random --scenario ideal_robot

writes ``<out>.json`` (per-episode rewards and successes, the rates) and ``<out>.png`` (the
running success rates).
"""

from __future__ import annotations

import argparse
import sys
import time

import gymnasium
import matplotlib
import numpy as np

import tt_drake.gym  # noqa: F401  (registers the environments)
from tt_drake.diagrams.commands.options import add_scenario_option
from tt_drake.outputs import OutputError, check_writable, write_json_atomic

matplotlib.use("Agg")


def rollouts(env, policy, episodes: int, seed: int) -> dict:
    """``episodes`` episodes; episode i replays serve i of the run (``seed``) whatever the
    policy, so policies compare on the same serves."""
    rewards, successes, serves = [], [], []
    serve_seeds = [int(s) for s in np.random.default_rng(seed).integers(0, 2**32, episodes)]
    for serve in serve_seeds:
        obs, _ = env.reset(options={"serve_seed": serve})
        _, reward, _, _, info = env.step(policy(obs))
        rewards.append(float(reward))
        successes.append(bool(info["is_success"]))
        serves.append(serve)
    return {"rewards": rewards, "successes": successes, "serve_seeds": serves,
            "success_rate": float(np.mean(successes)), "mean_reward": float(np.mean(rewards))}


def plot(path: str, curves: dict[str, list[bool]], title: str) -> None:
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 3.4), dpi=90)
    for label, successes in curves.items():
        n = np.arange(1, len(successes) + 1)
        ax.plot(n, np.cumsum(successes) / n, label=label)
    ax.set_xlabel("episode")
    ax.set_ylabel("success rate so far")
    ax.set_ylim(-0.02, 1.02)
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--episodes", type=int, default=30, help="episodes per policy "
                        "(default: 30)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the serves and the random "
                        "actions (default: 0)")
    parser.add_argument("--distribution", default="fixed", choices=["default", "real", "fixed"],
                        help="serve distribution (default: fixed)")
    add_scenario_option(parser)
    parser.add_argument("--out", default="gym_random", help="output stem: writes <out>.json and "
                        "<out>.png (default: gym_random)")
    args = parser.parse_args(argv)
    if args.episodes < 1:
        print("gym_random: --episodes must be >= 1", file=sys.stderr)
        return 2
    try:
        for suffix in (".json", ".png"):
            check_writable(args.out + suffix)
    except OutputError as err:
        print(f"gym_random: {err}", file=sys.stderr)
        return 2
    wall = time.perf_counter()
    env = gymnasium.make("tt_drake/ReturnBall-v0", scenario=args.scenario,
                         distribution=args.distribution)
    env.action_space.seed(args.seed)
    random = rollouts(env, lambda obs: env.action_space.sample(), args.episodes, args.seed)
    analytical = rollouts(env, lambda obs: np.zeros(env.action_space.shape), args.episodes,
                          args.seed)
    result = {"env": "tt_drake/ReturnBall-v0", "distribution": args.distribution,
              "episodes": args.episodes, "seed": args.seed, "random": random,
              "analytical": analytical, "wall_time_s": round(time.perf_counter() - wall, 1)}
    write_json_atomic(args.out + ".json", result)
    plot(args.out + ".png", {
        f"random actions ({random['success_rate']:.0%})": random["successes"],
        f"action 0 = analytical player ({analytical['success_rate']:.0%})":
            analytical["successes"]},
        f"ReturnBall-v0, {args.distribution} serves, seed {args.seed}")
    print(f"random policy: success {random['success_rate']:.1%}, mean reward "
          f"{random['mean_reward']:.3f}; analytical (action 0): success "
          f"{analytical['success_rate']:.1%}, mean reward {analytical['mean_reward']:.3f} "
          f"({args.episodes} {args.distribution} serves, seed {args.seed})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
