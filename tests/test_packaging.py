"""The package as a user gets it: a wheel that holds every module, the models, the real ball data
and the shipped learned player, installs without a setuptools warning into a fresh venv, and
serves from a folder outside the checkout exactly as the checkout does (marker ``wheel``: builds
and installs, a few minutes). And the honest demo: its seed is one no training stage used."""

import json
import os
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from tt_drake.diagrams import reproduce as rp

REPO = Path(__file__).resolve().parents[1]
# Where each folder of the checkout lands in the import package (setup.py's ROOTS).
ROOTS = {"tt_drake": "tt_drake", "systems": "tt_drake/systems", "diagrams": "tt_drake/diagrams",
         "models": "tt_drake/models"}
OPTIONAL = {"gymnasium", "cma", "ray"}  # extras: a module needing one may not import bare


def _reproduce_seeds(config: rp.ReproduceConfig) -> set[int]:
    """Every base seed a stage of ``tt-drake reproduce`` serves with."""
    c = config
    batches = -(-c.responsibility_rollouts // c.responsibility_batch)
    return ({c.teacher_seed, c.predictor_train_seed, c.predictor_test_seed, c.single_seed,
             c.gamma1_seed, c.final_seed, c.real_seed}
            | {c.crkr_seed + k for k in range(1, c.crkr_max_iterations + 1)}
            | {c.responsibility_seed + b for b in range(batches)})


def test_the_demo_serves_with_a_seed_no_reproduce_stage_used():
    makefile = (REPO / "Makefile").read_text()
    seed = int(re.search(r"^DEMO_SEED \?= (\d+)$", makefile, re.M).group(1))
    assert "--seed $(DEMO_SEED)" in makefile
    full = _reproduce_seeds(rp.ReproduceConfig())
    assert {1, 2026, 69} <= full  # the teacher, the final stage, the last responsibility batch
    assert seed not in full | _reproduce_seeds(rp.quick_config())


def _expected_files() -> set[str]:
    """What the wheel must hold: every Python module and every data file of the checkout's
    package folders, at its place in the import package."""
    keep = re.compile(r"\.(py|urdf|sdf|yaml|npz|json|md)$")
    out = set()
    for folder, package in ROOTS.items():
        for path in (REPO / folder).rglob("*"):
            if path.is_file() and keep.search(path.name) and "__pycache__" not in path.parts:
                out.add(f"{package}/{path.relative_to(REPO / folder).as_posix()}")
    return out


def _clean_env() -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    # Set on this machine: setuptools then logs "byte-compiling is disabled", a warning about the
    # environment, not the package.
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    return env


@pytest.fixture(scope="module")
def wheel_venv(tmp_path_factory):
    """Build the wheel from a copy of the checkout, install it into a fresh venv (no
    --system-site-packages: only what the wheel declares). Returns (venv, wheel, build log,
    install log)."""
    root = tmp_path_factory.mktemp("wheel")
    src = root / "src"
    shutil.copytree(REPO, src, ignore=shutil.ignore_patterns(
        ".venv", ".git", "out", "build", "*.egg-info", "__pycache__", ".pytest_cache",
        ".ruff_cache", "*.html"))
    env = _clean_env()
    build = subprocess.run([sys.executable, "-m", "pip", "wheel", "-v", "--no-deps", "-w",
                            str(root / "dist"), str(src)], capture_output=True, text=True,
                           env=env, timeout=900)
    assert build.returncode == 0, build.stdout[-3000:] + build.stderr[-3000:]
    (wheel,) = (root / "dist").glob("tt_drake-*.whl")
    venv = root / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, env=env, timeout=300)
    install = subprocess.run([str(venv / "bin" / "python"), "-m", "pip", "install", str(wheel)],
                             capture_output=True, text=True, env=env, timeout=1200)
    assert install.returncode == 0, install.stdout[-3000:] + install.stderr[-3000:]
    return venv, wheel, build.stdout + build.stderr, install.stdout + install.stderr


