"""tt-drake reproduce, hard profile: its stage sizes (a function of the protocol, the paper's
unchanged), its player (the teacher's IK as the hitting configuration, the moving goal), the same
evaluation serves before and after learning, and the report's before/after comparison and pruning
summary. Rollouts are synthetic (no simulation); ``make reproduce-quick-hard`` runs the stages."""

import json

import numpy as np
import pytest

from tt_drake.diagrams import reproduce as rp
from tt_drake.diagrams.ceiling import STRATEGIES
from tt_drake.diagrams.report import (
    format_markdown,
    learning_comparison,
    pruning_summary,
    table_rows,
)


def _stub_stages(monkeypatch):
    """Every stage replaced by one that records that it ran (the run folder's config is what
    these tests read), and no report."""
    ran = []
    stubs = {stage: (lambda run, stage=stage: ran.append(stage) or {}) for stage in rp.STAGES}
    monkeypatch.setattr(rp, "STAGE_FUNCTIONS", stubs)
    monkeypatch.setattr(rp, "write_report", lambda run: {})
    return ran


@pytest.mark.parametrize("quick", [False, True])
def test_the_default_sizes_depend_on_the_protocol_and_the_papers_are_unchanged(
        tmp_path, monkeypatch, quick):
    _stub_stages(monkeypatch)
    for protocol in ("paper", "hard"):
        rp.reproduce(tmp_path / protocol, quick=quick, workers=1, progress=False,
                     protocol=protocol, until="teacher")
    paper = json.loads((tmp_path / "paper" / "config.json").read_text())
    hard = json.loads((tmp_path / "hard" / "config.json").read_text())
    # a paper run's settings name no protocol; the version names the rules results are judged by
    assert paper == {"format": "tt-drake-reproduce", "version": rp.RUN_FORMAT_VERSION,
                     "quick": quick,
                     "config": (rp.quick_config() if quick else rp.ReproduceConfig()).to_dict()}
    assert hard["protocol"] == "hard" and hard["quick"] == quick
    assert hard["config"] == (rp.hard_quick_config() if quick else rp.hard_config()).to_dict()
    assert rp.SIZES["full"]() == rp.ReproduceConfig() and rp.SIZES["quick"]() == rp.quick_config()
    assert rp.SIZES["full"]("hard") == rp.hard_config()
    assert rp.SIZES["quick"]("hard") == rp.hard_quick_config()
    assert rp.SIZES["artefacts"]("hard") == rp.artefacts_config()  # the shipped set's run
    with pytest.raises(rp.ReproduceError, match="unknown sizes 'huge'"):
        rp.reproduce(tmp_path / "x", sizes="huge", protocol="hard")
    assert not (tmp_path / "x").exists()


