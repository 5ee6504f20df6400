"""Confusion matrices (stimulus × response) per group × mode."""
from __future__ import annotations

import pandas as pd

from analysis import confusion_matrices, confusion_matrix


def test_confusion_by_hand():
    # (group, mode, stimulus, response)
    answers = [("A", "real", 1, 1), ("A", "real", 1, 2), ("A", "real", 1, 2), ("A", "real", 4, 4),
               ("A", "simulated", 2, 3), ("B", "real", 3, 3)]
    trials = pd.DataFrame([{"group": g, "mode": m, "roughness_id": s, "response_id": r,
                            "correct": int(s == r), "participant": "P"} for g, m, s, r in answers])
    tab = confusion_matrix(trials, "A", "real")
    assert tab.shape == (4, 4)
    assert tab.loc[1].tolist() == [1, 2, 0, 0]
    assert tab.loc[4].tolist() == [0, 0, 0, 1]
    assert tab.loc[2].sum() == 0 and tab.to_numpy().sum() == 4
    long = confusion_matrices(trials)
    assert len(long) == 3 * 16                      # three group × mode pairs present
    row = long[(long["group"] == "A") & (long["mode"] == "real") & (long["stimulus_roughness_id"] == 1)
               & (long["response_id"] == 2)].iloc[0]
    assert row["n_trials"] == 2 and abs(row["proportion_of_stimulus"] - 2 / 3) < 1e-12
    empty_row = long[(long["group"] == "B") & (long["stimulus_roughness_id"] == 1)]
    assert empty_row["n_trials"].sum() == 0 and empty_row["proportion_of_stimulus"].isna().all()
