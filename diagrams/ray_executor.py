"""Run serve episodes on Ray actors: ``run_episodes(..., executor="ray")``.

One actor per worker builds its own diagram once (diagrams are not picklable) and then receives
only seeds; the seeds are dealt round-robin and the results come back in seed order, with at most
:data:`IN_FLIGHT` episodes queued per actor so that results stream and memory stays bounded.
The scenario travels as its YAML (it holds Drake configs that do not pickle).

Uses the Ray runtime that is already initialised, else connects to the cluster at ``RAY_ADDRESS``,
else starts a local one with ``workers`` CPUs; it shuts down (or disconnects from) only a runtime
it initialised itself. The cluster's nodes need ``tt-drake`` installed.
"""

import contextlib
import itertools
import os
from collections import deque
from collections.abc import Callable, Iterator

from pydrake.common.yaml import yaml_load_typed

from tt_drake.blas import one_blas_thread
from tt_drake.diagrams.episodes import EpisodeResult
from tt_drake.diagrams.scenario import Scenario, dump_scenario
from tt_drake.diagrams.workers import ExecutorError, run_one

IN_FLIGHT = 2  # episodes queued per actor


def _import_ray():
    try:
        import ray  # the optional ray extra: imported when the ray executor is asked for
    except ImportError:
        raise ExecutorError("the ray executor needs Ray: pip install 'tt-drake[ray]'") from None
    return ray


class _Worker:
    """The body of one actor: a diagram built once, run for one seed per call."""

    def __init__(self, scenario_yaml: str, player: str, make_diagram: Callable):
        self.error = None
        one_blas_thread()  # one CPU per actor
        try:
            scenario = yaml_load_typed(schema=Scenario, data=scenario_yaml, defaults=Scenario())
            self.diagram = make_diagram(scenario, player)
        except Exception as err:  # raised by run: a failed constructor would lose its type
            self.error = err

    def run(self, seed: int, gamma, weights=None) -> EpisodeResult:
        if self.error is not None:
            raise self.error
        return run_one(self.diagram, seed, gamma, weights)


def _get(ray, ref) -> EpisodeResult:
    """The result of ``ref``, or the episode's own exception (a PlayerError stays one)."""
    try:
        return ray.get(ref)
    except ray.exceptions.RayTaskError as err:
        raise err.cause from err


@contextlib.contextmanager
def ray_session(workers: int):
    """Ray for the duration of the block: the running one, else the cluster at RAY_ADDRESS, else a
    local one with ``workers`` CPUs; shut down on exit only if this block started it. Wrap many
    :func:`run_ray` calls in one session to start Ray once (``tt-drake reproduce`` does)."""
    ray = _import_ray()
    owned = not ray.is_initialized()
    if owned:
        if os.environ.get("RAY_ADDRESS"):
            ray.init(address=os.environ["RAY_ADDRESS"])
        else:
            ray.init(num_cpus=max(1, workers), include_dashboard=False)
    try:
        yield ray
    finally:
        if owned:
            ray.shutdown()


def run_ray(scenario: Scenario, player: str, seeds: list[int], workers: int,
            make_diagram: Callable, gamma, weights=None) -> Iterator[EpisodeResult]:
    """Yield the episodes of ``seeds`` in order, run on ``min(workers, len(seeds))`` actors."""
    seeds = list(seeds)
    if not seeds:
        return
    workers = max(1, workers)
    with ray_session(workers) as ray:
        yield from _run_actors(ray, scenario, player, seeds, workers, make_diagram, gamma,
                               weights)


def _run_actors(ray, scenario, player, seeds, workers, make_diagram, gamma, weights=None):
    per_seed = itertools.repeat(None) if weights is None else iter(weights)
    actors = []
    try:
        actor_class = ray.remote(num_cpus=1)(_Worker)
        text = dump_scenario(scenario)
        actors = [actor_class.remote(text, player, make_diagram)
                  for _ in range(min(workers, len(seeds)))]
        pending: deque = deque()
        submitted = 0
        while submitted < len(seeds) or pending:
            # Seed i goes to actor i % n, so the seed submitted after each result goes to the
            # actor that produced it: every actor keeps IN_FLIGHT episodes queued.
            while submitted < len(seeds) and len(pending) < IN_FLIGHT * len(actors):
                actor = actors[submitted % len(actors)]
                pending.append(actor.run.remote(seeds[submitted], gamma, next(per_seed)))
                submitted += 1
            yield _get(ray, pending.popleft())
    finally:
        for actor in actors:
            ray.kill(actor)
