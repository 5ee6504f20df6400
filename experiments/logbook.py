"""Durable session files: the append-only event log, atomic rewrites, the trials table.

What "nothing lost" means on disk (DESIGN.md, Durability):

* **Appends** (``events.jsonl``): one JSON object per line, written with a single
  ``write`` on an ``O_APPEND`` descriptor and ``fsync``-ed before :meth:`EventLog.append`
  returns; a new file is followed by an fsync of its folder.  A crash can therefore only
  leave a *torn last line*; :func:`read_events` tolerates it (and warns), and
  :class:`EventLog` cuts it off when it reopens the file, logging what it cut in a
  ``log_repaired`` event, so the next append starts on a fresh line.
* **Whole-file updates** (``session.json``, ``trials.csv``): :func:`atomic_write_text`
  writes a temporary file in the same folder, fsyncs it, renames it over the old one and
  fsyncs the folder: a reader sees the old file or the new one, never half of one.
* The event log is the source of truth: :func:`trials_from_events` and
  :func:`write_trials_csv` rebuild ``trials.csv`` from it at any time.

Events
------
Every event is a JSON object with ``event`` (its type), ``seq`` (1, 2, ... per file) and
``time`` (UTC, ISO 8601 with milliseconds; a caller may pass its own ``time``), plus:

``session_started``
    ``session``, ``participant``, ``protocol_hash``, ``seed`` (required); usually also
    ``group``, ``protocol``, ``n_trials``, ``skin_thickness_um``, ``sex``.
``session_resumed``
    As ``session_started`` (the context keys are taken from the latest of the two).
``trial_started``
    ``trial_index``, ``attempt`` (1, 2, ... per trial) and the rest of the
    :class:`~experiments.schedule.TrialSpec` (``block``, ``mode``, ``roughness_id``,
    ``roughness_um``, ``repetition``).
``trial_completed``
    ``trial_index``, ``attempt``, ``row``: the trial's row of ``trials.csv`` (see
    :data:`TRIAL_COLUMNS`; ``status`` "ok" or "fault").
``trial_aborted``
    ``trial_index``, ``attempt``, ``reason`` (e.g. "interrupted", "timeout",
    "killed"), optional ``fault_code``.  Becomes a row with status "aborted".
``session_interrupted``
    ``reason`` (e.g. "SIGTERM").
``session_finished``
    optional ``n_completed``.
``log_repaired``
    ``torn_bytes``, ``torn_tail`` (the cut bytes as text): written by :class:`EventLog`.

Any other snake_case type may be logged (state changes, display faults, notes); only the
types above have required fields.  Non-finite floats are written as ``null``; numpy
scalars and arrays, paths, dates and dataclasses are converted.
"""
from __future__ import annotations

import csv
import dataclasses
import datetime as _dt
import fcntl
import io
import json
import math
import os
import re
import threading
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Mapping

from experiments.errors import SessionError

__all__ = [
    "EventLog",
    "read_events",
    "LogReport",
    "LogDamageWarning",
    "atomic_write_text",
    "atomic_write_json",
    "fsync_dir",
    "fsync",
    "set_durable",
    "now_iso",
    "ensure_dir",
    "to_jsonable",
    "trials_from_events",
    "write_trials_csv",
    "replay",
    "SessionProgress",
    "TRIAL_COLUMNS",
    "COLUMN_DECIMALS",
    "CONTEXT_KEYS",
    "REQUIRED_FIELDS",
    "log_shortfall",
]

#: Columns of ``trials.csv``, in this order, all of them from the first row on (docs/session.md,
#: "The trial table"): identity, design, stimulus, response, timing, quality. A key a row has
#: beyond these (none written by this version) follows, sorted.
TRIAL_COLUMNS = (
    # identity (PsychoPy's names where PsychoPy has one: date, expName, psychopyVersion)
    "participant", "session", "group", "sex", "skin_thickness_um", "date", "expName",
    "protocol_version", "protocol_hash", "thermocue_version", "psychopyVersion",
    # design
    "block", "trial_index", "attempt", "repetition", "mode", "roughness_id", "roughness_um",
    # stimulus
    "target_side", "profile_skin_thickness_um", "profile_resistance_m2K_W",
    "profile_resistance_source", "pad_resistance_m2K_W", "rate_limited_max_change_C", "cue_played",
    # response
    "response_id", "correct", "rt_s", "response_source",
    # timing
    "started_at", "finished_at", "contact_onset_s", "contact_duration_s",
    # quality
    "status", "fault_code", "abort_reason", "skin_temperature_C", "skin_temperature_in_range",
    "tracking_rms_C", "tracking_max_C", "frames", "frames_lost", "trace_file",
    # the display's measured contact force (mean summed force over the contact; Eq. 5's force)
    "contact_force_N",
)

