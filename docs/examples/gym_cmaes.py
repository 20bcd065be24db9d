"""CMA-ES (the ``cma`` package) improves a stroke offset on tt_drake/ReturnBall-v0.

Parametrisation: one constant action x in [-1, 1]^14 played on every serve (an open-loop
correction of the analytical hitting configuration: 0.1 x[:7] rad on theta_hit, 1.0 x[7:] rad/s on
theta_dot_hit). The search starts from a random action (drawn from the action space with the
seed), as a random policy would play, not from 0 (the analytical player's stroke). Each
generation draws new serves; every candidate plays the same ones (common random numbers) and its
fitness is its mean reward (the paper's reward, which grades how close to the target a return
lands, so it guides the search where success alone is flat). After each generation the
distribution's mean plays the generation's first serve (one extra episode, outside the budget).
The learning curve shows the success rate (on target: a legal return within 0.2 m of the target)
of the generation's episodes, their mean reward and the mean's reward; at the end the mean is
evaluated on the serves of ``gym_random.py`` with the same ``--seed`` and ``--distribution``, so it
compares with the random policy's rate on the same serves.

The default serve distribution is ``fixed`` (one launch state, camera noise drawn per serve): a
constant offset is then a complete policy. On the ``default`` distribution a constant offset
must suit every serve at once, and the best one is 0.

    python docs/examples/gym_cmaes.py --episodes 200 --seed 0 --distribution fixed \
        --random-json docs/img/gym_random.json --out docs/img/gym_learning_curve \
        --scenario ideal_robot

writes ``<out>.json`` (per-generation rates, the final evaluation) and ``<out>.png`` (the
learning curve, with the random policy's and the analytical player's rates from
``--random-json`` if given; ``--replot`` draws it again from ``<out>.json``).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import cma
import gymnasium
import matplotlib
import numpy as np

import tt_drake.gym  # noqa: F401  (registers the environments)
from tt_drake.diagrams.commands.options import add_scenario_option
from tt_drake.outputs import OutputError, check_writable, write_json_atomic

matplotlib.use("Agg")
sys.path.insert(0, str(Path(__file__).resolve().parent))
from gym_random import rollouts  # noqa: E402


def play(env, action, serve_seeds) -> tuple[list[float], list[bool]]:
    rewards, successes = [], []
    for serve in serve_seeds:
        env.reset(options={"serve_seed": int(serve)})
        _, reward, _, _, info = env.step(action)
        rewards.append(float(reward))
        successes.append(bool(info["is_success"]))
    return rewards, successes


def optimise(env, episodes: int, seed: int, popsize: int, serves: int, sigma0: float) -> dict:
    """CMA-ES on the constant action for a budget of ``episodes`` training episodes."""
    rng = np.random.default_rng([seed, 1])
    x0 = rng.uniform(-1.0, 1.0, env.action_space.shape[0])
    es = cma.CMAEvolutionStrategy(x0, sigma0, {"popsize": popsize, "bounds": [-1.0, 1.0],
                                               "seed": seed + 1, "verbose": -9})
    history, used = [], 0
    while used + popsize * serves <= episodes:
        serve_seeds = rng.integers(0, 2**32, serves)
        candidates = es.ask()
        rewards, successes = zip(*(play(env, np.asarray(x), serve_seeds) for x in candidates),
                                 strict=True)
        es.tell(candidates, [-float(np.mean(r)) for r in rewards])
        used += popsize * serves
        # The search distribution's mean (the policy it would play now) on the generation's
        # first serve: one more episode per generation, not counted in the budget.
        mean_reward, mean_success = play(env, policy_mean(es), serve_seeds[:1])
        history.append({"generation": len(history) + 1, "episodes": used,
                        "success_rate": float(np.mean(successes)),
                        "mean_reward": float(np.mean(rewards)),
                        "best_candidate_reward": float(max(np.mean(r) for r in rewards)),
                        "policy_mean_reward": mean_reward[0],
                        "policy_mean_success": mean_success[0],
                        "sigma": float(es.sigma)})
        print(f"generation {len(history):2d}: {used:4d} episodes, success "
              f"{history[-1]['success_rate']:.0%}, mean reward {history[-1]['mean_reward']:.3f}, "
              f"the mean's reward {mean_reward[0]:.3f}, sigma {es.sigma:.3f}", flush=True)
    return {"x0": x0.tolist(), "mean": policy_mean(es).tolist(), "history": history}


def policy_mean(es) -> np.ndarray:
    """The search distribution's mean as an action (inside the bounds)."""
    return np.clip(np.asarray(es.result.xfavorite, dtype=float), -1.0, 1.0)


