"""Load every session under a data directory into one tidy, validated trials table.

A session directory is any folder holding ``trials.csv`` or ``events.jsonl``
(normally ``DATA/<participant>/<session>/``). For each session:

1. ``trials.csv`` is read up to the first damaged line (a torn last line, a row
   with the wrong number of fields, undecodable bytes); the damage is reported
   as a :class:`~analysis.errors.LogWarning` naming the file and the line.
2. ``events.jsonl`` (the source of truth) is read the same way and its trial
   rows rebuilt by the rules of ``experiments.logbook`` (``trial_completed``
   rows completed from ``session_started`` and ``trial_started``;
   ``trial_aborted`` as status ``aborted``; see :func:`read_trial_events`).
   Columns still missing (participant, session, group) come from
   ``session.json`` or the folder names.
3. ``trials.csv`` is used unless it is missing or *older* than the event log,
   which is judged by content, not by modification time (the session appends a
   closing event after its last rewrite of ``trials.csv``, so the log is
   normally the newer file): the table is rebuilt from the events when they hold
   trials (``trial_index``, ``attempt``) that ``trials.csv`` lacks.

Sessions of a protocol that asks for no answers (no block with ``response = true`` in
``session.json``'s protocol, e.g. Exp. 1's ``interface_temperature``, recorded for calibration
in the same data folder) are not roughness-recognition sessions: they are skipped with a
warning and listed in :attr:`TrialLog.sessions` with their ``skipped`` reason.
Optional columns missing from a session's table are filled with blanks, with a warning.

Rows are then validated (required columns, types, allowed values, duplicate
``(participant, session, trial_index, attempt)`` keys, ``correct`` consistent with
``response_id == roughness_id``) and marked ``included`` or given an
``exclusion`` reason: an unscored block ("familiarisation" for a block named ``familiarise``,
"unscored block" for any other, e.g. the protocol's ``review``), a non-ok status, or an ok
attempt superseded by a later ok attempt of the same trial.

Which sessions are analysed is an explicit policy (``sessions``): by default the first
complete session of each participant (``session_finished`` in its log), or ``"latest"`` (the
last complete one) or ``"all"`` (every session, complete or not). Rows of the other sessions are
kept, with the exclusion ``"session not analysed"``; :attr:`TrialLog.sessions` lists every
session with ``complete``, ``n_done``/``n_planned``, ``analysed`` and the ``reason``.

Which blocks are scored and answered is read from each session's ``session.json``
(``blocks``: ``name``, ``scored``, ``response``, ``feedback``, written by the session), else from
its stored protocol's ``[[blocks]]`` (``response`` defaults to true, ``scored`` to
``response``), else, for logs with neither, a block named ``familiarise`` is the one unscored
block. Any block name works.
"""
from __future__ import annotations

import csv
import io
import json
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from .errors import LogError, LogWarning

__all__ = [
    "TrialLog",
    "load_trials",
    "load_session",
    "read_trials_csv",
    "read_trial_events",
    "not_recognition_reason",
    "block_roles",
    "REQUIRED_COLUMNS",
    "STATUSES",
]

#: Columns every trial row must have (DESIGN.md, docs/internal-contracts.md "Trials table").
REQUIRED_COLUMNS = ("participant", "group", "session", "block", "trial_index", "mode",
                    "roughness_id", "response_id", "correct", "status")
#: Optional columns and their kinds; missing ones are added empty (``attempt`` defaults to 1).
OPTIONAL_COLUMNS = {"roughness_um": "float", "repetition": "int", "rt_s": "float",
                    "tracking_rms_C": "float", "skin_thickness_um": "float", "sex": "str",
                    "attempt": "int", "started_at": "str", "fault_code": "str"}
STATUSES = ("ok", "fault", "aborted")
MODES = ("real", "simulated", "familiarise")
GROUPS = ("A", "B")
FAMILIARISE = "familiarise"
N_ROUGHNESS = 4
_PAYLOAD_KEYS = ("row", "trial", "data", "record")


