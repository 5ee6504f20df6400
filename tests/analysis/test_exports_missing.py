"""Missing-data report (scheduled vs answered, reasons), abort_reason kept, tidy exports."""
from __future__ import annotations

import csv
import json

import numpy as np
import pandas as pd
import pytest

from analysis import analyze
from analysis.exports import check_codebook


def _damage_one_participant(data):
    """P A00: one attempt aborted for no contact, one faulted (neither re-run), the session
    ended two trials early; session.json gains the schedule the session would have written."""
    folder = data / "A00" / "S1"
    with open(folder / "trials.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    meta = json.loads((folder / "session.json").read_text())
    meta["schedule"] = [{k: int(r[k]) if k in ("trial_index", "roughness_id") else r[k]
                         for k in ("trial_index", "block", "mode", "roughness_id")} for r in rows]
    meta["protocol"] = {"blocks": [{"name": "familiarise", "response": False, "scored": False},
                                   {"name": "real"}, {"name": "simulated"}]}
    (folder / "session.json").write_text(json.dumps(meta))
    scored = [r for r in rows if r["block"] != "familiarise"]
    lost_contact, lost_fault = scored[2], scored[5]
    for r in rows:
        r["abort_reason"] = ""
    lost_contact.update(status="aborted", response_id="", correct="", rt_s="",
                        abort_reason="no_contact")
    lost_fault.update(status="fault", response_id="", correct="", rt_s="", fault_code="E_TRACK")
    kept = rows[:-2]
    with open(folder / "trials.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]), lineterminator="\n")
        writer.writeheader()
        writer.writerows(kept)
    return lost_contact, lost_fault, rows[-2:]


def test_missing_data_report_gives_each_missing_trial_its_reason(study, tmp_path):
    data, _ = study(n_per_group=4, sigma=0.3, seed=61, write_events=False)
    contact, fault, ended = _damage_one_participant(data)
    out = tmp_path / "out"
    # A00's only session ended early: the default policy keeps it as a partial participant
    # (the models need no complete cases) and counts its missing trials.
    result = analyze(data, out, n_boot=50, mixed=False)
    sessions = result.log.sessions.set_index("participant")
    assert sessions.loc["A00", "analysed"]
    assert sessions.loc["A00", "reason"].startswith("analysed, partial: ")
    assert result.log.analysable["participant"].eq("A00").sum() == 20
    summary = pd.read_csv(out / "missing.csv").set_index("participant")
    a00 = summary.loc["A00"]
    assert (a00["scheduled"], a00["answered"], a00["missing"]) == (24, 20, 4)
    assert (a00["analysed_trials"], a00["answered_excluded"]) == (20, 0)
    assert (a00["no_contact"], a00["fault"], a00["session_ended"], a00["time_out"]) == (1, 1, 2, 0)
    assert a00["schedule_source"] == "session.json"
    others = summary.drop(index="A00")
    assert (others["missing"] == 0).all() and (others["scheduled"] == 24).all()
    per_trial = pd.read_csv(out / "missing_trials.csv")
    reasons = dict(zip(per_trial["trial_index"], per_trial["reason"]))
    assert reasons == {int(contact["trial_index"]): "no_contact", int(fault["trial_index"]): "fault",
                       int(ended[0]["trial_index"]): "session_ended",
                       int(ended[1]["trial_index"]): "session_ended"}
    assert "other" not in set(per_trial["reason"])         # no answered trial is ever "missing"
    all_trials = pd.read_csv(out / "all_trials.csv", keep_default_na=False)
    aborted = all_trials[all_trials["status"] == "aborted"]
    assert list(aborted["abort_reason"]) == ["no_contact"]
    report = (out / "report.md").read_text()
    assert "### Missing data" in report and "1 no_contact, 1 fault, 2 session_ended" in report
    assert "are kept" in report and "A00 (20 of 24)" in report
    assert result.missing.set_index("participant").loc["A00", "missing"] == 4
    # the complete-cases sensitivity row: the primary test without A00, against a GEE refitted
    # here by statsmodels on the other participants
    row = result.tests.set_index("role").loc["sensitivity"]
    assert "7 of 8 participants" in row["compares"]
    _check_complete_cases(result.log.analysable, row)


def _check_complete_cases(trials, row):
    import statsmodels.api as sm
    from scipy import stats

    d = trials[trials["participant"] != "A00"].copy()
    d["cell"] = d["group"] + "_" + d["mode"] + "_" + d["roughness_id"].astype(str)
    x = pd.get_dummies(d["cell"]).astype(float)
    res = sm.GEE(d["correct"].astype(float), x, groups=d["participant"],
                 family=sm.families.Binomial(),
                 cov_struct=sm.cov_struct.Exchangeable()).fit(cov_type="bias_reduced")
    w = np.array([(1 if c.startswith("A_real") else -1 if c.startswith("B_real") else 0) / 4
                  for c in x.columns])
    est = w @ np.asarray(res.params)
    se = np.sqrt(w @ np.asarray(res.cov_params()) @ w)
    assert row["estimate"] == pytest.approx(est, abs=1e-6)
    assert row["se"] == pytest.approx(se, rel=1e-5)
    # Welch-Satterthwaite df of the two groups' parts (block-diagonal in cell-means coding)
    cov_cm = np.asarray(res.cov_params())
    part = {g: (lambda v: v @ cov_cm @ v)(np.where([c.startswith(g) for c in x.columns], w, 0))
            for g in "AB"}
    sizes = d.groupby("group")["participant"].nunique()
    df = (part["A"] + part["B"]) ** 2 / sum(part[g] ** 2 / (sizes[g] - 1) for g in "AB")
    assert row["df"] == pytest.approx(df, rel=1e-5) and row["test"] == f"Wald t({df:.1f})"
    assert row["p_value"] == pytest.approx(2 * stats.t.sf(abs(est / se), df), rel=1e-4)
    # the difference of mean proportions carries its delta-method interval (it was empty)
    beta, cov = np.asarray(res.params), np.asarray(res.cov_params())
    prob = 1 / (1 + np.exp(-beta))
    sign = np.sign(w)
    diff = float((sign * prob * np.abs(w)).sum())
    grad = sign * np.abs(w) * prob * (1 - prob)
    half = stats.t.ppf(0.975, df) * np.sqrt(grad @ cov @ grad)
    assert row["difference"] == pytest.approx(diff, abs=1e-6)
    assert row["difference_ci_low"] == pytest.approx(diff - half, abs=1e-5)
    assert row["difference_ci_high"] == pytest.approx(diff + half, abs=1e-5)


def test_exports_are_full_precision_with_a_complete_codebook(study, tmp_path):
    data, _ = study(n_per_group=5, sigma=0.5, seed=62)
    out = tmp_path / "out"
    result = analyze(data, out, n_boot=100)
    # full precision: the CSV reads back bit-for-bit (the old writer rounded to 6 digits)
    back = pd.read_csv(out / "proportions.csv")
    floats = result.proportions.select_dtypes("float").columns
    assert (back[floats].to_numpy() == result.proportions[floats].to_numpy()).all()
    glmm = pd.read_csv(out / "glmm.csv")
    assert (glmm["se"].dropna().to_numpy() == result.glmm.table["se"].dropna().to_numpy()).all()
    book = json.loads((out / "codebook.json").read_text())
    csvs = {p.name for p in out.glob("*.csv")}
    assert set(book) == csvs
    assert check_codebook(book) == []
    for name in csvs:
        assert list(book[name]) == list(pd.read_csv(out / name, nrows=0).columns)
    assert book["all_trials.csv"]["rt_s"]["unit"] == "s"
    settings = json.loads((out / "settings.json").read_text())
    assert settings["n_boot"] == 100 and settings["versions"]["statsmodels"]
    assert settings["undocumented_columns"] == []
    wide = pd.read_csv(out / "wide.csv")
    assert len(wide) == 10 and "p_real_3" in wide and "p_simulated_all" in wide
    trials = result.log.analysable
    one = trials[(trials["participant"] == "B02") & (trials["mode"] == "real")]
    assert wide.set_index("participant").loc["B02", "p_real_all"] == one["correct"].mean()
    counts = pd.read_csv(out / "cell_counts.csv")
    assert len(counts) == 10 * 8 and counts["n"].sum() == len(trials)
    assert counts["k"].sum() == trials["correct"].sum()
    conv = json.loads((out / "glmm_convergence.json").read_text())
    assert conv["optimiser_success"] and conv["iterations"] > 0 and 0 < conv["icc_latent"] < 1
    assert np.isfinite(conv["log_likelihood"])


def test_abort_reason_is_read_from_the_event_log(study):
    from analysis import LogWarning, load_trials
    data, _ = study(n_per_group=1, seed=64, write_csv=False)
    log_file = data / "A00" / "S1" / "events.jsonl"
    with open(log_file, "a") as fh:       # a re-run attempt that got no touch (logbook's format)
        fh.write(json.dumps({"event": "trial_started", "trial_index": 5, "attempt": 2,
                             "block": "real", "mode": "real", "roughness_id": 1}) + "\n")
        fh.write(json.dumps({"event": "trial_aborted", "trial_index": 5, "attempt": 2,
                             "reason": "no_contact", "fault_code": None}) + "\n")
    with pytest.warns(LogWarning, match="rebuilt"):      # no trials.csv: read from the events
        trials = load_trials(data).trials
    row = trials[(trials["participant"] == "A00") & (trials["trial_index"] == 5)
                 & (trials["attempt"] == 2)].iloc[0]
    assert row["status"] == "aborted" and row["abort_reason"] == "no_contact"
    assert (trials.loc[trials["status"] == "ok", "abort_reason"] == "").all()
