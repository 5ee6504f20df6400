"""``trials.csv`` of one run, rebuilt from ``events.jsonl`` after every trial.

One concept: the table a session keeps beside its event log. The event log is the source of
truth (:func:`~sessionfiles.logformat.trials_from_events`); the table is rebuilt from it and
replaced atomically, so it is never half-written. Only where durability is off (``durable=False``:
a simulated study on a virtual clock, recomputed from its seed) does a
table that only adds rows to the one this run last wrote grow by its new lines in one ``write``
(for speed); a session with a person in it always gets the atomic replace. The log is
decoded incrementally (only the lines appended since the last trial); anything unusual falls back
to :func:`~sessionfiles.logformat.read_events`.
"""
from __future__ import annotations

import os
from pathlib import Path

from sessionfiles.logbook import (append_text, atomic_write_text, read_events,
                                 trials_csv_columns, trials_csv_header, trials_csv_lines,
                                 trials_from_events)
from sessionfiles.logformat import decode_event

__all__ = ["TrialsTable"]


def _size(path) -> int | None:
    """A file's size in bytes, None if it is not there."""
    try:
        return os.stat(path).st_size
    except FileNotFoundError:
        return None


class TrialsTable:
    """``trials.csv`` at ``trials_path``, rebuilt from the events at ``events_path``
    (``durable``: fsynced, and always replaced atomically)."""

    def __init__(self, events_path, trials_path, *, durable: bool = True):
        self.events_path = Path(events_path)
        self.trials_path = Path(trials_path)
        self.durable = bool(durable)
        self._events_read: tuple = (0, None)    # (bytes of events.jsonl decoded, their events)
        self._text: tuple | None = None          # (trials.csv text, its size) as last written
        # the lines already formatted: (columns, header, {position of the row's event in the
        # log: (that event, the row, its line)}); a line is used again only for the same event
        # object at the same position and an equal row under the same columns
        self._lines: tuple = ((), "", {})

    def write(self) -> None:
        """Rebuild the table from the event log and write it (nothing if it is unchanged)."""
        events = self.events()
        sources: list = []
        rows = trials_from_events(events, sources=sources)
        aborted = {(e.get("trial_index"), e.get("attempt")): e.get("trace_file")
                   for e in events if e.get("event") == "trial_aborted"}
        for row in rows:  # an aborted row's trace_file comes from its event
            if row.get("status") == "aborted":
                row["trace_file"] = aborted.get((row.get("trial_index"), row.get("attempt")))
            else:
                row.setdefault("trace_file", None)
        text = self._table_text(rows, [events[i] for i in sources], sources)
        last = self._text
        if last is not None and text == last[0] and _size(self.trials_path) == last[1]:
            return                                      # the same table: nothing to write
        if not (last is not None and not self.durable and len(text) > len(last[0])
                and text.startswith(last[0])
                and append_text(self.trials_path, text[len(last[0]):], last[1], durable=False)):
            atomic_write_text(self.trials_path, text, durable=self.durable)
        self._text = (text, len(text.encode("utf-8")))

    def _table_text(self, rows, origins, positions) -> str:
        """``trials_csv_text(rows)[0]``, formatting only the rows not formatted before."""
        columns = tuple(trials_csv_columns(rows))
        cols, header, known = self._lines
        if columns != cols:
            header = trials_csv_header(columns)
            known = {}
        lines = [header]
        todo = []
        for row, ev, pos in zip(rows, origins, positions):
            hit = known.get(pos)
            if hit is not None and hit[0] is ev and hit[1] == row:
                lines.append(hit[2])
            else:
                todo.append((len(lines), row, ev, pos))
                lines.append(None)
        for (i, row, ev, pos), line in zip(todo, trials_csv_lines([t[1] for t in todo], columns)):
            lines[i] = line
            known[pos] = (ev, row, line)
        self._lines = (columns, header, known)
        return "".join(lines)

    def events(self) -> list:
        """The events of ``events.jsonl`` as :func:`~sessionfiles.logformat.read_events` reads
        them, decoding only the lines appended since the last call (the log only grows; any line
        that does not decode, a torn tail or a shorter file: read whole again)."""
        offset, events = self._events_read
        with open(self.events_path, "rb") as fh:
            if events is not None and os.fstat(fh.fileno()).st_size >= offset:
                fh.seek(offset)
            else:
                offset, events = 0, []
            data = fh.read()
        new = []
        try:
            if data and not data.endswith(b"\n"):
                raise ValueError("torn tail")
            for raw in data.split(b"\n")[:-1]:
                if raw.strip():
                    new.append(decode_event(raw))
        except (ValueError, UnicodeDecodeError):
            self._events_read = (0, None)
            return read_events(self.events_path, warn=False)[0]
        events = events + new      # a new list: rows of earlier calls keep theirs
        self._events_read = (offset + len(data), events)
        return events
