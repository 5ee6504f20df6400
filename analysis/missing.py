"""Missing data: scheduled scored trials that never got an analysable answer, and why.

A session's scheduled scored trials are the entries of ``session.json``'s
``schedule`` whose block is scored (the protocol's block has neither
``scored = false`` nor ``response = false``, and is not ``familiarise``). When
``session.json`` holds no schedule, the scored trials that were logged stand in
for it (and the table says so in ``schedule_source``).

Only analysed sessions count (``TrialLog.sessions``' ``analysed``). A scheduled trial is
*answered* when it has an ``ok`` attempt, and then it is never missing: when that answer is
left out of the analysis for another reason (e.g. a fingertip outside the protocol's range) it
is counted under ``answered_excluded`` with its exclusion in ``all_trials.csv``. Otherwise its
reason comes from its last logged attempt:

==========================  =====================================================
last attempt                reason
==========================  =====================================================
none logged                 ``session ended`` (the session stopped before it)
status ``fault``            ``fault`` (with the fault code)
aborted, ``no_contact``     ``no contact`` (no touch within the trial time-out)
aborted, ``*timeout*``      ``time-out``
aborted, ``interrupted``,   ``session ended`` (interrupted during the trial)
``killed``
aborted, ``error``          ``fault`` (software error)
==========================  =====================================================
"""
from __future__ import annotations

import json
from pathlib import Path

import pandas as pd

from sessionfiles.session_reader import read_text_file

__all__ = ["missing_trials", "missing_summary", "REASONS"]

#: The reasons, in the order the summary lists them.
REASONS = ("time_out", "no_contact", "fault", "session_ended", "other")
_UNSCORED = {"familiarise"}


def _schedule(path: Path) -> list[dict] | None:
    """The scored entries of a session's schedule, or None without one."""
    try:
        # the session reader's rules (regular file, UTF-8 with or without a byte-order mark)
        meta = json.loads(read_text_file(path / "session.json"))
    except (OSError, ValueError, UnicodeDecodeError):
        return None
    schedule = meta.get("schedule") if isinstance(meta, dict) else None
    if not isinstance(schedule, list):
        return None
    blocks = (meta.get("protocol") or {}).get("blocks") if isinstance(meta.get("protocol"), dict) \
        else None
    unscored = set(_UNSCORED)
    for b in blocks if isinstance(blocks, list) else []:
        if isinstance(b, dict) and (b.get("scored") is False or b.get("response") is False):
            unscored.add(str(b.get("name")))
    return [e for e in schedule if isinstance(e, dict) and "trial_index" in e
            and str(e.get("block")) not in unscored and e.get("mode") != "familiarise"]


def _groups(table: pd.DataFrame, keys: list) -> dict:
    """``table``'s rows per value of ``keys`` (tuple keys), each in ``table``'s order: the same
    rows a boolean selection per key gives, split once instead of once per session."""
    if table.empty:
        return {}
    return {(k if isinstance(k, tuple) else (k,)): part
            for k, part in table.groupby(keys, sort=False, observed=True, dropna=False)}


def _reason(last: pd.Series | None) -> tuple[str, str]:
    if last is None:
        return "session_ended", "no attempt logged"
    status = str(last["status"])
    reason = str(last.get("abort_reason", "") or "")
    code = str(last.get("fault_code", "") or "")
    if status == "fault":
        return "fault", f"display fault {code}".strip()
    if status == "aborted":
        low = reason.lower()
        if low == "no_contact":
            return "no_contact", "no touch within the trial time-out"
        if "timeout" in low or "time-out" in low or "timed_out" in low:
            return "time_out", reason
        if low in ("interrupted", "killed"):
            return "session_ended", f"session {low} during the trial"
        if low == "error":
            return "fault", "software error"
        return "other", f"aborted ({reason or 'no reason logged'})"
    return "other", f"status {status}"


