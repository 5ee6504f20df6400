"""The thermal model behind the simulated stimuli: the scene planner's decisions, from the logs.

Every ``profile_uploaded`` event of a session carries the target profile's parameters, among
them the scene planner's decisions (``parameters["plan"]``, :meth:`stimuli.planner.Plan.to_dict`):
which model computed the profile, and for every physical effect whether it was kept or
neglected and the error its neglect causes (K) at that scene. :func:`model_decisions` gathers
them over the analysed sessions; :func:`model_decisions_markdown` is the report's section.
Reads the event files only (no import of the experiment runtime).
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import pandas as pd

__all__ = ["model_decisions", "model_decisions_markdown"]

_COLUMNS = ["model", "effect", "decision", "n_profiles", "max_bound_K", "tolerance_K", "note"]


def _plans(folder: Path):
    """The plan dicts of a session's ``profile_uploaded`` events, one per distinct profile."""
    path = Path(folder) / "events.jsonl"
    seen = {}
    try:
        text = path.read_text("utf-8", errors="replace")
    except OSError:
        return []
    for line in text.splitlines():
        if "profile_uploaded" not in line and "\\u" not in line:
            continue              # not that event (unless its name is written with escapes)
        try:
            event = json.loads(line)
        except ValueError:        # a damaged line (the loader reports those)
            continue
        if not isinstance(event, dict) or event.get("event") != "profile_uploaded":
            continue
        plan = (event.get("parameters") or {}).get("plan")
        if isinstance(plan, dict):
            seen[event.get("content_hash", len(seen))] = plan
    out = []
    for plan in seen.values():
        out += plan["sides"] if isinstance(plan.get("sides"), list) else [plan]
    return out


def model_decisions(session_folders) -> pd.DataFrame:
    """Each (model, effect, kept or neglected) over the sessions' distinct profiles.

    Parameters
    ----------
    session_folders : iterable of path
        Session folders (holding ``events.jsonl``).

    Returns
    -------
    pandas.DataFrame
        ``model, effect, decision ("kept"/"neglected"), n_profiles, max_bound_K`` (the largest
        error the neglect causes over those profiles, K; NaN when not evaluated),
        ``tolerance_K`` (the smallest tolerance asked), ``note``.
    """
    rows = []
    for folder in session_folders:
        for plan in _plans(folder):
            if not plan.get("decisions") and plan.get("method") not in (None, "none"):
                # a profile computed by the method asked for (e.g. the printed Eq. 7), not
                # planned: one row naming it, its bound its distance from the exact model
                b = plan.get("bound_K")
                rows.append({"model": str(plan.get("model", "")), "effect": "(not planned)",
                             "decision": "as asked",
                             "bound": math.nan if b is None else float(b),
                             "tolerance": float(plan.get("tolerance_K") or math.nan),
                             "note": str(plan.get("note", ""))})
            for d in plan.get("decisions") or []:
                b = d.get("bound_K")
                rows.append({"model": str(plan.get("model", "")), "effect": str(d.get("effect")),
                             "decision": "kept" if d.get("included") else "neglected",
                             "bound": math.nan if b is None else float(b),
                             "tolerance": float(plan.get("tolerance_K", math.nan) or math.nan),
                             "note": str(d.get("note", ""))})
    if not rows:
        return pd.DataFrame(columns=_COLUMNS)
    df = pd.DataFrame(rows)
    g = df.groupby(["model", "effect", "decision"], sort=False)
    out = pd.DataFrame({"n_profiles": g.size(), "max_bound_K": g["bound"].max(),
                        "tolerance_K": g["tolerance"].min(), "note": g["note"].first()})
    return out.reset_index()[_COLUMNS]


def model_decisions_markdown(table: pd.DataFrame, md_table) -> list:
    """The report's "Model decisions" section (``md_table`` formats a table)."""
    parts = ["## Model decisions", ""]
    if table.empty:
        return parts + ["_No simulated profile with the scene planner's decisions in the logs "
                        "(no simulated trials, or sessions older than the scene planner)._", ""]
    neglected = table[table["decision"] == "neglected"]
    said = ", ".join(f"{r.effect} (<= {r.max_bound_K:.2g} K)" if not math.isnan(r.max_bound_K)
                     else str(r.effect) for r in neglected.itertuples()) or "nothing"
    asked = table[table["decision"] == "as asked"]
    asked_text = "".join(
        f" Computed by the method asked for, not planned: {r.model} in {r.n_profiles} "
        f"profile(s), at most {r.max_bound_K:.2g} K from the exact model." for r in asked.itertuples())
    return parts + [
        "The simulated stimuli's target profiles were computed by the scene planner's model "
        "(`stimuli.planner`): for each physical effect, whether it was kept or neglected, and the "
        "error its neglect causes (largest over the profiles, K, against the tolerance asked). "
        f"Neglected: {said}.{asked_text}", "", md_table(table), ""]
