"""Which sessions are analysed: each session's state and the inclusion policy (one concept).

A session is *complete* when its event log says it finished (``session_finished``), or, for a
trials table without a log, when the table holds every planned trial. The policy
(:data:`SESSION_POLICIES`) picks, per participant, the first or the latest complete session, or
all of them. A participant with no complete session is not dropped: the first (or latest)
session with at least one completed trial is analysed as a *partial* participant (GEE and mixed
models need no complete cases), and its reason says how many trials it holds.
"""
from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pandas as pd

from sessionfiles.logformat import read_events

from .trial_rows import int_text

__all__ = ["SESSION_POLICIES", "session_state", "apply_policy"]


#: Inclusion policies of :func:`load_trials` (``thermocue analyze --sessions``).
SESSION_POLICIES = ("first", "latest", "all")


def session_state(folder: Path, meta: dict, read=None) -> dict:
    """``complete``, ``n_done``, ``n_planned`` and ``created_at`` of one session folder.

    ``read``: the folder as :func:`sessionfiles.session_reader.read_session_folder` read it; its
    event log is then not read again (the log read past any damaged line, as without it).
    """
    done, finished = set(), False
    events, report = _events(folder, read)
    for ev in events:
        if ev.get("event") == "session_finished":
            finished = True
        elif ev.get("event") == "trial_completed" and isinstance(ev.get("row"), dict) \
                and ev["row"].get("status", "ok") == "ok":
            done.add(ev.get("trial_index"))
    planned = meta.get("schedule")
    n_planned = len(planned) if isinstance(planned, list) else np.nan
    if report is None or report.n_lines == 0:
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


def _events(folder: Path, read) -> tuple[list, object]:
    """The folder's events with every undecodable line skipped, and the log's report."""
    if read is not None:
        if read.events_report is None:                  # no readable event log
            return [], None
        if read.events_report.stopped_at is None:       # no damaged line: nothing to skip
            return read.events, read.events_report
        return read_events(folder / "events.jsonl", on_damage="skip", warn=False,
                           data=read.raw_events)
    try:
        return read_events(folder / "events.jsonl", on_damage="skip", warn=False)
    except OSError:
        return [], None


def _chosen(sessions: pd.DataFrame, policy: str) -> dict:
    """participant -> (the session ``policy`` analyses, a row or None; whether it is a partial
    one: the participant has no complete session), for every participant with a session not
    skipped. One sort of the usable sessions, split by participant: the same rows in the same
    order as sorting each participant's own (a participant's sessions have distinct names,
    so the sort key has no ties; with a repeated name each participant is sorted alone)."""
    usable = sessions[sessions["skipped"] == ""]
    if usable.duplicated(["participant", "session"]).any():
        parts = ((p, usable[usable["participant"] == p].sort_values(["created_at", "session"]))
                 for p in usable["participant"].unique())
    else:
        parts = usable.sort_values(["created_at", "session"]).groupby("participant", sort=False)
    out = {}
    for participant, theirs in parts:
        mine = theirs[theirs["complete"]]
        partial = mine.empty
        if partial:                 # no complete session: the participant's partial one
            mine = theirs[theirs["n_done"] > 0]
        out[participant] = (None if mine.empty else
                            (mine.iloc[0] if policy == "first" else mine.iloc[-1]), partial)
    return out


def apply_policy(sessions: pd.DataFrame, policy: str) -> pd.DataFrame:
    """Mark each session ``analysed`` (bool) with its ``reason`` under ``policy``."""
    analysed, reasons = [], []
    choices = _chosen(sessions, policy) if policy != "all" else {}
    for _, row in sessions.iterrows():
        if row["skipped"]:
            analysed.append(False)
            reasons.append(f"skipped: {row['skipped']}")
            continue
        if policy == "all":
            analysed.append(True)
            reasons.append("analysed (--sessions all)" + ("" if row["complete"] else
                           f"; incomplete: {row['n_done']} of {int_text(row['n_planned'])} trials"))
            continue
        chosen, partial = choices.get(row["participant"], (None, True))
        if chosen is not None and chosen["path"] == row["path"]:
            analysed.append(True)
            reasons.append(f"analysed: the {policy} complete session of {row['participant']}"
                           if not partial else
                           f"analysed, partial: {row['n_done']} of {int_text(row['n_planned'])} "
                           f"trials ({row['participant']} has no complete session; the "
                           f"{policy} with completed trials)")
        elif not row["complete"]:
            analysed.append(False)
            reasons.append(f"incomplete: {row['n_done']} of {int_text(row['n_planned'])} trials")
        else:
            analysed.append(False)
            reasons.append(f"repeated session: {row['participant']}'s {policy} complete session "
                           f"is {chosen['session']}")
    out = sessions.copy()
    out["analysed"] = analysed
    out["reason"] = reasons
    return out
