"""``analyze(data_dir, out_dir)``: every table, the figures and ``report.md`` in one call."""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
import pandas as pd

from .confusion import confusion_matrices
from .errors import LogError
from .figures import plot_confusion, plot_figure9
from .load import TrialLog, load_trials
from .models import FORMULA, ModelFit, fit_bayes, fit_gee, group_contrasts
from .proportions import cell_proportions, participant_summary

__all__ = ["AnalysisResult", "analyze", "plain_summary", "COLUMN_MEANINGS"]

#: Meaning and unit of every column written to the CSVs (copied into report.md).
COLUMN_MEANINGS = {
    "group": "skin-thickness group: A thin (600-750 um), B thick (900-1200 um)",
    "mode": "real = steel sample touched; simulated = thermal display replay",
    "roughness_id": "sample number 1#-4# (0 in contrasts = averaged over samples)",
    "roughness_um": "sample roughness Ra, micrometres",
    "n_participants": "participants contributing (count)",
    "n_trials": "trials (count)",
    "n_correct": "correct answers (count)",
    "proportion_correct": "fraction of trials answered correctly, 0-1",
    "wilson_low/high": "95% Wilson score interval of proportion_correct (trials independent), 0-1",
    "boot_low/high": "95% participant-cluster bootstrap interval (Wilson at the bootstrap's "
                     "effective sample size), 0-1",
    "boot_se": "bootstrap standard error of proportion_correct, 0-1",
    "design_effect": "bootstrap variance x m/(m-1) over binomial variance, floored at 1 (ratio)",
    "log_odds, se, ci_low/high": "GEE coefficient (log odds), its bias-reduced SE and 95% CI",
    "posterior_mean/sd, cri_low/high": "variational posterior mean, SD, 95% credible interval (log odds)",
    "log_odds_ratio_A_vs_B": "log odds of correct, group A minus group B",
    "odds_ratio_A_vs_B": "exp(log_odds_ratio_A_vs_B)",
    "p_correct_A/B": "model probability of a correct answer, 0-1",
    "difference_A_minus_B (+low/high)": "p_correct_A - p_correct_B with 95% delta-method CI, 0-1",
    "stimulus_roughness_id, response_id": "sample presented, sample named (1-4)",
    "proportion_of_stimulus": "share of the stimulus's trials given this response, 0-1",
    "median_rt_s": "median response time, seconds",
    "skin_thickness_um": "skin thickness, micrometres",
}


@dataclass
class AnalysisResult:
    """Everything :func:`analyze` computed and wrote.

    Attributes
    ----------
    log : TrialLog
        The loaded trials (all rows, inclusion marked), sessions and warnings.
    proportions, participants, confusion, contrasts : pandas.DataFrame
        The tables (see :func:`analysis.cell_proportions` etc.).
    gee, bayes : ModelFit
        The two models.
    summary : str
        Plain-language summary.
    files : dict of str to Path
        Every file written, by name.
    """

    log: TrialLog
    proportions: pd.DataFrame
    participants: pd.DataFrame
    confusion: pd.DataFrame
    gee: ModelFit
    bayes: ModelFit
    contrasts: pd.DataFrame
    summary: str
    files: dict = field(default_factory=dict)


def _md_table(df: pd.DataFrame, digits: int = 3) -> str:
    """A GitHub-markdown table (no extra dependency)."""
    def cell(v):
        if isinstance(v, (float, np.floating)):
            return "" if np.isnan(v) else f"{v:.{digits}f}"
        return str(v)
    lines = ["| " + " | ".join(map(str, df.columns)) + " |",
             "|" + "|".join("---" for _ in df.columns) + "|"]
    lines += ["| " + " | ".join(cell(v) for v in row) + " |" for row in df.itertuples(index=False)]
    return "\n".join(lines)


def _pct(p: float) -> str:
    return f"{100 * p:.0f} %"


