"""tt-drake reproduce: the run folder's guards, the figures it reports, and responsibility
learning (Algorithm 3) over batches of rollouts, resumed after an interruption. The rollouts are
synthetic here (no simulation); the CI runs the whole pipeline with ``make reproduce-quick``."""

import json

import numpy as np
import pytest

from tt_drake.diagrams import reproduce as rp
from tt_drake.diagrams.cli import main
from tt_drake.dmp import HittingDMP
from tt_drake.learned_player import StagePrimitive, load_player_library, save_player_library
from tt_drake.momp import MotorPrimitiveLibrary
from tt_drake.stages import AWAITING, FOLLOW_THROUGH, PREPARATION

SMALL = rp.ReproduceConfig(responsibility_rollouts=60, responsibility_batch=20)


def _episode(returned: bool, reward: float, primitives=(), mixture=(), fallback=False) -> dict:
    return {"hit": returned, "returned": returned, "on_target": returned, "reward": reward,
            "landing": None, "stroke": {"primitives": list(primitives), "mixture": list(mixture),
                                        "fallback": fallback, "stimulus": [0.0] * 6}}


def test_rates_do_not_credit_the_primitives_with_a_fallback_stroke():
    episodes = [_episode(True, 1.0, [0], [1.0]), _episode(True, 0.9, [1], [1.0], fallback=True),
                _episode(False, 0.0, [0], [1.0]), _episode(False, 0.2, [1], [1.0])]
    r = rp.rates(episodes)
    assert r["return_rate"] == 0.5 and r["momp_return_rate"] == 0.25
    assert r["target_rate"] == 0.5 and r["momp_target_rate"] == 0.25
    assert r["hit_rate"] == 0.5 and r["fallback_strokes"] == 1
    assert r["mean_reward"] == pytest.approx(2.1 / 4)
    assert [rp.credited_reward(e) for e in episodes] == [1.0, 0.0, 0.0, 0.2]


def test_a_folder_of_another_run_is_refused(tmp_path):
    rp.Run(tmp_path / "a", SMALL, quick=False, workers=1, progress=False)
    rp.Run(tmp_path / "a", SMALL, quick=False, workers=1, progress=False)  # resumes
    with pytest.raises(rp.ReproduceError, match="another run"):
        rp.Run(tmp_path / "a", rp.quick_config(), quick=True, workers=1, progress=False)
    (tmp_path / "b").mkdir()
    (tmp_path / "b" / "notes.txt").write_text("mine")
    with pytest.raises(rp.ReproduceError, match="not empty"):
        rp.Run(tmp_path / "b", SMALL, quick=False, workers=1, progress=False)
    assert (tmp_path / "b" / "notes.txt").read_text() == "mine"


def test_cli_bad_executor_exits_2_naming_it(tmp_path, capsys):
    # argparse checks --executor's choices (listed by --help): it exits with status 2.
    with pytest.raises(SystemExit) as exit_:
        main(["reproduce", "--out", str(tmp_path / "r"), "--executor", "spark"])
    assert exit_.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert "unknown executor 'spark'; choose one of local, ray" in err[-1]
    assert not (tmp_path / "r").exists()
    with pytest.raises(rp.ReproduceError, match="unknown executor"):
        rp.reproduce(tmp_path / "r", executor="spark")


def _library(path, n: int = 3) -> None:
    dmp = HittingDMP(n_basis=5)
    stimuli = np.eye(n, 6)
    library = MotorPrimitiveLibrary(dmp, np.zeros((n, 7, 5)), np.ones((n, 7)), stimuli,
                                    np.ones(6))
    stage = StagePrimitive(np.zeros((7, 5)), np.ones(7), 0.3)
    save_player_library(path, library, {PREPARATION: stage, FOLLOW_THROUGH: stage,
                                        AWAITING: stage},
                        {"scenario": "default", "hitting_y": -1.82})


class _Rollouts:
    """Primitive 0 always fails (reward 0), 1 always succeeds (reward 1), 2 succeeds one time in
    four: each rollout is carried by one primitive, chosen in turn among the unpruned ones."""

    def __init__(self, fail_at_batch: int | None = None):
        self.fail_at_batch, self.batches, self.gammas = fail_at_batch, 0, []

    def __call__(self, folder, scenario, player, serves, seed, gamma=None, desc="",
                 weights=None):
        if self.fail_at_batch is not None and self.batches == self.fail_at_batch:
            raise KeyboardInterrupt
        self.batches += 1
        self.gammas.append(np.array(gamma))
        alive = np.flatnonzero(np.asarray(gamma) > 0)
        out = []
        for k in range(serves):
            i = int(alive[(seed + k) % len(alive)])
            ok = i == 1 or (i == 2 and k % 4 == 0)
            out.append(_episode(ok, float(ok), [i], [1.0]))
        return out


