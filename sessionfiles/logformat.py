"""The on-disk log format of a session folder, in one home (standard library only).

One concept: what ``events.jsonl``, ``trials.csv`` and ``traces/trial-NNN.csv`` hold and how
they are read back. The format has exactly one home, this module: event types, column lists,
the cell format, the trial-row projection and replay are here, and the tolerant readers
(:mod:`sessionfiles.logread`, which knows nothing of the columns or the event types) are
re-exported here, so a caller imports the whole format from this one module. The writer (:mod:`sessionfiles.logbook`, :mod:`sessionfiles.session_files`)
and the reader of record (:mod:`analysis.load`) both use this module, so that neither
re-implements the other; it imports nothing outside the standard library (no numpy, serial,
stimuli, pandas), so that :mod:`analysis` can use it without importing the runtime.

Events
------
Every event is a JSON object on its own line with ``event`` (its type), ``seq`` (1, 2, ...
per file) and ``time`` (UTC, ISO 8601 with milliseconds; a caller may pass its own ``time``),
plus:

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
    ``torn_bytes``, ``torn_tail`` (the cut bytes as text): written by
    :class:`sessionfiles.logbook.EventLog`.

Any other snake_case type may be logged (state changes, display faults, notes); only the
types above have required fields.  Non-finite floats are written as ``null``; numpy
scalars and arrays, paths, dates and dataclasses are converted (:func:`to_jsonable`).

Damage
------
A crash can only leave a *torn last line* of a file (appends are single writes). Every
reader here reads a file up to its first damaged line and says where it stopped, in one
message per damaged line naming the file and the line (:func:`read_events`,
:func:`read_csv_prefix`).
"""
from __future__ import annotations

import dataclasses
import datetime as _dt
import json
import math
import os
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Mapping

from sessionfiles.columns import ANALYSIS_ORDER, STATUSES, TRIALS, column, names
# the tolerant readers: their own module, part of this format (re-exported here)
from sessionfiles.logread import LogDamageWarning, LogReport, decode_event, read_csv_prefix, read_events

__all__ = [
    "REQUIRED_FIELDS", "event_problem", "CONTEXT_KEYS", "SPEC_KEYS",
    "TRIAL_COLUMNS", "PSYCHOPY_COLUMNS", "RENAMED_COLUMNS", "COLUMN_DECIMALS", "REQUIRED_COLUMNS", "OPTIONAL_COLUMNS", "STATUSES",
    "TRACE_COLUMNS", "FORCE_COLUMNS", "TRACE_DECIMALS",
    "to_jsonable", "dumps", "format_cell", "decode_event", "event_time",
    "LogDamageWarning", "LogReport", "read_events", "read_csv_prefix",
    "trials_from_events", "session_context", "SessionProgress", "replay",
]

# --------------------------------------------------------------------------- events
#: Required fields per event type (other types: none).
REQUIRED_FIELDS = {
    "session_started": ("session", "participant", "protocol_hash", "seed"),
    "session_resumed": ("session", "participant", "protocol_hash", "seed"),
    "trial_started": ("trial_index", "attempt"),
    "trial_completed": ("trial_index", "attempt", "row"),
    "trial_aborted": ("trial_index", "attempt", "reason"),
    "session_interrupted": ("reason",),
}

#: Keys of ``session_started`` / ``session_resumed`` copied onto every trial row.
CONTEXT_KEYS = ("participant", "group", "session", "skin_thickness_um", "sex", "date", "expName",
                "expStart", "protocol_version", "thermocue_version")
#: Keys of ``trial_started`` (the :class:`~experiments.schedule.TrialSpec`) copied onto its rows.
SPEC_KEYS = ("block", "mode", "roughness_id", "roughness_um", "repetition")

_EVENT_NAME = re.compile(r"^[a-z][a-z0-9_]{0,63}$")