def plain_summary(log: TrialLog, proportions: pd.DataFrame, confusion: pd.DataFrame,
                  gee: ModelFit, bayes: ModelFit, contrasts: pd.DataFrame) -> str:
    """A few sentences a reader without statistics can follow.

    Parameters
    ----------
    log, proportions, confusion, gee, bayes, contrasts
        As computed by :func:`analyze`.

    Returns
    -------
    str
        Markdown paragraphs.
    """
    a = log.analysable
    people = a.drop_duplicates("participant")["group"].value_counts()
    excluded = int((~log.trials["included"]).sum())
    out = [f"{a['participant'].nunique()} participants (group A: {int(people.get('A', 0))}, "
           f"group B: {int(people.get('B', 0))}) gave {len(a)} analysable answers; {excluded} "
           f"logged trials were left out (familiarisation, faults, aborted or superseded attempts)."]
    for mode in ("real", "simulated"):
        sel = a[a["mode"] == mode]
        if sel.empty:
            continue
        rates = sel.groupby("group")["correct"].mean()
        text = ", ".join(f"group {g} {_pct(r)}" for g, r in rates.items())
        line = f"With {mode} samples the answers were correct in {text} of trials (chance: 25 %)."
        row = contrasts[(contrasts["model"] == "gee") & (contrasts["mode"] == mode)
                        & (contrasts["roughness_id"] == 0)]
        if not row.empty:
            r = row.iloc[0]
            verdict = ("a difference the data support (the interval excludes no difference)"
                       if r["ci_low"] > 0 or r["ci_high"] < 0 else
                       "a difference the data cannot tell apart from none")
            line += (f" Averaged over the four samples, the GEE puts group A's odds of a correct "
                     f"answer at {r['odds_ratio_A_vs_B']:.2f} times group B's (95 % CI "
                     f"{np.exp(r['ci_low']):.2f}-{np.exp(r['ci_high']):.2f}, p = {r['p_value']:.3f}): "
                     f"{verdict}.")
        out.append(line)
    gap = {}
    for mode in ("real", "simulated"):
        rates = a[a["mode"] == mode].groupby("group")["correct"].mean()
        if {"A", "B"} <= set(rates.index):
            gap[mode] = 100 * (rates["A"] - rates["B"])
    if len(gap) == 2:
        out.append(f"The paper (Figure 9, §3.2) reports group A above group B with real samples "
                   f"and a smaller difference with simulated ones; here group A minus group B is "
                   f"{gap['real']:+.1f} percentage points with real samples and "
                   f"{gap['simulated']:+.1f} with simulated ones.")
    if not proportions.empty:
        by_r = a.groupby("roughness_id")["correct"].mean()
        out.append(f"Pooled over groups and modes, the proportion correct was "
                   + ", ".join(f"{_pct(v)} for {r}#" for r, v in by_r.items()) + ".")
    below = proportions[proportions["boot_high"] < 0.25]
    if not below.empty:
        out.append("Below chance (whole bootstrap interval under 0.25): " + ", ".join(
            f"group {r.group} {r.mode} {r.roughness_id}# ({_pct(r.proportion_correct)})"
            for r in below.itertuples()) + "; these samples are systematically named as another "
            "one (see the confusion matrices).")
    if not confusion.empty:
        worst_by_mode = []
        for mode in ("real", "simulated"):
            conf = confusion[confusion["mode"] == mode]
            if conf.empty:
                continue
            diag = conf[conf["stimulus_roughness_id"] == conf["response_id"]]
            worst = diag.groupby("stimulus_roughness_id")["n_trials"].sum() / \
                conf.groupby("stimulus_roughness_id")["n_trials"].sum()
            worst_by_mode.append(f"with {mode} samples {int(worst.idxmin())}# "
                                 f"(named correctly in {_pct(worst.min())} of its trials)")
        out.append("The sample most often confused with the others was, "
                   + "; ".join(worst_by_mode) + ".")
    per_sample = contrasts[(contrasts["model"] == "gee") & (contrasts["roughness_id"] > 0)] \
        if not contrasts.empty else contrasts
    estimable = per_sample[per_sample["ci_low"].notna()] if not per_sample.empty else per_sample
    sig = estimable[(estimable["ci_low"] > 0) | (estimable["ci_high"] < 0)] \
        if not estimable.empty else estimable
    n_tests = len(estimable)
    if len(per_sample) > n_tests:
        out.append("No group comparison is possible for " + ", ".join(
            f"{r.roughness_id}# {r.mode}" for r in per_sample[per_sample["ci_low"].isna()].itertuples())
            + " (a group answered it all right or all wrong).")
    if n_tests and (per_sample["basis"].str.startswith("per-sample")).any():
        out.append("Per-sample group comparisons come from a GEE of each sample's trials alone "
                   "(the full model could not be fitted; see the model notes).")
    if n_tests:
        if sig.empty:
            out.append(f"No single sample shows a group difference whose 95 % interval excludes "
                       f"zero ({n_tests} comparisons).")
        else:
            out.append("Samples whose group difference excludes zero at 95 %: " + ", ".join(
                f"{r.roughness_id}# {r.mode} ({'A' if r.log_odds_ratio_A_vs_B > 0 else 'B'} higher)"
                for r in sig.itertuples()) + f" ({n_tests} comparisons at 95 %: about "
                f"{0.05 * n_tests:.1f} expected by chance alone).")
    if bayes.formula is not None:
        sd = bayes.table[bayes.table["term"] == "participant_sd"].iloc[0]
        out.append(f"The Bayesian mixed model estimates the spread between participants at "
                   f"SD {sd['posterior_mean']:.2f} on the log-odds scale "
                   f"(95 % credible interval {sd['cri_low']:.2f}-{sd['cri_high']:.2f}).")
    notes = gee.notes + bayes.notes
    if notes:
        out.append("Model notes:\n" + "\n".join(f"- {n}" for n in notes))
    return "\n\n".join(out)


