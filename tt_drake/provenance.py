"""Where a result came from: the installed package's version and, in a git checkout, the commit.

Every result file records these (:func:`run_provenance`) so that a figure can be traced to the
code that made it. Nothing here fails: an unknown version is ``"unknown"``, an unknown commit is
``None`` (an installed wheel, no git, or a package that is not the checkout's).
"""

from __future__ import annotations

import subprocess
from functools import lru_cache
from importlib import metadata
from pathlib import Path

DISTRIBUTION = "tt-drake"


def package_version() -> str:
    """The installed distribution's version (``importlib.metadata``), or ``"unknown"``."""
    try:
        return metadata.version(DISTRIBUTION)
    except metadata.PackageNotFoundError:
        return "unknown"


def _git(folder: Path, *args: str) -> str | None:
    try:
        done = subprocess.run(["git", "-C", str(folder), *args], capture_output=True, text=True,
                              timeout=10, check=False)
    except (OSError, subprocess.SubprocessError):
        return None
    return done.stdout.strip() if done.returncode == 0 else None


@lru_cache(maxsize=1)
def git_commit() -> str | None:
    """The commit of the git checkout this package is imported from (``<sha>-dirty`` when
    tracked files differ from it), or None: not a checkout, no git, or a copy of the package
    installed inside some other repository (its ``tt_drake`` folder is not the checkout's)."""
    package = Path(__file__).resolve().parent
    top = _git(package, "rev-parse", "--show-toplevel")
    if not top or Path(top).resolve() / "tt_drake" != package:
        return None
    sha = _git(package, "rev-parse", "HEAD")
    if not sha:
        return None
    status = _git(package, "status", "--porcelain", "--untracked-files=no")
    return f"{sha}-dirty" if status else sha


def run_provenance() -> dict:
    """``{"tt_drake_version": ..., "git_commit": ...}`` for a result file."""
    return {"tt_drake_version": package_version(), "git_commit": git_commit()}
