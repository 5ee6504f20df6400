"""Durable session files: the append-only event log, atomic rewrites, the trials table.

One concept: *writing* a session's files so that nothing is lost. What the files hold (event
types and their fields, the columns, the cell format) and how they are read back (the
tolerant reader, the event -> trial-row projection, replay) is :mod:`sessionfiles.logformat`;
its names are re-exported here for the writer's users.

What "nothing lost" means on disk (docs/design.md, Durability):

* **Appends** (``events.jsonl``): one JSON object per line, written with a single
  ``write`` on an ``O_APPEND`` descriptor and ``fsync``-ed before :meth:`EventLog.append`
  returns; a new file is followed by an fsync of its folder.  A crash can therefore only
  leave a *torn last line*; :func:`~sessionfiles.logformat.read_events` tolerates it (and
  warns), and :class:`EventLog` cuts it off when it reopens the file, logging what it cut in
  a ``log_repaired`` event, so the next append starts on a fresh line.
* **Whole-file updates** (``session.json``, ``trials.csv``): :func:`atomic_write_text`
  writes a temporary file in the same folder, fsyncs it, renames it over the old one and
  fsyncs the folder: a reader sees the old file or the new one, never half of one.
  Only with durability off (``durable=False``, a setting every writer takes: a simulated
  study, recomputed from its seed) does the session grow ``trials.csv`` between two trials by appending its new lines in one
  ``write`` (:func:`append_text`) instead; a session with a person in it is always replaced
  atomically.
* The event log is the source of truth: :func:`~sessionfiles.logformat.trials_from_events`
  and :func:`write_trials_csv` rebuild ``trials.csv`` from it at any time.
"""
from __future__ import annotations

import csv
import datetime as _dt
import errno
import fcntl
import io
import os
import re
import threading
from pathlib import Path
from typing import Any, Iterable, Mapping

from sessionfiles.atomicfile import atomic_file
from sessionfiles.errors import SessionError
from sessionfiles.logformat import (  # noqa: F401 - re-exported for the writer's users
    COLUMN_DECIMALS,
    CONTEXT_KEYS,
    REQUIRED_FIELDS,
    TRIAL_COLUMNS,
    LogDamageWarning,
    LogReport,
    SessionProgress,
    dumps,
    dumps_jsonable,
    event_problem,
    format_cell,
    read_events,
    replay,
    to_jsonable,
    trials_from_events,
)

__all__ = [
    "EventLog",
    "read_events",
    "LogReport",
    "LogDamageWarning",
    "atomic_write_text",
    "atomic_write_json",
    "fsync_dir",
    "fsync",
    "now_iso",
    "ensure_dir",
    "to_jsonable",
    "trials_from_events",
    "write_trials_csv",
    "trials_csv_text",
    "trials_csv_columns",
    "trials_csv_header",
    "trials_csv_lines",
    "append_text",
    "replay",
    "SessionProgress",
    "TRIAL_COLUMNS",
    "COLUMN_DECIMALS",
    "CONTEXT_KEYS",
    "REQUIRED_FIELDS",
    "log_shortfall",
]

# --------------------------------------------------------------------------- fsync helpers
# Durability is a setting each writer takes (``durable``, default True), not a process-wide flag:
# every write stays in the same order, atomic renames included; ``durable=False`` skips only the
# fsyncs that make them survive a power cut. A simulated study on a virtual clock, recomputed from
# its seed, passes False (on the shared 2-core machine fsync was 70 % of an emulated session's
# wall time); a session with a person in it never does.


def fsync(fd: int, durable: bool = True) -> None:
    """``os.fsync(fd)`` unless ``durable`` is False."""
    if durable:
        os.fsync(fd)


def fsync_dir(path: str | Path, durable: bool = True) -> None:
    """Flush a folder's entries (new, renamed or removed files) to disk.

    Parameters
    ----------
    path : str or Path
        The folder.
    durable : bool
        False: do nothing (a simulated study's writes, see above).
    """
    if not durable:
        return
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def ensure_dir(path: str | Path, *, durable: bool = True) -> Path:
    """Create a folder and any missing parents, fsyncing the parent of each one created
    (unless ``durable`` is False).

    Returns
    -------
    Path
        ``path``.
    """
    path = Path(path)
    missing = []
    p = path
    while not p.exists():
        missing.append(p)
        if p.parent == p:
            break
        p = p.parent
    for d in reversed(missing):
        try:
            d.mkdir()
        except FileExistsError:
            pass
        fsync_dir(d.parent, durable)
    if not path.is_dir():
        raise NotADirectoryError(errno.ENOTDIR, "expected a folder, got a file", str(path))
    return path