def _write_csv(df: pd.DataFrame, path: Path) -> Path:
    # Booleans one way, as in trials.csv: 1/0 (not True/False next to 0/1 columns).
    flags = [c for c in df.columns if df[c].dtype == bool]
    if flags:
        df = df.assign(**{c: df[c].astype(int) for c in flags})
    df.to_csv(path, index=False, float_format="%.6g")
    return path


def analyze(data_dir, out_dir, *, n_boot: int = 2000, level: float = 0.95, seed: int = 20261122,
            bayes: bool = True, progress: Callable[[str], None] | None = None,
            sessions: str = "first") -> AnalysisResult:
    """Load every session under ``data_dir``, analyse, and write the results to ``out_dir``.

    Parameters
    ----------
    data_dir : str or Path
        The data directory (``DATA/<participant>/<session>/``).
    out_dir : str or Path
        Created if missing. Receives ``figure9.png``, ``confusion.png``,
        ``proportions.csv``, ``participants.csv``, ``confusion.csv``, ``gee.csv``,
        ``bayes.csv``, ``contrasts.csv``, ``exclusions.csv``, ``sessions.csv``,
        ``all_trials.csv`` (every logged row, tidy, with its inclusion; not named
        ``trials.csv`` so that an output folder is never taken for a session)
        and ``report.md``.
    n_boot : int
        Bootstrap resamples for the cluster intervals.
    level : float
        Confidence level of every interval, 0–1.
    seed : int
        Seed of the bootstrap and of the variational fit.
    bayes : bool
        Fit the Bayesian mixed model too.
    progress : callable, optional
        Called with a short message before each step.
    sessions : {"first", "latest", "all"}
        Inclusion policy (:func:`analysis.load.load_trials`): each participant's first complete
        session (default), the latest complete one, or every session.

    Returns
    -------
    AnalysisResult

    Raises
    ------
    LogError
        Unusable logs (message names the file and column), or no analysable trial.
    """
    say = progress or (lambda message: None)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    say(f"loading sessions under {data_dir}")
    log = load_trials(data_dir, sessions=sessions)
    trials = log.analysable
    if trials.empty:
        raise LogError(f"{data_dir}: status: expected at least one ok, non-familiarisation trial, "
                       f"got none of {len(log.trials)} rows")
    say(f"{log.trials['participant'].nunique()} participants, {len(trials)} analysable trials; "
        f"proportions with {n_boot} bootstrap resamples")
    proportions = cell_proportions(trials, level=level, n_boot=n_boot, seed=seed)
    participants = participant_summary(trials)
    confusion = confusion_matrices(trials)
    say("fitting the GEE (bias-reduced covariance)")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")       # fallbacks are recorded in the notes
        gee = fit_gee(trials, level=level)
        if bayes:
            say("fitting the Bayesian mixed logit (variational Bayes)")
            bfit = fit_bayes(trials, level=level, seed=seed)
        else:
            bfit = ModelFit("bayes", None, FORMULA, pd.DataFrame(), ["Bayes: not requested"])
    contrasts = group_contrasts(gee, trials, level=level)
    if bfit.formula is not None:
        bc = group_contrasts(bfit, trials, level=level)
        bc["model"] = "bayes-vb (mean-field: intervals too narrow)"
        bc["p_value"] = np.nan
        contrasts = pd.concat([contrasts, bc], ignore_index=True) if not contrasts.empty else bc
    summary = plain_summary(log, proportions, confusion, gee, bfit, contrasts)
    say(f"writing figures and tables to {out}")
    files = {
        "figure9": plot_figure9(proportions, out / "figure9.png"),
        "confusion_png": plot_confusion(confusion, out / "confusion.png"),
        "proportions": _write_csv(proportions, out / "proportions.csv"),
        "participants": _write_csv(participants, out / "participants.csv"),
        "confusion": _write_csv(confusion, out / "confusion.csv"),
        "gee": _write_csv(gee.table, out / "gee.csv"),
        "bayes": _write_csv(bfit.table, out / "bayes.csv"),
        "contrasts": _write_csv(contrasts, out / "contrasts.csv"),
        "exclusions": _write_csv(log.exclusion_counts(), out / "exclusions.csv"),
        "sessions": _write_csv(log.sessions, out / "sessions.csv"),
        "trials": _write_csv(log.trials, out / "all_trials.csv"),
    }
    result = AnalysisResult(log, proportions, participants, confusion, gee, bfit, contrasts,
                            summary, files)
    files["report"] = out / "report.md"
    files["report"].write_text(_report_markdown(result, data_dir, n_boot, level, seed), "utf-8")
    return result