def event_problem(event: Any, fields: Mapping[str, Any]) -> str | None:
    """What is wrong with an event about to be logged, or None.

    Parameters
    ----------
    event : str
        Its type.
    fields : mapping
        Its content (without ``event`` and ``seq``, which the log sets).

    Returns
    -------
    str or None
        ``"<event>.<field>: expected ..., got ..."`` (the caller prefixes the file).
    """
    if not isinstance(event, str) or not _EVENT_NAME.match(event):
        return f"event: expected a snake_case name, got {event!r}"
    for reserved in ("event", "seq"):
        if reserved in fields:
            return f"{event}.{reserved}: expected no value (set by the log), got {fields[reserved]!r}"
    missing = [k for k in REQUIRED_FIELDS.get(event, ()) if k not in fields]
    if missing:
        return f"{event}.{missing[0]}: expected a value, got nothing"
    if event == "trial_completed" and not isinstance(fields["row"], Mapping):
        return f"trial_completed.row: expected a mapping, got {fields['row']!r}"
    return None


# --------------------------------------------------------------------------- columns
#: Columns of ``trials.csv``, in this order, all of them from the first row on (docs/session.md,
#: "The trial table"): identity, design, stimulus, response, timing, quality, force; each defined
#: once, in :data:`sessionfiles.columns.TRIALS`. A key a row has beyond these (none written by
#: this version) follows, sorted.
TRIAL_COLUMNS = names()

#: Columns named and meant as in PsychoPy's own data files: ``date`` (``data.getDateStr()``,
#: local time), ``expName``, ``expStart`` (local time with its UTC offset), ``psychopyVersion``
#: and ``frameRate`` (``n/a`` when no PsychoPy window ran; empty when PsychoPy could not measure
#: the rate), ``thisN`` / ``thisRepN`` (the trial's and the repetition's 0-based counters).
PSYCHOPY_COLUMNS = names(psychopy=True)
#: Earlier names of renamed columns (read from older logs and files).
RENAMED_COLUMNS = {"started_at": "started_at_utc", "finished_at": "finished_at_utc"}

#: Decimals each float column of ``trials.csv`` is written with: the resolution of what
#: measured it (the display's 0.01 °C and 1 ms device clock, the keyboard's 0.1 ms), or 4
#: significant digits for modelled resistances ("sig4"). Unlisted floats keep their shortest
#: round-trip form.
COLUMN_DECIMALS = {c.name: c.decimals for c in TRIALS if c.decimals is not None}

#: Columns every trial row must have for analysis (docs/design.md, docs/internal-contracts.md
#: "Trials table"); all of them are in :data:`TRIAL_COLUMNS`.
REQUIRED_COLUMNS = tuple(n for n in ANALYSIS_ORDER if column(n).analysis == "required")
#: Optional columns for analysis and their kinds; missing ones are added empty (``attempt``
#: defaults to 1), with a warning but for :data:`~sessionfiles.columns.QUIET_COLUMNS`.
OPTIONAL_COLUMNS = {n: column(n).kind for n in ANALYSIS_ORDER
                    if column(n).analysis in ("optional", "quiet")}

#: Columns of ``traces/trial-NNN.csv``.
TRACE_COLUMNS = ("time_s", "target_C", "contact_C", "ambient_C", "finger_C",
                 "force1_N", "force2_N", "force3_N", "force4_N", "state")
#: The four force sensors' columns of a trace (their sum is the contact force).
FORCE_COLUMNS = TRACE_COLUMNS[5:9]
#: The numeric cells of a trace (time_s .. force4_N): 10 significant digits keep the device's
#: 10 µs time stamps and 0.01 °C / 0.01 N readings exact.
TRACE_DECIMALS = {c: "10g" for c in TRACE_COLUMNS if c != "state"}


# --------------------------------------------------------------------------- encoding
def event_time(event: Mapping[str, Any]) -> _dt.datetime | None:
    """An event's ``time`` (UTC, ISO 8601, as the writer stamps it) as an aware datetime, or None
    if it has none or an unreadable one (a naive time is read as UTC)."""
    text = event.get("time")
    if not isinstance(text, str):
        return None
    try:
        t = _dt.datetime.fromisoformat(text.replace("Z", "+00:00"))
    except ValueError:
        return None
    return t if t.tzinfo is not None else t.replace(tzinfo=_dt.timezone.utc)