#: Decimals each float column is written with: the resolution of what measured it (the
#: display's 0.01 °C and 1 ms device clock, the keyboard's 0.1 ms), or 4 significant digits
#: for modelled resistances ("sig4"). Unlisted floats keep their shortest round-trip form.
COLUMN_DECIMALS = {
    "skin_thickness_um": 1, "roughness_um": 3, "profile_skin_thickness_um": 1,
    "profile_resistance_m2K_W": "sig4", "pad_resistance_m2K_W": "sig4",
    "rate_limited_max_change_C": 3, "rt_s": 4, "contact_onset_s": 3, "contact_duration_s": 3,
    "skin_temperature_C": 2, "tracking_rms_C": 3, "tracking_max_C": 3, "contact_force_N": 2,
}

#: Keys of ``session_started`` / ``session_resumed`` copied onto every trial row.
CONTEXT_KEYS = ("participant", "group", "session", "skin_thickness_um", "sex", "date", "expName",
                "protocol_version", "thermocue_version")

#: Required fields per event type (other types: none).
REQUIRED_FIELDS = {
    "session_started": ("session", "participant", "protocol_hash", "seed"),
    "session_resumed": ("session", "participant", "protocol_hash", "seed"),
    "trial_started": ("trial_index", "attempt"),
    "trial_completed": ("trial_index", "attempt", "row"),
    "trial_aborted": ("trial_index", "attempt", "reason"),
    "session_interrupted": ("reason",),
}

_EVENT_NAME = re.compile(r"^[a-z][a-z0-9_]{0,63}$")
_SPEC_KEYS = ("block", "mode", "roughness_id", "roughness_um", "repetition")


class LogDamageWarning(UserWarning):
    """An event log had a torn or undecodable line; the message names the file and line."""


# --------------------------------------------------------------------------- fsync helpers
#: Whether writes are made durable (fsync).  True everywhere except where a study of simulated
#: participants on a virtual clock turns it off for its own worker (:func:`set_durable`).
_DURABLE = True


def set_durable(flag: bool) -> bool:
    """Turn fsync on or off for this process; return the previous setting.

    Every write of this module (and of :mod:`experiments.session_files`) stays in the same
    order, atomic renames included; only the ``fsync`` calls that make them survive a power cut
    are skipped when off.  For simulated studies on a virtual clock
    (:func:`experiments.cohort.run_figure9_study`), which are recomputed from their seed: on
    the shared 2-core machine fsync was 70 % of an emulated session's wall time (issue 11).
    Never off for a session with a person in it.
    """
    global _DURABLE
    previous, _DURABLE = _DURABLE, bool(flag)
    return previous


def fsync(fd: int) -> None:
    """``os.fsync(fd)`` unless durability is off (:func:`set_durable`)."""
    if _DURABLE:
        os.fsync(fd)


def fsync_dir(path: str | Path) -> None:
    """Flush a folder's entries (new, renamed or removed files) to disk.

    Parameters
    ----------
    path : str or Path
        The folder.
    """
    if not _DURABLE:
        return
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def ensure_dir(path: str | Path) -> Path:
    """Create a folder and any missing parents, fsyncing the parent of each one created.

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
        fsync_dir(d.parent)
    if not path.is_dir():
        import errno
        raise NotADirectoryError(errno.ENOTDIR, "expected a folder, got a file", str(path))
    return path


def to_jsonable(obj: Any) -> Any:
    """A JSON-ready copy: non-finite floats -> None, numpy -> Python, Path/date -> str.

    Raises
    ------
    TypeError
        For an object with no JSON form.
    """
    if obj is None or isinstance(obj, (bool, str, int)):
        return obj
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, Mapping):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return to_jsonable(dataclasses.asdict(obj))
    if isinstance(obj, (Path, os.PathLike)):
        return os.fspath(obj)
    if isinstance(obj, (_dt.datetime, _dt.date)):
        return obj.isoformat()
    tolist = getattr(obj, "tolist", None)  # numpy scalars and arrays
    if callable(tolist):
        return to_jsonable(tolist())
    raise TypeError(f"expected a JSON-ready value, got {type(obj).__name__}: {obj!r}")


def _dumps(obj: Any, indent: int | None = None) -> str:
    return json.dumps(to_jsonable(obj), ensure_ascii=False, allow_nan=False, indent=indent,
                      separators=None if indent else (",", ":"))


def atomic_write_text(path: str | Path, text: str, encoding: str = "utf-8") -> None:
    """Replace a file's content atomically and durably.

    Writes ``.<name>.<pid>.tmp`` in the same folder, fsyncs it, renames it over ``path``
    and fsyncs the folder.  Readers see the old or the new content, never a mixture.

    Parameters
    ----------
    path : str or Path
    text : str
    encoding : str
    """
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "w", encoding=encoding, newline="") as fh:
            fh.write(text)
            fh.flush()
            fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            tmp.unlink()
        except FileNotFoundError:
            pass
        raise
    fsync_dir(path.parent)


def atomic_write_json(path: str | Path, obj: Any, indent: int = 2) -> None:
    """Write ``obj`` as JSON (see :func:`to_jsonable`) with :func:`atomic_write_text`."""
    atomic_write_text(path, _dumps(obj, indent=indent) + "\n")


def now_iso() -> str:
    """The current UTC time, ISO 8601 with milliseconds and a ``Z`` (as in every event's ``time``)."""
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="milliseconds").replace("+00:00", "Z")