def _warnings(log: str) -> list[str]:
    """Warning lines of a build or install log: Python warnings (``SomethingWarning:``), the
    ``!!`` banners setuptools frames them with, and distutils' ``warning:`` lines. The machine's
    own pip configuration may name package indexes that do not exist here: pip's ``WARNING:
    Location ... is ignored`` lines are about that configuration, not this project."""
    return [line for line in log.splitlines()
            if (re.search(r"\w*Warning: |^\s*!!\s*$|\bwarning: ", line)
                or re.search(r"WARNING", line) and "is ignored: it is neither" not in line)]


@pytest.mark.slow
@pytest.mark.wheel
def test_the_wheel_holds_every_module_model_and_shipped_artefact(wheel_venv):
    _, wheel, build_log, install_log = wheel_venv
    names = set(zipfile.ZipFile(wheel).namelist())
    expected = _expected_files()
    assert {"tt_drake/modelgen/wam.py", "tt_drake/data/serves.json",
            "tt_drake/models/learned/library.npz", "tt_drake/diagrams/cli.py",
            "tt_drake/models/learned-hard/library.npz"} <= expected
    assert expected <= names, sorted(expected - names)
    assert _warnings(build_log) == [] and _warnings(install_log) == []


def _run(venv, *args, cwd):
    return subprocess.run([str(venv / "bin" / "tt-drake"), *args], capture_output=True,
                          text=True, cwd=cwd, env=_clean_env(), timeout=900)


@pytest.mark.slow
@pytest.mark.wheel
def test_the_installed_wheel_imports_every_module_and_knows_its_version(wheel_venv, tmp_path):
    venv = wheel_venv[0]
    modules = sorted(n[:-3].replace("/", ".").removesuffix(".__init__")
                     for n in _expected_files() if n.endswith(".py")
                     and not n.endswith("__main__.py"))
    code = ("import importlib, json\nfailed = {}\n"
            f"for m in {modules!r}:\n"
            "    try:\n        importlib.import_module(m)\n"
            "    except ModuleNotFoundError as err:\n        failed[m] = err.name\n"
            "print(json.dumps(failed))")
    out = subprocess.run([str(venv / "bin" / "python"), "-c", code], capture_output=True,
                         text=True, cwd=tmp_path, env=_clean_env(), timeout=600, check=True)
    failed = json.loads(out.stdout)
    assert {name.split(".")[0] for name in failed.values()} <= OPTIONAL, failed
    from tt_drake.provenance import package_version

    version = _run(venv, "--version", cwd=tmp_path)
    assert version.returncode == 0 and version.stdout.strip() == f"tt-drake {package_version()}"
    # `tt-drake models` rewrites the installed package's model files: the same as the checkout's.
    models = _run(venv, "models", cwd=tmp_path)
    assert models.returncode == 0, models.stderr
    written = [Path(line.removeprefix("wrote ")) for line in models.stdout.splitlines()]
    assert {p.name for p in written} == {"table_world.sdf", "ball.sdf", "wam7_racket.urdf"}
    for path in written:
        assert venv in path.parents
        assert path.read_text() == (REPO / "models" / path.name).read_text()


@pytest.mark.slow
@pytest.mark.wheel
def test_the_installed_wheel_serves_like_the_checkout_from_another_folder(wheel_venv, tmp_path):
    """``tt-drake serve --player momp`` with no artefact named plays the shipped learned player;
    from the wheel, in a folder outside the checkout, its episodes are the checkout's."""
    from tt_drake.diagrams.cli import main

    venv = wheel_venv[0]
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    args = ["serve", "--player", "momp", "--serves", "2", "--seed", "3", "--quiet", "--json"]
    done = _run(venv, *args, "out.json", cwd=elsewhere)
    assert done.returncode == 0, done.stderr
    assert "shipped artefacts" in done.stderr
    installed = json.loads((elsewhere / "out.json").read_text())
    assert main([*args, str(tmp_path / "here.json")]) == 0
    here = json.loads((tmp_path / "here.json").read_text())

    assert installed["summary"]["serves"] == 2 and len(installed["episodes"]) == 2
    assert installed["summary"] == here["summary"]
    strip = [{k: v for k, v in e.items() if k != "wall_time"} for e in here["episodes"]]
    assert [{k: v for k, v in e.items() if k != "wall_time"}
            for e in installed["episodes"]] == strip
    assert all("stroke" in e for e in installed["episodes"])  # the learned player planned
    assert installed["scenario"] == here["scenario"]
    assert installed["scenario"]["learned"]["library"] == "tt_drake/models/learned/library.npz"
    assert installed["git_commit"] is None  # an installed wheel is no git checkout
    # The compiled flight kernel cached its machine code beside the installed module (where
    # the install cannot be written it falls back to the user's cache, then to memory:
    # tests/tt_drake/test_flight_kernel.py).
    cached = list(venv.glob("lib/python*/site-packages/tt_drake/__pycache__/flight_kernel*.nbi"))
    assert cached, "the installed flight kernel wrote no numba cache index"

    # The real serve states ship in the wheel too.
    real = _run(venv, "serve", "--distribution", "real", "--serves", "1", "--quiet",
                cwd=elsewhere)
    assert real.returncode == 0, real.stderr
    assert "1 real serves" in real.stdout