@dataclass
class TrialLog:
    """Every trial row read, validated, with its inclusion status.

    Attributes
    ----------
    trials : pandas.DataFrame
        One row per logged trial attempt: the contract's columns, typed, plus
        ``source`` (file the row came from), ``line`` (its line in that file),
        ``included`` (bool) and ``exclusion`` (reason, ``""`` when included).
    sessions : pandas.DataFrame
        One row per session folder read or skipped for its protocol: ``participant``,
        ``group``, ``session``, ``path``, ``source`` (``"trials.csv"`` or
        ``"events.jsonl"``; ``"session.json"`` for a skipped session), ``n_rows``,
        ``skipped`` (why the session was skipped for its protocol, ``""`` otherwise),
        ``complete`` (its log says it finished), ``n_done`` and ``n_planned`` (trials completed
        ok, trials in its schedule), ``analysed`` and ``reason`` (why it is, or is not, analysed
        under the inclusion policy).
    warnings : list of str
        Every problem that was worked around (also issued as :class:`LogWarning`).
    """

    trials: pd.DataFrame
    sessions: pd.DataFrame
    warnings: list = field(default_factory=list)
    #: The inclusion policy the sessions were chosen by ("first", "latest" or "all").
    policy: str = "first"

    @property
    def analysable(self) -> pd.DataFrame:
        """The rows used for inference (ok, not familiarisation, last ok attempt)."""
        return self.trials[self.trials["included"]].reset_index(drop=True)

    @property
    def skipped_sessions(self) -> pd.DataFrame:
        """The session folders not analysed because of their protocol (``skipped`` reason set)."""
        return self.sessions[self.sessions["skipped"] != ""].reset_index(drop=True)

    def exclusion_counts(self) -> pd.DataFrame:
        """Number of rows per exclusion reason (``"included"`` for the kept ones)."""
        reason = self.trials["exclusion"].where(~self.trials["included"], "included")
        out = reason.value_counts().rename_axis("reason").reset_index(name="n_trials")
        return out.sort_values("reason", ignore_index=True)


# --------------------------------------------------------------------------- readers

def _warn(messages: list, text: str) -> None:
    messages.append(text)
    warnings.warn(text, LogWarning, stacklevel=3)


def _decode_prefix(raw: bytes, path: Path, messages: list) -> str:
    """Decode ``raw`` as UTF-8 up to the first NUL or undecodable byte."""
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
        _warn(messages, f"{path}: line {line}: damaged bytes from here on; read the lines before it")
        text = text[: text.rfind("\n") + 1]      # the damaged line is not trusted either
    return text


def read_trials_csv(path, messages: list | None = None) -> pd.DataFrame:
    """Read a ``trials.csv`` up to its first damaged line.

    Parameters
    ----------
    path : str or Path
        The file.
    messages : list of str, optional
        Warnings are appended here (and issued as :class:`LogWarning`).

    Returns
    -------
    pandas.DataFrame
        All columns as strings (``""`` for empty cells) plus ``line`` (1-based
        line number in the file). Extra columns (PsychoPy-style wide CSV) are kept.

    Raises
    ------
    LogError
        If the file has no header line.
    """
    path = Path(path)
    messages = [] if messages is None else messages
    text = _decode_prefix(path.read_bytes(), path, messages)
    if text and not text.endswith("\n"):
        torn = text.count("\n") + 1
        _warn(messages, f"{path}: line {torn}: torn last line (no newline at its end); ignored")
        text = text[: text.rfind("\n") + 1]
    reader = csv.reader(io.StringIO(text))
    header = next(reader, None)
    if not header or not any(h.strip() for h in header):
        raise LogError(f"{path}: header: expected a CSV header line, got {''.join(header or [])!r}")
    header = [h.strip() for h in header]
    rows, lines = [], []
    for row in reader:
        if not row or all(not c.strip() for c in row):
            continue
        if len(row) != len(header):
            _warn(messages, f"{path}: line {reader.line_num}: expected {len(header)} fields, "
                            f"got {len(row)}; read the {len(rows)} rows before it")
            break
        rows.append(row)
        lines.append(reader.line_num)
    df = pd.DataFrame(rows, columns=header, dtype=object)
    df["line"] = lines
    return df


_CONTEXT_KEYS = ("participant", "group", "session", "skin_thickness_um", "sex")
_SPEC_KEYS = ("block", "mode", "roughness_id", "roughness_um", "repetition")


def _scalars(mapping: dict) -> dict:
    return {k: v for k, v in mapping.items() if not isinstance(v, (dict, list))}


def _payload(event: dict) -> dict | None:
    """A trial row carried by an event of another writer (``trial``/``row``/... member or top level)."""
    for key in _PAYLOAD_KEYS:
        inner = event.get(key)
        if isinstance(inner, dict) and "trial_index" in inner:
            return {**_scalars(event), **_scalars(inner)}
    if "trial_index" in event:
        return _scalars(event)
    return None