def atomic_write_text(path: str | Path, text: str, encoding: str = "utf-8", *,
                      durable: bool = True) -> None:
    """Replace a file's content atomically and durably.

    Writes ``.<name>.<pid>.tmp`` in the same folder, fsyncs it, renames it over ``path``
    and fsyncs the folder.  Readers see the old or the new content, never a mixture.

    Parameters
    ----------
    path : str or Path
    text : str
    encoding : str
    durable : bool
        False: the same writes and rename without the fsyncs (a simulated study's files).
    """
    # one helper for every whole-file write (sessionfiles.atomicfile), with this module's fsync
    # and fsync_dir (looked up at each call), skipped when ``durable`` is False
    with atomic_file(path, encoding=encoding, fsync=lambda fd: fsync(fd, durable),
                     fsync_dir=lambda folder: fsync_dir(folder, durable)) as fh:
        fh.write(text)


def atomic_write_json(path: str | Path, obj: Any, indent: int = 2, *, durable: bool = True) -> None:
    """Write ``obj`` as JSON (see :func:`to_jsonable`) with :func:`atomic_write_text`."""
    atomic_write_text(path, dumps(obj, indent=indent) + "\n", durable=durable)


def now_iso() -> str:
    """The current UTC time, ISO 8601 with milliseconds and a ``Z`` (as in every event's ``time``)."""
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="milliseconds").replace("+00:00", "Z")


