"""The files of a session directory: trials table, per-trial traces, package versions.

``DATA/<participant>/<session>/`` holds ``session.json``, ``events.jsonl`` (the source of truth),
``trials.csv`` (rebuilt from the events after every trial, :mod:`sessionfiles.logbook`) and
``traces/trial-NNN.csv``. This module writes the traces (their columns and cell format are
:mod:`sessionfiles.logformat`'s); :mod:`experiments.session` decides when things are written.
"""
from __future__ import annotations

import functools
import hashlib
import json
import os
import platform
import struct
import sys
import time
from array import array
from importlib import metadata
from pathlib import Path

import numpy as np

from sessionfiles.logbook import fsync, fsync_dir
from sessionfiles.logformat import TRACE_COLUMNS, TRACE_DECIMALS, format_cell

__all__ = [
    "TRACE_COLUMNS",
    "TraceWriter",
    "package_versions",
    "trace_name",
    "aborted_trace_name",
    "claim_session_folder",
    "schedule_sha256",
]

def trace_name(trial_index: int) -> str:
    """File name (inside ``traces/``) of a trial's trace."""
    return f"trial-{int(trial_index):03d}.csv"


def aborted_trace_name(trial_index: int, attempt: int, kind: str = "aborted") -> str:
    """File name the trace of an attempt that did not complete is kept under.

    ``kind`` is ``"aborted"`` or ``"fault"``; the trace of the trial's completed attempt keeps
    :func:`trace_name`.
    """
    return f"trial-{int(trial_index):03d}.attempt-{int(attempt)}.{kind}.csv"


#: The numeric cells of a trace line (time_s .. force4_N) in one C-level format: the same
#: text as :func:`~sessionfiles.logformat.format_cell` gives each finite cell.
_FRAME_FORMAT = ",".join(f"%.{TRACE_DECIMALS[c]}" for c in TRACE_COLUMNS[:-1])
#: A whole trace line, the state last.
_LINE_FORMAT = _FRAME_FORMAT + ",%s\n"
_CELL = "%.10g"
assert _FRAME_FORMAT == ",".join([_CELL] * (len(TRACE_COLUMNS) - 1)), "a trace cell's format changed"


class _Cells(dict):
    """``%.10g`` text of a number, remembered: the telemetry's readings are whole hundredths
    (a few thousand distinct values), so a look-up replaces most formatting. Equal numbers
    have the same text, except 0.0 and -0.0 (never remembered)."""

    def __missing__(self, v):
        text = _CELL % v
        if v != 0:
            if len(self) >= 100_000:           # bounded (readings out of the usual range)
                self.clear()
            self[v] = text
        return text


_CELLS = _Cells()
#: A frame's readings kept by :class:`TraceWriter` (time, target, contact, four forces) as the
#: bytes of seven C doubles, its ``array("d")``'s items (one C call; ``extend`` converts a tuple
#: item by item).
_PACK_READINGS = struct.Struct("@7d").pack