def _learn(root, rollouts, monkeypatch):
    run = rp.Run(root, SMALL, quick=False, workers=1, progress=False)
    lib = run.folder("library") / "library.npz"
    if not lib.exists():
        _library(lib)
        (run.folder("library") / "result.json").write_text(json.dumps({"library": str(lib)}))
    monkeypatch.setattr(run, "rollouts", rollouts)
    monkeypatch.setattr(rp, "_learned", lambda run, *args, **kwargs: None)
    return rp.stage_responsibility(run)


def test_responsibility_learning_prunes_the_failing_primitives_and_resumes(tmp_path, monkeypatch):
    straight = _Rollouts()
    whole = _learn(tmp_path / "whole", straight, monkeypatch)
    # Eq. 10's asymptote: a primitive is pruned iff its mean reward < 1 + zeta ln(thr) / kappa.
    assert whole["pruned"] == 2 and whole["primitives"] == 3
    assert 0.0 < whole["pruned_earlier_return"] < 0.25
    # what they did, gating-weighted: the same as their success here (reward 1 iff returned);
    # the kept primitive 1 always succeeded
    assert whole["pruned_earlier_reward"] == pytest.approx(whole["pruned_earlier_return"])
    assert whole["kept_earlier_return"] == whole["kept_earlier_reward"] == 1.0
    assert whole["library"] == "responsibility/library_learned.npz"  # no machine path
    library, _, _ = load_player_library(tmp_path / "whole" / whole["library"])
    assert library.n_primitives == 1 and library.stimuli[0, 1] == 1.0  # primitive 1 is kept
    curve = np.array(whole["curve"])
    assert curve[:, 0].tolist() == [20, 40, 60] and curve[-1, 1] > curve[0, 1]
    # the batch's mean credited reward: here its legal-return rate (reward 1 iff returned)
    np.testing.assert_allclose(curve[:, 4], curve[:, 1])
    assert whole["curve_columns"][4] == "mean_reward"

    interrupted = _Rollouts(fail_at_batch=2)
    with pytest.raises(KeyboardInterrupt):
        _learn(tmp_path / "resumed", interrupted, monkeypatch)
    rest = _Rollouts()
    resumed = _learn(tmp_path / "resumed", rest, monkeypatch)
    assert rest.batches == 1  # only the missing batch ran again
    np.testing.assert_array_equal(rest.gammas[0], straight.gammas[2])
    for key in ("pruned", "pruned_share", "curve"):
        assert resumed[key] == whole[key]


def test_report_rows_compare_with_the_paper_and_say_the_shortfall():
    from tt_drake.diagrams.report import table_rows

    stroke = {"return_rate": 0.99, "target_rate": 0.9, "momp_return_rate": 0.9,
              "momp_target_rate": 0.85, "fallback_strokes": 9, "serves": 100}
    results = {
        "predictor": {"max_nmse": 0.004, "eval": {"serves": 3500}, "command": "c"},
        "crkr": {"iterations": [{"iteration": 1, "return_rate": 0.9, "target_rate": 0.5,
                                 "serves": 100, "seed": 21}]},
        "final_partial": {"default": {**stroke, "seed": 2026, "partial": True}},
    }
    rows = {r["key"]: r for r in table_rows(results)}
    assert rows["gpr_nmse"]["meets_paper"]
    assert rows["crkr_1"]["shortfall"] == "4.0 points below the paper"
    final = rows["final"]
    assert final["value"] == 0.9 and "partial" in final["ours"] and "9 fallback" in final["ours"]
    assert final["shortfall"] == "4.0 points below the paper"
    assert "real" not in rows and "gamma1" not in rows


SMALL_POWER = rp.ReproduceConfig(power_rollouts=90, power_batch=30, power_sigma=0.2)