def plot(path: str, history: list[dict], final: dict, baseline: dict | None, title: str) -> None:
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 3.6), dpi=90)
    x = [h["episodes"] for h in history]
    ax.plot(x, [h["success_rate"] for h in history], "o-", ms=3,
            label="CMA-ES: success of the generation's episodes")
    ax.plot(x, [h["mean_reward"] for h in history], "s--", ms=3, alpha=0.6,
            label="CMA-ES: mean reward of the generation")
    ax.plot(x, [h["policy_mean_reward"] for h in history], "^-", ms=3, color="tab:purple",
            alpha=0.7, label="CMA-ES: reward of the distribution's mean")
    ax.plot([x[-1]], [final["success_rate"]], "r*", ms=12,
            label=f"CMA-ES mean, evaluated: {final['success_rate']:.0%}")
    if baseline is not None:
        ax.axhline(baseline["random"]["success_rate"], color="gray", ls=":",
                   label=f"random policy: {baseline['random']['success_rate']:.0%}")
        ax.axhline(baseline["analytical"]["success_rate"], color="green", ls=":", alpha=0.6,
                   label=f"action 0 (analytical player): "
                         f"{baseline['analytical']['success_rate']:.0%}")
    ax.set_xlabel("training episodes")
    ax.set_ylabel("success rate / reward")
    ax.set_ylim(-0.02, 1.05)
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--episodes", type=int, default=200,
                        help="training budget in episodes (default: 200)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the start, the serves and "
                        "CMA-ES (default: 0)")
    parser.add_argument("--popsize", type=int, default=8, help="CMA-ES population (default: 8)")
    parser.add_argument("--serves", type=int, default=1,
                        help="serves per candidate and generation (default: 1)")
    parser.add_argument("--sigma0", type=float, default=0.3,
                        help="CMA-ES initial step size (default: 0.3)")
    parser.add_argument("--eval-episodes", type=int, default=30, help="serves on which the "
                        "final mean is evaluated (default: 30, as gym_random.py)")
    parser.add_argument("--distribution", default="fixed", choices=["default", "real", "fixed"],
                        help="serve distribution (default: fixed)")
    add_scenario_option(parser)
    parser.add_argument("--random-json", default=None,
                        help="gym_random.py's JSON, to draw its rates (optional)")
    parser.add_argument("--out", default="gym_cmaes", help="output stem: writes <out>.json and "
                        "<out>.png (default: gym_cmaes)")
    parser.add_argument("--replot", action="store_true", help="only draw <out>.png again from "
                        "<out>.json (e.g. with --random-json)")
    args = parser.parse_args(argv)
    problems = [f"--{name} must be >= 1" for name in ("episodes", "popsize", "serves")
                if getattr(args, name) < 1]
    if args.eval_episodes < 1:
        problems.append("--eval-episodes must be >= 1")
    if args.popsize * args.serves > args.episodes:
        problems.append("--episodes must allow one generation (popsize x serves)")
    if not args.sigma0 > 0:
        problems.append("--sigma0 must be > 0")
    baseline = None
    if args.random_json:
        try:
            baseline = json.loads(Path(args.random_json).read_text())
            baseline["random"]["success_rate"], baseline["analytical"]["success_rate"]
        except (OSError, ValueError, KeyError, TypeError) as err:
            problems.append(f"cannot read --random-json {args.random_json}: {err}")
    try:
        for suffix in (".json", ".png"):
            check_writable(args.out + suffix)
    except OutputError as err:
        problems.append(str(err))
    run = None
    if args.replot:
        try:
            run = json.loads(Path(args.out + ".json").read_text())
            run["history"][-1]["episodes"], run["final"]["success_rate"]
        except (OSError, ValueError, KeyError, IndexError, TypeError) as err:
            problems.append(f"cannot read {args.out}.json to replot: {err}")
    if problems:
        print(f"gym_cmaes: {problems[0]}", file=sys.stderr)
        return 2
    if run is not None:
        plot(args.out + ".png", run["history"], run["final"], baseline,
             f"CMA-ES on ReturnBall-v0 ({run['distribution']} serves, seed {run['seed']})")
        return 0
    wall = time.perf_counter()
    env = gymnasium.make("tt_drake/ReturnBall-v0", scenario=args.scenario,
                         distribution=args.distribution)
    run = optimise(env, args.episodes, args.seed, args.popsize, args.serves, args.sigma0)
    mean = np.asarray(run["mean"])
    final = rollouts(env, lambda obs: mean, args.eval_episodes, args.seed)
    result = {"env": "tt_drake/ReturnBall-v0", "distribution": args.distribution,
              "seed": args.seed, "episodes": args.episodes, "popsize": args.popsize,
              "serves_per_candidate": args.serves, "sigma0": args.sigma0, **run,
              "final": final, "wall_time_s": round(time.perf_counter() - wall, 1)}
    write_json_atomic(args.out + ".json", result)
    plot(args.out + ".png", run["history"], final, baseline,
         f"CMA-ES on ReturnBall-v0 ({args.distribution} serves, seed {args.seed})")
    print(f"CMA-ES mean after {run['history'][-1]['episodes']} episodes: success "
          f"{final['success_rate']:.1%}, mean reward {final['mean_reward']:.3f} on "
          f"{args.eval_episodes} serves (start: a random action)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
