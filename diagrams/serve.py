"""``tt-drake serve``: N serves at a player; a summary, JSON results and a Meshcat HTML file.

With ``ceiling`` the same serves are also played by the oracle strategies of
:mod:`tt_drake.diagrams.ceiling` (the analytical player with the true ball state, choosing its
hitting point and aim in several ways), whose legal returns mark the serves that are returnable
from the robot's mount; the summary then gains ``returnable_rate`` (with ``returnable_serves``,
the count), ``return_rate_of_returnable`` (the player's legal returns among the returnable
serves over their number) and ``returns_outside_ceiling`` (docs/rules.md).
"""

import copy
import json
import sys
from importlib import resources
from pathlib import Path

from pydrake.common.yaml import yaml_load_data
from tqdm import tqdm

from tt_drake.diagrams.ceiling import (
    beyond_reach,
    ceiling_summary,
    returnable_by,
    strategy_player,
    strategy_scenario,
    within_reach,
)
from tt_drake.diagrams.episodes import ServeDiagram, check_run, episode_seed, summarize
from tt_drake.diagrams.parallel import run_episodes
from tt_drake.diagrams.recording import TAIL, Recording
from tt_drake.diagrams.scenario import Scenario, dump_scenario, resolve_model_paths
from tt_drake.errors import BadInputError
from tt_drake.intervals import wilson
from tt_drake.outputs import check_writable, write_json_atomic, write_text_atomic
from tt_drake.provenance import run_provenance
from tt_drake.result_fields import serve_fields


def run_serves(scenario: Scenario, player: str, serves: int, seed: int, html: str | None = None,
               json_path: str | None = None, progress: bool = True, workers: int = 1,
               ceiling: bool = False, ceiling_from: str | None = None) -> dict:
    """Run ``serves`` episodes; episode i uses ``episode_seed(seed, i)``. Returns the JSON dict.

    With ``workers`` > 1 the episodes run in that many processes (not with ``html``: the
    recording lives in this process's Meshcat). ``html``: a Meshcat recording of the episodes
    played one after the other; recording is observation only (the episodes and their results
    are those of the same command without ``html``). A pool distribution deals its serves
    without repeats within the run (``LauncherConfig.run_seed``). ``ceiling``: see the module
    docstring; ``ceiling_from``: take the returnable serves from this earlier ``--ceiling``
    run's JSON of the same serves instead (:func:`read_returnable`)."""
    check_run(seed, serves)
    if ceiling_from:
        read_returnable(ceiling_from, None)  # a bad file stops the run before it starts
    for path in (html, json_path):
        if path:
            check_writable(path)
    scenario = copy.deepcopy(scenario)
    scenario.launcher.run_seed = seed
    recording = None
    if not html and workers > 1:
        seeds = [episode_seed(seed, i) for i in range(serves)]
        results = _episodes(scenario, player, seeds, progress, workers)
    else:
        diagram = ServeDiagram(scenario, player, log_ball=bool(html))
        if html:
            recording = Recording(scenario, diagram.library)
        seeds = (episode_seed(seed, i) for i in range(serves))
        results = serve_episodes(diagram, seeds, recording, progress, player, total=serves)
    data = _report(scenario, player, seed, results)
    if ceiling_from:
        add_returnable(data, results, read_returnable(ceiling_from, data))
    elif ceiling:
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
    package, as ``tt_drake/models/learned/library.npz``, not by this machine's path to it. A model
    file given as a path (a scenario built in Python) is recorded by its absolute path, as
    :func:`tt_drake.diagrams.scenario.load_scenario` records it."""
    scenario = copy.deepcopy(scenario)
    resolve_model_paths(scenario)
    data = yaml_load_data(dump_scenario(scenario))
    models = Path(str(resources.files("tt_drake.models"))).resolve()
    learned = data["learned"]
    for key in ("library", "crkr", "predictor"):
        path = Path(learned[key]).resolve() if learned[key] else None
        if path is not None and path.is_relative_to(models):
            learned[key] = f"tt_drake/models/{path.relative_to(models).as_posix()}"
    return data


def _episodes(scenario, player, seeds: list[int], progress: bool, workers: int,
              label: str | None = None) -> list:
    results = []
    bar = tqdm(total=len(seeds), desc=f"serving ({label or player}, {workers} workers)",
               unit="serve", file=sys.stderr, disable=not progress)
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
    """Find the run's returnable serves (:mod:`tt_drake.diagrams.ceiling`) and add them to
    ``data``: per episode ``returnable`` and ``returnable_by`` (the first oracle strategy that
    returned it), and in the summary the figures of
    :func:`tt_drake.diagrams.ceiling.ceiling_summary`."""
    add_returnable(data, results, returnable_serves(scenario, serves, seed, progress, workers))


def add_returnable(data: dict, results: list, returnable: list[str | None]) -> None:
    """Add the returnable serves (per serve the first oracle strategy that returns it, or None)
    to the run's ``data`` (see :func:`add_ceiling`)."""
    data["summary"].update(ceiling_summary([r.outcome.returned for r in results], returnable))
    data["summary"]["beyond_reach_serves"] = sum(beyond_reach(r.launch_state) for r in results)
    for episode, by in zip(data["episodes"], returnable, strict=True):
        episode["returnable"] = by is not None
        episode["returnable_by"] = by


