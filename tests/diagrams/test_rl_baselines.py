"""The reinforcement-learning baselines' commands: training writes its progress and resumes on the
same serves, evaluation plays serves no training used, the table's intervals are Wilson's.
Stable-Baselines3 is optional (the ``rl`` extra): its tests carry the ``rl`` marker
(``make test-rl``)."""

import json
import warnings

import gymnasium
import numpy as np
import pytest

from tt_drake.diagrams.commands import rl_baselines as rl
from tt_drake.intervals import wilson
from tt_drake.seeds import episode_seed


def test_wilson_interval_matches_the_formula_and_stays_in_0_1():
    lo, hi = wilson(67, 100)
    # p = 0.67, z = 1.96: centre 0.66371, half width 0.09066
    assert (lo, hi) == pytest.approx((0.5731, 0.7544), abs=1e-4)
    assert wilson(0, 50)[0] == 0.0 and 0.06 < wilson(0, 50)[1] < 0.08
    assert wilson(50, 50)[1] == 1.0


def test_cmaes_run_resumes_on_the_same_serves_and_evaluates_on_others(tmp_path, capsys):
    out = tmp_path / "cmaes"
    common = ["--serves", "default", "--seed", "3", "--popsize", "2", "--out", str(out)]
    assert rl.main(["cmaes", "--steps", "2", *common]) == 0
    first = rl.read_progress(out)
    assert [x["serve_seed"] for x in first] == [episode_seed(rl.CMAES_BASE + 3, k)
                                                for k in range(2)]
    assert all(0.0 <= x["reward"] <= 1.0 and x["cpu_s"] > 0 for x in first)
    state = json.loads((out / "cmaes.json").read_text())
    assert state["episodes"] == 2 and len(state["mean"]) == 15 * 19
    # Run again with a larger budget: it continues after episode 2, on the next serves.
    assert rl.main(["cmaes", "--steps", "4", *common]) == 0
    lines = rl.read_progress(out)
    assert lines[:2] == first and [x["episode"] for x in lines] == [1, 2, 3, 4]
    assert lines[2]["serve_seed"] == episode_seed(rl.CMAES_BASE + 3, 2)
    assert lines[3]["cpu_s"] >= lines[1]["cpu_s"]
    with pytest.raises(SystemExit, match="another run"):
        rl.main(["cmaes", "--steps", "4", "--serves", "spin", "--seed", "3", "--out", str(out)])
    assert rl.main(["evaluate", str(out), "--episodes", "2"]) == 0
    ev = json.loads((out / "evaluation.json").read_text())
    assert [e["serve_seed"] for e in ev["episodes"]] == rl.evaluation_seeds(2)
    assert not {e["serve_seed"] for e in ev["episodes"]} & {x["serve_seed"] for x in lines}
    assert ev["returned_rate"] == np.mean([e["returned"] for e in ev["episodes"]])
    png = tmp_path / "curve.png"
    assert rl.main(["report", str(out), str(out), "--png", str(png), "--window", "2"]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    table = capsys.readouterr().out
    assert table.count("| default | CMA-ES from scratch | 4 episodes") == 2


def test_evaluation_refuses_a_run_that_trained_on_evaluation_serves(tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    (out / "config.json").write_text(json.dumps({"algorithm": "cmaes", "serves": "default"}))
    (out / "progress.jsonl").write_text(json.dumps({"serve_seed": rl.evaluation_seeds(3)[2]}))
    with pytest.raises(SystemExit, match="evaluation serves"):
        rl.main(["evaluate", str(out), "--episodes", "3"])


def test_training_serves_and_evaluation_serves_are_disjoint_for_the_documented_budgets():
    """Seeds 0-2 of every trainer over 3000 episodes never meet the first 500 evaluation
    serves (the documented runs use fewer of each)."""
    evaluation = set(rl.evaluation_seeds(500))
    for base in (rl.TRAIN_BASE, rl.CMAES_BASE):
        for seed in range(3):
            assert not evaluation & {episode_seed(base + seed, k) for k in range(3000)}


@pytest.mark.rl
@pytest.mark.parametrize("kwargs", [{}, {"action": "absolute"}])
def test_sb3_check_env_passes_without_warnings(kwargs):
    env_checker = pytest.importorskip("stable_baselines3.common.env_checker")
    for env_id in ("tt_drake/ReturnBall-v0", "tt_drake/ReturnBallStep-v0"):
        if kwargs and env_id.endswith("Step-v0"):
            continue
        env = gymnasium.make(env_id, **kwargs)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            env_checker.check_env(env)
        assert [str(w.message) for w in caught] == []


@pytest.mark.rl
def test_ppo_run_writes_progress_and_resumes(tmp_path):
    pytest.importorskip("stable_baselines3")
    out = tmp_path / "ppo"
    common = ["--serves", "default", "--seed", "1", "--checkpoint", "2", "--rollout", "2",
              "--out", str(out)]
    assert rl.main(["ppo", "--steps", "2", *common]) == 0
    assert json.loads((out / "checkpoint.json").read_text())["episodes"] == 2
    assert rl.main(["ppo", "--steps", "4", *common]) == 0
    lines = rl.read_progress(out)
    assert [x["serve_seed"] for x in lines] == [episode_seed(rl.TRAIN_BASE + 1, k)
                                                for k in range(4)]
    for x in lines:  # the environment's shaped reward, not VecNormalize's normalised one
        if not x["hit"]:
            assert x["reward"] == pytest.approx(0.1 * np.exp(-x["closest"] / 0.25), abs=2e-5)
    assert rl.main(["evaluate", str(out), "--episodes", "1"]) == 0
    assert json.loads((out / "evaluation.json").read_text())["n"] == 1


@pytest.mark.slow
def test_teachers_play_the_evaluation_serves(tmp_path, capsys):
    """The teachers' rows come from ``tt-drake serve --seed EVAL_BASE``: the same serves as the
    policies' evaluation (checked by the command), and the teachers return them."""
    assert rl.main(["teachers", "--serves", "default", "--episodes", "2", "--out",
                    str(tmp_path)]) == 0
    rows = json.loads((tmp_path / "default.json").read_text())
    assert set(rows) == {*rl.TEACHERS, "random absolute actions"}
    assert rows["analytical player"]["returned_rate"] == 1.0
    assert all(r["n"] == 2 for r in rows.values())
    data = json.loads((tmp_path / "default_analytical.json").read_text())
    assert [e["seed"] for e in data["episodes"]] == rl.evaluation_seeds(2)
