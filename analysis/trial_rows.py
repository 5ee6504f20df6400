"""Typing and checking trial rows: one concept, the trials table's contract for analysis.

The rows of any number of sessions, as read (:mod:`analysis.load`), are typed column by column
and checked (required columns, types, allowed values, ``correct`` consistent with
``response_id == roughness_id``); a bad cell raises :class:`~analysis.errors.LogError` naming
the file, the column and the line. Then each row is marked included or given its exclusion
reason. The column lists are the writer's, from the one column table (:mod:`sessionfiles.columns`).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from sessionfiles.columns import MODES, names
from sessionfiles.logformat import OPTIONAL_COLUMNS, RENAMED_COLUMNS, REQUIRED_COLUMNS, STATUSES

from .errors import LogError

__all__ = ["validate_rows", "require_columns", "fill_from_context", "mark_inclusion", "int_text",
           "MODES", "GROUPS", "FAMILIARISE", "N_ROUGHNESS"]

GROUPS = ("A", "B")
FAMILIARISE = "familiarise"
N_ROUGHNESS = 4


def int_text(value) -> str:
    """A trial_index/attempt cell as canonical text (blank attempt -> "1")."""
    if value is None or (isinstance(value, float) and np.isnan(value)) or str(value).strip() == "":
        return "1"
    try:
        return str(int(float(value)))
    except (TypeError, ValueError):
        return str(value)


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


def require_columns(df: pd.DataFrame, path: Path) -> None:
    missing = [c for c in REQUIRED_COLUMNS if c not in df.columns]
    if missing:
        raise LogError(f"{path}: {missing[0]}: expected a column named {missing[0]!r}, "
                       f"got columns {sorted(c for c in df.columns if c != 'line')!r}")


def validate_rows(df: pd.DataFrame) -> pd.DataFrame:
    """Type and check rows (of any number of sessions; ``source`` and ``line`` say where from)."""
    df = df.rename(columns={old: new for old, new in RENAMED_COLUMNS.items()
                            if old in df.columns and new not in df.columns})
    out = pd.DataFrame(index=df.index)
    for column in names(analysis="required", kind="str"):  # participant .. status
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
                blank = {"int": pd.NA, "str": ""}.get(kind, np.nan)    # float, flag: NaN
                out[column] = pd.Series(blank, index=df.index,
                                        dtype={"int": "Int64", "str": None}.get(kind, float))
            continue
        if kind == "str":
            out[column] = _as_str(df[column])
        else:   # a flag as a float: 1/0, NaN where blank (no thermometer reading taken)
            values = _as_number(df, column, integer=kind != "float", allow_blank=True)
            if column == "attempt":
                values = values.fillna(1)
            out[column] = values.astype("Int64") if kind == "int" else values.astype(float)
    out["familiarisation"] = familiar
    out["source"] = df["source"].astype(str).to_numpy()
    out["line"] = df["line"].astype("int64").to_numpy()
    return out


def fill_from_context(df: pd.DataFrame, context: dict) -> pd.DataFrame:
    for key, value in context.items():
        if key not in df.columns or _blank(df[key]).all():
            df[key] = value
        else:
            df[key] = df[key].where(~_blank(df[key]), value)
    return df


def mark_inclusion(trials: pd.DataFrame) -> pd.DataFrame:
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