# --------------------------------------------------------------------------- reading
@dataclass(frozen=True)
class LogReport:
    """What :func:`read_events` found besides the events.

    Attributes
    ----------
    path : str
    n_events : int
        Events returned.
    n_lines : int
        Lines in the file (a torn last line included).
    torn_tail : bytes or None
        The incomplete last line, if any (not returned as an event).
    torn_line : int or None
        Its line number.
    bad_lines : tuple of (int, str)
        Undecodable lines before the last one: (line number, reason).
    stopped_at : int or None
        With ``on_damage="stop"``: the first bad line; nothing from there on was returned.
    missing_newline : bool
        The last line was a whole object without its newline (returned as an event).
    """

    path: str
    n_events: int
    n_lines: int
    torn_tail: bytes | None = None
    torn_line: int | None = None
    bad_lines: tuple[tuple[int, str], ...] = ()
    stopped_at: int | None = None
    missing_newline: bool = False

    @property
    def ok(self) -> bool:
        """No torn line and no bad line."""
        return self.torn_tail is None and not self.bad_lines

    def describe(self) -> str:
        """One line for the experimenter."""
        if self.ok:
            return f"{self.path}: {self.n_events} events, intact"
        parts = []
        if self.torn_tail is not None:
            parts.append(f"torn last line {self.torn_line} ({len(self.torn_tail)} bytes) ignored")
        for n, why in self.bad_lines:
            parts.append(f"line {n} undecodable ({why})")
        if self.stopped_at is not None:
            parts.append(f"read up to line {self.stopped_at - 1}")
        return f"{self.path}: {self.n_events} events; " + "; ".join(parts)


def _decode(raw: bytes) -> dict:
    obj = json.loads(raw.decode("utf-8"))
    if not isinstance(obj, dict) or not isinstance(obj.get("event"), str):
        raise ValueError("not an event object")
    return obj


