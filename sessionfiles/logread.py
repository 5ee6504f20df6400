"""The tolerant readers of a session folder's files (standard library only).

Part of the log format (:mod:`sessionfiles.logformat`, which re-exports every name here and
documents the files): :func:`read_events` reads ``events.jsonl`` up to its first damaged line
(or past it, on request) and says what it skipped (:class:`LogReport`,
:class:`LogDamageWarning`); :func:`decode_event` is one line's reading; :func:`read_csv_prefix`
reads the undamaged prefix of ``trials.csv`` or a trace. Nothing here knows the columns or the
event types: that stays in :mod:`sessionfiles.logformat`.
"""
from __future__ import annotations

import csv
import io
import json
import warnings
from dataclasses import dataclass
from pathlib import Path

__all__ = ["LogDamageWarning", "LogReport", "decode_event", "read_events", "read_csv_prefix"]


class LogDamageWarning(UserWarning):
    """An event log had a torn or undecodable line; the message names the file and line."""


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
    event_lines : tuple of int
        The line number of each event returned.
    damage : tuple of str
        One message per damaged line, naming the file and the line (as warned).
    """

    path: str
    n_events: int
    n_lines: int
    torn_tail: bytes | None = None
    torn_line: int | None = None
    bad_lines: tuple[tuple[int, str], ...] = ()
    stopped_at: int | None = None
    missing_newline: bool = False
    event_lines: tuple[int, ...] = ()
    damage: tuple[str, ...] = ()

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


def decode_event(raw: bytes) -> dict:
    """One line of ``events.jsonl`` (without its newline) as an event; ValueError (or
    UnicodeDecodeError) if it is not a JSON object with a string ``event``."""
    obj = json.loads(raw.decode("utf-8"))
    if not isinstance(obj, dict) or not isinstance(obj.get("event"), str):
        raise ValueError("not an event object")
    return obj


def read_events(path: str | Path, on_damage: str = "stop", warn: bool = True,
                data: bytes | None = None) -> tuple[list[dict], LogReport]:
    """Read an event log, tolerating damage.

    Parameters
    ----------
    path : str or Path
        An ``events.jsonl`` file.
    on_damage : {"stop", "skip"}
        What to do at an undecodable line that is not the last: ``"stop"`` returns the
        events before it; ``"skip"`` leaves it out and goes on.
    warn : bool
        Issue a :class:`LogDamageWarning` (naming the file and line) per damaged line; the
        messages are in ``report.damage`` either way.
    data : bytes, optional
        The file's content, already read (by :mod:`sessionfiles.session_reader`, which refuses
        special files and other encodings first); ``path`` then only names it.

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
    crash during an append; it is reported and ignored.  Empty lines are skipped.  A line
    that is not a JSON object with an ``event`` string is undecodable.
    """
    if on_damage not in ("stop", "skip"):
        raise ValueError(f"on_damage: expected 'stop' or 'skip', got {on_damage!r}")
    path = Path(path)
    if data is None:
        data = path.read_bytes()
    lines = data.split(b"\n")
    last_complete = data.endswith(b"\n") or not data
    if last_complete:
        lines = lines[:-1]
    events: list[dict] = []
    numbers: list[int] = []
    damage: list[str] = []
    torn = torn_line = stopped = None
    bad: list[tuple[int, str]] = []
    missing_newline = False
    n = len(lines)
    for i, raw in enumerate(lines, start=1):
        is_tail = i == n and not last_complete
        if not raw.strip():
            continue
        try:
            ev = decode_event(raw)
        except (ValueError, UnicodeDecodeError) as exc:
            if is_tail:
                torn, torn_line = raw, i
                damage.append(f"{path}: line {i}: torn last line ({len(raw)} bytes) ignored")
                break
            reason = str(exc).split("\n")[0][:120]
            bad.append((i, reason))
            if on_damage == "stop":
                stopped = i
                damage.append(f"{path}: line {i}: undecodable line ({reason}); "
                              f"events read up to line {i - 1}")
                break
            damage.append(f"{path}: line {i}: undecodable line ({reason}) skipped")
            continue
        if is_tail:
            missing_newline = True
        events.append(ev)
        numbers.append(i)
    if warn:
        for text in damage:
            warnings.warn(text, LogDamageWarning, stacklevel=2)
    report = LogReport(path=str(path), n_events=len(events), n_lines=n, torn_tail=torn,
                       torn_line=torn_line, bad_lines=tuple(bad), stopped_at=stopped,
                       missing_newline=missing_newline, event_lines=tuple(numbers),
                       damage=tuple(damage))
    return events, report


def _decode_prefix(raw: bytes, path: Path, damage: list) -> str:
    """Decode ``raw`` as UTF-8 up to the first NUL or undecodable byte (whole lines only)."""
    cut = len(raw)
    nul = raw.find(b"\x00")
    if nul >= 0:
        cut = nul
    try:
        text = raw[:cut].decode("utf-8")
    except UnicodeDecodeError as exc:
        cut = exc.start
        text = raw[:cut].decode("utf-8")
    if cut < len(raw):
        line = text.count("\n") + 1
        damage.append(f"{path}: line {line}: damaged bytes from here on; read the lines before it")
        text = text[: text.rfind("\n") + 1]      # the damaged line is not trusted either
    return text


def read_csv_prefix(path: str | Path, data: bytes | None = None
                    ) -> tuple[list[str] | None, list[list[str]], list[int], list[str]]:
    """Read a CSV file (``trials.csv``) up to its first damaged line.

    Damage is a NUL or undecodable byte (the lines before its line are read), a torn last
    line (no newline at its end) or a row with the wrong number of fields (the rows before
    it are read).

    Parameters
    ----------
    path : str or Path
    data : bytes, optional
        The file's content, already read (``path`` then only names it).

    Returns
    -------
    header : list of str or None
        The first line's cells as written (None for an empty file; no rows are read after a
        header with no name in it).
    rows : list of list of str
        The rows read (blank lines left out).
    lines : list of int
        The 1-based line number of each row.
    damage : list of str
        One message per damage found, naming the file and the line.
    """
    path = Path(path)
    damage: list[str] = []
    text = _decode_prefix(path.read_bytes() if data is None else data, path, damage)
    if text and not text.endswith("\n"):
        torn = text.count("\n") + 1
        damage.append(f"{path}: line {torn}: torn last line (no newline at its end); ignored")
        text = text[: text.rfind("\n") + 1]
    reader = csv.reader(io.StringIO(text))
    header = next(reader, None)
    if not header or not any(h.strip() for h in header):
        return header, [], [], damage
    rows, lines = [], []
    for row in reader:
        if not row or all(not c.strip() for c in row):
            continue
        if len(row) != len(header):
            damage.append(f"{path}: line {reader.line_num}: expected {len(header)} fields, "
                          f"got {len(row)}; read the {len(rows)} rows before it")
            break
        rows.append(row)
        lines.append(reader.line_num)
    return header, rows, lines, damage
