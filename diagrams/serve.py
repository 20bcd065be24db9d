"""``tt-drake serve``: N serves at a player; a summary, JSON results and a Meshcat HTML file."""

import sys

from tqdm import tqdm

from tt_drake.diagrams.episodes import ServeDiagram, episode_seed, summarize
from tt_drake.diagrams.scenario import Scenario, dump_scenario
from tt_drake.outputs import check_writable, write_json_atomic, write_text_atomic
from tt_drake.provenance import run_provenance
from tt_drake.result_fields import serve_fields


def run_serves(scenario: Scenario, player: str, serves: int, seed: int, html: str | None = None,
               json_path: str | None = None, progress: bool = True, workers: int = 1) -> dict:
    """Run ``serves`` episodes; episode i uses ``episode_seed(seed, i)``. Returns the JSON dict.

    With ``workers`` > 1 the episodes run in that many processes (not with ``html``: the
    recording lives in this process's Meshcat). ``html``: a Meshcat recording of the episodes
    played one after the other; recording is observation only (the episodes and their results
    are those of the same command without ``html``)."""
    for path in (html, json_path):
        if path:
            check_writable(path)
    if not html and workers > 1:
        return _run_parallel(scenario, player, serves, seed, json_path, progress, workers)
    diagram = ServeDiagram(scenario, player, log_ball=bool(html))
    recording = None
    if html:
        from tt_drake.diagrams.recording import Recording

        recording = Recording(scenario, diagram.library)
    seeds = (episode_seed(seed, i) for i in range(serves))
    results = serve_episodes(diagram, seeds, recording, progress, player, total=serves)
    data = _report(scenario, player, seed, results)
    if recording is not None:
        write_text_atomic(html, recording.html(data))
    if json_path:
        write_json_atomic(json_path, data)
    return data


def serve_episodes(diagram: ServeDiagram, seeds, recording=None, progress: bool = False,
                   label: str = "", total: int | None = None) -> list:
    """Run one episode per seed on ``diagram``; with a ``Recording`` (and a diagram built with
    ``log_ball``), add each to it once its result is taken."""
    results = []
    bar = tqdm(seeds, desc=f"serving ({label})", unit="serve", file=sys.stderr, total=total,
               disable=not progress)
    for i, seed in enumerate(bar):
        result = diagram.run(seed)
        results.append(result)
        if recording is not None:
            from tt_drake.diagrams.recording import TAIL

            beliefs = diagram.beliefs
            diagram.extend(TAIL)  # after the result: the bounce after the decided landing
            recording.add(i, result, diagram.poses(), beliefs, result.stroke)
        bar.set_postfix(returned=f"{summarize(results)['return_rate']:.0%}")
    return results


def _report(scenario: Scenario, player: str, seed: int, results: list) -> dict:
    """The result file: provenance, the full scenario, the run's settings, a ``fields`` legend
    (names and units of every vector, :mod:`tt_drake.result_fields`), summary and episodes."""
    return {
        **run_provenance(), "scenario": scenario_dict(scenario), "player": player, "seed": seed,
        "distribution": scenario.launcher.distribution, "fields": serve_fields(),
        "summary": summarize(results), "episodes": [r.as_dict() for r in results],
    }


def scenario_dict(scenario: Scenario) -> dict:
    """Every field of ``scenario`` (defaults included) as plain data. A learned artefact inside
    the installed package (the shipped ones, ``tt_drake.models``) is named relative to the
    package, as ``tt_drake/models/learned/library.npz``, not by this machine's path to it."""
    from importlib import resources
    from pathlib import Path

    from pydrake.common.yaml import yaml_load_data

    data = yaml_load_data(dump_scenario(scenario))
    models = Path(str(resources.files("tt_drake.models"))).resolve()
    learned = data["learned"]
    for key in ("library", "crkr", "predictor"):
        path = Path(learned[key]).resolve() if learned[key] else None
        if path is not None and path.is_relative_to(models):
            learned[key] = f"tt_drake/models/{path.relative_to(models).as_posix()}"
    return data


def _run_parallel(scenario, player, serves, seed, json_path, progress, workers) -> dict:
    from tt_drake.diagrams.parallel import run_episodes

    seeds = [episode_seed(seed, i) for i in range(serves)]
    results = []
    bar = tqdm(total=serves, desc=f"serving ({player}, {workers} workers)", unit="serve",
               file=sys.stderr, disable=not progress)
    for result in run_episodes(scenario, player, seeds, workers):
        results.append(result)
        bar.update()
        bar.set_postfix(returned=f"{summarize(results)['return_rate']:.0%}")
    bar.close()
    data = _report(scenario, player, seed, results)
    if json_path:
        write_json_atomic(json_path, data)
    return data


def format_summary(data: dict) -> str:
    s = data["summary"]
    return (f"{data['player']} player, {s['serves']} {data['distribution']} serves (seed "
            f"{data['seed']}): hit {s['hit_rate']:.1%}, legal return {s['return_rate']:.1%}, "
            f"on target {s['target_rate']:.1%}, mean reward {s['mean_reward']:.3f}")