def to_jsonable(obj: Any) -> Any:
    """A JSON-ready copy: non-finite floats -> None, numpy -> Python, Path/date -> str.

    Raises
    ------
    TypeError
        For an object with no JSON form.
    """
    t = type(obj)          # the exact types of nearly every value first (no ABC check)
    if t is str or t is int or t is bool or obj is None:
        return obj
    if t is float:
        return obj if math.isfinite(obj) else None
    if t is dict:
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if t is list or t is tuple:
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, (bool, str, int)):
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


def dumps(obj: Any, indent: int | None = None) -> str:
    """``obj`` as JSON text (:func:`to_jsonable` first); compact unless ``indent`` is given."""
    if indent is None:
        return dumps_jsonable(to_jsonable(obj))
    return json.dumps(to_jsonable(obj), ensure_ascii=False, allow_nan=False, indent=indent,
                      separators=None if indent else (",", ":"))


#: The compact form of :func:`dumps` (one encoder, made once).
_COMPACT = json.JSONEncoder(ensure_ascii=False, allow_nan=False, separators=(",", ":"))


def dumps_jsonable(obj: Any) -> str:
    """:func:`dumps` of a value :func:`to_jsonable` has already made JSON-ready (compact)."""
    return _COMPACT.encode(obj)


def format_cell(v: Any, column: str = "", decimals: Mapping[str, Any] = COLUMN_DECIMALS) -> str:
    """One CSV cell, as every file of a session folder writes it.

    Parameters
    ----------
    v : object
        The value.
    column : str
        Its column; ``decimals[column]`` says how a float is written: a number of decimals
        (trailing zeros cut, ``-0`` written ``0``), ``"sig4"`` (4 significant digits) or
        ``"10g"`` (10 significant digits, ``%.10g``); a column not listed keeps the shortest
        round-trip form (``repr``).
    decimals : mapping
        :data:`COLUMN_DECIMALS` (``trials.csv``, the default) or :data:`TRACE_DECIMALS`.

    Returns
    -------
    str
        ``""`` for None and non-finite floats; ``1``/``0`` for booleans; compact JSON for
        dicts and lists; ``str`` for anything else.
    """
    if v is None:
        return ""
    if isinstance(v, bool):
        return "1" if v else "0"
    if isinstance(v, float):
        if not math.isfinite(v):
            return ""
        places = decimals.get(column)
        if places == "sig4":
            return f"{v:.4g}"
        if places == "10g":
            return f"{v:.10g}"
        if places is not None:
            text = f"{v:.{places}f}".rstrip("0").rstrip(".")
            return "0" if text in ("-0", "") else text
        return repr(v)
    if isinstance(v, (dict, list, tuple)):
        return dumps(v)
    return str(v)


# --------------------------------------------------------------------------- trial rows
def session_context(events: Iterable[Mapping[str, Any]]) -> dict:
    """The :data:`CONTEXT_KEYS` of the latest ``session_started``/``session_resumed``."""
    ctx: dict[str, Any] = {}
    for ev in events:
        if ev.get("event") in ("session_started", "session_resumed"):
            ctx.update({k: ev[k] for k in CONTEXT_KEYS if k in ev})
    return ctx


def _shape_problem(kind: str, ev: Mapping[str, Any], key: tuple) -> str:
    """What makes a trial outcome event unusable as a row (``""`` when nothing)."""
    for name, value in zip(("trial_index", "attempt"), key):
        if not isinstance(value, (int, str)) or isinstance(value, bool):
            return f"{name}: expected an integer, got {value!r}"
    if kind == "trial_completed" and not isinstance(ev.get("row"), Mapping):
        return f"row: expected a mapping, got {ev.get('row')!r}"
    return ""


