"""Reinforcement-learning baselines on ``tt_drake/ReturnBall-v0`` from scratch
(``action="absolute"``: no teacher inside), each one command with a seed, resumable, writing
its progress as it goes:

    python -m tt_drake.diagrams.commands.rl_baselines COMMAND ...

with COMMAND one of

    sac   --serves default --seed 0 --steps 1500 --out DIR [--scenario S]
    ppo   --serves default --seed 0 --steps 1500 --out DIR [--scenario S]
    cmaes --serves default --seed 0 --steps 1500 --out DIR [--scenario S]
    evaluate DIR [DIR ...] --episodes 100
    teachers --serves default --episodes 100 --out DIR [--scenario S]
    report DIR [DIR ...] --teachers DIR --png FILE

``--scenario`` (a name in models/ or a YAML path; default ``default``) is the environments' and
the teachers' scenario; a run records it in ``config.json`` and ``evaluate`` plays it there.

One step of ReturnBall-v0 is one serve, so ``--steps`` counts training episodes. SAC and PPO are
Stable-Baselines3's (``pip install "tt-drake[rl]"``: SB3 and torch, optional); CMA-ES (the
``cma`` package of the ``gym`` extra) searches a linear policy a = tanh(W x + b) of the
observation x scaled to its bounds, W and b starting at 0 (every joint at the centre of its
range, no velocity, the hit in the middle of the window).

Training uses the shaped reward by default (``--reward shaped``: the referee's, and for a missed
ball SHAPING_MAX exp(-d^2 / (2 sigma^2)) of the closest racket-to-ball distance d; docs/gym.md);
evaluation counts the referee's verdicts (legal returns: ``outcome.returned``; on target).

Serves: training episode k of a run with ``--seed s`` plays serve ``episode_seed(TRAIN_BASE + s,
k)`` (CMA-ES: ``CMAES_BASE + s``); evaluation serve i is ``episode_seed(EVAL_BASE, i)``, the
serves ``tt-drake serve --seed EVAL_BASE`` plays, so the teachers (``teachers``: the analytical
player, the learned player with the paper set and with the hard set) play the same ones.
``evaluate`` checks that no evaluation serve was a training serve.

Each run folder holds ``config.json``, ``progress.jsonl`` (one line per training episode: serve,
reward, the referee's verdict, cumulative CPU seconds of the run), the policy (``model.zip`` and
the observation normaliser ``vecnormalize.pkl``, SB3; ``cmaes.json``), saved every
``--checkpoint`` episodes; run the command again to continue
from the last checkpoint (episodes after it are played again, on the same serves).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import gymnasium
import numpy as np
from matplotlib.figure import Figure

import tt_drake.gym  # noqa: F401  (registers the environments)
from tt_drake.diagrams.cli import main as tt_drake_main
from tt_drake.diagrams.commands.options import add_scenario_option
from tt_drake.intervals import wilson
from tt_drake.outputs import write_json_atomic, write_text_atomic
from tt_drake.seeds import episode_seed

TRAIN_BASE = 100  # + --seed: the SB3 runs' training serves
CMAES_BASE = 200  # + --seed: CMA-ES's
EVAL_BASE = 4000  # the evaluation serves (no training stage of tt-drake reproduce uses it)
ENV_ID = "tt_drake/ReturnBall-v0"
SB3_ALGORITHMS = ("sac", "ppo")
#: The teachers the table compares with: label -> ``tt-drake serve`` player options.
TEACHERS = {"analytical player": ["--player", "analytical"],
            "MoMP, paper set": ["--player", "momp"],
            "MoMP, hard set": ["--player", "momp", "--artefacts", "hard"]}

#: The table's "training" column for the rows that are not runs.
TRAINING = {"analytical player": "none (physical model)",
            "MoMP, paper set": "shipped artefacts (models/learned)",
            "MoMP, hard set": "shipped artefacts (models/learned-hard)",
            "random absolute actions": "none"}
NAMES = {"ppo": "PPO", "sac": "SAC", "cmaes": "CMA-ES"}


class SeededServes(gymnasium.Wrapper):
    """Episode k (counted from ``first``) plays serve ``episode_seed(base, k)``; ``serve_seeds``
    lists those played."""

    def __init__(self, env, base: int, first: int = 0):
        super().__init__(env)
        self.base, self.k, self.serve_seeds = int(base), int(first), []

    def reset(self, *, seed=None, options=None):
        serve = episode_seed(self.base, self.k)
        self.k += 1
        self.serve_seeds.append(serve)
        return self.env.reset(seed=seed, options={**(options or {}), "serve_seed": serve})


#: The scenario of a run whose ``config.json`` names none: such runs were made when the default
#: robot had ideal drives and no camera latency, the ``ideal_robot`` scenario's.
LEGACY_SCENARIO = "ideal_robot"


def make_env(serves: str, reward: str = "shaped", scenario: str = "default"):
    return gymnasium.make(ENV_ID, scenario=scenario, distribution=serves, action="absolute",
                          reward=reward)


class Progress:
    """``progress.jsonl`` of a run: one line per training episode, appended as it ends."""

    def __init__(self, folder: Path):
        self.path = folder / "progress.jsonl"
        self.lines = read_progress(folder)
        self.cpu0 = self.lines[-1]["cpu_s"] if self.lines else 0.0
        self.start = time.process_time()

    def truncate(self, episodes: int) -> None:
        """Keep the first ``episodes`` lines (those before the checkpoint resumed from)."""
        self.lines = self.lines[:episodes]
        self.cpu0 = self.lines[-1]["cpu_s"] if self.lines else 0.0
        write_text_atomic(self.path, "".join(json.dumps(x) + "\n" for x in self.lines))

    def add(self, serve: int, reward: float, info: dict) -> None:
        outcome = info["outcome"]
        line = {"episode": len(self.lines) + 1, "serve_seed": int(serve),
                "reward": round(float(reward), 5), "hit": bool(outcome["hit"]),
                "returned": bool(outcome["returned"]), "on_target": bool(outcome["on_target"]),
                "closest": round(float(info.get("closest_approach", math.nan)), 4),
                "cpu_s": round(self.cpu0 + time.process_time() - self.start, 2)}
        self.lines.append(line)
        with self.path.open("a") as f:
            f.write(json.dumps(line) + "\n")


def read_progress(folder: Path) -> list[dict]:
    path = Path(folder) / "progress.jsonl"
    if not path.exists():
        return []
    return [json.loads(x) for x in path.read_text().splitlines() if x.strip()]


def _start_run(args, algorithm: str) -> tuple[Path, dict]:
    folder = Path(args.out)
    folder.mkdir(parents=True, exist_ok=True)
    config = {"algorithm": algorithm, "env": ENV_ID, "action": "absolute", "serves": args.serves,
              "seed": args.seed, "reward": args.reward, "scenario": args.scenario,
              "train_base": (CMAES_BASE if algorithm == "cmaes" else TRAIN_BASE) + args.seed}
    path = folder / "config.json"
    if path.exists():
        old = json.loads(path.read_text())
        old.setdefault("scenario", LEGACY_SCENARIO)
        if {k: old.get(k) for k in config} != config:
            raise SystemExit(f"rl_baselines: {folder} holds another run ({old}); choose another "
                             "--out")
    write_json_atomic(path, config)
    return folder, config


def train_sb3(args) -> int:
    """SAC or PPO (Stable-Baselines3's default hyper-parameters except PPO's rollout length and
    initial noise, below), resumed from ``model.zip`` if there is one."""
    try:  # Stable-Baselines3 is the optional rl extra
        import stable_baselines3 as sb3
        from stable_baselines3.common.callbacks import BaseCallback
        from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize
    except ImportError:
        print('rl_baselines: needs Stable-Baselines3: pip install "tt-drake[rl]"', file=sys.stderr)
        return 2
    folder, config = _start_run(args, args.algorithm)
    model_path = folder / "model.zip"
    buffer_path = folder / "replay_buffer.pkl"
    done = json.loads((folder / "checkpoint.json").read_text())["episodes"] if (
        folder / "checkpoint.json").exists() and model_path.exists() else 0
    progress = Progress(folder)
    progress.truncate(done)
    norm_path = folder / "vecnormalize.pkl"
    env = SeededServes(make_env(args.serves, args.reward, args.scenario), config["train_base"],
                       first=done)
    # Observations and rewards normalised by running statistics (SB3's VecNormalize): the raw
    # observation mixes metres, m/s and spins of tens of rad/s (the MLP's tanh saturates), and a
    # miss's shaped reward is at most 0.1.
    venv = DummyVecEnv([lambda: env])
    venv = VecNormalize.load(norm_path, venv) if done else VecNormalize(venv)
    cls = {"sac": sb3.SAC, "ppo": sb3.PPO}[args.algorithm]
    if done:
        model = cls.load(model_path, env=venv, seed=args.seed, device="cpu")
        if args.algorithm == "sac" and buffer_path.exists():
            model.load_replay_buffer(buffer_path)
    else:
        # PPO: rollouts of --rollout (128) one-step episodes, and an initial action noise of std 0.5
        # (log std -0.7) instead of 1, which in [-1, 1] would clip most actions to the bounds.
        kwargs = ({"n_steps": args.rollout, "batch_size": min(64, args.rollout),
                   "policy_kwargs": {"log_std_init": -0.7}} if args.algorithm == "ppo" else {})
        model = cls("MlpPolicy", venv, seed=args.seed, device="cpu", verbose=0, **kwargs)

    def checkpoint(episodes: int) -> None:
        model.save(model_path)
        venv.save(norm_path)
        if args.algorithm == "sac":
            model.save_replay_buffer(buffer_path)
        write_json_atomic(folder / "checkpoint.json", {"episodes": episodes})

    class Record(BaseCallback):
        def _on_step(self) -> bool:
            rewards = venv.get_original_reward()  # the environment's, not the normalised
            for reward, info in zip(rewards, self.locals["infos"], strict=True):
                progress.add(info["serve_seed"], reward, info)
                n = len(progress.lines)
                if n % args.checkpoint == 0:
                    checkpoint(n)
                if n % 50 == 0:
                    last = progress.lines[-50:]
                    mean = {k: np.mean([x[k] for x in last])
                            for k in ("returned", "hit", "reward")}
                    print(f"{n} episodes: last 50 returned {mean['returned']:.0%}, hit "
                          f"{mean['hit']:.0%}, reward {mean['reward']:.3f}, "
                          f"{progress.lines[-1]['cpu_s'] / 60:.1f} CPU-min", flush=True)
            return True

    if args.steps > done:
        model.learn(total_timesteps=args.steps - done, callback=Record(),
                    reset_num_timesteps=not done, progress_bar=False)
    checkpoint(len(progress.lines))
    return 0


class LinearPolicy:
    """a = tanh(W x / high + b): the observation x scaled by its bounds."""

    def __init__(self, params, observation_space, action_size: int):
        n = observation_space.shape[0]
        p = np.asarray(params, dtype=float)
        self.W, self.b = p[: action_size * n].reshape(action_size, n), p[action_size * n:]
        self.scale = np.maximum(np.abs(observation_space.low), np.abs(observation_space.high))

    def __call__(self, obs) -> np.ndarray:
        return np.tanh(self.W @ (np.asarray(obs, dtype=float) / self.scale) + self.b)


def train_cmaes(args) -> int:
    """CMA-ES (diagonal covariance: hundreds of parameters) on :class:`LinearPolicy`; every
    candidate plays one new serve, its fitness the (shaped) reward; resumed from ``cmaes.json``
    (the distribution's mean and step size; the covariance restarts)."""
    import cma  # the optional gym extra: only CMA-ES runs need it

    folder, config = _start_run(args, "cmaes")
    state_path = folder / "cmaes.json"
    state = json.loads(state_path.read_text()) if state_path.exists() else None
    done = state["episodes"] if state else 0
    progress = Progress(folder)
    progress.truncate(done)
    env = SeededServes(make_env(args.serves, args.reward, args.scenario), config["train_base"],
                       first=done)
    n_obs, n_act = env.observation_space.shape[0], env.action_space.shape[0]
    size = n_act * (n_obs + 1)
    x0 = np.asarray(state["mean"]) if state else np.zeros(size)
    sigma = state["sigma"] if state else args.sigma0
    es = cma.CMAEvolutionStrategy(x0, sigma, {"popsize": args.popsize, "seed": args.seed + 1,
                                              "CMA_diagonal": True, "verbose": -9})
    used = done
    while used + args.popsize <= args.steps:
        candidates = es.ask()
        fitness = []
        for x in candidates:
            policy = LinearPolicy(x, env.observation_space, n_act)
            obs, _ = env.reset()
            _, reward, _, _, info = env.step(policy(obs).astype(np.float32))
            progress.add(env.serve_seeds[-1], reward, info)
            fitness.append(-float(reward))
        es.tell(candidates, fitness)
        used += args.popsize
        write_json_atomic(state_path, {"episodes": used, "mean": list(map(float, es.mean)),
                                       "sigma": float(es.sigma)})
        last = progress.lines[-args.popsize:]
        print(f"{used} episodes: generation returned {np.mean([x['returned'] for x in last]):.0%}"
              f", reward {np.mean([x['reward'] for x in last]):.3f}, sigma {es.sigma:.3f}, "
              f"{progress.lines[-1]['cpu_s'] / 60:.1f} CPU-min", flush=True)
    return 0


def load_policy(folder: Path, env):
    """The trained policy of a run folder, as obs -> action (SB3's deterministic action; the
    CMA-ES distribution's mean)."""
    config = json.loads((folder / "config.json").read_text())
    if config["algorithm"] == "cmaes":
        mean = json.loads((folder / "cmaes.json").read_text())["mean"]
        policy = LinearPolicy(mean, env.observation_space, env.action_space.shape[0])
        return lambda obs: policy(obs).astype(np.float32)
    import stable_baselines3 as sb3  # the optional rl extra: only SB3 runs need it
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    model = {"sac": sb3.SAC, "ppo": sb3.PPO}[config["algorithm"]].load(folder / "model.zip",
                                                                         device="cpu")
    norm = VecNormalize.load(folder / "vecnormalize.pkl", DummyVecEnv([lambda: env]))
    norm.training = False  # the statistics as training left them
    return lambda obs: model.predict(norm.normalize_obs(obs), deterministic=True)[0]


def evaluation_seeds(episodes: int) -> list[int]:
    return [episode_seed(EVAL_BASE, i) for i in range(episodes)]


def evaluate(args) -> int:
    """Each run's policy on the evaluation serves of its distribution, the referee's reward;
    writes ``evaluation.json`` in the run folder."""
    for name in args.runs:
        folder = Path(name)
        config = json.loads((folder / "config.json").read_text())
        seeds = evaluation_seeds(args.episodes)
        trained = {x["serve_seed"] for x in read_progress(folder)}
        overlap = trained.intersection(seeds)
        if overlap:
            raise SystemExit(f"rl_baselines: {folder} trained on evaluation serves {overlap}")
        env = make_env(config["serves"], reward="referee",
                       scenario=config.get("scenario", LEGACY_SCENARIO))
        policy = load_policy(folder, env)
        episodes, cpu = [], time.process_time()
        for serve in seeds:
            obs, _ = env.reset(options={"serve_seed": serve})
            _, reward, _, _, info = env.step(policy(obs))
            episodes.append({"serve_seed": serve, "reward": float(reward),
                             **{k: info["outcome"][k] for k in ("hit", "returned", "on_target")}})
        result = {"serves": config["serves"], "eval_base": EVAL_BASE,
                  "training_episodes": len(trained), "episodes": episodes,
                  **rates(episodes), "cpu_s": round(time.process_time() - cpu, 1)}
        write_json_atomic(folder / "evaluation.json", result)
        print(f"{folder}: {summary_line(result)}")
    return 0


def rates(episodes: list[dict]) -> dict:
    n = len(episodes)
    out = {"n": n, "mean_reward": float(np.mean([e["reward"] for e in episodes]))}
    for key in ("hit", "returned", "on_target"):
        k = sum(bool(e[key]) for e in episodes)
        out[f"{key}_rate"], out[f"{key}_ci95"] = k / n, list(wilson(k, n))
    return out


def summary_line(r: dict) -> str:
    return (f"legal returns {r['returned_rate']:.1%} [{r['returned_ci95'][0]:.1%}, "
            f"{r['returned_ci95'][1]:.1%}], on target {r['on_target_rate']:.1%} "
            f"[{r['on_target_ci95'][0]:.1%}, {r['on_target_ci95'][1]:.1%}], hit "
            f"{r['hit_rate']:.1%}, mean reward {r['mean_reward']:.3f} ({r['n']} serves)")


def teachers(args) -> int:
    """The analytical player and the learned player (paper and hard sets) on the evaluation
    serves, with ``tt-drake serve --seed EVAL_BASE`` (its JSON per player in ``--out``), and
    uniform random absolute actions on the same serves; ``<out>/<serves>.json`` their rates."""
    folder = Path(args.out)
    folder.mkdir(parents=True, exist_ok=True)
    results = {}
    for label, options in TEACHERS.items():
        path = folder / f"{args.serves}_{options[1]}{'_hard' if 'hard' in options else ''}.json"
        if not path.exists():
            code = tt_drake_main(["serve", *options, "--distribution", args.serves, "--serves",
                             str(args.episodes), "--seed", str(EVAL_BASE), "--scenario",
                             args.scenario, "--quiet", "--json", str(path)])
            if code:
                return code
        data = json.loads(path.read_text())
        episodes = [{"serve_seed": e["seed"], "reward": e["reward"], "hit": e["hit"],
                     "returned": e["returned"], "on_target": e["on_target"]}
                    for e in data["episodes"]]
        if [e["serve_seed"] for e in episodes] != evaluation_seeds(len(episodes)):
            raise SystemExit(f"rl_baselines: {path} did not play the evaluation serves")
        results[label] = rates(episodes)
        print(f"{label} ({args.serves}): {summary_line(results[label])}")
    # The floor: uniform random absolute actions (seeded) on the same serves.
    env = make_env(args.serves, reward="referee", scenario=args.scenario)
    rng = np.random.default_rng(EVAL_BASE)
    episodes = []
    for serve in evaluation_seeds(args.episodes):
        env.reset(options={"serve_seed": serve})
        _, reward, _, _, info = env.step(rng.uniform(-1.0, 1.0, 15).astype(np.float32))
        episodes.append({"reward": float(reward),
                         **{k: info["outcome"][k] for k in ("hit", "returned", "on_target")}})
    label = "random absolute actions"
    results[label] = rates(episodes)
    print(f"{label} ({args.serves}): {summary_line(results[label])}")
    write_json_atomic(folder / f"{args.serves}.json", results)
    return 0


def report(args) -> int:
    """The table (Markdown, printed) and the learning curves (``--png``) of the runs."""
    rows = ["| serves | policy | training | legal returns (95 % CI) | on target (95 % CI) | "
            "hit | mean reward |", "| --- | --- | --- | --- | --- | --- | --- |"]

    def row(serves, label, training, r):
        return (f"| {serves} | {label} | {training} | {r['returned_rate']:.1%} "
                f"[{r['returned_ci95'][0]:.1%}, {r['returned_ci95'][1]:.1%}] | "
                f"{r['on_target_rate']:.1%} [{r['on_target_ci95'][0]:.1%}, "
                f"{r['on_target_ci95'][1]:.1%}] | {r['hit_rate']:.1%} | {r['mean_reward']:.3f} |")

    runs = [Path(r) for r in args.runs]
    fig = Figure(figsize=(10.0, 8.0), dpi=90)
    axes = fig.subplots(3, 2, sharex="col", sharey="row")
    for folder in runs:
        config = json.loads((folder / "config.json").read_text())
        lines = read_progress(folder)
        label = f"{NAMES[config['algorithm']]} ({config['serves']}, seed {config['seed']})"
        if (folder / "evaluation.json").exists():
            ev = json.loads((folder / "evaluation.json").read_text())
            training = f"{len(lines)} episodes, {lines[-1]['cpu_s'] / 60:.1f} CPU-min"
            rows.append(row(config["serves"], f"{NAMES[config['algorithm']]} from scratch",
                            training, ev))
        if not lines:
            continue
        w = min(args.window, len(lines))
        episodes = np.arange(1, len(lines) + 1)
        hours = np.array([v["cpu_s"] for v in lines]) / 3600.0
        for i, key in enumerate(("returned", "hit", "reward")):
            y = np.array([float(v[key]) for v in lines])
            smooth = np.convolve(y, np.ones(w) / w, mode="valid")
            for j, x in enumerate((episodes, hours)):
                axes[i, j].plot(x[w - 1:], smooth, label=label)
    if args.teachers:
        for serves in sorted({json.loads((r / "config.json").read_text())["serves"]
                              for r in runs}):
            path = Path(args.teachers) / f"{serves}.json"
            if path.exists():
                for label, r in json.loads(path.read_text()).items():
                    rows.append(row(serves, label, TRAINING.get(label, ""), r))
    axes[0, 0].set_ylabel(f"legal returns (moving mean of {args.window})")
    axes[1, 0].set_ylabel(f"hits (moving mean of {args.window})")
    axes[2, 0].set_ylabel(f"training reward (moving mean of {args.window})")
    axes[2, 0].set_xlabel("training episode (one serve each)")
    axes[2, 1].set_xlabel("CPU-hours of the run (process time)")
    for ax in axes.flat:
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    fig.suptitle("ReturnBall-v0 from scratch (action='absolute', shaped reward)", fontsize=10)
    fig.tight_layout()
    if args.png:
        fig.savefig(args.png)
    print("\n".join(rows))
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="python -m tt_drake.diagrams.commands.rl_baselines",
                                     description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    for name in (*SB3_ALGORITHMS, "cmaes"):
        p = sub.add_parser(name, help=f"train {name.upper()} from scratch")
        p.add_argument("--serves", default="default", help="serve distribution (default, spin, "
                       "real, ...; default: default)")
        p.add_argument("--seed", type=int, default=0)
        p.add_argument("--steps", type=int, default=1500, help="training episodes in all")
        p.add_argument("--out", required=True, help="run folder (resumed if it exists)")
        p.add_argument("--reward", default="shaped", choices=("shaped", "referee"))
        p.add_argument("--checkpoint", type=int, default=100, help="episodes per checkpoint")
        add_scenario_option(p)
        if name == "ppo":
            p.add_argument("--rollout", type=int, default=128,
                           help="episodes per PPO update (n_steps; default: 128)")
        if name == "cmaes":
            p.add_argument("--popsize", type=int, default=16)
            p.add_argument("--sigma0", type=float, default=0.5)
        p.set_defaults(algorithm=name)
    ev = sub.add_parser("evaluate", help="evaluate trained runs on the evaluation serves")
    ev.add_argument("runs", nargs="+")
    ev.add_argument("--episodes", type=int, default=100)
    te = sub.add_parser("teachers", help="the teachers on the evaluation serves")
    te.add_argument("--serves", default="default")
    te.add_argument("--episodes", type=int, default=100)
    te.add_argument("--out", required=True)
    add_scenario_option(te)
    rep = sub.add_parser("report", help="table and learning curves")
    rep.add_argument("runs", nargs="+")
    rep.add_argument("--teachers", default=None, help="the teachers' folder")
    rep.add_argument("--png", default=None)
    rep.add_argument("--window", type=int, default=50, help="moving average (episodes)")
    return parser


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    if args.command in SB3_ALGORITHMS:
        return train_sb3(args)
    return {"cmaes": train_cmaes, "evaluate": evaluate, "teachers": teachers,
            "report": report}[args.command](args)


if __name__ == "__main__":
    sys.exit(main())
