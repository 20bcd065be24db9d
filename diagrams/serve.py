"""``tt-drake serve``: N serves at a player; a summary, JSON results and a Meshcat HTML file.

With ``ceiling`` the same serves are also played by the oracle analytical player (the true ball
state, no noise: ``Scenario.perception = "oracle"``), whose legal returns mark the serves that
are physically returnable from the robot's mount; the summary then gains ``returnable_rate``
(with ``returnable_serves``, the count) and ``return_rate_of_returnable``: the player's legal
returns among the returnable serves over their number (docs/serves.md).
"""

import copy
import sys

from tqdm import tqdm

from tt_drake.diagrams.episodes import ServeDiagram, check_run, episode_seed, summarize
from tt_drake.diagrams.scenario import Scenario, dump_scenario
from tt_drake.outputs import check_writable, write_json_atomic, write_text_atomic
from tt_drake.provenance import run_provenance
from tt_drake.result_fields import serve_fields


def run_serves(scenario: Scenario, player: str, serves: int, seed: int, html: str | None = None,
               json_path: str | None = None, progress: bool = True, workers: int = 1,
               ceiling: bool = False) -> dict:
    """Run ``serves`` episodes; episode i uses ``episode_seed(seed, i)``. Returns the JSON dict.

    With ``workers`` > 1 the episodes run in that many processes (not with ``html``: the
    recording lives in this process's Meshcat). ``html``: a Meshcat recording of the episodes
    played one after the other; recording is observation only (the episodes and their results
    are those of the same command without ``html``). A pool distribution deals its serves
    without repeats within the run (``LauncherConfig.run_seed``). ``ceiling``: see the module
    docstring."""
    check_run(seed, serves)
    for path in (html, json_path):
        if path:
            check_writable(path)
    scenario = copy.deepcopy(scenario)
    scenario.launcher.run_seed = seed
    recording = None
    if not html and workers > 1:
        results = _episodes(scenario, player, serves, seed, progress, workers)
    else:
        diagram = ServeDiagram(scenario, player, log_ball=bool(html))
        if html:
            from tt_drake.diagrams.recording import Recording

            recording = Recording(scenario, diagram.library)
        seeds = (episode_seed(seed, i) for i in range(serves))
        results = serve_episodes(diagram, seeds, recording, progress, player, total=serves)
    data = _report(scenario, player, seed, results)
    if ceiling:
        add_ceiling(data, scenario, player, serves, seed, results, progress, workers)
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
    returned = 0  # counted as the results come (summarize at each would be O(serves^2))
    for i, seed in enumerate(bar):
        result = diagram.run(seed)
        results.append(result)
        returned += bool(result.outcome.returned)
        if recording is not None:
            from tt_drake.diagrams.recording import TAIL

            beliefs = diagram.beliefs
            diagram.extend(TAIL)  # after the result: the bounce after the decided landing
            recording.add(i, result, diagram.poses(), beliefs, result.stroke)
        bar.set_postfix(returned=f"{returned / len(results):.0%}")
    return results


def _report(scenario: Scenario, player: str, seed: int, results: list) -> dict:
    """The result file: provenance, the full scenario, the run's settings, a ``fields`` legend
    (names and units of every vector, :mod:`tt_drake.result_fields`), summary and episodes."""
    return {
        **run_provenance(), "scenario": scenario_dict(scenario), "player": player, "seed": seed,
        "distribution": scenario.launcher.distribution, "perception": scenario.perception,
        "fields": serve_fields(),
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


def _episodes(scenario, player, serves, seed, progress, workers) -> list:
    from tt_drake.diagrams.parallel import run_episodes

    seeds = (episode_seed(seed, i) for i in range(serves))  # streamed, not listed
    results = []
    bar = tqdm(total=serves, desc=f"serving ({player}, {workers} workers)", unit="serve",
               file=sys.stderr, disable=not progress)
    returned = 0  # counted as the results come (summarize at each would be O(serves^2))
    for result in run_episodes(scenario, player, seeds, workers):
        results.append(result)
        returned += bool(result.outcome.returned)
        bar.update()
        bar.set_postfix(returned=f"{returned / len(results):.0%}")
    bar.close()
    return results


def add_ceiling(data: dict, scenario: Scenario, player: str, serves: int, seed: int,
                results: list, progress: bool, workers: int) -> None:
    """Play the run's serves with the oracle analytical player (unless the run is that player)
    and add the returnable serves to ``data``: per episode ``returnable``, and in the summary
    ``returnable_rate``, ``returnable_serves``, ``return_rate_of_returnable`` (None when no
    serve is returnable) and ``returns_of_returnable``."""
    if player == "analytical" and scenario.perception == "oracle":
        returnable = [r.outcome.returned for r in results]
    else:
        returnable = oracle_returns(scenario, serves, seed, progress, workers)
    returned = sum(r.outcome.returned and ok for r, ok in zip(results, returnable, strict=True))
    n = sum(returnable)
    summary = data["summary"]
    summary["returnable_rate"] = n / serves if serves else 0.0
    summary["returnable_serves"] = n
    summary["returns_of_returnable"] = returned
    summary["return_rate_of_returnable"] = returned / n if n else None
    for episode, ok in zip(data["episodes"], returnable, strict=True):
        episode["returnable"] = bool(ok)


def oracle_returns(scenario: Scenario, serves: int, seed: int, progress: bool = False,
                   workers: int = 1) -> list[bool]:
    """Whether the oracle analytical player legally returns each serve of the run (episode i:
    ``episode_seed(seed, i)``, the pools dealt by ``scenario.launcher.run_seed``): the returnable
    serves. ``scenario`` is left as it was."""
    teacher = copy.deepcopy(scenario)
    teacher.perception = "oracle"
    return [r.outcome.returned
            for r in _episodes(teacher, "analytical", serves, seed, progress, workers)]


def format_summary(data: dict) -> str:
    s = data["summary"]
    line = (f"{data['player']} player, {s['serves']} {data['distribution']} serves (seed "
            f"{data['seed']}): hit {s['hit_rate']:.1%}, legal return {s['return_rate']:.1%}, "
            f"on target {s['target_rate']:.1%}, mean reward {s['mean_reward']:.3f}")
    if "returnable_rate" in s:
        of = s["return_rate_of_returnable"]
        line += (f"; returnable (oracle analytical) {s['returnable_rate']:.1%} "
                 f"({s['returnable_serves']} serves), legal returns of those "
                 f"{s['returns_of_returnable']} = "
                 + ("n/a" if of is None else f"{of:.1%}"))
    return line