def missing_trials(trials: pd.DataFrame, sessions: pd.DataFrame) -> pd.DataFrame:
    """Every scheduled scored trial without an analysable answer, with its reason.

    Parameters
    ----------
    trials : pandas.DataFrame
        ``TrialLog.trials`` (every logged row; ``abort_reason`` used when present).
    sessions : pandas.DataFrame
        ``TrialLog.sessions`` (``participant, session, path``; skipped sessions ignored).

    Returns
    -------
    pandas.DataFrame
        ``participant, group, session, trial_index, block, mode, roughness_id,
        attempts, reason, detail``.
    """
    rows = []
    by_session = _groups(trials, ["participant", "session"])
    for s in sessions.itertuples():
        if getattr(s, "skipped", "") or not getattr(s, "analysed", True):
            continue
        mine = by_session.get((s.participant, s.session), trials.iloc[:0])
        scheduled = _schedule(Path(s.path))
        if scheduled is None:
            logged = mine[~mine["familiarisation"]].drop_duplicates("trial_index")
            scheduled = logged[["trial_index", "block", "mode", "roughness_id"]].to_dict("records")
        answered = set(mine.loc[mine["included"] | (mine["status"].astype(str) == "ok"),
                                "trial_index"].astype(int))
        for entry in scheduled:
            index = int(entry["trial_index"])
            if index in answered:
                continue
            attempts = mine[mine["trial_index"] == index].sort_values("attempt")
            last = attempts.iloc[-1] if len(attempts) else None
            reason, detail = _reason(last)
            rows.append({"participant": s.participant, "group": s.group, "session": s.session,
                         "trial_index": index, "block": entry.get("block"),
                         "mode": entry.get("mode"), "roughness_id": entry.get("roughness_id"),
                         "attempts": len(attempts), "reason": reason, "detail": detail})
    return pd.DataFrame(rows, columns=["participant", "group", "session", "trial_index", "block",
                                       "mode", "roughness_id", "attempts", "reason", "detail"])


def missing_summary(trials: pd.DataFrame, sessions: pd.DataFrame,
                    missing: pd.DataFrame | None = None) -> pd.DataFrame:
    """Per participant: scheduled vs answered scored trials, missing ones by reason.

    Returns
    -------
    pandas.DataFrame
        ``participant, group, sessions, scheduled, answered`` (an ``ok`` attempt),
        ``analysed_trials`` (included in the models), ``answered_excluded`` (answered but left out,
        e.g. a cold fingertip), ``missing`` and one count column per reason (``time_out``,
        ``no_contact``, ``fault``, ``session_ended``, ``other``), ``schedule_source``
        (``session.json`` or ``logged trials``).
    """
    missing = missing_trials(trials, sessions) if missing is None else missing
    rows = []
    keep = sessions.get("skipped", "") == ""
    if "analysed" in sessions:
        keep = keep & sessions["analysed"].astype(bool)
    # only the columns used: selecting rows of the whole log (~40 columns) per participant, and
    # iterating the sessions' whole rows, were most of this function's time
    trials = trials[["participant", "session", "familiarisation", "status", "included",
                     "trial_index"]]
    by_person, gone_by_person = _groups(trials, ["participant"]), _groups(missing, ["participant"])
    for participant, sel in sessions[keep].groupby("participant"):
        scheduled, sources = 0, set()
        theirs = by_person.get((participant,), trials.iloc[:0])
        for path, session in zip(sel["path"], sel["session"]):
            entries = _schedule(Path(path))
            if entries is None:
                mine = theirs[theirs["session"] == session]
                scheduled += mine.loc[~mine["familiarisation"], "trial_index"].nunique()
                sources.add("logged trials")
            else:
                scheduled += len(entries)
                sources.add("session.json")
        gone = gone_by_person.get((participant,), missing.iloc[:0])
        mine = theirs[theirs["session"].isin(set(sel["session"])) & ~theirs["familiarisation"]]
        ok = mine[mine["status"].astype(str) == "ok"]
        analysed = int(mine.loc[mine["included"], "trial_index"].nunique())
        row = {"participant": participant, "group": sel["group"].iloc[0], "sessions": len(sel),
               "scheduled": scheduled, "answered": scheduled - len(gone),
               "analysed_trials": analysed,
               "answered_excluded": max(int(ok["trial_index"].nunique()) - analysed, 0),
               "missing": len(gone)}
        row.update({r: int((gone["reason"] == r).sum()) for r in REASONS})
        row["schedule_source"] = ", ".join(sorted(sources))
        rows.append(row)
    return pd.DataFrame(rows)