def trials_from_events(events: Iterable[Mapping[str, Any]], *, sources: list | None = None,
                       damage: list | None = None) -> list[dict]:
    """The rows of ``trials.csv``, rebuilt from the event log.

    Parameters
    ----------
    events : iterable of dict
        As returned by :func:`read_events`.
    sources : list, optional
        If given, the position (in ``events``) of the event each row comes from is appended.
    damage : list, optional
        If given, a second event for an attempt is reported here (one message each)
        instead of as a :class:`LogDamageWarning`.

    Returns
    -------
    list of dict
        In log order: one row per ``trial_completed`` (its ``row``) and one per
        ``trial_aborted`` (status ``"aborted"``, plus ``abort_reason``).  Each row is
        completed from the session context (:data:`CONTEXT_KEYS` of the latest
        ``session_started``/``session_resumed``) and the attempt's ``trial_started``
        (:data:`SPEC_KEYS` and ``started_at``, its ``time``); the row's own values win.
        ``correct`` is filled from ``response_id == roughness_id`` (the values as logged)
        when the row lacks it.  A second event for the same (trial_index, attempt) is
        ignored.
    """
    ctx: dict[str, Any] = {}
    starts: dict[tuple, Mapping] = {}
    seen: set[tuple] = set()
    rows: list[dict] = []
    for position, ev in enumerate(events):
        kind = ev.get("event")
        if kind in ("session_started", "session_resumed"):
            ctx.update(session_context([ev]))
        elif kind == "trial_started":
            try:
                starts[(ev.get("trial_index"), ev.get("attempt"))] = ev
            except TypeError:           # a damaged event (a list or object as index): no spec
                pass
        elif kind in ("trial_completed", "trial_aborted"):
            key = (ev.get("trial_index"), ev.get("attempt"))
            shape = _shape_problem(kind, ev, key)
            if shape:                   # a damaged event: not a row (reported, not raised)
                note = f"{kind} event (seq {ev.get('seq')}): {shape}; ignored"
                if damage is None:
                    warnings.warn(f"events: {note}", LogDamageWarning, stacklevel=2)
                else:
                    damage.append(note)
                continue
            if key in seen:
                note = (f"trial {key[0]} attempt {key[1]}: a second {kind} event "
                        f"(seq {ev.get('seq')}) ignored")
                if damage is None:
                    warnings.warn(f"events: {note}", LogDamageWarning, stacklevel=2)
                else:
                    damage.append(note)
                continue
            seen.add(key)
            start = starts.get(key, {})
            row: dict[str, Any] = dict(ctx)
            row.update({k: start[k] for k in SPEC_KEYS if k in start})
            row["trial_index"], row["attempt"] = key
            if "time" in start:
                row["started_at_utc"] = start["time"]
            if kind == "trial_completed":
                row.update({RENAMED_COLUMNS.get(k, k): v for k, v in ev["row"].items()})
                row.setdefault("status", "ok")
                if row.get("correct") is None and row.get("response_id") is not None \
                        and row.get("roughness_id") is not None:
                    row["correct"] = int(row["response_id"] == row["roughness_id"])
            else:
                row["status"] = "aborted"
                row["abort_reason"] = ev.get("reason")
                if ev.get("fault_code") is not None:
                    row["fault_code"] = ev["fault_code"]
            _psychopy_counters(row)
            rows.append(row)
            if sources is not None:
                sources.append(position)
    return rows


def _psychopy_counters(row: dict) -> None:
    """PsychoPy's 0-based loop counters beside the 1-based ones; ``n/a`` for what only a
    PsychoPy window has when none ran."""
    for one, zero in (("trial_index", "thisN"), ("repetition", "thisRepN")):
        v = row.get(one)
        if isinstance(v, int) and not isinstance(v, bool):
            row[zero] = v - 1
    if row.get("psychopyVersion") in (None, ""):
        row["psychopyVersion"] = "n/a"
        row.setdefault("frameRate", "n/a")


# --------------------------------------------------------------------------- replay
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