def _strings(value):
    if isinstance(value, dict):
        for v in value.values():
            yield from _strings(v)
    elif isinstance(value, list):
        for v in value:
            yield from _strings(v)
    elif isinstance(value, str):
        yield value


def _machine_paths(value) -> list[str]:
    """Strings that name a folder of some machine: absolute paths, home folders."""
    return [s for s in _strings(value) if re.search(r"(^|[\s'\"(])(/|~/|[A-Za-z]:\\)\w", s)]


def test_the_shipped_provenance_names_no_machine_path():
    from tt_drake.artefacts import load_artefact

    learned = REPO / "models" / "learned"
    provenance = json.loads((learned / "provenance.json").read_text())
    assert _machine_paths(provenance) == []
    assert provenance["sources"]["library.npz"] == "responsibility/library_learned.npz"
    for name, kind in (("library", "momp-player-library"), ("crkr", "crkr-hitting-configuration"),
                       ("predictor", "hitting-point-gpr")):
        _, meta = load_artefact(learned / f"{name}.npz", kind)
        assert _machine_paths(meta) == [], name
    assert _machine_paths({"a": ["/work/runs/R"]}) == ["/work/runs/R"]  # the check can fail


def test_reproduce_records_files_relative_to_its_run_folder(tmp_path):
    """Stage results and the exported provenance name files relative to the run folder (no
    machine path), and the run still finds them, also when started from another folder."""
    from tt_drake.outputs import portable_path

    run = rp.Run(tmp_path / "run", rp.quick_config(), quick=True, workers=1, progress=False)
    files = {"library": "library/library.npz", "crkr": "crkr/crkr_1.npz",
             "predictor": "predictor/predictor.npz"}
    for stage, rel in files.items():
        path = run.root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(stage.encode())
        assert run.rel(path) == rel and run.path(rel) == path
    (run.root / "crkr" / "result.json").write_text(json.dumps({"best": files["crkr"]}))
    (run.root / "predictor" / "result.json").write_text(json.dumps({"model":
                                                                    files["predictor"]}))
    exported = rp._export_artefacts(run, files["library"])
    assert exported == {n: f"artefacts/{n}" for n in ("library.npz", "crkr.npz",
                                                      "predictor.npz")}
    provenance = json.loads((run.root / "artefacts" / "provenance.json").read_text())
    assert provenance["sources"] == {"library.npz": files["library"], "crkr.npz": files["crkr"],
                                     "predictor.npz": files["predictor"]}
    assert _machine_paths(provenance) == []
    assert set(provenance) >= {"tt_drake_version", "git_commit", "config", "command"}
    assert (run.root / "artefacts" / "crkr.npz").read_bytes() == b"crkr"
    # Outside the working folder a path is its name; inside, relative to it; relative as given.
    assert portable_path("/elsewhere/teacher/data", root=tmp_path) == "data"
    assert portable_path(tmp_path / "a" / "b.npz", root=tmp_path) == "a/b.npz"
    assert portable_path("out/run/teacher/data") == "out/run/teacher/data"
