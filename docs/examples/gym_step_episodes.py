"""Step-env episodes with fixed policies, recorded for comparing two versions of the code
(docs/performance.md, "The integrator's accuracy").

    OPENBLAS_NUM_THREADS=1 python docs/examples/gym_step_episodes.py OUT.json [--episodes 8] \
        [--scenario S]
    python docs/examples/gym_step_episodes.py --compare A.json B.json

Runs ``tt_drake/ReturnBallStep-v0`` (100 Hz) on serves 1000, 1001, ...: even episodes with zero
actions, odd ones with seeded uniform actions in [-0.3, 0.3]; writes every step's observation,
the termination and the referee's outcome, and prints the CPU seconds spent stepping. With
``--compare``: per episode the number of steps in each, whether the terminations and outcomes
are equal, and the largest observation difference (and at which observation index).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from tt_drake.diagrams.commands.options import add_scenario_option


def record(out: str, episodes: int, scenario: str = "default") -> None:
    import gymnasium

    import tt_drake.gym  # noqa: F401 (registers the environments)
    from tt_drake.outputs import write_json_atomic

    env = gymnasium.make("tt_drake/ReturnBallStep-v0", scenario=scenario, control_rate=100.0)
    runs = []
    cpu = 0.0
    for i in range(episodes):
        rng = np.random.default_rng(100 + i)
        obs, _ = env.reset(options={"serve_seed": 1000 + i})
        observations, done = [obs.tolist()], False
        c0 = time.process_time()
        while not done:
            action = rng.uniform(-0.3, 0.3, 7) if i % 2 else np.zeros(7)
            obs, _, terminated, truncated, info = env.step(action)
            observations.append(obs.tolist())
            done = terminated or truncated
        cpu += time.process_time() - c0
        runs.append({"observations": observations, "terminated": bool(terminated),
                     "truncated": bool(truncated), "info": info})
    print(f"{episodes} episodes, {cpu:.2f} CPU s stepping")
    write_json_atomic(out, runs)


def compare(a_path: str, b_path: str) -> None:
    with open(a_path) as fa, open(b_path) as fb:
        a, b = json.load(fa), json.load(fb)
    for i, (x, y) in enumerate(zip(a, b, strict=True)):
        oa, ob = np.array(x["observations"]), np.array(y["observations"])
        line = f"episode {i}: steps {len(oa) - 1} / {len(ob) - 1}"
        if oa.shape == ob.shape:
            d = np.nan_to_num(np.abs(oa - ob)).max(axis=0)
            line += f", largest observation difference {d.max():.2g} (index {int(d.argmax())})"
        same = (x["terminated"], x["truncated"], x["info"]) == (y["terminated"], y["truncated"],
                                                               y["info"])
        print(f"{line}, ending and outcome {'equal' if same else 'DIFFER'} "
              f"({x['info'].get('outcome', {}).get('outcome')})")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out", nargs="?")
    ap.add_argument("--episodes", type=int, default=8)
    ap.add_argument("--compare", nargs=2, metavar=("A", "B"))
    add_scenario_option(ap)
    args = ap.parse_args()
    if args.compare:
        compare(*args.compare)
    elif args.out:
        record(args.out, args.episodes, args.scenario)
    else:
        ap.error("give OUT.json or --compare A B")


if __name__ == "__main__":
    main()