def read_trial_events(path, messages: list | None = None) -> tuple[pd.DataFrame, dict]:
    """Rebuild the trial rows of an ``events.jsonl``, reading up to its first damaged line.

    Parameters
    ----------
    path : str or Path
        The event log.
    messages : list of str, optional
        Warnings are appended here (and issued as :class:`LogWarning`).

    Returns
    -------
    trials : pandas.DataFrame
        One row per trial attempt, in log order (columns as logged, plus ``line``).
    context : dict
        Session-level values (``participant``, ``group``, ``session``, ``sex``,
        ``skin_thickness_um``) from ``session_started``/``session_resumed``.

    Notes
    -----
    The rules of ``experiments.logbook`` (re-implemented here so that analysis
    does not import the experiment runtime): a ``trial_completed`` event gives
    one row, its ``row`` member completed by the session context, the
    attempt's ``trial_started`` event (``block``, ``mode``, ``roughness_id``,
    ``roughness_um``, ``repetition``; its ``time`` as ``started_at``) and the
    event's ``trial_index``/``attempt`` (the row's own values win; ``status``
    defaults to ``ok``; ``correct`` is derived from ``response_id ==
    roughness_id`` when missing). A ``trial_aborted`` event gives a row with
    status ``aborted``. Only in a log without such events, events of other types
    whose payload (the event or its ``trial``/``data``/``record`` member) holds
    ``trial_index`` and a final ``status`` are taken as rows. A second event for the same
    ``(trial_index, attempt)`` is ignored, as ``experiments`` does.
    """
    path = Path(path)
    messages = [] if messages is None else messages
    text = _decode_prefix(path.read_bytes(), path, messages)
    lines = text.split("\n")
    torn_last = bool(text) and not text.endswith("\n")
    context: dict = {}
    starts: dict = {}
    rows: dict = {}
    others: dict = {}        # rows from events of other writers, used only if the log has no trial_* rows
    for number, line in enumerate(lines, start=1):
        if not line.strip():
            continue
        try:
            event = json.loads(line)
        except json.JSONDecodeError:
            what = "torn last line" if number == len(lines) and torn_last else "not a JSON object"
            _warn(messages, f"{path}: line {number}: {what}; read the lines before it")
            break
        if not isinstance(event, dict):
            _warn(messages, f"{path}: line {number}: not a JSON object; read the lines before it")
            break
        kind = event.get("event")
        if kind in ("session_started", "session_resumed"):
            context.update({k: event[k] for k in _CONTEXT_KEYS
                            if isinstance(event.get(k), (str, int, float))
                            and not isinstance(event.get(k), bool)})
            continue
        key = (_int_text(event.get("trial_index")), _int_text(event.get("attempt")))
        if kind == "trial_started":
            spec = {k: event[k] for k in _SPEC_KEYS if k in event}
            if "time" in event:
                spec["started_at"] = event["time"]
            starts[key] = spec
            continue
        if kind in ("trial_completed", "trial_aborted"):
            row = {**context, **starts.get(key, {}),
                   "trial_index": event.get("trial_index"), "attempt": event.get("attempt", 1)}
            if kind == "trial_completed":
                inner = event.get("row")
                row.update(_scalars(inner) if isinstance(inner, dict) else {})
                row.setdefault("status", "ok")
                if row.get("correct") in (None, "") and row.get("response_id") not in (None, "") \
                        and row.get("roughness_id") not in (None, ""):
                    row["correct"] = int(str(row["response_id"]) == str(row["roughness_id"]))
            else:
                row["status"] = "aborted"
                if event.get("reason") is not None:
                    row["abort_reason"] = event["reason"]
                if event.get("fault_code") is not None:
                    row["fault_code"] = event["fault_code"]
        else:
            payload = _payload(event)
            if payload is None or payload.get("status") not in STATUSES:
                continue
            row = {**context, **payload}
        row = {k: v for k, v in row.items() if k not in ("event", "seq", "time")}
        row["line"] = number
        key = (_int_text(row.get("trial_index")), _int_text(row.get("attempt")))
        (rows if kind in ("trial_completed", "trial_aborted") else others).setdefault(key, row)
    return pd.DataFrame(list((rows or others).values())), context


def _session_meta(folder: Path) -> dict:
    """``session.json`` as a dict, or ``{}`` when missing or unreadable (reported elsewhere)."""
    try:
        data = json.loads((folder / "session.json").read_text("utf-8"))
    except (OSError, ValueError, UnicodeDecodeError):
        return {}
    return data if isinstance(data, dict) else {}


