"""Saving and loading learned artefacts as ``.npz`` + JSON metadata, without pickle.

One file holds named numpy arrays plus a JSON document (stored as a ``uint8`` array under the
reserved name ``__meta__``)::

    {"format": "tt-drake-artefact", "format_version": 1, "kind": "<what it is>",
     "arrays": {name: {"dtype": ..., "shape": [...], "sha256": ...}}, "meta": {...caller's...}}

Loading uses ``np.load(..., allow_pickle=False)`` and checks everything it can: the file is a zip,
every member's ``.npy`` header declares no more bytes than the member holds (and the artefact no
more than :data:`MAX_ARTEFACT_BYTES`) before any array is read, the metadata parses, format /
kind / version match, every listed array is present with its dtype, shape and checksum, and every
floating-point array is finite (except those the caller names in ``allow_nonfinite``). Any
failure raises :class:`ArtefactError` (a ``ValueError``) naming the file and the problem. Files
are written atomically (temporary file in the same folder, then ``os.replace``), so a crash never
leaves a half-written artefact under the final name.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import zipfile
import zlib
from collections.abc import Collection
from pathlib import Path
from typing import Any

import numpy as np
from numpy.lib import format as npy

from tt_drake.outputs import atomic_file

__all__ = ["ArtefactError", "FORMAT", "FORMAT_VERSION", "save_artefact", "load_artefact",
           "check_npz_sizes"]

FORMAT = "tt-drake-artefact"
FORMAT_VERSION = 1
_META_KEY = "__meta__"
#: The most bytes the arrays of one artefact may declare (the largest shipped one holds ~2 MB).
MAX_ARTEFACT_BYTES = 1 << 30


class ArtefactError(ValueError):
    """A missing, corrupt, truncated or mismatched artefact file."""


def _digest(a: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(a).tobytes()).hexdigest()


def save_artefact(
    path: str | os.PathLike,
    kind: str,
    arrays: dict[str, Any],
    meta: dict[str, Any] | None = None,
) -> Path:
    """Write ``arrays`` and JSON-serialisable ``meta`` to ``path`` (``.npz``) atomically.

    Array names must be identifiers not starting with ``__``; object arrays are refused (they
    would need pickle). Returns the path written.
    """
    path = Path(path)
    if not kind or not isinstance(kind, str):
        raise ValueError("kind must be a non-empty string")
    clean: dict[str, np.ndarray] = {}
    info: dict[str, dict[str, Any]] = {}
    for name, value in arrays.items():
        if not name.isidentifier() or name.startswith("__"):
            raise ValueError(f"invalid array name {name!r}")
        a = np.asarray(value)
        if a.dtype.hasobject:
            raise ValueError(f"array {name!r} has dtype object (would need pickle)")
        clean[name] = a
        info[name] = {"dtype": a.dtype.str, "shape": list(a.shape), "sha256": _digest(a)}
    doc = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "kind": kind,
        "arrays": info,
        "meta": meta or {},
    }
    try:
        text = json.dumps(doc, allow_nan=True, sort_keys=True)
    except TypeError as exc:
        raise ValueError(f"metadata is not JSON-serialisable: {exc}") from exc
    clean[_META_KEY] = np.frombuffer(text.encode("utf-8"), dtype=np.uint8)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_file(path, binary=True, check=False) as fh:
        np.savez_compressed(fh, **clean)
    return path


def check_npz_sizes(path: str | os.PathLike) -> None:
    """Raise :class:`ArtefactError` if an ``.npz`` file's members declare more bytes than they
    hold (or than :data:`MAX_ARTEFACT_BYTES` in all), reading only their headers."""
    path = Path(path)
    try:
        _check_declared_sizes(path, lambda msg: ArtefactError(f"{path}: {msg}"))
    except ArtefactError:
        raise
    except (zipfile.BadZipFile, zlib.error, EOFError, OSError, ValueError,
            NotImplementedError) as exc:
        raise ArtefactError(f"{path}: corrupt or truncated file ({type(exc).__name__}: "
                            f"{exc})") from None


def _check_declared_sizes(path: Path, fail) -> None:
    """Read each member's ``.npy`` header (not its data): refuse a member whose declared shape
    and dtype need more bytes than it holds, object arrays, and artefacts declaring more than
    :data:`MAX_ARTEFACT_BYTES` in all; so a small file claiming a huge array is never read."""
    total = 0
    with zipfile.ZipFile(path) as zf:
        for info in zf.infolist():
            with zf.open(info) as f:
                version = npy.read_magic(f)
                if version == (1, 0):
                    shape, _, dtype = npy.read_array_header_1_0(f)
                elif version == (2, 0):
                    shape, _, dtype = npy.read_array_header_2_0(f)
                else:
                    raise fail(f"member {info.filename!r} has .npy format {version}")
                header = f.tell()
            if dtype.hasobject:
                raise fail(f"member {info.filename!r} holds objects (would need pickle)")
            declared = math.prod(shape) * dtype.itemsize
            if declared != info.file_size - header:
                raise fail(f"member {info.filename!r} declares {list(shape)} {dtype.str} "
                           f"({declared} bytes) but holds {info.file_size - header} bytes")
            total += declared
            if total > MAX_ARTEFACT_BYTES:
                raise fail(f"declares more than {MAX_ARTEFACT_BYTES} bytes of arrays")


def load_artefact(
    path: str | os.PathLike, kind: str, *, max_version: int = FORMAT_VERSION,
    allow_nonfinite: Collection[str] = (),
) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Load an artefact written by :func:`save_artefact`; returns ``(arrays, meta)``.

    Raises :class:`ArtefactError` if the file is missing, not an artefact, corrupt or truncated,
    declares arrays larger than it holds, of another ``kind``, of a newer format version than
    ``max_version``, or has a NaN or infinite value in a floating-point array not named in
    ``allow_nonfinite`` (arrays that use NaN for "not available").
    """
    path = Path(path)

    def fail(msg: str) -> ArtefactError:
        return ArtefactError(f"{path}: {msg}")

    if not path.is_file():
        raise fail("no such artefact file")
    try:
        if zipfile.is_zipfile(path):
            _check_declared_sizes(path, fail)
        loaded = np.load(path, allow_pickle=False)
        if not isinstance(loaded, np.lib.npyio.NpzFile):
            raise fail(f"not a {FORMAT} file (a bare .npy array)")
        with loaded as npz:
            names = set(npz.files)
            if _META_KEY not in names:
                raise fail(f"not a {FORMAT} file (no {_META_KEY} entry)")
            doc = json.loads(bytes(npz[_META_KEY]).decode("utf-8"))
            if not isinstance(doc, dict) or doc.get("format") != FORMAT:
                raise fail(f"not a {FORMAT} file")
            version = doc.get("format_version")
            if not isinstance(version, int) or version < 1 or version > max_version:
                raise fail(
                    f"format version {version!r} is not supported (reads 1..{max_version})"
                )
            if doc.get("kind") != kind:
                raise fail(f"holds a {doc.get('kind')!r} artefact, expected {kind!r}")
            info = doc.get("arrays")
            if not isinstance(info, dict):
                raise fail("metadata lacks the array table")
            missing = sorted(set(info) - names)
            if missing:
                raise fail(f"missing arrays {missing} (truncated or edited file)")
            arrays: dict[str, np.ndarray] = {}
            for name, spec in info.items():
                a = npz[name]
                if a.dtype.str != spec.get("dtype") or list(a.shape) != spec.get("shape"):
                    raise fail(
                        f"array {name!r} is {a.dtype.str}{list(a.shape)}, metadata says "
                        f"{spec.get('dtype')}{spec.get('shape')}"
                    )
                if _digest(a) != spec.get("sha256"):
                    raise fail(f"array {name!r} fails its checksum (corrupt file)")
                if (a.dtype.kind in "fc" and name not in allow_nonfinite
                        and not np.all(np.isfinite(a))):
                    raise fail(f"array {name!r} holds NaN or infinite values")
                arrays[name] = a
    except ArtefactError:
        raise
    except (zipfile.BadZipFile, zlib.error, EOFError, OSError, KeyError, ValueError,
            UnicodeDecodeError, NotImplementedError) as exc:
        # zipfile CRC errors, truncated members, bad JSON (a ValueError), pickled content
        raise fail(f"corrupt or truncated file ({type(exc).__name__}: {exc})") from exc
    meta = doc.get("meta", {})
    return arrays, meta if isinstance(meta, dict) else {}
