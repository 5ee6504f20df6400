"""Load every session under a data directory into one tidy, validated trials table.

A session directory is any folder holding ``trials.csv`` or ``events.jsonl``
(normally ``DATA/<participant>/<session>/``). For each session:

1. ``trials.csv`` is read up to the first damaged line (a torn last line, a row
   with the wrong number of fields, undecodable bytes); the damage is reported
   as a :class:`~analysis.errors.LogWarning` naming the file and the line.
2. ``events.jsonl`` (the source of truth) is read the same way and its trial
   rows rebuilt by the writer's own rules, :mod:`sessionfiles.logformat` (``trial_completed``
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

This module reads session folders and combines them; the parts it calls each hold one concept:
:mod:`sessionfiles.logformat` (the files' format and tolerant readers, shared with the writer),
:mod:`analysis.trial_rows` (typing and checking rows, inclusion),
:mod:`analysis.session_meta` (block roles from ``session.json``) and
:mod:`analysis.session_policy` (which sessions are analysed).
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from sessionfiles.columns import ANALYSIS_ORDER, QUIET_COLUMNS
from sessionfiles.logformat import (  # noqa: F401 - REQUIRED_COLUMNS, STATUSES re-exported
    OPTIONAL_COLUMNS,
    RENAMED_COLUMNS,
    REQUIRED_COLUMNS,
    STATUSES,
    read_csv_prefix,
    read_events,
    session_context,
    trials_from_events,
)

from sessionfiles.session_reader import (SessionFileError, SessionFolder, read_session_folder,
                                        read_session_folders, row_problem)

from .conditions import CONDITION_COLUMNS, choose_condition, session_condition
from .errors import LogError, LogWarning
from .session_meta import block_roles, not_recognition_reason, read_session_meta
from .session_policy import SESSION_POLICIES, apply_policy, session_state
from .trial_rows import fill_from_context, int_text, mark_inclusion, require_columns, validate_rows

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
    #: Session folders found but not read as a session (``path``, ``reason``): a copy of
    #: another folder's session (read once), a folder without trial rows.
    not_read: pd.DataFrame = field(default_factory=lambda: pd.DataFrame(columns=["path", "reason"]))
    #: The condition analysed, ``BACKEND/CONTACT`` (:mod:`analysis.conditions`).
    condition: str = ""

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


def read_trials_csv(path, messages: list | None = None, data: bytes | None = None) -> pd.DataFrame:
    """Read a ``trials.csv`` up to its first damaged line.

    Parameters
    ----------
    path : str or Path
        The file.
    messages : list of str, optional
        Warnings are appended here (and issued as :class:`LogWarning`).
    data : bytes, optional
        The content, already read and checked (:mod:`sessionfiles.session_reader`).

    Returns
    -------
    pandas.DataFrame
        All columns as strings (``""`` for empty cells) plus ``line`` (1-based
        line number in the file). Extra columns (PsychoPy-style wide CSV) are kept.

    Raises
    ------
    LogError
        If the file has no header line.

    Notes
    -----
    What counts as damage is :func:`sessionfiles.logformat.read_csv_prefix`'s.
    """
    path = Path(path)
    messages = [] if messages is None else messages
    header, rows, lines, damage = read_csv_prefix(path, data)
    for text in damage:
        _warn(messages, text)
    if not header or not any(h.strip() for h in header):
        raise LogError(f"{path}: header: expected a CSV header line, got {''.join(header or [])!r}")
    df = pd.DataFrame(rows, columns=[h.strip() for h in header], dtype=object)
    df["line"] = lines
    return df


#: The types of the session-level values :func:`read_trial_events` returns (to fill blank cells).
_SCALAR = (str, int, float)


def _scalars(mapping: dict) -> dict:
    return {k: v for k, v in mapping.items() if not isinstance(v, (dict, list))}


def read_trial_events(path, messages: list | None = None,
                      read: tuple | None = None) -> tuple[pd.DataFrame, dict]:
    """Rebuild the trial rows of an ``events.jsonl``, reading up to its first damaged line.

    Parameters
    ----------
    path : str or Path
        The event log.
    messages : list of str, optional
        Warnings are appended here (and issued as :class:`LogWarning`).
    read : (events, report), optional
        The log, already read (:class:`sessionfiles.session_reader.SessionFolder`).

    Returns
    -------
    trials : pandas.DataFrame
        One row per trial attempt, in log order (columns as logged, plus ``line``, the
        line of the event the row comes from); JSON objects and lists are left out.
    context : dict
        Session-level values (:data:`sessionfiles.logformat.CONTEXT_KEYS` holding a string
        or a number) of the latest ``session_started``/``session_resumed``.

    Notes
    -----
    The rows are :func:`sessionfiles.logformat.trials_from_events`' (the writer's rules, the
    same ``trials.csv`` is rebuilt with); the log is read by
    :func:`sessionfiles.logformat.read_events`, stopping at the first damaged line.
    """
    path = Path(path)
    messages = [] if messages is None else messages
    events, report = read_events(path, on_damage="stop", warn=False) if read is None else read
    for text in report.damage:
        _warn(messages, text)
    sources: list = []
    duplicates: list = []
    rows = trials_from_events(events, sources=sources, damage=duplicates)
    for text in duplicates:
        _warn(messages, f"{path}: {text}")
    table = [dict(_scalars(row), line=report.event_lines[i]) for row, i in zip(rows, sources)]
    context = {k: v for k, v in session_context(events).items()
               if isinstance(v, _SCALAR) and not isinstance(v, bool)}
    return pd.DataFrame(table), context


def _session_context(meta: dict | None) -> dict:
    """participant/session/group/sex from ``session.json`` (as read); ``{}`` without one."""
    data = meta
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


# --------------------------------------------------------------------------- sessions

def load_session(folder, messages: list | None = None, read: SessionFolder | None = None,
                 check: bool = True) -> tuple[pd.DataFrame, str]:
    """Read and validate one session folder.

    Parameters
    ----------
    folder : str or Path
        A folder with ``trials.csv`` and/or ``events.jsonl``.
    messages : list of str, optional
        Warnings are appended here.
    read : SessionFolder, optional
        The folder as :func:`sessionfiles.session_reader.read_session_folder` read it (read
        here when not given).
    check : bool
        Check every row against the trial table's domain and the session's identity here
        (:func:`check_session_rows`; :func:`load_trials` does it after reading every folder).

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
        Unusable input: a special file, another encoding, a session.json naming another
        session, a value outside the trial table's domain; the message names the file and
        the column.
    """
    folder = Path(folder)
    messages = [] if messages is None else messages
    if read is None:
        try:
            read = read_session_folder(folder)
        except SessionFileError as exc:
            raise LogError(str(exc)) from None
        for text in read.notes:
            _warn(messages, text)
    csv_path, events_path = folder / "trials.csv", folder / "events.jsonl"
    table = events = None
    ev_ctx: dict = {}
    if read.events_report is not None:
        events, ev_ctx = read_trial_events(events_path, messages,
                                           read=(read.events, read.events_report))
    if read.trials_csv is not None:
        try:
            table = read_trials_csv(csv_path, messages, data=read.trials_csv)
        except LogError as exc:             # e.g. an empty file left by a crash
            if events is None or events.empty:
                raise
            _warn(messages, f"{exc}; using {events_path.name} instead")
    # session.json first, then the event log, then the folder names (checked to agree by the
    # reader; the reader's identity wins for participant and session)
    ctx = {"participant": folder.parent.name, "session": folder.name, **ev_ctx,
           **_session_context(read.meta), "participant": read.participant,
           "session": read.session}
    use_events = False
    if table is None:
        if events is None or events.empty:
            _warn(messages, f"{folder}: no trial rows (no trials.csv, no finished trial in "
                            f"events.jsonl); session skipped")
            return pd.DataFrame(), ""
        if read.trials_csv is None:
            _warn(messages, f"{csv_path}: missing; rebuilt {len(events)} rows from {events_path}")
        use_events = True
    elif events is not None and not events.empty and "trial_index" in table.columns:
        def keys(df):
            attempts = df["attempt"] if "attempt" in df.columns else [1] * len(df)
            return {(int_text(t), int_text(a)) for t, a in zip(df["trial_index"], attempts)}
        lacking = keys(events) - keys(table)
        if lacking:
            _warn(messages, f"{csv_path}: older than {events_path.name} ({len(lacking)} trial rows "
                            f"missing); rebuilt {len(events)} rows from {events_path}")
            use_events = True
    if use_events:
        rows, path = fill_from_context(events, ctx), events_path
    else:
        rows, path = table, csv_path
    if rows.empty:
        _warn(messages, f"{path}: no trial rows; session skipped")
        return pd.DataFrame(), ""
    rows = rows.reset_index(drop=True)
    require_columns(rows, path)
    rows = rows.rename(columns={old: new for old, new in RENAMED_COLUMNS.items()
                                if old in rows.columns and new not in rows.columns})
    if check:
        check_session_rows(rows, path, read)
    # a column newer than older logs (spoken answers, the thermometer, the force, abort reasons)
    # stays blank, unsaid
    missing = [c for c in OPTIONAL_COLUMNS if c not in rows.columns and c not in QUIET_COLUMNS]
    if missing:
        how = "blank" + ("; attempt taken as 1" if "attempt" in missing else "")
        _warn(messages, f"{path}: {', '.join(missing)}: expected optional column(s) "
                        f"{', '.join(missing)}, got none; filled with {how}")
    rows["source"] = str(path)
    return rows, path.name


def check_session_rows(rows: pd.DataFrame, path: Path, read: SessionFolder) -> None:
    """Refuse a row outside the trial table's domain or filed under another session
    (:class:`LogError`, one line naming the file, the column and the line)."""
    _check_domain(rows, path, read.samples)
    _check_identity(rows, path, read)


def _check_domain(rows: pd.DataFrame, path: Path, samples) -> None:
    """Refuse the first row outside the trial table's domain (one line: file, column, line)."""
    columns = [c for c in rows.columns if c != "line"]
    for record, line in zip(_records(rows, columns), rows["line"]):
        problem = row_problem(record, samples)
        if problem:
            column, expected, value = problem
            raise LogError(f"{path}: {column}: {expected} (line {line}), got {value!r}")