def not_recognition_reason(meta: dict) -> str:
    """Why a session's protocol is not a roughness-recognition protocol (``""`` if it is).

    Parameters
    ----------
    meta : dict
        The session's ``session.json``; its ``protocol`` member is the protocol's TOML as
        parsed (``[protocol]`` table, ``[[blocks]]`` list).

    Returns
    -------
    str
        ``""`` when any block asks for an answer (``response`` true, the default) or when the
        protocol cannot be judged (no stored protocol or blocks: loaded as before); otherwise
        a reason naming the protocol, e.g. Exp. 1's ``interface_temperature``, whose single
        block records contact traces and asks for no answer.

    Notes
    -----
    A block's ``response`` decides rather than ``[protocol] experiment``: the experiment
    number is informative (0 when a custom protocol leaves it out), whereas a protocol
    without a block asking for an answer has no recognition trial to analyse.
    """
    protocol = meta.get("protocol")
    if not isinstance(protocol, dict):
        return ""
    blocks = protocol.get("blocks")
    if not isinstance(blocks, list) or not blocks or not all(isinstance(b, dict) for b in blocks):
        return ""
    if any(b.get("response", True) is not False for b in blocks):
        return ""
    head = protocol.get("protocol") if isinstance(protocol.get("protocol"), dict) else {}
    name = head.get("name", meta.get("protocol_name", "unnamed"))
    experiment = f" (experiment {head['experiment']})" if "experiment" in head else ""
    names = ", ".join(repr(str(b.get("name", "?"))) for b in blocks)
    which = f"block {names} has" if len(blocks) == 1 else f"blocks {names} have"
    return (f"expected a roughness-recognition protocol (a block asking for an answer), got "
            f"{name!r}{experiment}, whose {which} response = false")


def block_roles(meta: dict) -> dict:
    """Block name -> ``{"scored": bool, "response": bool}`` from a session's ``session.json``.

    ``blocks`` (written by the session) first, else the stored protocol's ``[[blocks]]`` with
    their defaults (``response`` true, ``scored`` = ``response``); ``{}`` when neither is there.
    """
    listed = meta.get("blocks")
    if not isinstance(listed, list):
        protocol = meta.get("protocol")
        listed = protocol.get("blocks") if isinstance(protocol, dict) else None
    if not isinstance(listed, list):
        return {}
    roles = {}
    for b in listed:
        if not isinstance(b, dict) or not isinstance(b.get("name"), str):
            continue
        response = b.get("response", True) is not False
        roles[b["name"]] = {"scored": b.get("scored", response) is not False, "response": response}
    return roles


def _session_context(folder: Path, messages: list) -> dict:
    """participant/session/group/sex from ``session.json`` (tolerant); ``{}`` if unreadable."""
    meta = folder / "session.json"
    if not meta.exists():
        return {}
    try:
        data = json.loads(meta.read_text("utf-8"))
    except (ValueError, UnicodeDecodeError):
        _warn(messages, f"{meta}: not valid JSON; participant and session taken from the event log "
                        f"or the folder names")
        return {}
    if not isinstance(data, dict):
        return {}
    found: dict = {}

    def scan(source: dict, aliases: dict) -> None:
        for key, names in aliases.items():
            for name in names:
                value = source.get(name)
                if isinstance(value, (str, int)) and not isinstance(value, bool):
                    found.setdefault(key, value)
                    break

    scan(data, {"participant": ("participant", "participant_id"), "session": ("session", "session_id"),
                "group": ("group",), "sex": ("sex",)})
    for name in ("participant", "assignment", "group_assignment"):
        if isinstance(data.get(name), dict):
            scan(data[name], {"participant": ("id", "participant_id"), "group": ("group",),
                              "sex": ("sex",)})
    return found


# --------------------------------------------------------------------------- validation

def _blank(series: pd.Series) -> pd.Series:
    return series.isna() | series.astype(str).str.strip().isin(["", "nan", "None", "NaN"])


def _as_str(series: pd.Series) -> pd.Series:
    out = series.astype(object).where(~_blank(series), "")
    return out.map(lambda v: str(v).strip() if not isinstance(v, float) or not np.isnan(v) else "")


def _as_number(df: pd.DataFrame, column: str, *, integer: bool, allow_blank) -> pd.Series:
    """Parse ``column`` as numbers; LogError names the file, column and line of the first bad cell."""
    series = df[column].astype(object)
    series = series.map(lambda v: {True: 1, False: 0, "True": 1, "False": 0, "true": 1,
                                   "false": 0}.get(v, v) if isinstance(v, (bool, str)) else v)
    blank = _blank(series)
    values = pd.to_numeric(series.where(~blank, np.nan), errors="coerce")
    bad = (~blank & values.isna())
    if integer:
        bad |= ~blank & values.notna() & (values != np.round(values))
    if not isinstance(allow_blank, pd.Series):
        allow_blank = pd.Series(bool(allow_blank), index=df.index)
    bad |= blank & ~allow_blank
    if bad.any():
        i = bad.idxmax()
        what = "an integer" if integer else "a number"
        raise LogError(f"{df.at[i, 'source']}: {column}: expected {what} (line {df.at[i, 'line']}), "
                       f"got {df.at[i, column]!r}")
    return values


def _check_allowed(values: pd.Series, allowed, df, column, *, mask=None) -> None:
    bad = ~values.isin(allowed)
    if mask is not None:
        bad &= mask
    if bad.any():
        i = bad.idxmax()
        raise LogError(f"{df.at[i, 'source']}: {column}: expected one of {', '.join(map(str, allowed))} "
                       f"(line {df.at[i, 'line']}), got {df.at[i, column]!r}")


