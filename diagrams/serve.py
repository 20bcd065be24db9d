"""``tt-drake serve``: N serves at a player; a summary, JSON results and a Meshcat HTML file."""

import sys

from tqdm import tqdm

from tt_drake.diagrams.episodes import ServeDiagram, check_run, episode_seed, summarize
from tt_drake.diagrams.scenario import Scenario
from tt_drake.outputs import check_writable, write_json_atomic, write_text_atomic


def run_serves(scenario: Scenario, player: str, serves: int, seed: int, html: str | None = None,
               json_path: str | None = None, progress: bool = True, workers: int = 1) -> dict:
    """Run ``serves`` episodes; episode i uses ``episode_seed(seed, i)``. Returns the JSON dict.

    With ``workers`` > 1 the episodes run in that many processes (not with ``html``: the
    recording lives in this process's Meshcat)."""
    check_run(seed, serves)
    for path in (html, json_path):
        if path:
            check_writable(path)
    if not html and workers > 1:
        return _run_parallel(scenario, player, serves, seed, json_path, progress, workers)
    meshcat = None
    if html:
        from tt_drake.diagrams.recording import make_meshcat, mark_target

        meshcat = make_meshcat()
        mark_target(meshcat, scenario.referee.target_x, scenario.referee.target_y,
                    scenario.referee.target_radius)
    diagram = ServeDiagram(scenario, player, meshcat=meshcat, log_ball=bool(html))
    if meshcat is not None:
        diagram.visualizer.StartRecording()
    results = []
    clock = 0.0
    bar = tqdm(range(serves), desc=f"serving ({player})", unit="serve", file=sys.stderr,
               disable=not progress)
    for i in bar:
        result = diagram.run(episode_seed(seed, i), start_time=clock)
        results.append(result)
        if meshcat is not None:
            from tt_drake.diagrams.recording import draw_beliefs, draw_episode, draw_stroke

            draw_episode(meshcat, i, result)
            draw_stroke(meshcat, i, result.stroke, diagram.library)
            draw_beliefs(meshcat, diagram.visualizer.get_mutable_recording(), i,
                         diagram.beliefs)
            clock += result.duration
        bar.set_postfix(returned=f"{summarize(results)['return_rate']:.0%}")
    data = _report(scenario, player, seed, results)
    if meshcat is not None:
        diagram.visualizer.StopRecording()
        diagram.visualizer.PublishRecording()
        write_text_atomic(html, meshcat.StaticHtml())
    if json_path:
        write_json_atomic(json_path, data)
    return data


def _report(scenario: Scenario, player: str, seed: int, results: list) -> dict:
    return {
        "scenario": scenario.name, "player": player, "seed": seed,
        "distribution": scenario.launcher.distribution,
        "summary": summarize(results), "episodes": [r.as_dict() for r in results],
    }


def _run_parallel(scenario, player, serves, seed, json_path, progress, workers) -> dict:
    from tt_drake.diagrams.parallel import run_episodes

    seeds = (episode_seed(seed, i) for i in range(serves))  # streamed, not listed
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
