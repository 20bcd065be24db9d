"""Writing result files safely: check a destination before a long run, write atomically after.

Nothing half-written is ever left behind: text goes to a temporary file in the destination's
folder and is renamed over the destination only when complete.
"""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
from pathlib import Path


class OutputError(OSError):
    """An output path cannot be written."""


def check_writable(path: str | os.PathLike) -> Path:
    """Fail early (before any simulation) if ``path`` cannot be created or replaced."""
    path = Path(path)
    if path.is_dir():
        raise OutputError(f"output path is a directory: {path}")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise OutputError(f"output folder does not exist: {parent}")
    if not os.access(parent, os.W_OK | os.X_OK) or (path.exists() and not os.access(path, os.W_OK)):
        raise OutputError(f"output path is not writable: {path}")
    return path


@contextlib.contextmanager
def atomic_file(path: str | os.PathLike, binary: bool = False, check: bool = True):
    """A file object whose content replaces ``path`` only when the block completes: written to
    a temporary file in the same folder, flushed to disk, given the usual mode (0666 less the
    umask; ``mkstemp`` makes it 0600) and renamed over ``path``. On any error nothing is left."""
    path = check_writable(path) if check else Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent or ".")
    try:
        with os.fdopen(fd, "wb" if binary else "w") as f:
            yield f
            f.flush()
            os.fsync(f.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def write_text_atomic(path: str | os.PathLike, text: str) -> None:
    with atomic_file(path) as f:
        f.write(text)


def write_json_atomic(path: str | os.PathLike, data: object) -> None:
    write_text_atomic(path, json.dumps(data, indent=2) + "\n")


def claim_folder(folder: str | os.PathLike, manifest_name: str, manifest: dict,
                 error: type[Exception], what: str = "run") -> Path:
    """Make ``folder`` the home of the run ``manifest`` describes, or check it already is.

    A new or empty folder is created with ``folder/manifest_name``; a folder whose manifest
    equals ``manifest`` is resumed; anything else (another run's manifest, an unreadable one, or
    files but no manifest) raises ``error`` naming the difference, and nothing is touched."""
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise error(f"not a folder: {folder}")
    path = folder / manifest_name
    if path.exists():
        try:
            existing = json.loads(path.read_text())
        except (OSError, json.JSONDecodeError) as err:
            raise error(f"unreadable {path}: {err}") from None
        if existing != manifest:
            keys = set(existing) | set(manifest) if isinstance(existing, dict) else set(manifest)
            diff = sorted(k for k in keys if not isinstance(existing, dict)
                          or existing.get(k) != manifest.get(k))
            raise error(f"{folder} holds another {what} (differs in {', '.join(diff)}); use "
                        "another --out")
        return folder
    if folder.exists() and any(folder.iterdir()):
        raise error(f"{folder} is not empty and has no {manifest_name}; use another --out")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise error(f"cannot create {folder}: {err}") from None
    write_json_atomic(path, manifest)
    return folder


def portable_path(path: str | os.PathLike, root: str | os.PathLike | None = None) -> str:
    """``path`` as a result or provenance file may record it, without this machine's folders:
    relative to ``root`` (default: the working folder) when it lies inside it, a relative path
    as given, otherwise the file's name alone."""
    path = Path(path)
    if not path.is_absolute():
        return path.as_posix()
    base = Path(root if root is not None else Path.cwd()).resolve()
    resolved = path.resolve()
    if resolved.is_relative_to(base):
        return resolved.relative_to(base).as_posix()
    return path.name
