"""The display's measured contact force in the analysis: read, tabulated, a covariate."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from analysis import analyze
from analysis.load import load_trials
from analysis.psychophysics import covariate_table, force_table

from _study_writer import paper_like_cells, write_study


def _add_forces(root: Path, seed: int = 3) -> None:
    """A contact_force_N column: 2.0 N in group A, 3.0 N in group B, +0.5 N on simulated trials,
    plus a per-trial spread of +-0.4 N that decides the answer (correct iff the press is firm)."""
    rng = np.random.default_rng(seed)
    for path in sorted(root.glob("*/*/trials.csv")):
        df = pd.read_csv(path, keep_default_na=False, dtype=str)
        base = np.where(df["group"] == "A", 2.0, 3.0) + np.where(df["mode"] == "simulated", 0.5, 0.0)
        spread = rng.choice([-0.4, 0.4], size=len(df))
        df["contact_force_N"] = [f"{v:.2f}" for v in base + spread]
        answered = df["response_id"] != ""
        rid = df["roughness_id"].astype(int)
        firm = spread > 0
        response = np.where(firm, rid, rid % 4 + 1).astype(str)
        df["response_id"] = np.where(answered, response, "")
        df["correct"] = np.where(answered, firm.astype(int).astype(str), "")
        df.to_csv(path, index=False, lineterminator="\n")


def test_force_is_read_tabulated_by_group_and_mode_and_a_covariate(tmp_path):
    write_study(tmp_path / "data", paper_like_cells(), n_per_group=6, reps=3, seed=8)
    _add_forces(tmp_path / "data")
    log = load_trials(tmp_path / "data")
    assert log.trials["contact_force_N"].notna().all()
    trials = log.trials[log.trials["included"]]
    table = force_table(trials).set_index(["group", "mode"])
    # each cell is half 0.4 N below and half above its base on average (random signs): the mean
    # lies within 0.4 N of the base, and min/max are base -+ 0.4 exactly
    for (group, mode), base in {("A", "real"): 2.0, ("A", "simulated"): 2.5,
                                ("B", "real"): 3.0, ("B", "simulated"): 3.5}.items():
        row = table.loc[(group, mode)]
        assert row["min_force_N"] == pytest.approx(base - 0.4)
        assert row["max_force_N"] == pytest.approx(base + 0.4)
        assert abs(row["mean_force_N"] - base) < 0.4 and row["n_trials"] == 6 * 12
    cov = covariate_table(trials)
    term = cov[cov["term"] == "force_N"]
    assert len(term) == 1 and term["log_odds"].iloc[0] > 2      # firmer press, right answer
    assert term["ci_low"].iloc[0] > 0


def test_report_shows_the_force_and_old_logs_say_it_was_not_logged(tmp_path):
    write_study(tmp_path / "data", paper_like_cells(), n_per_group=4, reps=2, seed=9)
    write_study(tmp_path / "old", paper_like_cells(), n_per_group=4, reps=2, seed=9)
    _add_forces(tmp_path / "data")
    analyze(tmp_path / "data", tmp_path / "out", n_boot=50, mixed=False)
    report = (tmp_path / "out" / "report.md").read_text()
    assert "Contact force the display measured" in report and "mean_force_N" in report
    assert "| force_N |" in report         # the covariate row (the force varies here)
    analyze(tmp_path / "old", tmp_path / "out_old", n_boot=50, mixed=False)
    old = (tmp_path / "out_old" / "report.md").read_text()
    assert "not logged (sessions older than the contact-force column)" in old and "mean_force_N" not in old
