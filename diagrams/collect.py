"""``tt-drake collect``: a teacher-demonstration dataset, in resumable chunks.

    DIR/manifest.json        what the run is: player, distribution, seed, serves, chunk size
    DIR/chunk_00000.npz ...  ``chunk_size`` serves each (default :data:`CHUNK_SIZE`; artefact kind
                             "teacher-demonstrations", loaded without pickle)

Serve i uses ``episode_seed(seed, i)``, exactly as ``tt-drake serve``. Chunks are written
atomically as they complete; an interrupted run, started again with the same arguments, keeps the
chunks that load and simulates only the missing ones. A DIR that holds another run's data is
refused rather than mixed. :func:`load_dataset` concatenates the chunks.
"""

import functools
import json
import sys
from pathlib import Path

import numpy as np
from tqdm import tqdm

from tt_drake.artefacts import ArtefactError, load_artefact, save_artefact
from tt_drake.diagrams.episodes import ServeDiagram, check_run, episode_seed
from tt_drake.diagrams.parallel import run_episodes
from tt_drake.diagrams.scenario import Scenario
from tt_drake.errors import BadInputError
from tt_drake.outputs import claim_folder
from tt_drake.stages import STAGES

KIND = "teacher-demonstrations"
CHUNK_SIZE = 25
MANIFEST = "manifest.json"
PER_SERVE = ("features", "true_hit", "stimulus", "q_hit", "qd_hit", "durations", "landing",
             "hit", "returned", "on_target", "reward", "spin_hit")
# Per-sample arrays (rows of TRAJECTORY_COLUMNS) with an owner array "<name>_serve": the executed
# plan's stages, and the same stages as the arm's measured state (diagrams/demonstrations.py).
TRAJECTORIES = ("trajectory", "recorded")
TRAJECTORY_COLUMNS = ["t", "stage"] + [f"{name}{j}" for name in ("q", "qd", "qdd")
                                       for j in range(1, 8)]


class DatasetError(ValueError, BadInputError):
    """A dataset folder that cannot be used (another run's data, unreadable, empty)."""


def _chunk_path(folder: Path, index: int) -> Path:
    return folder / f"chunk_{index:05d}.npz"


def _manifest(scenario: Scenario, player: str, serves: int, seed: int, chunk_size: int) -> dict:
    manifest = {"format": KIND, "player": player, "scenario": scenario.name,
                "distribution": scenario.launcher.distribution, "seed": seed, "serves": serves,
                "chunk_size": chunk_size, "stages": list(STAGES),
                "trajectory_columns": TRAJECTORY_COLUMNS}
    # Named only when not the camera's, so datasets collected before perception was recorded
    # (all through the camera) still resume.
    if scenario.perception != "camera":
        manifest["perception"] = scenario.perception
    return manifest


def prepare_folder(folder: Path, manifest: dict):
    """Create ``folder`` with its manifest, or check an existing one is this run's; returns the
    folder's lock (:class:`tt_drake.outputs.FolderLock`), to hold while the run writes."""
    return claim_folder(folder, MANIFEST, manifest, DatasetError, "run's dataset")


def _missing_chunks(folder: Path, n_chunks: int) -> list[int]:
    """Chunks to simulate: absent ones, and damaged ones (reported on stderr, one line each)."""
    missing = []
    for c in range(n_chunks):
        path = _chunk_path(folder, c)
        if not path.exists():
            missing.append(c)
            continue
        try:
            load_artefact(path, KIND, allow_nonfinite=PER_SERVE)
        except ArtefactError as err:
            print(f"tt-drake collect: damaged chunk, simulating it again: {err}", file=sys.stderr)
            missing.append(c)
    return missing


def _pack(indices: list[int], seeds: list[int], results: list) -> dict:
    """One chunk's arrays: per-serve arrays and the concatenated trajectories with an owner
    column (the serve's index in the run)."""
    arrays = {"index": np.array(indices), "seed": np.array(seeds, dtype=np.uint64)}
    for key in PER_SERVE:
        arrays[key] = np.array([r.record[key] for r in results], dtype=float)
    for name in TRAJECTORIES:
        trajectories = [r.record[name] for r in results]
        owners = [np.full(len(traj), i) for i, traj in zip(indices, trajectories, strict=True)]
        arrays[name] = np.vstack(trajectories) if trajectories else np.zeros((0, 23))
        arrays[f"{name}_serve"] = np.concatenate(owners) if owners else np.zeros(0, int)
    return arrays


def collect(scenario: Scenario, player: str, serves: int, seed: int, out: str,
            workers: int = 1, progress: bool = True, chunk_size: int = CHUNK_SIZE,
            executor: str = "local") -> dict:
    """Simulate the missing chunks of the dataset (on ``executor``, see
    :func:`tt_drake.diagrams.parallel.run_episodes`); returns a summary."""
    folder = Path(out)
    check_run(seed, serves)  # before the folder is claimed: nothing written for a bad seed
    with prepare_folder(folder, _manifest(scenario, player, serves, seed, chunk_size)):
        missing = _missing_chunks(folder, -(-serves // chunk_size))

        def indices():  # streamed: no list of every serve's seed up front
            for c in missing:
                yield from range(c * chunk_size, min(serves, (c + 1) * chunk_size))

        n_todo = sum(min(serves, (c + 1) * chunk_size) - c * chunk_size for c in missing)
        bar = tqdm(total=serves, initial=serves - n_todo, desc=f"collecting ({player})",
                   unit="serve", file=sys.stderr, disable=not progress)
        make = functools.partial(ServeDiagram, record=True)
        seeds = (episode_seed(seed, i) for i in indices())
        pending: dict[int, list] = {}
        for i, result in zip(indices(), run_episodes(scenario, player, seeds, workers, make,
                                                     executor=executor), strict=True):
            chunk = i // chunk_size
            pending.setdefault(chunk, []).append((i, result.seed, result))
            bar.update()
            size = min(serves, (chunk + 1) * chunk_size) - chunk * chunk_size
            if len(pending[chunk]) == size:
                items = pending.pop(chunk)
                save_artefact(_chunk_path(folder, chunk), KIND,
                              _pack([i for i, _, _ in items], [s for _, s, _ in items],
                                    [r for _, _, r in items]),
                              {"chunk": chunk, "seed": seed, "player": player})
        bar.close()
    data = load_dataset(folder)
    return {"serves": serves, "simulated": n_todo, "kept": serves - n_todo,
            "return_rate": float(data["returned"].mean()), "folder": str(folder)}


def load_dataset(folder) -> dict:
    """All chunks of a dataset concatenated (per-serve arrays in serve order, trajectories with
    their ``trajectory_serve`` owner), plus ``manifest``. Raises DatasetError if incomplete."""
    folder = Path(folder)
    try:
        manifest = json.loads((folder / MANIFEST).read_text())
    except (OSError, json.JSONDecodeError) as err:
        raise DatasetError(f"not a dataset folder {folder}: {err}") from None
    n_chunks = -(-manifest["serves"] // manifest["chunk_size"])
    parts = []
    for c in range(n_chunks):
        try:
            arrays, _ = load_artefact(_chunk_path(folder, c), KIND, allow_nonfinite=PER_SERVE)
        except ArtefactError as err:
            raise DatasetError(f"dataset {folder} is incomplete or damaged: {err}") from None
        parts.append(arrays)
    # Arrays every chunk holds (a dataset collected before an array existed lacks it).
    keys = [key for key in parts[0] if all(key in p for p in parts)]
    data = {key: np.concatenate([p[key] for p in parts]) for key in keys}
    data["manifest"] = manifest
    return data
