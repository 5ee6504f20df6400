"""A trial's trace as the page plots it: time, target, pad, finger, summed force and the
display's state per frame, read from ``traces/trial-NNN.csv`` as it grows or once it is done."""
from __future__ import annotations

import math
from pathlib import Path

from sessionfiles.logformat import TRACE_COLUMNS
from experiments.monitor.faults import explain
from experiments.monitor.tail import LineTail, open_regular

__all__ = ["TraceColumns", "LiveTrace", "read_trace", "fault_marker", "SERIES"]

#: The page's series of a trace (the four forces summed: the contact force the threshold is for).
SERIES = ("t", "target", "contact", "finger", "force", "state")
_HEADER = ",".join(TRACE_COLUMNS).encode()
_MAX_TRACE_BYTES = 64 << 20


def _number(text: bytes):
    if not text:
        return None
    v = float(text)
    return v if math.isfinite(v) else None


class TraceColumns:
    """The series of a trace, appended line by line; a line that is not a trace line is
    counted in :attr:`bad` and left out (the page says so)."""

    def __init__(self):
        self.cols = {k: [] for k in SERIES}
        self.bad = 0
        self.header_ok: bool | None = None

    def __len__(self):
        return len(self.cols["t"])

    def add_lines(self, lines) -> None:
        for line in lines:
            line = line.rstrip(b"\r")
            if self.header_ok is None:
                self.header_ok = line.lstrip(b"\xef\xbb\xbf") == _HEADER
                if self.header_ok:
                    continue
            cells = line.split(b",")
            try:
                if len(cells) != len(TRACE_COLUMNS):
                    raise ValueError(line)
                t, target, contact, _ambient, finger = (_number(c) for c in cells[:5])
                forces = [_number(c) for c in cells[5:9]]
                if t is None:
                    raise ValueError(line)
            except ValueError:
                self.bad += 1
                continue
            c = self.cols
            c["t"].append(t)
            c["target"].append(target)
            c["contact"].append(contact)
            c["finger"].append(finger)
            c["force"].append(None if None in forces else round(sum(forces), 3))
            c["state"].append(cells[9].decode("ascii", "replace"))

    def slice(self, start: int) -> dict:
        return {k: v[start:] for k, v in self.cols.items()}


class LiveTrace:
    """The trace of the running attempt, followed as the session writes it."""

    def __init__(self, path, key):
        self.key = key                    # (trial_index, attempt)
        self.tail = LineTail(path)
        self.data = TraceColumns()
        self.fault: dict | None = None    # the marker, once the attempt ended in a fault
        self.done = False

    def poll(self) -> None:
        if not self.done:
            self.data.add_lines(self.tail.read())

    def finish(self) -> None:
        """The attempt ended: the rest of the file (the descriptor follows a rename)."""
        self.poll()
        self.done = True
        self.tail.close()


def read_trace(path: Path) -> TraceColumns:
    """A finished trace, whole (OSError, NotRegular; ValueError when it is too large)."""
    import os
    fd = open_regular(path)
    try:
        size = os.fstat(fd).st_size
        if size > _MAX_TRACE_BYTES:
            raise ValueError(f"{path}: expected a trace of at most {_MAX_TRACE_BYTES} bytes, got {size}")
        chunks = []
        while True:
            chunk = os.read(fd, 1 << 20)
            if not chunk:
                break
            chunks.append(chunk)
    finally:
        os.close(fd)
    data = TraceColumns()
    body = b"".join(chunks)
    lines = body.split(b"\n")
    if lines and lines[-1] == b"":
        lines.pop()
    elif lines:
        lines.pop()                        # a torn last line (a crash mid-write): left out
    data.add_lines(lines)
    return data


def fault_marker(data: TraceColumns, code, message=None) -> dict | None:
    """Where a fault shows on the trace: the first frame the display reported FAULT, else the
    first frame it fell back to IDLE after arming (the watchdog's neutral), else the last frame."""
    if code in (None, ""):
        return None
    t, states = data.cols["t"], data.cols["state"]
    at = None
    for i, s in enumerate(states):
        if s == "FAULT":
            at = i
            break
    if at is None:
        active = False
        for i, s in enumerate(states):
            if s in ("ARMED", "PLAYING", "RECORDING"):
                active = True
            elif s == "IDLE" and active:
                at = i
                break
    if at is None and t:
        at = len(t) - 1
    words = explain(code)
    return {"code": str(code), "words": words, "message": message or "",
            "time_s": None if at is None else t[at],
            "value_C": None if at is None else data.cols["contact"][at]}
