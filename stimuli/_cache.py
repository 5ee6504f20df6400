"""On-disk cache of computed target profiles, keyed by content hash (the only I/O in stimuli).

Location: the ``directory`` argument, else ``$THERMOCUE_CACHE``, else ``~/.cache/thermocue``.
Entries are JSON files ``<kind>-<sha256>.json`` written atomically (temporary file in the same
folder, fsync, rename, fsync of the folder), so a reader never sees a half-written entry; an
unreadable or mismatching entry is a miss (and is recomputed and replaced).
"""
from __future__ import annotations

import hashlib
import json
import os
import tempfile
from pathlib import Path

__all__ = ["cache_dir", "load", "store", "content_hash"]

ENV = "THERMOCUE_CACHE"


def cache_dir(directory=None) -> Path:
    """The cache folder: ``directory``, else ``$THERMOCUE_CACHE``, else ``~/.cache/thermocue``."""
    if directory is not None:
        return Path(directory).expanduser()
    env = os.environ.get(ENV)
    if env:
        return Path(env).expanduser()
    return Path.home() / ".cache" / "thermocue"


def content_hash(payload: dict) -> str:
    """sha256 hex of the canonical JSON of ``payload`` (sorted keys, no spaces, float repr)."""
    text = json.dumps(payload, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _path(kind: str, key: str, directory) -> Path:
    return cache_dir(directory) / f"{kind}-{key}.json"


def load(kind: str, key: str, directory=None) -> dict | None:
    """The cached entry for ``key`` or ``None`` (missing, unreadable or for another key)."""
    path = _path(kind, key, directory)
    try:
        with open(path, encoding="utf-8") as fh:
            data = json.load(fh)
    except (OSError, ValueError):
        return None
    if not isinstance(data, dict) or data.get("content_hash") != key:
        return None
    return data


def _fsync_dir(path: Path) -> None:
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:  # pragma: no cover - platforms without directory fds
        return
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def store(kind: str, key: str, data: dict, directory=None) -> Path | None:
    """Write ``data`` atomically as the entry for ``key``; return its path (None if unwritable)."""
    folder = cache_dir(directory)
    try:
        new = not folder.exists()
        folder.mkdir(parents=True, exist_ok=True)
        if new:
            _fsync_dir(folder.parent)
        fd, tmp = tempfile.mkstemp(prefix=f".{kind}-", suffix=".tmp", dir=folder)
        try:
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                json.dump(data, fh, sort_keys=True, separators=(",", ":"), allow_nan=False)
                fh.flush()
                os.fsync(fh.fileno())
            path = _path(kind, key, directory)
            os.replace(tmp, path)
        except BaseException:
            try:
                os.unlink(tmp)
            except OSError:
                pass
            raise
        _fsync_dir(folder)
        return path
    except OSError:
        return None  # a read-only or full disk only costs a recomputation next time
