"""The report of ``tt-drake reproduce``: the paper's table next to ours, and the plots.

``DIR/report.json`` holds every stage's result and :data:`PAPER`'s rows with ours; ``report.md``
the same table in Markdown with each row's command and seed; ``DIR/plots/`` the PNG figures
(:mod:`tt_drake.diagrams.report_plots`). Written from whatever stages have finished, so it can be
read part-way through a run.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from tt_drake.artefacts import load_artefact
from tt_drake.diagrams import report_plots as rp
from tt_drake.diagrams.protocols import PROTOCOLS, STAGES, rates
from tt_drake.hitting_point import OUTPUT_NAMES, OUTPUT_UNITS
from tt_drake.outputs import write_json_atomic, write_text_atomic
from tt_drake.referee_rules import RefereeConfig

# The paper's figures (Muelling, Kober, Peters 2010, section III), as fractions.
PAPER = {
    "gpr_nmse": ("GPR virtual hitting point: largest nMSE over the outputs", "< 0.01", 0.01),
    "crkr_1": ("CrKR, policy iteration 1: legal return / on target", "94 % / 48 %", 0.94),
    "crkr_2": ("CrKR, policy iteration 2: legal return / on target", "95 % / 63 %", 0.95),
    "single": ("Single primitives alone: legal-return range", "23 % - 89 %", None),
    "gamma1": ("MoMP, gamma = 1 (CrKR): legal return / on target", "67 %", 0.67),
    "gamma1_ik": ("MoMP, gamma = 1, analytical IK instead of CrKR: legal return / on target",
                  "-", None),
    "pruned": ("Responsibility learning: primitives pruned (their earlier success)",
               "about 27 % (30 %)", None),
    "power": ("PoWER (Eq. 9) in Algorithm 3: mean reward per batch, first -> last (legal return "
              "by the primitives)", "-", None),
    "final": ("Learned MoMP player (responsibilities learned): legal return / on target",
              "94 %", 0.94),
    "real": ("Learned MoMP player on real serve states (D'Ambrosio et al. 2025, CC-BY 4.0): "
             "legal return / on target", "-", None),
    # The hard protocol's rows (not in the paper): before and after learning on the same
    # evaluation serves, each also relative to the returnable bound (diagrams/ceiling.py).
    "hard_gamma1": ("Hard protocol, MoMP gamma = 1 (before learning), {label} serves: legal "
                    "return / on target", "-", None),
    "hard_final": ("Hard protocol, learned MoMP player, {label} serves: legal return / on "
                   "target", "-", None),
}


def _ceiling(r: dict) -> str:
    """The figure relative to the returnable serves (one of the oracle strategies returns
    them), the legal returns outside that bound, and the strokes an early physical-model
    prediction carried."""
    text = ""
    if "returnable_serves" in r:
        of = r["return_rate_of_returnable"]
        text += (f"; {r['returns_of_returnable']} of the {r['returnable_serves']} returnable "
                 f"serves = {_pct(of)}; legal returns outside the bound "
                 f"{r.get('returns_outside_ceiling', '-')}")
    if "early_strokes" in r:
        text += f"; {r['early_strokes']} strokes began on an early physical-model prediction"
    return text


def _pct(x) -> str:
    return "-" if x is None else f"{100.0 * x:.1f} %"


def _momp(r: dict) -> str:
    """A MoMP player's figure: legal returns carried by the primitives / on target, with the
    strokes the teacher's quintics carried (the primitives' plan left the joint or effort
    limits)."""
    text = f"{_pct(r['momp_return_rate'])} / {_pct(r['momp_target_rate'])}"
    if r.get("fallback_strokes"):
        text += (f" ({r['fallback_strokes']} fallback strokes; {_pct(r['return_rate'])} / "
                 f"{_pct(r['target_rate'])} counting them)")
    return text


def _player(result: dict) -> str:
    """The hard profile's momp player settings a stage result records, as ``serve`` options
    (the moving goal is a scenario setting: ``learned.moving_goal``)."""
    text = ""
    if result.get("configuration"):
        text += f" --configuration {result['configuration']}"
    if result.get("moving_goal"):
        text += " (scenario learned.moving_goal: true)"
    return text


def _row(key: str, ours: str, value, serves, command: str, label: str = "") -> dict:
    what, paper_text, paper_value = PAPER[key]
    what = what.format(label=label)
    row = {"key": key, "experiment": what, "paper": paper_text, "ours": ours, "value": value,
           "serves": serves, "command": command}
    if paper_value is not None and value is not None:
        if key == "gpr_nmse":
            row["meets_paper"] = value < paper_value
        else:
            row["meets_paper"] = value >= paper_value
            if not row["meets_paper"]:
                row["shortfall"] = f"{100.0 * (paper_value - value):.1f} points below the paper"
    return row


def table_rows(results: dict) -> list[dict]:
    """Our figure for every paper row whose stage has finished."""
    rows = []
    # A hard-protocol run splits the learning stages' serves among several distributions.
    mix = (results.get("teacher") or {}).get("distributions")
    split = f" (serves split among {', '.join(mix)})" if mix else ""
    pred = results.get("predictor")
    if pred:
        rows.append(_row("gpr_nmse", f"{pred['max_nmse']:.4f}", pred["max_nmse"],
                         pred["eval"]["serves"], pred["command"]))
    crkr = results.get("crkr")
    if crkr:
        for it in crkr["iterations"][:2]:
            rows.append(_row(f"crkr_{it['iteration']}",
                             f"{_pct(it['return_rate'])} / {_pct(it['target_rate'])}",
                             it["return_rate"], it["serves"],
                             f"--player crkr --crkr DIR/crkr/crkr_{it['iteration']}.npz --seed "
                             f"{it['seed']}{split}"))
    single = results.get("single")
    if single:
        rows.append(_row("single", f"{_pct(single['min_return'])} - "
                                   f"{_pct(single['max_return'])} ({len(single['primitives'])} "
                                   "primitives)", None, single["serves"],
                         f"gamma one-hot, --seed {single['seed']}{split}"))
    g1 = results.get("gamma1")
    if g1 and "evaluation" in g1:  # hard protocol: on the evaluation serves
        for label, r in g1["evaluation"].items():
            rows.append(_row("hard_gamma1", _momp(r) + _ceiling(r), r["momp_return_rate"],
                             r["serves"], f"--player momp --library DIR/library/library.npz"
                                          f"{_player(g1)} --distribution {r['distribution']} "
                                          f"--seed {r['seed']}", label=label))
    elif g1:
        for key, conf in (("gamma1", "crkr"), ("gamma1_ik", "analytical")):
            rows.append(_row(key, _momp(g1[conf]), g1[conf]["momp_return_rate"],
                             g1["serves"], f"--player momp --configuration {conf} --seed "
                                           f"{g1['seed']}"))
    resp = results.get("responsibility")
    if resp:
        earlier = resp["pruned_earlier_return"]
        if resp.get("pruned_earlier_reward") is not None:
            earlier = (f"{_pct(earlier)}; their mean reward {resp['pruned_earlier_reward']:.3f}, "
                       f"the kept ones' {resp['kept_earlier_reward']:.3f}")
        else:
            earlier = _pct(earlier)
        rows.append(_row("pruned", f"{_pct(resp['pruned_share'])} ({earlier})",
                         resp["pruned_share"], resp["rollouts"],
                         f"{resp['rollouts']} rollouts in batches of {resp['batch']}, --seed "
                         f"{resp['seed']}+batch{split}"))
    power = results.get("power")
    if power and power["curve"]:
        curve = np.array(power["curve"])
        rows.append(_row("power", f"{curve[0, 1]:.3f} -> {curve[-1, 1]:.3f} ({_pct(curve[0, 2])} "
                                  f"-> {_pct(curve[-1, 2])}); {power['pruned']} of "
                                  f"{power['primitives']} pruned; weights moved "
                                  f"{100.0 * curve[-1, 6]:.2f} % (relative norm)",
                         curve[-1, 1], power["rollouts"], power["command"] + split))
    final = results.get("final") or results.get("final_partial")
    library = (results.get("final") or {}).get("library") or (
        (power or {}).get("library") or "responsibility/library_learned.npz")
    if final:
        for key, r in final.items():
            if not isinstance(r, dict):
                continue  # the library, the artefacts
            note = " (partial: the stage is still running)" if r.get("partial") else ""
            if "distribution" in r:  # hard protocol
                rows.append(_row("hard_final", _momp(r) + _ceiling(r) + note,
                                 r["momp_return_rate"], r["serves"],
                                 f"--player momp --library DIR/{library}"
                                 f"{_player(results.get('final') or {})} --distribution "
                                 f"{r['distribution']} --seed {r['seed']}", label=key))
                continue
            if key not in ("default", "real"):
                continue
            rows.append(_row("final" if key == "default" else "real",
                             _momp(r) + _ceiling(r) + note, r["momp_return_rate"], r["serves"],
                             f"--player momp --library DIR/{library} "
                             f"--distribution {key} --seed {r['seed']}"))
    return rows


#: The axes of the hard profile's before/after comparison: (key in a gamma1 / final result,
#: what it is, "rate" (drawn in percent) or "reward" or "count").
LEARNING_AXES = (
    ("momp_return_rate", "legal return by the primitives", "rate"),
    ("return_rate_of_returnable", "legal return by the primitives, of the returnable serves",
     "rate"),
    ("returns_outside_ceiling", "legal returns of serves the bound calls unreturnable",
     "count"),
    ("momp_target_rate", "on target by the primitives", "rate"),
    ("target_of_ceiling", "on target, per oracle teacher's on-target return", "rate"),
    ("momp_mean_reward", "mean reward (0 for a fallback stroke)", "reward"),
    ("reward_of_ceiling", "mean reward, per oracle teacher's mean reward", "rate"),
    ("fallback_strokes", "fallback strokes (the teacher's quintics)", "count"),
    ("early_strokes", "strokes begun on an early physical-model prediction", "count"),
)


def learning_comparison(results: dict) -> dict:
    """The hard profile's before (``gamma1``, gamma = 1) and after (``final``) figures on the same
    evaluation serves, per set and axis (:data:`LEARNING_AXES`): ``{label: {"serves", "seed",
    "oracle": {...}, "axes": [{"key", "what", "kind", "before", "after", "change"}]}}``; empty
    unless both stages have finished on a protocol with evaluation sets."""
    before = (results.get("gamma1") or {}).get("evaluation")
    after = results.get("final")
    if not before or not after:
        return {}
    out = {}
    for label, b in before.items():
        a = after.get(label)
        if not isinstance(a, dict):
            continue
        axes = []
        for key, what, kind in LEARNING_AXES:
            x, y = b.get(key), a.get(key)
            axes.append({"key": key, "what": what, "kind": kind, "before": x, "after": y,
                         "change": None if x is None or y is None else y - x})
        out[label] = {"serves": a["serves"], "seed": a["seed"],
                      "distribution": a.get("distribution"),
                      "oracle": {k: a.get(k) for k in ("returnable_serves", "returnable_rate",
                                                       "oracle_target_rate",
                                                       "oracle_mean_reward")},
                      "axes": axes}
    return out


def pruning_summary(results: dict) -> dict | None:
    """Primitives pruned by responsibility learning and then by Algorithm 3 with PoWER, of the
    library's, with what they did before: legal returns carried by them and their credited mean
    reward, gating-weighted (the kept primitives' next to them)."""
    resp = results.get("responsibility")
    if not resp:
        return None
    keys = ("pruned", "pruned_earlier_return", "pruned_earlier_reward", "kept_earlier_return",
            "kept_earlier_reward")
    out = {"primitives": resp["primitives"],
           "responsibility": {k: resp.get(k) for k in keys}}
    power = results.get("power")
    if power:
        out["power"] = {k: power.get(k) for k in keys}
    total = resp["pruned"] + (power["pruned"] if power else 0)
    out["pruned"], out["pruned_share"] = total, total / resp["primitives"]
    return out


def _plots(run, results: dict) -> list[str]:
    folder = run.root / "plots"
    folder.mkdir(exist_ok=True)
    written = []
    paper = run.protocol.name == "paper"  # the paper's figures are reference lines there only
    resp = results.get("responsibility")
    if resp and resp["curve"]:
        curve = np.array(resp["curve"], dtype=float)
        series = [{"label": "legal return by the primitives", "x": curve[:, 0], "y": curve[:, 1]},
                  {"label": "on target (fallbacks counted)", "x": curve[:, 0], "y": curve[:, 2]},
                  {"label": "share pruned", "x": curve[:, 0],
                   "y": curve[:, 3] / resp["primitives"]}]
        if curve.shape[1] > 4 and np.all(np.isfinite(curve[:, 4])):
            series.append({"label": "mean reward x 100 (0 for a fallback)", "x": curve[:, 0],
                           "y": curve[:, 4]})
        written.append(rp.plot_learning_curve(
            folder / "responsibility_learning.png", series,
            xlabel="rollouts", ylabel="per batch", title="Responsibility learning (Algorithm 3)",
            paper={"final success": 0.94, "gamma = 1": 0.67} if paper else None))

        state, _ = load_artefact(run.root / "responsibility" / "state.npz",
                                 "responsibility-learning")
        written.append(rp.plot_gamma_histogram(
            folder / "responsibilities.png", np.ones_like(state["gamma"]), state["gamma"],
            threshold=float(resp["threshold"])))
    power = results.get("power")
    if power and power["curve"]:
        curve = np.array(power["curve"])
        written.append(rp.plot_learning_curve(
            folder / "power_learning.png",
            [{"label": "mean reward (explored weights)", "x": curve[:, 0], "y": curve[:, 1]},
             {"label": "legal return by the primitives", "x": curve[:, 0], "y": curve[:, 2]},
             {"label": "share pruned", "x": curve[:, 0], "y": curve[:, 4] / power["primitives"]}],
            xlabel="rollouts", ylabel="per batch", title="Algorithm 3 with PoWER (Eq. 9)",
            paper={"final success": 0.94} if paper else None))
    groups = {f"{label} serves ({c['serves']}, seed {c['seed']})":
              {ax["what"]: (ax["before"], ax["after"]) for ax in c["axes"]
               if ax["kind"] != "count" and ax["before"] is not None and ax["after"] is not None}
              for label, c in learning_comparison(results).items()}
    groups = {title: axes for title, axes in groups.items() if axes}
    if groups:
        written.append(rp.plot_before_after(
            folder / "before_after_learning.png", groups,
            labels=("gamma = 1 (before learning)", "learned player")))
    crkr = results.get("crkr")
    if crkr:
        its = crkr["iterations"]
        x = np.array([it["iteration"] for it in its], dtype=float)
        written.append(rp.plot_learning_curve(
            folder / "crkr_policy_iteration.png",
            [{"label": "legal return", "x": x, "y": np.array([it["return_rate"] for it in its])},
             {"label": "on target", "x": x, "y": np.array([it["target_rate"] for it in its])}],
            xlabel="policy iteration", ylabel="rate", title="CrKR hitting configuration",
            paper={"return, iteration 2": 0.95, "on target, iteration 2": 0.63}))
    if results.get("final") or results.get("final_partial"):
        points = {}
        for key, _ in run.protocol.evaluate:
            path = run.root / "final" / f"landings_{key}.npy"
            if path.exists():
                points[f"{key} serves"] = np.load(path)
            else:
                landings = [e["landing"] for e in _chunk_episodes(run.root / "final" / key)
                            if e["landing"] is not None]
                if landings:
                    points[f"{key} serves (so far)"] = np.array(landings).reshape(-1, 2)
        if points:
            referee = RefereeConfig()
            written.append(rp.plot_landing_points(
                folder / "landing_points.png", points,
                target=(referee.target_x, referee.target_y), target_radius=referee.target_radius))
    errors = run.root / "predictor" / "errors.npy"
    if errors.exists():
        keep = [k for k, n in enumerate(OUTPUT_NAMES) if n != "p_y"]
        written.append(rp.plot_prediction_errors(
            folder / "prediction_errors.png", np.load(errors)[:, keep],
            [OUTPUT_NAMES[k] for k in keep], [OUTPUT_UNITS[k] for k in keep]))
    return [str(Path(p).relative_to(run.root)) for p in written]


def _chunk_episodes(folder: Path) -> list[dict]:
    """The episodes of the rollout chunks finished so far in ``folder``."""
    episodes = []
    for path in sorted(folder.glob("episodes_*.json")):
        try:
            episodes += json.loads(path.read_text())
        except (OSError, json.JSONDecodeError):
            continue
    return episodes


def _partial_final(run) -> dict:
    """The final stage's figures from the chunks finished so far (a run read part-way)."""
    out = {}
    (first, d1), (second, d2) = run.protocol.evaluate
    for key, dist, seed in ((first, d1, run.config.final_seed),
                            (second, d2, run.config.real_seed)):
        episodes = _chunk_episodes(run.root / "final" / key)
        if episodes:
            out[key] = {**rates(episodes), "seed": seed, "partial": True}
            if run.protocol.ceiling:
                out[key]["distribution"] = dist
    return out


def write_report(run) -> dict:
    results = {stage: run.result(stage) for stage in STAGES}
    results = {k: v for k, v in results.items() if v is not None}
    if "final" not in results:
        partial = _partial_final(run)
        if partial:
            results["final_partial"] = partial
    rows = table_rows(results)
    plots = _plots(run, results)
    report = {"quick": run.quick, "protocol": run.protocol.name,
              "config": run.config.to_dict(), "workers": run.workers,
              "executor": run.executor, "table": rows, "stages": results, "plots": plots,
              "learning": learning_comparison(results), "pruning": pruning_summary(results),
              "wall_seconds": round(sum(r.get("wall_seconds", 0.0) for r in results.values()),
                                    1)}
    write_json_atomic(run.root / "report.json", report)
    write_text_atomic(run.root / "report.md", format_markdown(report))
    return report


def format_markdown(report: dict) -> str:
    kind = "quick (CI-sized: few serves, figures are noisy)" if report["quick"] else "full"
    protocol = report.get("protocol", "paper")
    lines = [f"# tt-drake reproduce: {kind} run"
             + ("" if protocol == "paper" else f", {protocol} protocol"), "",
             f"Stages finished: {', '.join(report['stages'])}; total stage time "
             f"{report['wall_seconds'] / 60:.1f} min on {report['workers']} workers "
             f"({report['executor']}).", "",
             "| experiment | paper | ours | serves | command / seed |", "|---|---|---|---|---|"]
    for r in report["table"]:
        ours = r["ours"] + (f" ({r['shortfall']})" if "shortfall" in r else "")
        lines.append(f"| {r['experiment']} | {r['paper']} | {ours} | {r['serves']} | "
                     f"`{r['command']}` |")
    if protocol != "paper":
        lines += _player_note(protocol) + _learning_markdown(report)
    lines += ["", "Stage times: " + ", ".join(f"{k} {v.get('wall_seconds', 0) / 60:.1f} min"
                                             for k, v in report["stages"].items()), ""]
    lines += [f"![{Path(p).stem}]({p})" for p in report["plots"]]
    return "\n".join(lines) + "\n"


def _figure(value, kind: str) -> str:
    if value is None:
        return "-"
    if kind == "rate":
        return _pct(value)
    return f"{value:.3f}" if kind == "reward" else f"{value:g}"


def _change(value, kind: str) -> str:
    if value is None:
        return "-"
    if kind == "rate":
        return f"{100.0 * value:+.1f} points"
    return f"{value:+.3f}" if kind == "reward" else f"{value:+g}"


def _player_note(protocol: str) -> list[str]:
    """What the protocol's momp player plays, when it is not the paper's (CrKR, committed at the
    swing start)."""
    chosen = PROTOCOLS[protocol]
    if chosen.configuration == "crkr":
        return []
    return ["", f"The CrKR rows are the paper's method, trained and judged by the `crkr` player "
                f"(CrKR with the teacher's quintic stages); the {protocol} profile's momp player "
                f"(`single`, `gamma1`, `responsibility`, `power`, `final`) does not play it: its "
                f"hitting configuration is the teacher's IK (`--configuration "
                f"{chosen.configuration}`)"
                + (", and its hitting DMP follows each new prediction (the moving goal)."
                   if chosen.moving_goal else ".")]


def _learning_markdown(report: dict) -> list[str]:
    """The hard profile's sections: before and after learning on the same serves, what was
    pruned, and the learning stages' curves batch by batch."""
    lines = []
    comparison = report.get("learning") or {}
    if comparison:
        lines += ["", "## Before and after learning, on the same serves", "",
                  "gamma = 1 is the library before any learning (stage `gamma1`); the learned "
                  "player is the `final` stage's (responsibilities and PoWER). Both play the same "
                  "serves (same distribution, seed and count). Returnable: one of the oracle "
                  "strategies returns the serve legally (docs/rules.md); on target and reward "
                  "are compared with the oracle teacher's (the bound's first strategy).", ""]
        for label, c in comparison.items():
            o = c["oracle"]
            lines += [f"**{label}** serves ({c['serves']}, `--distribution {c['distribution']} "
                      f"--seed {c['seed']}`); returnable: {o['returnable_serves']} "
                      f"({_pct(o['returnable_rate'])}); oracle teacher on target "
                      f"{_pct(o['oracle_target_rate'])}, mean reward "
                      f"{_figure(o['oracle_mean_reward'], 'reward')}", "",
                      "| | gamma = 1 | learned | change |", "|---|---|---|---|"]
            lines += [f"| {ax['what']} | {_figure(ax['before'], ax['kind'])} | "
                      f"{_figure(ax['after'], ax['kind'])} | {_change(ax['change'], ax['kind'])} |"
                      for ax in c["axes"]]
            lines.append("")
    pruning = report.get("pruning")
    if pruning:
        lines += ["## Pruned primitives", ""]
        for stage, what in (("responsibility", "responsibility learning"),
                            ("power", "Algorithm 3 with PoWER, afterwards")):
            p = pruning.get(stage)
            if p is None:
                continue
            lines.append(
                f"- {what}: {p['pruned']} of {pruning['primitives']}; while they played, "
                f"legal returns {_pct(p['pruned_earlier_return'])}, mean reward "
                f"{_figure(p['pruned_earlier_reward'], 'reward')} (the kept primitives: "
                f"{_pct(p['kept_earlier_return'])}, {_figure(p['kept_earlier_reward'], 'reward')}"
                "; gating-weighted over the stage's rollouts)")
        lines += [f"- in all: {pruning['pruned']} of {pruning['primitives']} "
                  f"({_pct(pruning['pruned_share'])}; the paper: about 27 %)", ""]
    stages = report["stages"]
    for stage, title, columns in (
            ("responsibility", "Responsibility learning, batch by batch",
             ("rollouts", "legal return by the primitives", "on target", "pruned",
              "mean reward")),
            ("power", "Algorithm 3 with PoWER, batch by batch (explored weights)",
             ("rollouts", "mean reward", "legal return by the primitives", "on target",
              "pruned", "primitives updated", "weights moved"))):
        curve = (stages.get(stage) or {}).get("curve")
        if not curve:
            continue
        lines += [f"## {title}", "", "| " + " | ".join(columns) + " |",
                  "|" + "---|" * len(columns)]
        for row in curve:
            cells = [f"{row[0]:.0f}"]
            for name, v in zip(columns[1:], row[1:], strict=False):
                if name in ("pruned", "primitives updated"):
                    cells.append(f"{v:.0f}")
                elif name == "mean reward":
                    cells.append("-" if v != v else f"{v:.3f}")  # NaN: not recorded
                else:
                    cells.append(_pct(v))
            lines.append("| " + " | ".join(cells) + " |")
        lines.append("")
    return lines


def load_report(folder) -> dict:
    return json.loads((Path(folder) / "report.json").read_text())