def _records(rows: pd.DataFrame, columns: list) -> list[dict]:
    """``rows[columns].to_dict("records")``, the same Python values (NumPy scalars boxed as
    Python's), column by column: pandas' row-wise ``to_dict`` over Arrow-backed text columns
    took most of the loader's time."""
    def values(series: pd.Series) -> list:
        out = series.tolist()
        if series.dtype == object:
            out = [v.item() if isinstance(v, np.generic) else v for v in out]
        return out
    lists = [values(rows[c]) for c in columns]
    return [dict(zip(columns, row)) for row in zip(*lists)]


def _check_identity(rows: pd.DataFrame, path: Path, read: SessionFolder) -> None:
    """Refuse rows filed under another participant or session than the folder's session."""
    for column, expected in (("participant", read.participant), ("session", read.session)):
        values = rows[column].map(lambda v: "" if v is None or (isinstance(v, float) and v != v)
                                  else str(v).strip())
        bad = (values != "") & (values != expected)
        if bad.any():
            i = int(bad.to_numpy().argmax())
            raise LogError(f"{path}: {column}: expected {expected!r} (the session's own, from "
                           f"session.json and events.jsonl) (line {rows['line'].iloc[i]}), got "
                           f"{rows[column].iloc[i]!r}")


def load_trials(data_dir, sessions: str = "first", condition: str | None = None) -> TrialLog:
    """Load, validate and combine every session under ``data_dir``.

    Parameters
    ----------
    data_dir : str or Path
        A data directory (``DATA/<participant>/<session>/...``); any folder that
        holds ``trials.csv`` or ``events.jsonl`` below it is a session.
    sessions : {"first", "latest", "all"}
        Which sessions are analysed: each participant's first complete session (default),
        the latest complete one, or all of them (incomplete ones included).
    condition : str, optional
        ``BACKEND/CONTACT`` (:func:`analysis.conditions.choose_condition`): analyse only the
        sessions of that display and contact model. Without it, sessions of two or more
        conditions are refused (never pooled).

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
    try:
        found = read_session_folders(root)
    except SessionFileError as exc:
        raise LogError(str(exc)) from None
    folders = [sf.path for sf in found.folders]
    if not folders:
        raise LogError(f"{root}: trials.csv: expected session folders holding trials.csv or "
                       f"events.jsonl, got none")
    messages: list = []
    parts, sessions, skipped, not_read = _read_sessions(found, messages)
    if not parts:
        also = f" ({len(skipped)} skipped for their protocol)" if skipped else ""
        raise LogError(f"{root}: trials.csv: expected at least one session with trial rows, got "
                       f"{len(folders)} session folder(s) without any{also}")
    for rows, sf in parts:          # after every folder is read: its warnings come first
        check_session_rows(rows, Path(rows["source"].iloc[0]), sf)
    raw = pd.concat([rows for rows, _ in parts], ignore_index=True)
    trials = validate_rows(raw)
    sessions, chosen = _sessions_table(trials, sessions, skipped, condition, policy)
    trials = _drop_duplicates(trials, messages)
    for column in ("participant", "group"):
        per = trials.groupby("participant")["group"].nunique() if column == "group" else None
        if per is not None and (per > 1).any():
            who = per[per > 1].index[0]
            files = sorted(trials.loc[trials["participant"] == who, "source"].unique())
            raise LogError(f"{files[0]}: group: expected one group per participant, got "
                           f"{sorted(trials.loc[trials['participant'] == who, 'group'].unique())!r} "
                           f"for participant {who!r}")
    trials = mark_inclusion(trials)
    left_out = set(sessions.loc[~sessions["analysed"], "path"])
    out_of_policy = trials["source"].map(lambda f: str(Path(f).parent) in left_out)
    trials.loc[out_of_policy, "exclusion"] = "session not analysed"
    trials.loc[out_of_policy, "included"] = False
    by_folder = sessions.set_index("path")
    folder_of = trials["source"].map(lambda f: str(Path(f).parent))
    other = folder_of.map(by_folder["skipped"]).fillna("").str.startswith("condition ")
    trials.loc[other, "exclusion"] = "another condition (see --condition)"
    trials.loc[other, "included"] = False
    for column in CONDITION_COLUMNS:
        trials[column] = folder_of.map(by_folder[column]).fillna("")
    order = [*ANALYSIS_ORDER, "familiarisation", *CONDITION_COLUMNS, "included", "exclusion",
             "source", "line"]
    trials = trials[order].sort_values(["participant", "session", "trial_index", "attempt"],
                                       ignore_index=True)
    return TrialLog(trials=trials, sessions=pd.DataFrame(sessions), warnings=messages, policy=policy,
                    not_read=pd.DataFrame(not_read, columns=["path", "reason"]),
                    condition=chosen)


def _read_sessions(found, messages: list):
    """Step 1 of :func:`load_trials`: each folder's trial rows (with the folder as read), the
    sessions' rows, the sessions skipped for their protocol, and the folders not read."""
    parts, sessions, skipped = [], [], []
    not_read = [{"path": str(path), "reason": reason} for path, reason in found.skipped]
    for path, reason in found.skipped:
        _warn(messages, f"{path}: {reason}")
    for sf in found.folders:
        folder = sf.path
        for text in sf.notes:
            _warn(messages, text)
        meta = sf.meta or {}
        reason = not_recognition_reason(meta)
        if reason:
            _warn(messages, f"{folder / 'session.json'}: protocol: {reason}; session {folder} "
                            f"skipped")
            context = _session_context(meta)
            skipped.append({"participant": sf.participant,
                            "group": str(context.get("group", "")),
                            "session": sf.session,
                            "path": str(folder), "source": "session.json", "n_rows": 0,
                            "skipped": reason, **session_state(folder, meta, sf),
                            **session_condition(meta)})
            continue
        rows, source = load_session(folder, messages, read=sf, check=False)
        if rows.empty:
            not_read.append({"path": str(folder), "reason": "no trial rows (no trials.csv, no "
                                                            "finished trial in events.jsonl)"})
            continue
        roles = block_roles(meta)
        if roles:
            blocks = rows["block"].astype(str)
            rows["_scored"] = blocks.map(lambda b: roles[b]["scored"] if b in roles else None)
            rows["_answered"] = blocks.map(lambda b: roles[b]["response"] if b in roles else None)
        parts.append((rows, sf))
        sessions.append({"path": str(folder), "source": source, "n_rows": len(rows),
                         **session_state(folder, meta, sf), **session_condition(meta)})
    return parts, sessions, skipped, not_read


