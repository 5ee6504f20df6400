"""Confusion matrices (stimulus roughness × response) per group × mode."""
from __future__ import annotations

import pandas as pd

__all__ = ["confusion_matrices", "confusion_matrix"]

N_ROUGHNESS = 4


def confusion_matrix(trials: pd.DataFrame, group: str, mode: str) -> pd.DataFrame:
    """Counts of each response to each stimulus for one group and mode.

    Parameters
    ----------
    trials : pandas.DataFrame
        Analysable trials.
    group, mode : str
        The cell, e.g. ``"A"``, ``"real"``.

    Returns
    -------
    pandas.DataFrame
        4 × 4 integer counts; index ``stimulus`` (roughness_id 1–4), columns
        ``response`` (response_id 1–4). Rows sum to the trials per stimulus.
    """
    sel = trials[(trials["group"] == group) & (trials["mode"] == mode)]
    levels = range(1, N_ROUGHNESS + 1)
    tab = pd.crosstab(sel["roughness_id"].astype(int), sel["response_id"].astype(int))
    tab = tab.reindex(index=levels, columns=levels, fill_value=0).astype(int)
    tab.index.name, tab.columns.name = "stimulus", "response"
    return tab


def confusion_matrices(trials: pd.DataFrame) -> pd.DataFrame:
    """All confusion matrices in one long table.

    Parameters
    ----------
    trials : pandas.DataFrame
        Analysable trials.

    Returns
    -------
    pandas.DataFrame
        ``group, mode, stimulus_roughness_id, response_id, n_trials,
        proportion_of_stimulus`` (the row-normalised share, fraction 0–1), for
        every group × mode present and all 16 stimulus × response pairs.
    """
    rows = []
    for (group, mode), _ in trials.groupby(["group", "mode"], observed=True):
        tab = confusion_matrix(trials, group, mode)
        totals = tab.sum(axis=1)
        for s in tab.index:
            for r in tab.columns:
                n = int(tab.at[s, r])
                rows.append({"group": group, "mode": mode, "stimulus_roughness_id": int(s),
                             "response_id": int(r), "n_trials": n,
                             "proportion_of_stimulus": n / totals[s] if totals[s] else float("nan")})
    return pd.DataFrame(rows, columns=["group", "mode", "stimulus_roughness_id", "response_id",
                                       "n_trials", "proportion_of_stimulus"])