def read_events(path: str | Path, on_damage: str = "stop", warn: bool = True) -> tuple[list[dict], LogReport]:
    """Read an event log, tolerating damage.

    Parameters
    ----------
    path : str or Path
        An ``events.jsonl`` file.
    on_damage : {"stop", "skip"}
        What to do at an undecodable line that is not the last: ``"stop"`` returns the
        events before it; ``"skip"`` leaves it out and goes on.
    warn : bool
        Issue a :class:`LogDamageWarning` (naming the file and line) per damaged line.

    Returns
    -------
    events : list of dict
    report : LogReport

    Raises
    ------
    FileNotFoundError
        If there is no such file.

    Notes
    -----
    A last line without its newline that does not decode is a *torn* line, the trace of a
    crash during an append; it is reported and ignored.  Empty lines are skipped.
    """
    if on_damage not in ("stop", "skip"):
        raise ValueError(f"on_damage: expected 'stop' or 'skip', got {on_damage!r}")
    path = Path(path)
    data = path.read_bytes()
    lines = data.split(b"\n")
    last_complete = data.endswith(b"\n") or not data
    if last_complete:
        lines = lines[:-1]
    events: list[dict] = []
    torn = torn_line = stopped = None
    bad: list[tuple[int, str]] = []
    missing_newline = False
    n = len(lines)
    for i, raw in enumerate(lines, start=1):
        is_tail = i == n and not last_complete
        if not raw.strip():
            continue
        try:
            ev = _decode(raw)
        except (ValueError, UnicodeDecodeError) as exc:
            if is_tail:
                torn, torn_line = raw, i
                if warn:
                    warnings.warn(f"{path}: line {i}: torn last line ({len(raw)} bytes) ignored",
                                  LogDamageWarning, stacklevel=2)
                break
            reason = str(exc).split("\n")[0][:120]
            bad.append((i, reason))
            if on_damage == "stop":
                stopped = i
                if warn:
                    warnings.warn(f"{path}: line {i}: undecodable line ({reason}); "
                                  f"events read up to line {i - 1}", LogDamageWarning, stacklevel=2)
                break
            if warn:
                warnings.warn(f"{path}: line {i}: undecodable line ({reason}) skipped",
                              LogDamageWarning, stacklevel=2)
            continue
        if is_tail:
            missing_newline = True
        events.append(ev)
    report = LogReport(path=str(path), n_events=len(events), n_lines=n, torn_tail=torn,
                       torn_line=torn_line, bad_lines=tuple(bad), stopped_at=stopped,
                       missing_newline=missing_newline)
    return events, report


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

    def __init__(self, path: str | Path, lock: bool = True):
        self.path = Path(path)
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
                fsync(self._fd)
                fsync_dir(self.path.parent)
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
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", LogDamageWarning)
            events, report = read_events(self.path, on_damage="stop")
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
        fsync(self._fd)

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
        if not isinstance(event, str) or not _EVENT_NAME.match(event):
            raise ValueError(f"{self.path}: event: expected a snake_case name, got {event!r}")
        for reserved in ("event", "seq"):
            if reserved in fields:
                raise ValueError(f"{self.path}: {event}.{reserved}: expected no value (set by the log), "
                                 f"got {fields[reserved]!r}")
        missing = [k for k in REQUIRED_FIELDS.get(event, ()) if k not in fields]
        if missing:
            raise ValueError(f"{self.path}: {event}.{missing[0]}: expected a value, got nothing")
        if event == "trial_completed" and not isinstance(fields["row"], Mapping):
            raise ValueError(f"{self.path}: trial_completed.row: expected a mapping, got {fields['row']!r}")
        with self._lock:
            if self.closed:
                raise ValueError(f"{self.path}: the log is closed")
            rec = {"event": event, "seq": self._seq + 1, "time": fields.pop("time", None) or now_iso()}
            rec.update(fields)
            rec = to_jsonable(rec)
            line = _dumps(rec) + "\n"
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
def trials_from_events(events: Iterable[Mapping[str, Any]]) -> list[dict]:
    """The rows of ``trials.csv``, rebuilt from the event log.

    Parameters
    ----------
    events : iterable of dict
        As returned by :func:`read_events`.

    Returns
    -------
    list of dict
        In log order: one row per ``trial_completed`` (its ``row``) and one per
        ``trial_aborted`` (status ``"aborted"``, plus ``abort_reason``).  Each row is
        completed from the session context (:data:`CONTEXT_KEYS` of the latest
        ``session_started``/``session_resumed``) and the attempt's ``trial_started``
        (``block``, ``mode``, ``roughness_id``, ``roughness_um``, ``repetition``,
        ``started_at``); the row's own values win.  ``correct`` is filled from
        ``response_id == roughness_id`` when the row lacks it.  A second event for the
        same (trial_index, attempt) is ignored with a :class:`LogDamageWarning`.
    """
    ctx: dict[str, Any] = {}
    starts: dict[tuple, Mapping] = {}
    seen: set[tuple] = set()
    rows: list[dict] = []
    for ev in events:
        kind = ev.get("event")
        if kind in ("session_started", "session_resumed"):
            ctx.update({k: ev[k] for k in CONTEXT_KEYS if k in ev})
        elif kind == "trial_started":
            starts[(ev.get("trial_index"), ev.get("attempt"))] = ev
        elif kind in ("trial_completed", "trial_aborted"):
            key = (ev.get("trial_index"), ev.get("attempt"))
            if key in seen:
                warnings.warn(f"events: trial {key[0]} attempt {key[1]}: a second {kind} event "
                              f"(seq {ev.get('seq')}) ignored", LogDamageWarning, stacklevel=2)
                continue
            seen.add(key)
            start = starts.get(key, {})
            row: dict[str, Any] = dict(ctx)
            row.update({k: start[k] for k in _SPEC_KEYS if k in start})
            row["trial_index"], row["attempt"] = key
            if "time" in start:
                row["started_at"] = start["time"]
            if kind == "trial_completed":
                row.update(ev["row"])
                row.setdefault("status", "ok")
                if row.get("correct") is None and row.get("response_id") is not None \
                        and row.get("roughness_id") is not None:
                    row["correct"] = int(row["response_id"] == row["roughness_id"])
            else:
                row["status"] = "aborted"
                row["abort_reason"] = ev.get("reason")
                if ev.get("fault_code") is not None:
                    row["fault_code"] = ev["fault_code"]
            rows.append(row)
    return rows