class _ExploringRollouts:
    """Each rollout is carried by one primitive (in turn); it returns the ball and lands
    |theta_i[0, 0] - 0.3| metres from the target, theta the rollout's explored weights: the
    library's zero weights start 0.3 m off."""

    def __init__(self, fail_at_batch: int | None = None):
        self.fail_at_batch, self.batches, self.first_weights = fail_at_batch, 0, []

    def __call__(self, folder, scenario, player, serves, seed, gamma=None, desc="",
                 weights=None):
        from tt_drake.referee_rules import return_reward

        if self.fail_at_batch is not None and self.batches == self.fail_at_batch:
            raise KeyboardInterrupt
        self.batches += 1
        alive = np.flatnonzero(np.asarray(gamma) > 0)
        out = []
        for k in range(serves):
            theta = weights(k)
            if k == 0:
                self.first_weights.append(theta)
            i = int(alive[k % len(alive)])
            d = abs(theta[i, 0, 0] - 0.3)
            e = _episode(True, return_reward(d), [i], [1.0])
            e["stroke"]["stimulus"] = np.eye(3, 6)[i].tolist()
            out.append(e)
        return out


def _power(root, rollouts, monkeypatch):
    from types import SimpleNamespace

    run = rp.Run(root, SMALL_POWER, quick=False, workers=1, progress=False)
    lib = run.folder("responsibility") / "library_learned.npz"
    if not lib.exists():
        _library(lib)
        (run.folder("responsibility") / "result.json").write_text(
            json.dumps({"library": "responsibility/library_learned.npz"}))
    monkeypatch.setattr(run, "rollouts", rollouts)
    monkeypatch.setattr(rp, "_learned", lambda run, *args, **kwargs: SimpleNamespace(
        learned=SimpleNamespace(library="")))
    return rp.stage_power(run)


def test_power_stage_moves_the_weights_towards_better_strokes_and_resumes(tmp_path, monkeypatch):
    straight = _ExploringRollouts()
    whole = _power(tmp_path / "whole", straight, monkeypatch)
    library, _, _ = load_player_library(tmp_path / "whole" / whole["library"])
    assert library.n_primitives == 3 and whole["pruned"] == 0
    assert whole["pruned_earlier_return"] is None and whole["kept_earlier_return"] == 1.0
    off = np.abs(library.weights[:, 0, 0] - 0.3)
    assert np.all(off < 0.2)  # from 0.3 m off
    curve = np.array(whole["curve"])
    assert curve[:, 0].tolist() == [30, 60, 90] and np.all(np.diff(curve[:, 1]) > 0)
    assert curve[:, 5].tolist() == [3, 3, 3]  # every primitive took part in every batch
    # exploration: each batch explores around that batch's mean, seeded by batch and rollout
    assert not np.allclose(straight.first_weights[0], straight.first_weights[1])

    interrupted = _ExploringRollouts(fail_at_batch=2)
    with pytest.raises(KeyboardInterrupt):
        _power(tmp_path / "resumed", interrupted, monkeypatch)
    rest = _ExploringRollouts()
    resumed = _power(tmp_path / "resumed", rest, monkeypatch)
    assert rest.batches == 1  # only the missing batch ran again
    np.testing.assert_array_equal(rest.first_weights[0], straight.first_weights[2])
    assert resumed["curve"] == whole["curve"]
    again, _, _ = load_player_library(tmp_path / "resumed" / resumed["library"])
    np.testing.assert_array_equal(again.weights, library.weights)


def test_hard_protocol_splits_the_training_serves_and_deals_each_pool_without_repeats(
        tmp_path, monkeypatch):
    from types import SimpleNamespace

    from tt_drake.serves import ServeSampler

    warmed = []  # pools are flown once in this process, before any worker forks
    monkeypatch.setattr(ServeSampler, "pool", lambda self: warmed.append(self.distribution))
    run = rp.Run(tmp_path / "hard", SMALL, quick=False, workers=1, progress=False,
                 protocol="hard")
    calls = []

    def rollouts(folder, scenario, player, serves, seed, gamma=None, desc="", weights=None):
        calls.append((folder.name, scenario.launcher.distribution, scenario.launcher.run_seed,
                      serves, seed))
        return [{"i": weights(i) if weights else None} for i in range(serves)]

    run.rollouts = rollouts
    scenario = SimpleNamespace(launcher=SimpleNamespace(distribution="default", run_seed=-1,
                                                        spin_max=0.0, real_serves="",
                                                        rallies=""))
    out = run.train_rollouts(tmp_path / "stage", scenario, "momp", 8, 50,
                             weights=lambda i: 100 + i)
    assert calls == [("spin", "spin", 50, 3, 50), ("real-train", "real-train", 50, 3, 50),
                     ("rally-train", "rally-train", 50, 2, 50)]
    # the rollout function's weights are indexed over the whole list, in distribution order
    assert [e["i"] for e in out] == list(range(100, 108))
    assert warmed == ["real-train", "rally-train"]
    assert scenario.launcher.distribution == "default"  # the caller's scenario is not changed
    # the paper protocol: one distribution, the folder as given
    paper = rp.Run(tmp_path / "paper", SMALL, quick=False, workers=1, progress=False)
    paper.rollouts = rollouts
    calls.clear()
    paper.train_rollouts(tmp_path / "stage", scenario, "momp", 8, 50)
    assert calls == [("stage", "default", -1, 8, 50)]