def _sessions_table(trials: pd.DataFrame, sessions: list, skipped: list, condition, policy):
    """Step 2 of :func:`load_trials`: ``sessions.csv``'s table (identity from the rows, the
    skipped sessions, the condition chosen, the inclusion policy applied) and the condition."""
    first = trials.groupby("source", sort=False)[["participant", "group", "session"]].first()
    sessions = pd.DataFrame(sessions)
    sessions["file"] = [str(Path(p) / s) for p, s in zip(sessions["path"], sessions["source"])]
    sessions = sessions.join(first, on="file").drop(columns="file")
    state = ["complete", "n_done", "n_planned", "created_at"]
    sessions = sessions[["participant", "group", "session", "path", "source", "n_rows", *state,
                         *CONDITION_COLUMNS]].copy()
    sessions["skipped"] = ""
    if skipped:
        sessions = pd.concat([sessions, pd.DataFrame(skipped)], ignore_index=True)
        sessions = sessions.sort_values("path", ignore_index=True)
    sessions, chosen = choose_condition(sessions, condition)
    sessions = apply_policy(sessions, policy).drop(columns="created_at")
    return sessions, chosen


def _same(a, b) -> bool:
    """Two cells equal, missing values (NaN, None, pandas.NA) equal to each other."""
    if pd.isna(a) or pd.isna(b):
        return bool(pd.isna(a) and pd.isna(b))
    return bool(a == b)


def _drop_duplicates(trials: pd.DataFrame, messages: list) -> pd.DataFrame:
    key = ["participant", "session", "trial_index", "attempt"]
    dup = trials.duplicated(key, keep=False)
    if not dup.any():
        return trials
    data_cols = [c for c in trials.columns if c not in ("source", "line")]
    for _, group in trials[dup].groupby(key, sort=False):
        a, b = group.iloc[0], group.iloc[1]
        differ = [c for c in data_cols if not _same(a[c], b[c])]
        if differ:
            raise LogError(f"{b['source']}: {differ[0]}: expected one row per (participant, session, "
                           f"trial_index, attempt) = ({a['participant']}, {a['session']}, "
                           f"{a['trial_index']}, {a['attempt']}), got different rows at line "
                           f"{a['line']} and line {b['line']}")
        _warn(messages, f"{b['source']}: line {b['line']}: exact duplicate of line {a['line']} "
                        f"(trial_index {a['trial_index']}, attempt {a['attempt']}); dropped")
    return trials.drop_duplicates(subset=data_cols, keep="first").reset_index(drop=True)
