"""Writing result files safely: check a destination before a long run, write atomically after.

Nothing half-written is ever left behind: text goes to a temporary file in the destination's
folder and is renamed over the destination only when complete.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import tempfile
from pathlib import Path

from tt_drake.errors import BadInputError


class OutputError(OSError, BadInputError):
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


def _os_error(path, err: OSError) -> OutputError:
    reason = err.strerror or str(err)
    return OutputError(f"cannot write {path}: {reason}")


@contextlib.contextmanager
def atomic_file(path: str | os.PathLike, binary: bool = False, check: bool = True):
    """A file object whose content replaces ``path`` only when the block completes: written to
    a temporary file in the same folder, flushed to disk, given the usual mode (0666 less the
    umask; ``mkstemp`` makes it 0600) and renamed over ``path``. On any error nothing is left,
    and an ``OSError`` (a full disk, a permission) becomes an :class:`OutputError` naming
    ``path`` (one line for the user, exit status 2)."""
    path = check_writable(path) if check else Path(path)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp",
                                   dir=path.parent or ".")
    except OSError as err:
        raise _os_error(path, err) from None
    try:
        with os.fdopen(fd, "wb" if binary else "w") as f:
            yield f
            f.flush()
            os.fsync(f.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except OutputError:
        _remove(tmp)
        raise
    except OSError as err:
        _remove(tmp)
        raise _os_error(path, err) from None
    except BaseException:
        _remove(tmp)
        raise


def _remove(tmp: str) -> None:
    with contextlib.suppress(OSError):
        os.unlink(tmp)


def write_text_atomic(path: str | os.PathLike, text: str) -> None:
    with atomic_file(path) as f:
        f.write(text)


def write_json_atomic(path: str | os.PathLike, data: object) -> None:
    write_text_atomic(path, json.dumps(data, indent=2) + "\n")


LOCK_NAME = ".lock"


_HELD: dict[str, list] = {}  # folder (real path) -> [lock file, number of holders in this process]


class FolderLock:
    """An exclusive OS lock (``flock``) on ``folder/.lock``, held until :meth:`release` or until
    this object is garbage-collected (or the process ends): a run into a folder that another
    process holds is refused at once instead of racing with it. Within one process the lock is
    shared (a resumed run may claim its folder again while the first object lives). The lock
    file is removed on the last release; one left by a killed process holds no lock."""

    def __init__(self, folder: str | os.PathLike, error: type[Exception], what: str = "run"):
        self.folder = Path(folder)
        self.path = self.folder / LOCK_NAME
        self._key = None
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            raise error(f"cannot create {self.folder}: {err.strerror or err}") from None
        key = os.path.realpath(self.folder)
        if key in _HELD:
            _HELD[key][1] += 1
            self._key = key
            return
        try:
            file = open(self.path, "a")  # noqa: SIM115 (held open: it carries the lock)
        except OSError as err:
            raise error(f"cannot create {self.path}: {err.strerror or err}") from None
        try:
            fcntl.flock(file.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
            # The holder before us may have removed the file after we opened it: then our lock
            # is on a file nobody else will look at, and the folder may be another run's now.
            if os.fstat(file.fileno()).st_ino != os.stat(self.path).st_ino:
                raise BlockingIOError
        except OSError:
            file.close()
            raise error(f"{self.folder} is in use by another {what} (another process holds "
                        f"{self.path}); wait for it to finish or use another folder") from None
        _HELD[key] = [file, 1]
        self._key = key

    def release(self) -> None:
        key, self._key = self._key, None
        if key is None or key not in _HELD:
            return
        held = _HELD[key]
        held[1] -= 1
        if held[1] == 0:
            del _HELD[key]
            with contextlib.suppress(OSError):
                self.path.unlink()  # while still locked: no one can take a stale file
            held[0].close()

    def __del__(self) -> None:
        try:
            self.release()
        except Exception:  # noqa: BLE001 (at interpreter exit the process drops the lock anyway)
            pass

    def __enter__(self) -> FolderLock:
        return self

    def __exit__(self, *exc) -> None:
        self.release()


def claim_folder(folder: str | os.PathLike, manifest_name: str, manifest: dict,
                 error: type[Exception], what: str = "run") -> FolderLock:
    """Make ``folder`` the home of the run ``manifest`` describes, or check it already is, and
    lock it for this run (:class:`FolderLock`: keep the returned lock while the run writes).

    A new or empty folder is created with ``folder/manifest_name``; a folder whose manifest
    equals ``manifest`` is resumed; a folder another run holds is refused; anything else
    (another run's manifest, an unreadable one, or files but no manifest) raises ``error``
    naming the difference, and nothing is touched."""
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise error(f"not a folder: {folder}")
    lock = FolderLock(folder, error, what)
    try:
        _check_manifest(folder, manifest_name, manifest, error, what)
    except BaseException:
        lock.release()
        raise
    return lock


def _check_manifest(folder: Path, manifest_name: str, manifest: dict,
                    error: type[Exception], what: str) -> None:
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
        return
    if any(p.name != LOCK_NAME for p in folder.iterdir()):
        raise error(f"{folder} is not empty and has no {manifest_name}; use another --out")
    write_json_atomic(path, manifest)


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