def test_a_hard_run_is_kept_apart_from_a_paper_run_and_a_bad_protocol_is_refused(tmp_path,
                                                                                  capsys):
    rp.Run(tmp_path / "a", SMALL, quick=False, workers=1, progress=False)
    with pytest.raises(rp.ReproduceError, match="another run"):
        rp.Run(tmp_path / "a", SMALL, quick=False, workers=1, progress=False, protocol="hard")
    with pytest.raises(rp.ReproduceError, match="unknown protocol 'easy'"):
        rp.reproduce(tmp_path / "b", protocol="easy")
    assert not (tmp_path / "b").exists()
    with pytest.raises(SystemExit) as exit_:
        main(["reproduce", "--out", str(tmp_path / "c"), "--protocol", "easy"])
    assert exit_.value.code == 2 and "--protocol" in capsys.readouterr().err
    assert not (tmp_path / "c").exists()


def test_ceiling_rates_count_the_primitives_returns_among_the_returnable_serves():
    episodes = [_episode(True, 1.0, [0], [1.0]), _episode(True, 0.9, [0], [1.0], fallback=True),
                _episode(True, 0.8, [0], [1.0]), _episode(False, 0.0, [0], [1.0])]
    teacher = [{"returned": True, "on_target": True, "reward": 0.9},
               {"returned": True, "on_target": False, "reward": 0.5},
               {"returned": False, "on_target": False, "reward": 0.2},
               {"returned": True, "on_target": True, "reward": 1.0}]
    returnable = ["teacher", "teacher", None, "teacher"]
    r = rp.ceiling_rates(episodes, returnable, teacher)
    # serve 2 is returned but outside the bound: counted as such, not in the ratio; on target:
    # the primitives carried 2 (serve 1's was a fallback), the oracle teacher 2; the mean
    # reward credits the fallback stroke 0: (1 + 0 + 0.8 + 0) / 4 against the teacher's 2.6 / 4
    assert r == {"returnable_serves": 3, "returnable_rate": 0.75, "returns_of_returnable": 1,
                 "return_rate_of_returnable": pytest.approx(1 / 3),
                 "returns_outside_ceiling": 1, "oracle_target_rate": 0.5,
                 "target_of_ceiling": 1.0, "momp_mean_reward": pytest.approx(0.45),
                 "oracle_mean_reward": pytest.approx(0.65),
                 "reward_of_ceiling": pytest.approx(0.45 / 0.65)}
    # a fallback stroke's legal return outside the bound proves it wrong too
    r = rp.ceiling_rates(episodes, [None, None, "long", "teacher"], teacher)
    assert r["returns_outside_ceiling"] == 2 and r["returns_of_returnable"] == 1
    nothing = [{"returned": False, "on_target": False, "reward": 0.0}] * 4
    r = rp.ceiling_rates(episodes, [None] * 4, nothing)
    assert r["return_rate_of_returnable"] is None and r["target_of_ceiling"] is None
    assert r["reward_of_ceiling"] is None


def test_rates_count_the_strokes_carried_by_an_early_prediction():
    episodes = [_episode(True, 1.0, [0], [1.0]) for _ in range(3)]
    episodes[1]["stroke"]["early_prediction"] = True
    assert rp.rates(episodes)["early_strokes"] == 1