def _cell(v: Any, column: str = "") -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return "1" if v else "0"
    if isinstance(v, float):
        if not math.isfinite(v):
            return ""
        decimals = COLUMN_DECIMALS.get(column)
        if decimals == "sig4":
            return f"{v:.4g}"
        if decimals is not None:
            text = f"{v:.{decimals}f}".rstrip("0").rstrip(".")
            return "0" if text in ("-0", "") else text
        return repr(v)
    if isinstance(v, (dict, list, tuple)):
        return _dumps(v)
    return str(v)


def write_trials_csv(path: str | Path, rows: Iterable[Mapping[str, Any]],
                     columns: Iterable[str] | None = None) -> list[str]:
    """Write ``trials.csv`` atomically.

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
    rows = list(rows)
    if columns is None:
        extra = sorted({k for r in rows for k in r} - set(TRIAL_COLUMNS))
        columns = list(TRIAL_COLUMNS) + extra
    columns = list(columns)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(columns)
    for r in rows:
        w.writerow([_cell(r.get(c), c) for c in columns])
    atomic_write_text(path, buf.getvalue())
    return columns


# --------------------------------------------------------------------------- progress
@dataclass
class SessionProgress:
    """Where a session stands, from its events (for ``thermocue resume``).

    Attributes
    ----------
    session : dict or None
        The first ``session_started`` event.
    completed : dict of int to str
        trial_index -> status of its ``trial_completed`` row ("ok" or "fault"; the last
        one if a trial was completed more than once).
    aborted : list of (int, int)
        (trial_index, attempt) of ``trial_aborted`` events.
    open_attempts : list of (int, int)
        Attempts started and neither completed nor aborted (cut off by a crash): log a
        ``trial_aborted`` for each before re-running the trial.
    attempts : dict of int to int
        trial_index -> highest attempt number seen.
    finished : bool
        A ``session_finished`` event is present.
    last_seq : int
    """

    session: dict | None = None
    completed: dict[int, str] = field(default_factory=dict)
    aborted: list[tuple[int, int]] = field(default_factory=list)
    open_attempts: list[tuple[int, int]] = field(default_factory=list)
    attempts: dict[int, int] = field(default_factory=dict)
    finished: bool = False
    last_seq: int = 0

    def next_attempt(self, trial_index: int) -> int:
        """The attempt number for the next try of a trial."""
        return self.attempts.get(trial_index, 0) + 1

    def first_incomplete(self, trial_indices: Iterable[int]) -> int | None:
        """The first of ``trial_indices`` (schedule order) with no completed attempt."""
        for i in trial_indices:
            if i not in self.completed:
                return i
        return None


def replay(events: Iterable[Mapping[str, Any]]) -> SessionProgress:
    """Summarise a session's events into a :class:`SessionProgress`."""
    p = SessionProgress()
    open_: dict[tuple[int, int], None] = {}
    for ev in events:
        kind = ev.get("event")
        if isinstance(ev.get("seq"), int):
            p.last_seq = max(p.last_seq, ev["seq"])
        if kind == "session_started" and p.session is None:
            p.session = dict(ev)
        elif kind in ("trial_started", "trial_completed", "trial_aborted"):
            ti, att = ev.get("trial_index"), ev.get("attempt")
            if isinstance(ti, int) and isinstance(att, int):
                p.attempts[ti] = max(p.attempts.get(ti, 0), att)
            if kind == "trial_started":
                open_[(ti, att)] = None
            else:
                open_.pop((ti, att), None)
                if kind == "trial_completed":
                    p.completed[ti] = ev.get("row", {}).get("status", "ok")
                else:
                    p.aborted.append((ti, att))
        elif kind == "session_finished":
            p.finished = True
    p.open_attempts = list(open_)
    return p


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