def _require_columns(df: pd.DataFrame, path: Path) -> None:
    missing = [c for c in REQUIRED_COLUMNS if c not in df.columns]
    if missing:
        raise LogError(f"{path}: {missing[0]}: expected a column named {missing[0]!r}, "
                       f"got columns {sorted(c for c in df.columns if c != 'line')!r}")


def _validate(df: pd.DataFrame) -> pd.DataFrame:
    """Type and check rows (of any number of sessions; ``source`` and ``line`` say where from)."""
    out = pd.DataFrame(index=df.index)
    for column in ("participant", "session", "group", "block", "mode", "status"):
        out[column] = _as_str(df[column])
    for column in ("participant", "session"):
        if (out[column] == "").any():
            i = (out[column] == "").idxmax()
            raise LogError(f"{df.at[i, 'source']}: {column}: expected a non-empty value (line {df.at[i, 'line']}), got ''")
    _check_allowed(out["status"], STATUSES, df, "status")
    named = (out["block"] == FAMILIARISE) | (out["mode"] == FAMILIARISE)
    if "_scored" in df.columns:   # the session's own block roles (session.json), else the name
        known = df["_scored"].notna()
        scored = df["_scored"].where(known, ~named).astype(bool)
        answered = df["_answered"].where(known, ~named).astype(bool)
    else:
        scored, answered = ~named, ~named
    familiar = ~scored.to_numpy()
    _check_allowed(out["mode"], MODES, df, "mode")
    _check_allowed(out["group"], GROUPS, df, "group")
    ok = out["status"] == "ok"
    out["trial_index"] = _as_number(df, "trial_index", integer=True, allow_blank=False).astype("int64")
    out["roughness_id"] = _as_number(df, "roughness_id", integer=True, allow_blank=False).astype("int64")
    _check_allowed(out["roughness_id"], range(1, N_ROUGHNESS + 1), df, "roughness_id")
    unanswered = ~ok | ~answered.to_numpy() | familiar
    response = _as_number(df, "response_id", integer=True, allow_blank=unanswered)
    _check_allowed(response, list(range(1, N_ROUGHNESS + 1)), df, "response_id",
                   mask=response.notna())
    out["response_id"] = response.astype("Int64")
    correct = _as_number(df, "correct", integer=True, allow_blank=unanswered)
    _check_allowed(correct, [0, 1], df, "correct", mask=correct.notna())
    out["correct"] = correct.astype("Int64")
    both = correct.notna() & response.notna()
    mismatch = both & ((response == out["roughness_id"]).astype(int) != correct)
    if mismatch.any():
        i = mismatch.idxmax()
        raise LogError(f"{df.at[i, 'source']}: correct: expected {int(response[i] == out.at[i, 'roughness_id'])} "
                       f"for response_id {int(response[i])} on roughness_id "
                       f"{out.at[i, 'roughness_id']} (line {df.at[i, 'line']}), got {df.at[i, 'correct']!r}")
    for column, kind in OPTIONAL_COLUMNS.items():
        if column not in df.columns:
            if column == "attempt":
                out[column] = pd.Series(1, index=df.index, dtype="Int64")
            else:
                out[column] = pd.Series(pd.NA if kind == "int" else (np.nan if kind == "float" else ""),
                                        index=df.index, dtype="Int64" if kind == "int" else None)
            continue
        if kind == "str":
            out[column] = _as_str(df[column])
        else:
            values = _as_number(df, column, integer=kind == "int", allow_blank=True)
            if column == "attempt":
                values = values.fillna(1)
            out[column] = values.astype("Int64") if kind == "int" else values.astype(float)
    # Written by sessions since issue 10; older logs lack them (blank, without a warning).
    # (Floats: 1/0/NaN for the flag, blank where no thermometer reading was taken.)
    for column, integer in (("skin_temperature_C", False), ("skin_temperature_in_range", True),
                            ("contact_force_N", False)):   # the display's force (issue 12)
        if column in df.columns:
            out[column] = _as_number(df, column, integer=integer, allow_blank=True).astype(float)
        else:
            out[column] = pd.Series(np.nan, index=df.index, dtype=float)
    # why an attempt was aborted (experiments.logbook: trial_aborted's reason); kept, not required
    out["abort_reason"] = _as_str(df["abort_reason"]) if "abort_reason" in df.columns else ""
    out["familiarisation"] = familiar
    out["source"] = df["source"].astype(str).to_numpy()
    out["line"] = df["line"].astype("int64").to_numpy()
    return out


