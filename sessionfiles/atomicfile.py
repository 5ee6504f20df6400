"""Files written whole or not at all, and folders of outputs marked complete last (one concept).

Standard library only, so that every writer can use it: the session's files
(:mod:`sessionfiles.logbook`, whose :func:`~sessionfiles.logbook.atomic_write_text` is
:func:`atomic_file`), and the outputs of ``analyze``, ``export-bids``, ``calibrate``, ``power``
and ``reproduce`` (:mod:`analysis` may import this module: it is not the experiment's runtime).

* :func:`atomic_file` / :func:`atomic_path`: the content goes to a temporary file in the target's
  folder (``.<name>.<pid>.tmp``), is flushed and fsynced, then renamed over the target and the
  folder fsynced. A reader sees the old file or the new one, never a part of one. A failure
  (disk full, file too large, read-only) removes the temporary file and raises an ``OSError``
  whose ``filename`` is the target, so the command line names it in one line.
* :func:`output_file` / :func:`output_path`: the same for a command's outputs, without an fsync
  per file (an output is recomputed, not a record; on the machine that runs the suite an fsync
  costs ~70 ms): :meth:`OutputFolder.finish` flushes them once (``sync``) before ``COMPLETE``.
* :class:`OutputFolder`: a folder of outputs holds ``COMPLETE`` (a JSON manifest: the command,
  the files and their sizes) only once every file of the run is in place. :meth:`~OutputFolder.begin`
  removes an old ``COMPLETE`` (and temporary files a killed run left) before the first file is
  written; :meth:`~OutputFolder.finish` writes it last. A folder without ``COMPLETE`` is a run
  that did not finish: its files are whole, but they may mix this run's and an earlier one's.
"""
from __future__ import annotations

import datetime as _dt
import json
import os
from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Iterable, Iterator

__all__ = ["atomic_file", "atomic_path", "output_file", "output_path", "sync_folder",
           "OutputFolder", "COMPLETE_NAME", "named_os_error"]

#: The file that marks a folder of outputs complete (written last).
COMPLETE_NAME = "COMPLETE"


def sync_folder(path) -> None:
    """fsync a folder's entries (new, renamed or removed files)."""
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def named_os_error(exc: OSError, path) -> OSError:
    """``exc`` itself when it names a file, else the same error naming ``path``.

    A failed ``write`` (disk full, file too large) raises an ``OSError`` without a file name;
    the command line prints ``<path>: <reason>`` only for errors that have one.
    """
    if exc.filename is not None:
        return exc
    new = OSError(exc.errno, exc.strerror or str(exc), str(path))
    new.__cause__ = exc
    return new


def _temp_name(path: Path, keep_suffix: bool) -> Path:
    if keep_suffix:          # writers that choose the format by the suffix (matplotlib, pandas)
        return path.with_name(f".{path.stem}.{os.getpid()}.tmp{path.suffix}")
    return path.with_name(f".{path.name}.{os.getpid()}.tmp")


def _discard(tmp: Path) -> None:
    try:
        tmp.unlink()
    except FileNotFoundError:
        pass


@contextmanager
def _replacing(path, keep_suffix: bool, fsync_dir: Callable | None) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it over ``path`` on a clean exit.

    On any failure the temporary file is removed and an OSError is re-raised naming ``path``.
    """
    path = Path(path)
    tmp = _temp_name(path, keep_suffix=keep_suffix)
    try:
        yield tmp
        os.replace(tmp, path)
    except OSError as exc:
        _discard(tmp)
        err = named_os_error(exc, path)
        if err is exc:
            raise
        raise err from exc
    except BaseException:
        _discard(tmp)
        raise
    if fsync_dir is not None:
        fsync_dir(path.parent)


@contextmanager
def atomic_path(path, *, fsync: Callable[[int], None] | None = os.fsync,
                fsync_dir: Callable | None = sync_folder) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on a clean exit rename it over ``path``.

    For writers that take a path (``Figure.savefig``, ``DataFrame.to_csv``): the temporary
    name keeps ``path``'s suffix. ``fsync``/``fsync_dir`` (None: skipped) make the file and
    the rename durable.

    Raises
    ------
    OSError
        What the writer or the rename raised, naming ``path`` (:func:`named_os_error`); the
        temporary file is removed and ``path`` is untouched.
    """
    with _replacing(path, True, fsync_dir) as tmp:
        yield tmp
        if fsync is not None:
            fd = os.open(tmp, os.O_RDONLY)
            try:
                fsync(fd)
            finally:
                os.close(fd)