class CeilingFileError(ValueError, BadInputError):
    """A ``--ceiling-from`` file that is not an earlier ``--ceiling`` run of the same serves."""


def read_returnable(path: str, data: dict | None) -> list[str | None]:
    """The ``returnable_by`` of every serve of an earlier ``serve --ceiling --json`` run. With
    the new run's ``data``, the file must hold the same serves: the same episode seeds and
    launch states, in order (any player). Only the serves are checked: the bound is that of
    the scenario the file was made with (its drives and teacher settings)."""
    try:
        with open(path, encoding="utf-8") as f:
            saved = json.load(f)
        episodes = saved["episodes"]
        returnable = [e["returnable_by"] for e in episodes]
        serves = [(e["seed"], e["launch_state"]) for e in episodes]
    except (OSError, ValueError, KeyError, TypeError) as err:
        raise CeilingFileError(f"--ceiling-from {path}: not a serve --ceiling --json result "
                               f"({' '.join(str(err).split())})") from None
    if not all(r is None or isinstance(r, str) for r in returnable):
        raise CeilingFileError(f"--ceiling-from {path}: returnable_by must be strategy names "
                               f"or null")
    if data is not None and serves != [(e["seed"], e["launch_state"])
                                       for e in data["episodes"]]:
        raise CeilingFileError(f"--ceiling-from {path}: another run's serves (the seed, "
                               f"distribution, count or launcher settings differ)")
    return returnable


def returnable_serves(scenario: Scenario, serves: int, seed: int, progress: bool = False,
                      workers: int = 1) -> list[str | None]:
    """For each serve of the run (episode i: ``episode_seed(seed, i)``, the pools dealt by
    ``scenario.launcher.run_seed``), the first oracle strategy that returns it legally, or None
    (:func:`tt_drake.diagrams.ceiling.returnable_by`). ``scenario`` is left as it was."""

    def play(strategy, indices):
        seeds = [episode_seed(seed, i) for i in indices]
        return [r.outcome.returned for r in _episodes(
            strategy_scenario(strategy, scenario), strategy_player(strategy), seeds, progress,
            workers, label=f"oracle {strategy.name}")]

    return returnable_by(play, serves, within_reach=within_reach(scenario, serves, seed))


def _interval(rate: float, n: int) -> str:
    """The Wilson 95 % interval of a rate of n trials, as "[lo, hi]" in per cent."""
    lo, hi = wilson(round(rate * n), n)
    return f"[{lo:.1%}, {hi:.1%}]"


def format_summary(data: dict) -> str:
    s = data["summary"]
    line = (f"{data['player']} player, {s['serves']} {data['distribution']} serves (seed "
            f"{data['seed']}): hit {s['hit_rate']:.1%}, legal return {s['return_rate']:.1%} "
            f"{_interval(s['return_rate'], s['serves'])}, on target {s['target_rate']:.1%}, "
            f"mean reward {s['mean_reward']:.3f}")
    if s.get("double_bounce_faults"):
        line += f", {s['double_bounce_faults']} hit after a double bounce (lost points)"
    if "returnable_rate" in s:
        of = s["return_rate_of_returnable"]
        line += (f"; returnable (oracle strategies) {s['returnable_rate']:.1%} "
                 f"({s['returnable_serves']} serves), legal returns of those "
                 f"{s['returns_of_returnable']} = "
                 + ("n/a" if of is None else
                    f"{of:.1%} {_interval(of, s['returnable_serves'])}")
                 + f", legal returns outside the bound {s['returns_outside_ceiling']}")
    return line