def _fill_from_context(df: pd.DataFrame, context: dict) -> pd.DataFrame:
    for key, value in context.items():
        if key not in df.columns or _blank(df[key]).all():
            df[key] = value
        else:
            df[key] = df[key].where(~_blank(df[key]), value)
    return df


# --------------------------------------------------------------------------- sessions

def load_session(folder, messages: list | None = None) -> tuple[pd.DataFrame, str]:
    """Read and validate one session folder.

    Parameters
    ----------
    folder : str or Path
        A folder with ``trials.csv`` and/or ``events.jsonl``.
    messages : list of str, optional
        Warnings are appended here.

    Returns
    -------
    trials : pandas.DataFrame
        The rows as read (strings or JSON values), with ``source`` (the file)
        and ``line``; typed and checked later by :func:`load_trials`.
    source : str
        ``"trials.csv"`` or ``"events.jsonl"``: the file the rows came from
        (``""`` and an empty table, with a warning, for a session without trials).

    Raises
    ------
    LogError
        Unusable input; the message names the file and the column.
    """
    folder = Path(folder)
    messages = [] if messages is None else messages
    csv_path, events_path = folder / "trials.csv", folder / "events.jsonl"
    table = events = None
    ev_ctx: dict = {}
    if events_path.exists():
        events, ev_ctx = read_trial_events(events_path, messages)
    if csv_path.exists():
        try:
            table = read_trials_csv(csv_path, messages)
        except LogError as exc:             # e.g. an empty file left by a crash
            if events is None or events.empty:
                raise
            _warn(messages, f"{exc}; using {events_path.name} instead")
    # session.json first, then the event log, then the folder names
    ctx = {"participant": folder.parent.name, "session": folder.name, **ev_ctx,
           **_session_context(folder, messages)}
    use_events = False
    if table is None:
        if events is None or events.empty:
            _warn(messages, f"{folder}: no trial rows (no trials.csv, no finished trial in "
                            f"events.jsonl); session skipped")
            return pd.DataFrame(), ""
        if not csv_path.exists():
            _warn(messages, f"{csv_path}: missing; rebuilt {len(events)} rows from {events_path}")
        use_events = True
    elif events is not None and not events.empty and "trial_index" in table.columns:
        def keys(df):
            attempts = df["attempt"] if "attempt" in df.columns else [1] * len(df)
            return {(_int_text(t), _int_text(a)) for t, a in zip(df["trial_index"], attempts)}
        lacking = keys(events) - keys(table)
        if lacking:
            _warn(messages, f"{csv_path}: older than {events_path.name} ({len(lacking)} trial rows "
                            f"missing); rebuilt {len(events)} rows from {events_path}")
            use_events = True
    if use_events:
        rows, path = _fill_from_context(events, ctx), events_path
    else:
        rows, path = table, csv_path
    if rows.empty:
        _warn(messages, f"{path}: no trial rows; session skipped")
        return pd.DataFrame(), ""
    rows = rows.reset_index(drop=True)
    _require_columns(rows, path)
    missing = [c for c in OPTIONAL_COLUMNS if c not in rows.columns]
    if missing:
        how = "blank" + ("; attempt taken as 1" if "attempt" in missing else "")
        _warn(messages, f"{path}: {', '.join(missing)}: expected optional column(s) "
                        f"{', '.join(missing)}, got none; filled with {how}")
    rows["source"] = str(path)
    return rows, path.name


def _int_text(value) -> str:
    """A trial_index/attempt cell as canonical text (blank attempt -> "1")."""
    if value is None or (isinstance(value, float) and np.isnan(value)) or str(value).strip() == "":
        return "1"
    try:
        return str(int(float(value)))
    except (TypeError, ValueError):
        return str(value)


#: Inclusion policies of :func:`load_trials` (``thermocue analyze --sessions``).
SESSION_POLICIES = ("first", "latest", "all")


def _session_state(folder: Path, meta: dict) -> dict:
    """``complete``, ``n_done``, ``n_planned`` and ``created_at`` of one session folder."""
    done, finished = set(), False
    try:
        lines = (folder / "events.jsonl").read_text("utf-8", errors="replace").splitlines()
    except OSError:
        lines = []
    for line in lines:
        try:
            ev = json.loads(line)
        except ValueError:
            continue
        if not isinstance(ev, dict):
            continue
        if ev.get("event") == "session_finished":
            finished = True
        elif ev.get("event") == "trial_completed" and isinstance(ev.get("row"), dict) \
                and ev["row"].get("status", "ok") == "ok":
            done.add(ev.get("trial_index"))
    planned = meta.get("schedule")
    n_planned = len(planned) if isinstance(planned, list) else np.nan
    if not lines:
        # No event log (a trials table alone, e.g. exported elsewhere): complete when it holds
        # every planned trial, or when nothing says how many were planned.
        try:
            with open(folder / "trials.csv", newline="", encoding="utf-8") as fh:
                table = [r for r in csv.DictReader(fh) if r.get("status", "ok") == "ok"]
        except (OSError, UnicodeDecodeError, csv.Error):
            table = []
        done = {r.get("trial_index") for r in table}
        finished = bool(table) and (np.isnan(n_planned) or len(done) >= n_planned)
    return {"complete": finished, "n_done": len(done), "n_planned": n_planned,
            "created_at": str(meta.get("created_at", ""))}