def test_hard_report_rows_give_the_ceiling_and_the_early_strokes():
    from tt_drake.diagrams.report import table_rows

    r = {"return_rate": 0.5, "target_rate": 0.3, "momp_return_rate": 0.4,
         "momp_target_rate": 0.25, "serves": 10, "seed": 7, "distribution": "real-test",
         "returnable_serves": 5, "returns_of_returnable": 4, "return_rate_of_returnable": 0.8,
         "returnable_rate": 0.5, "returns_outside_ceiling": 0, "early_strokes": 2}
    rows = table_rows({"gamma1": {"evaluation": {"real-test": r}},
                       "final": {"library": "power/library_power.npz", "real-test": r}})
    before, after = rows
    teacher = {"distributions": {"spin": {}, "real-train": {}}}
    single = {"min_return": 0.1, "max_return": 0.2, "primitives": [1], "serves": 5, "seed": 30}
    (mixed,) = table_rows({"teacher": teacher, "single": single})
    assert mixed["command"].endswith("(serves split among spin, real-train)")
    assert before["key"] == "hard_gamma1" and "real-test serves" in before["experiment"]
    assert after["key"] == "hard_final" and "power/library_power.npz" in after["command"]
    for row in rows:
        assert ("4 of the 5 returnable serves = 80.0 %; legal returns outside the bound 0"
                in row["ours"])
        assert "2 strokes began on an early physical-model prediction" in row["ours"]


def test_the_hard_protocol_trains_its_library_crkr_and_predictor_with_its_own_settings():
    """The paper profile's stages read the run's config (the shipped artefacts' settings); the
    hard profile's library and CrKR take HARD_PROFILE (recorded strokes, alpha_y 11, spin in the
    stimulus) and its GPR the spin features, trained on its training mix."""
    from tt_drake.diagrams.reproduce import PROTOCOLS, quick_config
    from tt_drake.diagrams.train import library_options, stimulus_of
    from tt_drake.stimulus import PAPER_STIMULUS, SPIN_STIMULUS

    config = quick_config()
    assert PROTOCOLS["paper"].library_settings(config) is config
    assert stimulus_of(PROTOCOLS["paper"].library_settings(config)) == PAPER_STIMULUS
    assert PROTOCOLS["paper"].predictor_features == "states"
    hard = library_options(PROTOCOLS["hard"].library_settings(config))
    assert hard["stimulus"] == SPIN_STIMULUS and hard["dmp"].alpha_y == 11.0
    assert hard["demonstrations"] == "recorded" and hard["hitting_borrow"] == 0.0
    assert PROTOCOLS["hard"].predictor_features == "states+spin"
    # Its Eq. 10 can prune a primitive that took the ~3 rollouts' worth of gating weight a
    # primitive gets in the full run (1,000 rollouts over 300 primitives) and earned a reward of
    # 0.3 (legal returns far off the target) in each; the defaults (kappa 1) cannot.
    from tt_drake.responsibility import ResponsibilityParams, responsibility_update

    def pruned(params, rollouts=3, reward=0.3):
        s, n = np.zeros(1), np.zeros(1)
        for _ in range(rollouts):
            s, n, gamma, prune = responsibility_update(s, n, [1.0], reward, params)
        return bool(prune[0])

    assert pruned(hard["responsibility"]) and not pruned(ResponsibilityParams())
    assert not pruned(hard["responsibility"], reward=0.9)  # a primitive returning on target


@pytest.mark.parametrize("protocol, perception", [("paper", "oracle"), ("hard", "camera")])
def test_the_teacher_demonstrates_with_its_protocols_perception(tmp_path, monkeypatch, protocol,
                                                                 perception):
    """The paper protocol's teacher sees the oracle (its spin at impact is then not the EKF's
    noisy one), the hard protocol's the camera; the stage's result and command say which."""
    from tt_drake.serves import ServeSampler

    seen = []

    def collect(scenario, player, serves, seed, out, workers, progress, executor):
        seen.append((scenario.perception, player))
        return {"return_rate": 1.0}

    monkeypatch.setattr(rp, "collect", collect)
    monkeypatch.setattr(rp, "_merge_datasets", lambda folders, out: 1.0)
    monkeypatch.setattr(ServeSampler, "pool", lambda self: [])  # no pool is flown here
    run = rp.Run(tmp_path / protocol, rp.quick_config(), quick=True, workers=1, progress=False,
                 protocol=protocol)
    result = rp.stage_teacher(run)
    assert set(seen) == {(perception, "analytical")} and result["perception"] == perception
    assert ("--perception oracle" in result["command"]) == (perception == "oracle")
