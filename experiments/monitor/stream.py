"""What a page has not seen yet: the update messages of the server-sent event stream.

Each page (each ``/events`` connection) has a :class:`Cursor`; :func:`update_for` returns the
part of the :class:`~experiments.monitor.folder.FolderView` the page lacks, as one JSON-ready
message (or None): ``meta`` (the session's record, once), ``problem`` (what is wrong with the
folder, or null), ``rows`` from ``rows_from`` (finished attempts), ``trace`` (the running
attempt's frames: ``reset`` with a new attempt, else the frames from ``from``; ``fault`` once the
attempt ended in one) and ``status`` (state, trial n of N, elapsed, time left: when it changed,
and once a second for the clocks). When the view read the log afresh (it was cut or replaced),
the page gets everything again, starting with ``rows_from`` 0 (the table cleared).
"""
from __future__ import annotations

import time
from dataclasses import dataclass

__all__ = ["Cursor", "update_for"]


@dataclass
class Cursor:
    meta_version: int = 0
    problem: object = ""          # "" (never sent) so that the first message says None too
    rows: int = 0
    trace_key: object = None
    trace_frames: int = 0
    trace_fault: bool = False
    version: int = -1
    status_at: float = 0.0
    generation: int = 0


def update_for(view, cursor: Cursor, now_s: float | None = None) -> dict | None:
    now_s = time.time() if now_s is None else now_s
    msg: dict = {}
    if cursor.generation != view.generation:       # the log was read afresh: so is the page
        cursor.__init__(generation=view.generation)
        msg["rows_from"], msg["rows"] = 0, []
    if view.meta is not None and cursor.meta_version != view.meta_version:
        msg["meta"] = view.meta_public()
        cursor.meta_version = view.meta_version
    if cursor.problem != view.problem:
        msg["problem"] = view.problem
        cursor.problem = view.problem
    if len(view.rows) > cursor.rows or "rows" in msg:
        msg["rows_from"], msg["rows"] = cursor.rows, view.rows[cursor.rows:]
        cursor.rows = len(view.rows)
    trace = _trace_part(view.live, cursor)
    if trace is not None:
        msg["trace"] = trace
    if cursor.version != view.version or now_s - cursor.status_at >= 1.0 or "trace" in msg:
        msg["status"] = view.status(now_s)
        cursor.version, cursor.status_at = view.version, now_s
    return msg or None


def _trace_part(live, cursor: Cursor) -> dict | None:
    if live is None:
        return None
    key = list(live.key)
    n = len(live.data)
    if cursor.trace_key != key:
        cursor.trace_key, cursor.trace_frames, cursor.trace_fault = key, 0, False
        part = {"key": key, "reset": True, "from": 0, **live.data.slice(0)}
    elif n > cursor.trace_frames:
        part = {"key": key, "reset": False, "from": cursor.trace_frames,
                **live.data.slice(cursor.trace_frames)}
    elif live.fault is not None and not cursor.trace_fault:
        part = {"key": key, "reset": False, "from": n, **live.data.slice(n)}
    else:
        return None
    cursor.trace_frames = n
    if live.fault is not None and not cursor.trace_fault:
        part["fault"] = live.fault
        cursor.trace_fault = True
    part["done"] = live.done
    return part