def test_the_hard_runs_evaluation_serves_are_apart_from_its_training_serves():
    """``spin`` is both a training and an evaluation distribution of the hard protocol: the
    evaluation seed is none of the seeds a training stage serves ``spin`` with, and the
    ``real-test`` evaluation deals each of its balls once (fewer serves than the pool)."""
    from tt_drake.seeds import episode_seed
    from tt_drake.serves import ServeSampler

    for c in (rp.hard_config(), rp.hard_quick_config()):
        batches = -(-c.responsibility_rollouts // c.responsibility_batch)
        power = -(-c.power_rollouts // c.power_batch)
        training = ({c.teacher_seed, c.predictor_train_seed, c.single_seed, c.gamma1_seed}
                    | {c.crkr_seed + k for k in range(1, c.crkr_max_iterations + 1)}
                    | {c.responsibility_seed + b for b in range(batches)}
                    | {c.power_seed + b for b in range(power)})
        assert c.final_seed not in training | {c.predictor_test_seed}
        sampler = ServeSampler("real-test", run_seed=c.real_seed)
        assert c.real_serves <= len(sampler.pool())
        dealt = {sampler.pool_index(episode_seed(c.real_seed, i)) for i in range(c.real_serves)}
        assert len(dealt) == c.real_serves


class _Recorder:
    """Rollouts that record what they were asked to play: player, hitting configuration, moving
    goal, perception, distribution, the pool's run seed, count and seed."""

    def __init__(self):
        self.calls = []
        self.strategies = []

    def __call__(self, folder, scenario, player, serves, seed, gamma=None, desc="",
                 weights=None):
        self.calls.append({"folder": folder, "player": player,
                           "configuration": scenario.learned.configuration,
                           "moving_goal": scenario.learned.moving_goal,
                           "perception": scenario.perception,
                           "distribution": scenario.launcher.distribution,
                           "run_seed": scenario.launcher.run_seed, "serves": serves,
                           "seed": seed})
        return [{"hit": True, "returned": k % 2 == 0, "on_target": k % 4 == 0,
                 "reward": 0.9 if k % 2 == 0 else 0.2, "landing": [0.0, 1.0],
                 "stroke": {"fallback": False, "primitives": [0], "mixture": [1.0],
                            "early_prediction": False, "stimulus": [0.0] * 9}}
                for k in range(serves)]


def _hard_run(tmp_path, monkeypatch, protocol="hard"):
    from tt_drake.serves import ServeSampler

    monkeypatch.setattr(ServeSampler, "pool", lambda self: [])  # no pool is flown here
    # every fourth serve (from the fourth), one the recorder's episodes do not return, is
    # beyond the racket's reach
    monkeypatch.setattr(rp, "within_reach", lambda scenario, serves, seed:
                        [k % 4 != 3 for k in range(serves)])
    run = rp.Run(tmp_path / protocol, rp.hard_quick_config(), quick=True, workers=1,
                 progress=False, protocol=protocol)
    for stage, key, rel in (("predictor", "model", "predictor/predictor.npz"),
                            ("library", "library", "library/library.npz"),
                            ("crkr", "best", "crkr/crkr_1.npz"),
                            ("power", "library", "power/library_power.npz")):
        run.folder(stage)
        (run.root / rel).write_bytes(stage.encode())
        result = {key: rel, "primitives": 4} if stage == "library" else {key: rel}
        (run.root / stage / "result.json").write_text(json.dumps(result))
    recorder = _Recorder()
    monkeypatch.setattr(run, "rollouts", recorder)

    def strategy_returns(path, scenario, strategy, indices, seed, desc=""):
        recorder.strategies.append({"path": path, "strategy": strategy.name,
                                    "perception": scenario.perception,
                                    "noise_stream": scenario.camera.noise_stream,
                                    "indices": indices, "seed": seed})
        return [False] * len(indices)  # the other strategies return nothing more

    monkeypatch.setattr(run, "strategy_returns", strategy_returns)
    return run, recorder


def test_the_hard_player_plays_the_teachers_ik_and_is_judged_on_the_same_serves_before_and_after(
        tmp_path, monkeypatch):
    run, recorder = _hard_run(tmp_path, monkeypatch)
    gamma1 = rp.stage_gamma1(run)
    before = list(recorder.calls)
    recorder.calls.clear()
    final = rp.stage_final(run)
    after = list(recorder.calls)
    recorder.calls.clear()
    rp.stage_single(run)
    single = list(recorder.calls)

    def momp(calls):
        return [{k: v for k, v in c.items() if k != "folder"} for c in calls
                if c["player"] == "momp"]

    def oracle(calls):
        return [{k: v for k, v in c.items() if k != "player"} for c in calls
                if c["perception"] == "oracle"]

    c = run.config
    # the same serves before and after: distribution, the pool's deal seed, count and seeds
    assert momp(before) == momp(after)
    assert [(m["distribution"], m["run_seed"], m["serves"], m["seed"]) for m in momp(after)] == [
        ("spin", c.final_seed, c.final_serves, c.final_seed),
        ("real-test", c.real_seed, c.real_serves, c.real_seed)]
    # the learned player: the teacher's IK as configuration, the moving goal, the camera
    for m in momp(before) + momp(single):
        assert m["configuration"] == "analytical" and m["moving_goal"]
        assert m["perception"] != "oracle"
    assert len(momp(single)) == 3 * 3  # 3 primitives x the 3 training distributions
    # the returnable bound: the oracle strategies on the same serves, into the same folders
    # (the teacher on all of them, each later strategy on the serves within reach none before
    # returned)
    assert [(o["distribution"], o["run_seed"], o["serves"], o["seed"], o["folder"].name)
            for o in oracle(after)] == [
        (m["distribution"], m["run_seed"], m["serves"], m["seed"], label)
        for m, label in zip(momp(after), ("spin", "real-test"), strict=True)]
    assert oracle(before) == oracle(after)
    unreturned = [k for k in range(c.final_serves) if k % 4 == 1]
    assert [(s["strategy"], s["indices"], s["path"].parent.name)
            for s in recorder.strategies[:len(STRATEGIES) - 1]] == [
        (s.name, unreturned, "spin") for s in STRATEGIES[1:]]
    # each strategy sees the serves as it says: the oracle, or the camera through a noise
    # stream of its own (never the evaluated players' stream 0)
    by_name = {s.name: s for s in STRATEGIES}
    assert all((s["perception"], s["noise_stream"]) == (by_name[s["strategy"]].perception,
                                                        by_name[s["strategy"]].noise_stream)
               for s in recorder.strategies)
    assert all(s["perception"] == "oracle" or s["noise_stream"] > 0
               for s in recorder.strategies)
    # the stage results say which player played (the report's commands name it)
    assert gamma1["configuration"] == final["configuration"] == "analytical"
    rows = table_rows({"gamma1": gamma1, "final": final})
    assert all("--configuration analytical" in r["command"] for r in rows)


def test_the_paper_profile_plays_crkr_as_before(tmp_path, monkeypatch):
    run, recorder = _hard_run(tmp_path, monkeypatch, protocol="paper")
    assert rp._learned(run).learned.configuration == "crkr"
    assert not rp._learned(run).learned.moving_goal
    rp.stage_single(run)
    assert {c["configuration"] for c in recorder.calls} == {"crkr"}


def test_the_paper_profiles_real_serves_come_with_the_oracles_ceiling_on_the_same_serves(
        tmp_path, monkeypatch):
    run, recorder = _hard_run(tmp_path, monkeypatch, protocol="paper")
    final = rp.stage_final(run)
    momp = [c for c in recorder.calls if c["player"] == "momp"]
    oracle = [c for c in recorder.calls if c["perception"] == "oracle"]
    # only the real set gets a ceiling, played on the momp player's serves: the same
    # distribution, count and seeds, the pool dealt as `tt-drake serve --seed` deals it (the
    # report's command replays the figure)
    real = next(m for m in momp if m["distribution"] == "real")
    serves = ("distribution", "run_seed", "serves", "seed")
    assert [[o[k] for k in serves] for o in oracle] == [[real[k] for k in serves]]
    assert oracle[0]["perception"] == "oracle" and real["perception"] != "oracle"
    assert oracle[0]["folder"] == run.folder("ceiling") / "real"
    assert real["run_seed"] == real["seed"] == run.config.real_seed
    # every serve returned by the recorder's even-numbered episodes, oracle and momp alike
    assert final["real"]["returnable_serves"] == (real["serves"] + 1) // 2
    assert final["real"]["return_rate_of_returnable"] == 1.0
    assert "returnable_serves" not in final["default"]
    rows = {r["key"]: r for r in table_rows({"final": final})}
    assert ("returnable serves = 100.0 %; legal returns outside the bound 0"
            in rows["real"]["ours"])


def _evaluation(rate, target, reward, returns, early):
    return {"serves": 10, "seed": 7, "distribution": "real-test", "momp_return_rate": rate,
            "momp_target_rate": target, "return_rate": rate, "target_rate": target,
            "fallback_strokes": 1, "early_strokes": early, "returnable_serves": 8,
            "returnable_rate": 0.8, "returns_of_returnable": returns,
            "return_rate_of_returnable": returns / 8, "oracle_target_rate": 0.4,
            "target_of_ceiling": target / 0.4, "momp_mean_reward": reward,
            "oracle_mean_reward": 0.8, "reward_of_ceiling": reward / 0.8}


def test_the_hard_report_shows_before_and_after_on_the_same_serves_and_the_pruned_share():
    before = _evaluation(0.5, 0.1, 0.40, 4, 2)
    after = _evaluation(0.7, 0.3, 0.56, 6, 1)
    results = {
        "gamma1": {"evaluation": {"real-test": before}, "configuration": "analytical"},
        "final": {"real-test": after, "library": "power/library_power.npz",
                  "configuration": "analytical"},
        "responsibility": {"primitives": 20, "pruned": 3, "pruned_share": 0.15,
                           "pruned_earlier_return": 0.2, "pruned_earlier_reward": 0.3,
                           "kept_earlier_return": 0.9, "kept_earlier_reward": 0.8,
                           "rollouts": 90, "batch": 30, "seed": 50,
                           "curve": [[30, 0.5, 0.1, 1, 0.4], [60, 0.6, 0.2, 3, 0.5]]},
        "power": {"primitives": 17, "pruned": 1, "pruned_earlier_return": 0.0,
                  "pruned_earlier_reward": 0.1, "kept_earlier_return": 0.9,
                  "kept_earlier_reward": 0.8, "rollouts": 60, "command": "c",
                  "curve": [[30, 0.5, 0.6, 0.2, 1, 5, 0.01]]},
    }
    comparison = learning_comparison(results)
    axes = {a["key"]: a for a in comparison["real-test"]["axes"]}
    assert axes["momp_return_rate"]["change"] == pytest.approx(0.2)
    assert axes["return_rate_of_returnable"]["before"] == 0.5
    assert axes["return_rate_of_returnable"]["change"] == pytest.approx(0.25)
    assert axes["momp_target_rate"]["change"] == pytest.approx(0.2)
    assert axes["reward_of_ceiling"]["change"] == pytest.approx(0.2)
    assert axes["early_strokes"]["change"] == -1
    pruning = pruning_summary(results)
    assert pruning["pruned"] == 4 and pruning["pruned_share"] == pytest.approx(0.2)
    assert learning_comparison({"gamma1": results["gamma1"]}) == {}  # no final yet

    report = {"quick": True, "protocol": "hard", "stages": results, "wall_seconds": 60.0,
              "workers": 2, "executor": "local", "table": table_rows(results), "plots": [],
              "learning": comparison, "pruning": pruning}
    text = format_markdown(report)
    assert "| legal return by the primitives | 50.0 % | 70.0 % | +20.0 points |" in text
    assert "| mean reward (0 for a fallback stroke) | 0.400 | 0.560 | +0.160 |" in text
    assert "- in all: 4 of 20 (20.0 %; the paper: about 27 %)" in text
    assert "- responsibility learning: 3 of 20; while they played, legal returns 20.0 %, mean " \
           "reward 0.300 (the kept primitives: 90.0 %, 0.800" in text
    assert "| 60 | 60.0 % | 20.0 % | 3 | 0.500 |" in text  # the responsibility curve
    assert "their mean reward 0.300, the kept ones' 0.800" in \
        {r["key"]: r for r in report["table"]}["pruned"]["ours"]
    assert "momp player (`single`, `gamma1`, `responsibility`, `power`, `final`) does not " \
           "play it: its hitting configuration is the teacher's IK (`--configuration " \
           "analytical`), and its hitting DMP follows each new prediction" in text
    # the paper profile's report has none of these sections
    paper = format_markdown({**report, "protocol": "paper"})
    assert "Before and after" not in paper and "does not play it" not in paper


def test_before_after_plot(tmp_path):
    from tt_drake.diagrams.report_plots import before_after_figure, plot_before_after

    groups = {"spin": {"legal return": (0.5, 0.7), "reward": (0.4, 0.6)},
              "real-test": {"legal return": (0.2, 0.3)}}
    fig = before_after_figure(groups, labels=("gamma = 1", "learned"))
    panels = fig.get_axes()
    assert [ax.get_title() for ax in panels] == ["spin", "real-test"]
    widths = sorted(p.get_width() for p in panels[0].patches)
    assert widths == pytest.approx([0.4, 0.5, 0.6, 0.7])
    path = plot_before_after(tmp_path / "b.png", groups)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(ValueError, match="before, after"):
        plot_before_after(tmp_path / "bad.png", {"spin": {"legal return": (0.5, 0.7, 0.9)}})
    assert not (tmp_path / "bad.png").exists()


def test_a_hard_run_folder_writes_the_comparison_and_its_plot(tmp_path):
    from tt_drake.diagrams.report import write_report

    run = rp.Run(tmp_path / "hard", rp.hard_quick_config(), quick=True, workers=1,
                 progress=False, protocol="hard")
    before = _evaluation(0.5, 0.1, 0.40, 4, 2)
    after = {**_evaluation(0.7, 0.3, 0.56, 6, 1), "target_of_ceiling": None}
    for stage, result in (("gamma1", {"evaluation": {"real-test": before}}),
                          ("final", {"real-test": after, "library": "power/library_power.npz"})):
        (run.folder(stage) / "result.json").write_text(json.dumps(result))
    report = write_report(run)
    assert "plots/before_after_learning.png" in report["plots"]
    assert (run.root / "plots" / "before_after_learning.png").exists()
    axes = {a["key"]: a for a in report["learning"]["real-test"]["axes"]}
    assert axes["target_of_ceiling"]["change"] is None  # not recorded: no figure, no change
    text = (run.root / "report.md").read_text()
    assert "| on target, per oracle teacher's on-target return | 25.0 % | - | - |" in text


#: The splits kept for reporting (docs/rules.md): no choice and no training draws them.
TEST_SPLITS = {"real-test", "rally-test"}


def test_no_protocol_learns_from_a_test_split():
    for protocol in rp.PROTOCOLS.values():
        assert not set(protocol.train) & TEST_SPLITS, protocol.name


@pytest.mark.parametrize("protocol", ["hard", "paper"])
def test_the_training_and_selection_stages_never_draw_a_test_split(tmp_path, monkeypatch,
                                                                   protocol):
    """Every stage before the evaluations (teacher, predictor training, CrKR with its choice of
    the best iteration, single primitives, responsibility learning, PoWER) is run with every
    source of serves recorded: none of them draws real-test or rally-test serves. The
    evaluations (the predictor's report, gamma = 1 and final) may, and the hard protocol does."""
    import shutil
    from importlib import resources

    run, recorder = _hard_run(tmp_path, monkeypatch, protocol=protocol)
    models = resources.files("tt_drake.models")
    shutil.copy(str(models / "learned-hard" / "library.npz"), run.root / "library" / "library.npz")
    (run.root / "library" / "result.json").write_text(json.dumps(
        {"library": "library/library.npz", "primitives": 4}))
    drawn = []

    def collect(scenario, player, serves, seed, out, *args, **kwargs):
        drawn.append(("teacher", scenario.launcher.distribution))
        return {"return_rate": 1.0}

    def train_predictor(serves, seed, out, distribution=None, **kwargs):
        drawn.append(("predictor training", distribution or "default"))
        return {"serves": serves, "used": serves, "skipped": 0}

    def eval_predictor(model, serves, seed, out, distribution=None, **kwargs):
        drawn.append(("predictor report", distribution or "default"))
        (run.root / "predictor" / "eval.json").write_text("{}")
        return {"serves": serves, "used": serves, "skipped": 0, "gpr": [{"nmse": 0.1}],
                "physical": [], "errors": np.zeros(1)}

    monkeypatch.setattr(rp, "collect", collect)
    monkeypatch.setattr(rp, "_merge_datasets", lambda folders, out: 1.0)
    monkeypatch.setattr(rp, "train_predictor", train_predictor)
    monkeypatch.setattr(rp, "eval_predictor", eval_predictor)
    monkeypatch.setattr(rp, "train_crkr", lambda *a, **k: None)
    for stage in (rp.stage_teacher, rp.stage_predictor, rp.stage_crkr, rp.stage_single,
                  rp.stage_responsibility, rp.stage_power):
        name = stage.__name__.removeprefix("stage_")
        before = len(recorder.calls)
        run.finish(name, stage(run), 0.0)
        drawn += [(name, c["distribution"]) for c in recorder.calls[before:]]
    training = [d for d in drawn if d[0] != "predictor report"]
    assert {stage for stage, _ in training} >= {"teacher", "predictor training", "crkr",
                                                 "single", "responsibility", "power"}
    assert not [d for d in training if set(d[1].split(",")) & TEST_SPLITS]
    assert {d for _, dist in training for d in dist.split(",")} <= set(
        run.protocol.train) | {"default"}
    recorder.calls.clear()
    rp.stage_gamma1(run)
    rp.stage_final(run)
    evaluated = {c["distribution"] for c in recorder.calls}
    assert ("real-test" in evaluated) == (protocol == "hard")


def test_a_run_plays_its_scenario_and_refuses_a_folder_of_another(tmp_path, monkeypatch):
    """``scenario``: every stage's scenario is the one named (``ideal_robot``: no drive limit,
    no camera latency), recorded in the run's settings; resuming the folder with the default
    scenario is refused, not mixed."""
    played = []
    stubs = {stage: (lambda run: played.append(run.scenario()) or {}) for stage in rp.STAGES}
    monkeypatch.setattr(rp, "STAGE_FUNCTIONS", stubs)
    monkeypatch.setattr(rp, "write_report", lambda run: {})
    rp.reproduce(tmp_path / "run", quick=True, workers=1, progress=False, until="teacher",
                 scenario="ideal_robot")
    settings = json.loads((tmp_path / "run" / "config.json").read_text())
    assert settings["scenario"] == "ideal_robot"
    assert played[0].controller.drive_voltage == 0.0 and played[0].camera.latency == 0.0
    with pytest.raises(rp.ReproduceError):
        rp.reproduce(tmp_path / "run", quick=True, workers=1, progress=False, until="teacher")
    rp.reproduce(tmp_path / "default", quick=True, workers=1, progress=False, until="teacher")
    assert played[-1].controller.drive_voltage == 48.0
    assert played[-1].camera.latency_frames == 1
