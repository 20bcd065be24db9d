"""The optional Ray executor: same episodes as the local one, in seed order; clear errors."""

import subprocess
import sys

import pytest

from tt_drake.diagrams.episodes import PlayerError, episode_seed
from tt_drake.diagrams.parallel import ExecutorError, run_episodes
from tt_drake.diagrams.scenario import load_scenario


def _outcomes(results) -> list[tuple]:
    return [(r.seed, r.launch_state, r.predicted_crossing, r.outcome.as_dict()) for r in results]


@pytest.mark.ray
def test_ray_serves_match_local_in_seed_order():
    ray = pytest.importorskip("ray")
    scenario = load_scenario("default")
    seeds = [episode_seed(7, i) for i in range(4)]
    local = list(run_episodes(scenario, "idle", seeds, workers=1))
    assert not ray.is_initialized()
    remote = list(run_episodes(scenario, "idle", seeds, workers=2, executor="ray"))
    assert not ray.is_initialized()  # the local cluster it started is shut down
    assert [r.seed for r in remote] == seeds
    assert _outcomes(remote) == _outcomes(local)


@pytest.mark.ray
def test_episode_errors_keep_their_type_and_a_running_ray_stays_up():
    ray = pytest.importorskip("ray")
    ray.init(num_cpus=2, include_dashboard=False)
    try:
        with pytest.raises(PlayerError, match="unknown player 'nobody'"):
            list(run_episodes(load_scenario("default"), "nobody", [1, 2], workers=2,
                              executor="ray"))
        assert ray.is_initialized()  # not the executor's to shut down
    finally:
        ray.shutdown()


def test_unknown_executor_is_an_executor_error():
    with pytest.raises(ExecutorError, match="unknown executor 'dask'; choose one of local, ray"):
        list(run_episodes(load_scenario("default"), "idle", [1], executor="dask"))


def test_missing_ray_is_a_clear_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # `import ray` now raises ImportError
    with pytest.raises(ExecutorError, match=r"needs Ray: pip install 'tt-drake\[ray\]'"):
        list(run_episodes(load_scenario("default"), "idle", [1], executor="ray"))


def test_importing_parallel_does_not_import_ray():
    code = "import sys, tt_drake.diagrams.parallel; print('ray' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