# --------------------------------------------------------------------------- writing
class EventLog:
    """An append-only, fsynced event log (``events.jsonl``).

    Parameters
    ----------
    path : str or Path
        The log file; its folder must exist (see :func:`ensure_dir`).  A new file is
        created and its folder fsynced; an existing one is continued (``seq`` goes on).
    lock : bool
        Take an exclusive ``flock`` so that a second process cannot write the same log.
    durable : bool
        False: appends are written the same way but not fsynced (a simulated study's log).

    Raises
    ------
    SessionError
        If another process holds the log, or the log is damaged before its last line
        (appending would bury the damage; repair it by hand).

    Notes
    -----
    On reopening, a torn last line (the trace of a crash during an append) is cut off and
    a ``log_repaired`` event records the cut bytes, so they are not lost either.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> with EventLog(d / "events.jsonl") as log:
    ...     ev = log.append("note", text="hello")
    >>> ev["event"], ev["seq"], read_events(d / "events.jsonl")[0][0]["text"]
    ('note', 1, 'hello')
    """

    def __init__(self, path: str | Path, lock: bool = True, *, durable: bool = True):
        self.path = Path(path)
        self.durable = bool(durable)
        self._lock = threading.Lock()   # appends from several threads stay whole and ordered
        existed = self.path.exists()
        self._fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_APPEND | os.O_CLOEXEC, 0o644)
        try:
            if lock:
                try:
                    fcntl.flock(self._fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                except BlockingIOError:
                    raise SessionError(f"{self.path}: expected no other process writing this log, "
                                       f"got it locked (is the session running elsewhere?)") from None
            self._seq = 0
            self.repaired: str | None = None    # what reopening repaired (to be printed)
            torn = None
            if existed:
                torn = self._open_existing()
            else:
                fsync(self._fd, self.durable)
                fsync_dir(self.path.parent, self.durable)
            if torn is not None:
                self.append("log_repaired", torn_bytes=len(torn),
                            torn_tail=torn.decode("utf-8", errors="replace"))
                self.repaired = (f"{self.path}: cut a torn last line ({len(torn)} bytes, the "
                                 f"trace of a crash during an append); its bytes are kept in "
                                 f"the log_repaired event (seq {self._seq})")
        except BaseException:
            os.close(self._fd)
            self._fd = -1
            raise

    def _open_existing(self) -> bytes | None:
        events, report = read_events(self.path, on_damage="stop", warn=False)
        if report.bad_lines:
            n, why = report.bad_lines[0]
            raise SessionError(f"{self.path}: line {n}: expected one JSON event per line, got an "
                               f"undecodable line ({why}); repair the log before appending")
        self._seq = max((e.get("seq", 0) for e in events if isinstance(e.get("seq"), int)),
                        default=0)
        self._seq = max(self._seq, len(events))
        size = os.fstat(self._fd).st_size
        if report.torn_tail is not None:
            cut = size - len(report.torn_tail)
            os.ftruncate(self._fd, cut)
            os.fsync(self._fd)
            return report.torn_tail
        if report.missing_newline:
            self._write(b"\n")
            self.repaired = f"{self.path}: added the newline missing after the last event"
        return None

    @property
    def seq(self) -> int:
        """The ``seq`` of the last event written (0 for an empty log)."""
        return self._seq

    @property
    def closed(self) -> bool:
        return self._fd < 0

    def _write(self, data: bytes) -> None:
        view = memoryview(data)
        while view:
            n = os.write(self._fd, view)
            view = view[n:]
        fsync(self._fd, self.durable)

    def append(self, event: str, **fields: Any) -> dict:
        """Write one event and fsync it.

        Parameters
        ----------
        event : str
            The event type (snake_case; see the module docstring).
        **fields
            Its content; ``time`` may be given, ``event`` and ``seq`` may not.

        Returns
        -------
        dict
            The event as written (JSON-ready, with ``event``, ``seq``, ``time``).

        Raises
        ------
        ValueError
            For a bad type name, a reserved or missing required field.
        TypeError
            For a value with no JSON form.
        """
        if self.closed:
            raise ValueError(f"{self.path}: the log is closed")
        problem = event_problem(event, fields)
        if problem is not None:
            raise ValueError(f"{self.path}: {problem}")
        with self._lock:
            if self.closed:
                raise ValueError(f"{self.path}: the log is closed")
            rec = {"event": event, "seq": self._seq + 1, "time": fields.pop("time", None) or now_iso()}
            rec.update(fields)
            rec = to_jsonable(rec)
            line = dumps_jsonable(rec) + "\n"
            self._write(line.encode("utf-8"))
            self._seq += 1
        return rec

    def close(self) -> None:
        """Close the file (and release the lock); further appends raise."""
        with self._lock:
            if self._fd >= 0:
                os.close(self._fd)
                self._fd = -1

    def __enter__(self) -> "EventLog":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __del__(self):  # pragma: no cover - safety net
        try:
            self.close()
        except Exception:
            pass


# --------------------------------------------------------------------------- trials table
def write_trials_csv(path: str | Path, rows: Iterable[Mapping[str, Any]],
                     columns: Iterable[str] | None = None, *, durable: bool = True) -> list[str]:
    """Write ``trials.csv`` atomically (fsynced unless ``durable`` is False).

    Parameters
    ----------
    path : str or Path
    rows : iterable of dict
        E.g. :func:`trials_from_events` output.
    columns : iterable of str, optional
        Default: :data:`TRIAL_COLUMNS`, then any other keys of the rows, sorted.

    Returns
    -------
    list of str
        The columns written.

    Notes
    -----
    PsychoPy-style wide CSV: one row per trial, participant and session on every row, every
    column of :data:`TRIAL_COLUMNS` from the first row on. Missing values and non-finite
    floats are empty cells; booleans are 1/0; floats are rounded as :data:`COLUMN_DECIMALS`
    says (else the shortest round-trip form).
    """
    text, columns = trials_csv_text(rows, columns)
    atomic_write_text(path, text, durable=durable)
    return columns


def trials_csv_text(rows: Iterable[Mapping[str, Any]],
                    columns: Iterable[str] | None = None) -> tuple[str, list[str]]:
    """The text :func:`write_trials_csv` writes, and its columns (same parameters)."""
    rows = list(rows)
    columns = trials_csv_columns(rows) if columns is None else list(columns)
    return trials_csv_header(columns) + "".join(trials_csv_lines(rows, columns)), columns


def trials_csv_columns(rows: Iterable[Mapping[str, Any]]) -> list[str]:
    """The columns :func:`trials_csv_text` writes by default: :data:`TRIAL_COLUMNS`, then any
    other keys of the rows, sorted."""
    extra = sorted({k for r in rows for k in r} - set(TRIAL_COLUMNS))
    return list(TRIAL_COLUMNS) + extra


def trials_csv_header(columns: Iterable[str]) -> str:
    """The header line (with its newline) :func:`trials_csv_text` writes for ``columns``: the
    column names as a row (a name is a string, which a cell writes as it is)."""
    columns = list(columns)
    return trials_csv_lines([dict(zip(columns, columns))], columns)[0]


def trials_csv_lines(rows: Iterable[Mapping[str, Any]], columns: Iterable[str]) -> list[str]:
    """The row lines (each with its newline) :func:`trials_csv_text` writes for ``rows`` and
    ``columns``, after :func:`trials_csv_header`."""
    columns = list(columns)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    out = []
    for r in rows:
        w.writerow([format_cell(r.get(c), c) for c in columns])
        out.append(buf.getvalue())
        buf.seek(0)
        buf.truncate()
    return out


def append_text(path: str | Path, text: str, expected_size: int, encoding: str = "utf-8", *,
                durable: bool = True) -> bool:
    """Append whole lines to a file in one ``write``, fsynced (unless ``durable`` is False);
    False (nothing written) unless the file exists and is exactly ``expected_size`` bytes long.

    For a file that only ever grows by whole lines (``trials.csv`` between two trials): one
    ``write`` of the new lines at the end, so a killed process leaves the old lines or all the
    new ones, never a part of one (the caller rewrites with :func:`atomic_write_text` whenever
    the new text does not merely extend the old).
    """
    data = text.encode(encoding)
    if not data.endswith(b"\n"):
        raise ValueError("append_text: whole lines only")
    try:
        fd = os.open(path, os.O_WRONLY | os.O_APPEND)
    except FileNotFoundError:
        return False
    try:
        if os.fstat(fd).st_size != expected_size:
            return False
        if os.write(fd, data) != len(data):       # a regular file: short only when full
            os.ftruncate(fd, expected_size)
            raise OSError(f"{path}: short write")
        fsync(fd, durable)
    finally:
        os.close(fd)
    return True


_TRACE_NAME = re.compile(r"^trial-(\d+)(?:\.attempt-(\d+)\.[a-z]+)?\.csv$")


def log_shortfall(events: Iterable[Mapping[str, Any]], trials_path: str | Path,
                  traces_dir: str | Path | None = None) -> list[str]:
    """What the session's other files record and its event log does not (damage, not a crash).

    A crash during an append can lose only the log's last line, and ``trials.csv`` and the
    traces are written *after* the events they follow from. So a row of ``trials.csv`` whose
    attempt the log does not end, or a trace of a trial the log never started, means the log
    was cut or replaced by an older copy: resuming would re-run completed trials and overwrite
    their traces.

    Parameters
    ----------
    events : iterable of dict
    trials_path : path-like
        ``trials.csv`` (missing: nothing to compare).
    traces_dir : path-like, optional
        ``traces/``.

    Returns
    -------
    list of str
        One item per missing record (empty: the log holds everything).
    """
    ended, started = set(), set()
    for ev in events:
        kind = ev.get("event")
        if kind in ("trial_completed", "trial_aborted"):
            ended.add((str(ev.get("trial_index")), str(ev.get("attempt"))))
        elif kind == "trial_started":
            started.add(str(ev.get("trial_index")))
    missing = []
    trials_path = Path(trials_path)
    if trials_path.exists():
        with open(trials_path, newline="", encoding="utf-8", errors="replace") as fh:
            try:
                for row in csv.DictReader(fh):
                    key = (row.get("trial_index") or "", row.get("attempt") or "")
                    if all(key) and key not in ended:
                        missing.append(f"trial {key[0]} attempt {key[1]} "
                                       f"({row.get('status') or 'no status'}) of {trials_path.name}")
            except csv.Error as exc:
                missing.append(f"{trials_path.name} unreadable ({exc})")
    if traces_dir is not None and Path(traces_dir).is_dir():
        for f in sorted(Path(traces_dir).iterdir()):
            m = _TRACE_NAME.match(f.name)
            if m and str(int(m.group(1))) not in started:
                missing.append(f"the start of trial {int(m.group(1))} (traces/{f.name} exists)")
    return missing