class TraceWriter:
    """Streams telemetry frames of one trial attempt to a CSV file.

    Lines are written as frames arrive and flushed every ``flush_every`` frames or, at the
    first frame after ``flush_interval_s`` of the host's time since the last flush, whichever
    comes first: a killed session leaves the trace up to the last flush, and a reader following
    the folder (``thermocue monitor``) sees the trial's frames at most about
    ``flush_interval_s`` after they arrived (it reads up to the last complete line: a full
    buffer may reach the file mid-line). A flush hands the lines to the OS (no fsync);
    :meth:`close` fsyncs the file and its folder.

    Parameters
    ----------
    path : path-like
        The CSV file (created; an existing file is never overwritten: FileExistsError).
    flush_every : int
        Frames between flushes at most (default 50: a virtual clock's burst of frames).
    flush_interval_s : float
        Host seconds between flushes at most while frames arrive (default 0.05: 100 Hz
        telemetry is flushed every 5 frames, 20 ``write`` calls a second).
    durable : bool
        False: :meth:`close` does not fsync (a simulated study's traces).
    """

    def __init__(self, path, flush_every: int = 50, *, durable: bool = True,
                 flush_interval_s: float = 0.05):
        self.path = Path(path)
        self.flush_every = int(flush_every)
        self.flush_interval_s = float(flush_interval_s)
        self.durable = bool(durable)
        # "x": a trace is never overwritten (the session moves an old one aside first)
        self._fh = open(self.path, "x", encoding="utf-8", newline="")
        self._fh.write(",".join(TRACE_COLUMNS) + "\n")
        # the lines since the last flush, handed to the file at the flush in one write (a text
        # file's write cost ~330 ns a line, a list's append and a share of one write ~230 ns)
        self._lines = []
        self._n = 0
        self._flushed_at = time.monotonic()
        # per frame: time, target, contact, the four forces (doubles, not objects: a trace's
        # readings kept as Python floats and tuples cost more than the line written)
        self._values = array("d")
        self._arrays = None

    def write(self, frame) -> None:
        """Append one :class:`~experiments.display.Telemetry` frame."""
        # the hot path of a session (100 frames a second of device time): the whole line in
        # one C-level format, the decoded frame's floats kept as they are
        if not isinstance(frame, tuple):        # any frame with Telemetry's field names
            frame = (None, frame.device_time_s, frame.setpoint_C, frame.contact_C, frame.ambient_C,
                     frame.finger_C, tuple(frame.forces_N), frame.state)
        try:                                    # Telemetry: nine fields
            _, t, target, contact, ambient, finger, forces, state, _ = frame
        except ValueError:
            _, t, target, contact, ambient, finger, forces, state = frame[:8]
        c = _CELLS
        try:
            f0, f1, f2, f3 = forces
        except (TypeError, ValueError):        # not four forces: the line as the format has it
            line = _LINE_FORMAT % (t, target, contact, ambient, finger, *forces, state)
        else:
            line = (f"{_CELL % t},{c[target]},{c[contact]},{c[ambient]},{c[finger]},"
                    f"{c[f0]},{c[f1]},{c[f2]},{c[f3]},{state}\n")
        if "n" in line:                         # maybe nan or inf (or a letter of the state)
            fields = (float(t), float(target), float(contact), float(ambient), float(finger),
                      *map(float, forces))
            line = _FRAME_FORMAT % fields
            if "n" in line:                     # nan or inf: blank cells (format_cell)
                line = ",".join(format_cell(v, c, TRACE_DECIMALS)
                                for v, c in zip(fields, TRACE_COLUMNS))
            line = f"{line},{state}\n"
        self._lines.append(line)
        self._values.frombytes(_PACK_READINGS(t, target, contact, f0, f1, f2, f3))
        self._n += 1
        now = time.monotonic()
        if self._n % self.flush_every == 0 or now - self._flushed_at >= self.flush_interval_s:
            self._flush()
            self._flushed_at = now

    def _flush(self) -> None:
        """The lines written since the last flush to the file, and the file to the OS."""
        lines = self._lines
        if lines:
            self._fh.write("".join(lines))
            lines.clear()
        self._fh.flush()

    @property
    def frames(self) -> int:
        return self._n

    def arrays(self) -> tuple:
        """The frames written so far as arrays: time_s (s), target_C, contact_C (°C), each
        ``(n,)``, and forces_N ``(n, 4)`` (N); made once per frame count (do not modify)."""
        if self._arrays is None or self._arrays[0] != self._n:
            v = np.array(self._values, dtype=float).reshape(-1, 7)
            self._arrays = (self._n, (v[:, 0].copy(), v[:, 1].copy(), v[:, 2].copy(),
                                      v[:, 3:7].copy()))
        return self._arrays[1]

    @property
    def time_s(self) -> list:
        """Frame times, s."""
        return self._values[0::7].tolist()

    @property
    def target_C(self) -> list:
        """Target temperatures, °C."""
        return self._values[1::7].tolist()

    @property
    def contact_C(self) -> list:
        """Contact temperatures, °C."""
        return self._values[2::7].tolist()

    @property
    def forces_N(self) -> list:
        """The four forces per frame, N."""
        return [tuple(r) for r in self.arrays()[3].tolist()]

    def close(self) -> None:
        """Flush, fsync, close, fsync the folder."""
        if self._fh.closed:
            return
        self._flush()
        fsync(self._fh.fileno(), self.durable)
        self._fh.close()
        fsync_dir(self.path.parent, self.durable)


def package_versions() -> dict[str, str]:
    """Versions of Python, the platform and the packages a session depends on.

    Read once per process (the packages a process has imported do not change under it; a
    study's sessions each record them) and returned as a new dict each time."""
    return dict(_package_versions())


@functools.lru_cache(maxsize=1)
def _package_versions() -> tuple:
    out = {"python": sys.version.split()[0], "platform": platform.platform()}
    for name in ("thermocue", "numpy", "scipy", "pyserial", "jsonschema", "psychopy",
                 "psychtoolbox", "sounddevice"):
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = None
    return tuple(out.items())


def schedule_sha256(schedule) -> str:
    """SHA-256 of a schedule (a list of TrialSpec or their dicts) in canonical JSON.

    ``session_started`` records it, so a resume can tell an edited ``session.json`` schedule.
    """
    items = [s if isinstance(s, dict) else s.to_dict() for s in schedule]
    text = json.dumps(items, sort_keys=True, separators=(",", ":"), ensure_ascii=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def claim_session_folder(directory, *, durable: bool = True):
    """Claim a new session folder for this process; return its locked, empty event log.

    The folder is made with ``mkdir`` and ``events.jsonl`` with an exclusive create, then locked
    (:class:`~sessionfiles.logbook.EventLog`) *before* anything else is written: of two runs
    claiming one folder, exactly one gets it, and ``session.json`` is only ever written by the
    holder of the log's lock. A folder left by a run killed while claiming (no ``session.json``,
    an empty unlocked log) is claimed again. ``durable=False`` skips the fsyncs (a simulated
    study's session).

    Raises
    ------
    SessionError
        The folder is a session already, or another run is claiming it right now.
    """
    from sessionfiles.errors import SessionError
    from sessionfiles.logbook import EventLog, ensure_dir, fsync_dir

    directory = Path(directory)
    ensure_dir(directory.parent, durable=durable)
    try:
        os.mkdir(directory)
        fsync_dir(directory.parent, durable)
    except FileExistsError:
        if not directory.is_dir():
            raise SessionError(f"{directory}: expected a new session folder, got a file") from None
    events = directory / "events.jsonl"
    existing = SessionError(f"{directory}: expected a new session folder, got an existing one "
                            f"(resume it with `thermocue resume {directory}` or choose --session)")
    try:
        os.close(os.open(events, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, 0o644))
        fsync_dir(directory, durable)
    except FileExistsError:
        if (directory / "session.json").exists() or events.stat().st_size > 0:
            raise existing from None
    try:
        log = EventLog(events, durable=durable)
    except SessionError:
        raise SessionError(f"{directory}: expected a new session folder, got one another run is "
                           f"creating right now (choose --session)") from None
    if (directory / "session.json").exists() or log.seq > 0:
        log.close()                       # the other run finished its claim before our lock
        raise existing
    return log