@contextmanager
def atomic_file(path, mode: str = "w", *, encoding: str | None = "utf-8", newline: str | None = "",
                fsync: Callable[[int], None] | None = os.fsync,
                fsync_dir: Callable | None = sync_folder):
    """Yield a file object on ``.<name>.<pid>.tmp``; on a clean exit it replaces ``path``.

    ``mode`` is ``"w"`` (text, ``encoding`` and ``newline`` as :func:`open`'s) or ``"wb"``.
    The file is flushed and fsynced (``fsync``), renamed over ``path`` and the folder fsynced
    (``fsync_dir``); either callable None skips it.

    Raises
    ------
    OSError
        Naming ``path`` (:func:`named_os_error`); the temporary file is removed and ``path``
        keeps its old content.
    """
    binary = "b" in mode
    with _replacing(path, False, fsync_dir) as tmp:
        with open(tmp, mode, **({} if binary else {"encoding": encoding, "newline": newline})) as fh:
            yield fh
            fh.flush()
            if fsync is not None:
                fsync(fh.fileno())


def _sync_filesystem(folder: Path) -> None:
    """Flush the file system holding ``folder`` (Linux ``syncfs``; ``sync`` elsewhere): one call
    for every output of a run instead of an fsync per file."""
    try:
        import ctypes
        libc = ctypes.CDLL(None, use_errno=True)
        fd = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
        try:
            if libc.syncfs(fd) == 0:
                return
        finally:
            os.close(fd)
    except (OSError, AttributeError):
        pass
    os.sync()


def output_path(path):
    """:func:`atomic_path` for a command's outputs: whole or not at all, without an fsync per
    file (:meth:`OutputFolder.finish` flushes them all once before ``COMPLETE``)."""
    return atomic_path(path, fsync=None, fsync_dir=None)


def output_file(path, mode: str = "w"):
    """:func:`atomic_file` for a command's outputs (see :func:`output_path`)."""
    return atomic_file(path, mode, fsync=None, fsync_dir=None)


class OutputFolder:
    """A folder of a command's outputs, marked complete only when every file is in place.

    Parameters
    ----------
    path : path-like
        The folder (created by :meth:`begin`).
    command : str
        What wrote it (recorded in ``COMPLETE``).

    Examples
    --------
    >>> import tempfile
    >>> out = OutputFolder(Path(tempfile.mkdtemp()) / "results", "analyze")
    >>> with output_file(out.begin() / "report.md") as fh:
    ...     _ = fh.write("# report")
    >>> out.finish().name, (out.path / "report.md").read_text()
    ('COMPLETE', '# report')
    """

    def __init__(self, path, command: str):
        self.path = Path(path)
        self.command = command

    @property
    def marker(self) -> Path:
        return self.path / COMPLETE_NAME

    def begin(self) -> Path:
        """Create the folder; remove an old ``COMPLETE`` and temporary files left by a killed run."""
        self.path.mkdir(parents=True, exist_ok=True)
        try:
            self.marker.unlink()
            sync_folder(self.path)
        except FileNotFoundError:
            pass
        import time
        for stale in self.path.rglob(".*.tmp*"):
            try:       # another process's file being written now is younger than a minute
                if stale.is_file() and stale.stat().st_mtime < time.time() - 60:
                    stale.unlink()
            except OSError:
                pass
        return self.path

    def finish(self, files: Iterable | None = None) -> Path:
        """Write ``COMPLETE`` (atomically, last): the command, the time, each file and its size.

        ``files`` (paths) defaults to every regular file under the folder but ``COMPLETE``.
        """
        if files is None:
            files = [p for p in self.path.rglob("*") if p.is_file() and p.name != COMPLETE_NAME
                     and not p.name.startswith(".")]
        listed = {}
        for p in sorted({Path(f) for f in files}):
            try:
                rel = p.relative_to(self.path).as_posix()
            except ValueError:
                rel = str(p)
            listed[rel] = p.stat().st_size
        _sync_filesystem(self.path)   # the outputs (no fsync each) on disk before COMPLETE
        manifest = {"command": self.command,
                    "finished_at": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
                    "files": listed}
        with atomic_file(self.marker) as fh:
            fh.write(json.dumps(manifest, indent=2, ensure_ascii=False) + "\n")
        return self.marker