def _apply_policy(sessions: pd.DataFrame, policy: str) -> pd.DataFrame:
    """Mark each session ``analysed`` (bool) with its ``reason`` under ``policy``."""
    analysed, reasons = [], []
    for _, row in sessions.iterrows():
        if row["skipped"]:
            analysed.append(False)
            reasons.append(f"skipped: {row['skipped']}")
            continue
        if policy == "all":
            analysed.append(True)
            reasons.append("analysed (--sessions all)" + ("" if row["complete"] else
                           f"; incomplete: {row['n_done']} of {_int_text(row['n_planned'])} trials"))
            continue
        mine = sessions[(sessions["participant"] == row["participant"]) & (sessions["skipped"] == "")
                        & sessions["complete"]].sort_values(["created_at", "session"])
        chosen = None if mine.empty else (mine.iloc[0] if policy == "first" else mine.iloc[-1])
        if chosen is not None and chosen["path"] == row["path"]:
            analysed.append(True)
            reasons.append(f"analysed: the {policy} complete session of {row['participant']}")
        elif not row["complete"]:
            analysed.append(False)
            reasons.append(f"incomplete: {row['n_done']} of {_int_text(row['n_planned'])} trials")
        else:
            analysed.append(False)
            reasons.append(f"repeated session: {row['participant']}'s {policy} complete session "
                           f"is {chosen['session']}")
    out = sessions.copy()
    out["analysed"] = analysed
    out["reason"] = reasons
    return out


def _session_folders(root: Path) -> list[Path]:
    found = {p.parent for name in ("trials.csv", "events.jsonl") for p in root.rglob(name)}
    return sorted(found)


def _mark_inclusion(trials: pd.DataFrame) -> pd.DataFrame:
    exclusion = pd.Series("", index=trials.index, dtype=object)
    exclusion[trials["status"] != "ok"] = "status " + trials["status"]
    unscored = trials["familiarisation"]
    exclusion[unscored] = np.where(trials.loc[unscored, "block"] == FAMILIARISE, "familiarisation",
                                   "unscored block")
    ok = exclusion == ""
    key = ["participant", "session", "trial_index"]
    last = trials[ok].groupby(key)["attempt"].transform("max")
    superseded = pd.Series(False, index=trials.index)
    superseded[last.index] = trials.loc[last.index, "attempt"] < last
    exclusion[superseded] = "superseded attempt"
    trials["exclusion"] = exclusion
    trials["included"] = exclusion == ""
    return trials