def _sessions_markdown(log) -> list:
    """Every session and why it was or was not analysed; trials with the skin out of range."""
    cols = ["participant", "session", "complete", "n_done", "n_planned", "analysed", "reason"]
    table = log.sessions[[c for c in cols if c in log.sessions.columns]].copy()
    for c in ("complete", "analysed"):
        if c in table.columns:
            table[c] = table[c].map({True: "yes", False: "no"})
    for c in ("n_done", "n_planned"):
        if c in table.columns:
            table[c] = table[c].map(lambda v: "" if pd.isna(v) else str(int(v)))
    policy = {"first": "each participant's first complete session",
              "latest": "each participant's latest complete session",
              "all": "every session, complete or not"}.get(getattr(log, "policy", "first"), "")
    parts = ["### Sessions", "", f"Inclusion policy (`--sessions {getattr(log, 'policy', 'first')}`): "
             f"{policy}. Every session found is listed, with why it was or was not analysed.", "",
             _md_table(table), ""]
    t = log.trials
    if "skin_temperature_in_range" in t.columns:
        cold = t[t["skin_temperature_in_range"] == 0]
        parts += ["### Skin temperature out of the protocol's range", ""]
        if cold.empty:
            parts += ["None of the measured trials.", ""]
        else:
            parts += [f"{len(cold)} trial(s) were run with the fingertip outside the protocol's "
                      "range (each confirmed by the experimenter, or logged unanswered):", "",
                      _md_table(cold[["participant", "session", "trial_index", "attempt", "block",
                                      "skin_temperature_C", "included"]]), ""]
    return parts


def _report_markdown(r: AnalysisResult, data_dir, n_boot: int, level: float, seed: int) -> str:
    log = r.log
    a = log.analysable
    pct = f"{100 * level:.0f} %"
    counts = a.groupby(["group", "mode"]).agg(participants=("participant", "nunique"),
                                              trials=("correct", "size"),
                                              correct=("correct", "sum")).reset_index()
    props = r.proportions.copy()
    props.insert(2, "sample", props.pop("roughness_id").map(lambda v: f"{v}#"))
    parts = [
        "# Roughness recognition: analysis report", "",
        f"Data: `{data_dir}`; {len(log.sessions)} session folder(s), "
        f"{log.trials['participant'].nunique()} participants, {len(log.trials)} logged rows, "
        f"{len(a)} analysed. Intervals: {pct}; bootstrap: {n_boot} participant resamples "
        f"within group, seed {seed}.", "",
        "## Summary", "", r.summary, "",
        "![Figure 9](figure9.png)", "",
        "## Counts", "", _md_table(counts), "",
        "### Excluded from inference", "", _md_table(log.exclusion_counts()), "",
    ]
    parts += _sessions_markdown(log)
    if log.warnings:
        parts += ["### Problems in the logs (worked around)", ""]
        parts += [f"- {w}" for w in log.warnings] + [""]
    parts += [
        "## Proportion correct (Figure 9)", "",
        "Wilson intervals treat trials as independent; bootstrap intervals resample participants "
        "(the design effect measures how much one person's answers hang together) and are the "
        "ones to read when participants differ.", "",
        _md_table(props.drop(columns=["boot_se"])), "",
        "## GEE: logit, participant clusters, exchangeable, bias-reduced covariance", "",
        f"Formula: `{r.gee.formula}`" + (f" (requested `{r.gee.requested}`)" if r.gee.simplified
                                          else ""), "",
        _md_table(r.gee.table) if not r.gee.table.empty else "_not estimable_", "",
        "## Bayesian mixed logit (participant random intercepts, variational Bayes)", "",
        f"Formula: `{r.bayes.formula}` + participant intercepts. Mean-field posterior SDs ignore "
        f"the correlation between terms and understate uncertainty; inference uses the GEE.", "",
        _md_table(r.bayes.table) if not r.bayes.table.empty else "_not fitted_", "",
        "## Group contrasts (A vs B within each mode)", "",
        "roughness_id 0 = averaged over the four samples (mean log odds).", "",
        _md_table(r.contrasts[r.contrasts["model"] == "gee"]) if not r.contrasts.empty
        else "_no group term_", "",
        "## Confusion matrices", "", "![confusion](confusion.png)", "",
        "Counts in `confusion.csv` (stimulus × response per group and mode).", "",
        "## Files and columns", "",
        ", ".join(f"`{p.name}`" for p in r.files.values()), "",
    ]
    parts += [f"- `{k}`: {v}" for k, v in COLUMN_MEANINGS.items()]
    return "\n".join(parts) + "\n"