def load_trials(data_dir, sessions: str = "first") -> TrialLog:
    """Load, validate and combine every session under ``data_dir``.

    Parameters
    ----------
    data_dir : str or Path
        A data directory (``DATA/<participant>/<session>/...``); any folder that
        holds ``trials.csv`` or ``events.jsonl`` below it is a session.
    sessions : {"first", "latest", "all"}
        Which sessions are analysed: each participant's first complete session (default),
        the latest complete one, or all of them (incomplete ones included).

    Returns
    -------
    TrialLog
        The tidy table of every row, the sessions and the warnings.

    Raises
    ------
    LogError
        ``data_dir`` missing or holding no session, a missing required column,
        a value of the wrong type, an unknown status, or two different rows with
        the same ``(participant, session, trial_index, attempt)``.

    Warns
    -----
    LogWarning
        A truncated file (read up to the damage), a missing or stale
        ``trials.csv`` (rebuilt from ``events.jsonl``), an exact duplicate row (dropped),
        missing optional columns (filled with blanks), a session whose protocol asks for no
        answers (skipped; see :func:`not_recognition_reason`).
    """
    if sessions not in SESSION_POLICIES:
        raise LogError(f"--sessions: expected one of {SESSION_POLICIES}, got {sessions!r}")
    policy = sessions
    root = Path(data_dir)
    if not root.is_dir():
        raise LogError(f"{root}: data directory: expected an existing directory, got {str(root)!r}")
    folders = _session_folders(root)
    if not folders:
        raise LogError(f"{root}: trials.csv: expected session folders holding trials.csv or "
                       f"events.jsonl, got none")
    messages: list = []
    parts, sessions, skipped = [], [], []
    for folder in folders:
        meta = _session_meta(folder)
        reason = not_recognition_reason(meta)
        if reason:
            _warn(messages, f"{folder / 'session.json'}: protocol: {reason}; session {folder} "
                            f"skipped")
            context = _session_context(folder, [])
            skipped.append({"participant": str(context.get("participant", folder.parent.name)),
                            "group": str(context.get("group", "")),
                            "session": str(context.get("session", folder.name)),
                            "path": str(folder), "source": "session.json", "n_rows": 0,
                            "skipped": reason, **_session_state(folder, meta)})
            continue
        rows, source = load_session(folder, messages)
        if rows.empty:
            continue
        roles = block_roles(meta)
        if roles:
            blocks = rows["block"].astype(str)
            rows["_scored"] = blocks.map(lambda b: roles[b]["scored"] if b in roles else None)
            rows["_answered"] = blocks.map(lambda b: roles[b]["response"] if b in roles else None)
        parts.append(rows)
        sessions.append({"path": str(folder), "source": source, "n_rows": len(rows),
                         **_session_state(folder, meta)})
    if not parts:
        also = f" ({len(skipped)} skipped for their protocol)" if skipped else ""
        raise LogError(f"{root}: trials.csv: expected at least one session with trial rows, got "
                       f"{len(folders)} session folder(s) without any{also}")
    raw = pd.concat(parts, ignore_index=True)
    trials = _validate(raw)
    first = trials.groupby("source", sort=False)[["participant", "group", "session"]].first()
    sessions = pd.DataFrame(sessions)
    sessions["file"] = [str(Path(p) / s) for p, s in zip(sessions["path"], sessions["source"])]
    sessions = sessions.join(first, on="file").drop(columns="file")
    state = ["complete", "n_done", "n_planned", "created_at"]
    sessions = sessions[["participant", "group", "session", "path", "source", "n_rows", *state]].copy()
    sessions["skipped"] = ""
    if skipped:
        sessions = pd.concat([sessions, pd.DataFrame(skipped)], ignore_index=True)
        sessions = sessions.sort_values("path", ignore_index=True)
    sessions = _apply_policy(sessions, policy).drop(columns="created_at")
    trials = _drop_duplicates(trials, messages)
    for column in ("participant", "group"):
        per = trials.groupby("participant")["group"].nunique() if column == "group" else None
        if per is not None and (per > 1).any():
            who = per[per > 1].index[0]
            files = sorted(trials.loc[trials["participant"] == who, "source"].unique())
            raise LogError(f"{files[0]}: group: expected one group per participant, got "
                           f"{sorted(trials.loc[trials['participant'] == who, 'group'].unique())!r} "
                           f"for participant {who!r}")
    trials = _mark_inclusion(trials)
    left_out = set(sessions.loc[~sessions["analysed"], "path"])
    out_of_policy = trials["source"].map(lambda f: str(Path(f).parent) in left_out)
    trials.loc[out_of_policy, "exclusion"] = "session not analysed"
    trials.loc[out_of_policy, "included"] = False
    order = ["participant", "group", "session", "block", "trial_index", "attempt", "mode",
             "roughness_id", "roughness_um", "repetition", "response_id", "correct", "rt_s", "status",
             "tracking_rms_C", "skin_thickness_um", "sex", "started_at", "fault_code",
             "skin_temperature_C", "skin_temperature_in_range", "contact_force_N",
             "abort_reason", "familiarisation", "included", "exclusion", "source", "line"]
    trials = trials[order].sort_values(["participant", "session", "trial_index", "attempt"],
                                       ignore_index=True)
    return TrialLog(trials=trials, sessions=pd.DataFrame(sessions), warnings=messages, policy=policy)


def _drop_duplicates(trials: pd.DataFrame, messages: list) -> pd.DataFrame:
    key = ["participant", "session", "trial_index", "attempt"]
    dup = trials.duplicated(key, keep=False)
    if not dup.any():
        return trials
    data_cols = [c for c in trials.columns if c not in ("source", "line")]
    for _, group in trials[dup].groupby(key, sort=False):
        a, b = group.iloc[0], group.iloc[1]
        differ = [c for c in data_cols if not (a[c] == b[c] or (pd.isna(a[c]) and pd.isna(b[c])))]
        if differ:
            raise LogError(f"{b['source']}: {differ[0]}: expected one row per (participant, session, "
                           f"trial_index, attempt) = ({a['participant']}, {a['session']}, "
                           f"{a['trial_index']}, {a['attempt']}), got different rows at line "
                           f"{a['line']} and line {b['line']}")
        _warn(messages, f"{b['source']}: line {b['line']}: exact duplicate of line {a['line']} "
                        f"(trial_index {a['trial_index']}, attempt {a['attempt']}); dropped")
    return trials.drop_duplicates(subset=data_cols, keep="first").reset_index(drop=True)
