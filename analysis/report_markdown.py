"""``report.md``: the analysis written out as Markdown (sections, tables, column meanings)."""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from .model_decisions import model_decisions_markdown

if TYPE_CHECKING:                       # the result type only; report.py imports this module
    from .result import AnalysisResult

__all__ = ["COLUMN_MEANINGS", "report_markdown"]

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
    "log_odds, se, ci_low/high": "model coefficient (log odds), its SE (GEE: bias-reduced "
                                 "sandwich) and 95% CI with t(participants - 2) quantiles",
    "posterior_mean/sd, cri_low/high": "mean-field VB posterior (only with --bayes-vb; too narrow)",
    "p_holm": "Holm-adjusted p-value within its family of tests",
    "compares": "what a contrast or test compares, in words",
    "log_odds_ratio_A_vs_B": "log odds of correct, group A minus group B",
    "odds_ratio_A_vs_B": "exp(log_odds_ratio_A_vs_B)",
    "p_correct_A/B": "model probability of a correct answer, 0-1",
    "difference_A_minus_B (+low/high)": "p_correct_A - p_correct_B with 95% delta-method CI, 0-1",
    "stimulus_roughness_id, response_id": "sample presented, sample named (1-4)",
    "proportion_of_stimulus": "share of the stimulus's trials given this response, 0-1",
    "median_rt_s": "median response time, seconds",
    "skin_thickness_um": "skin thickness, micrometres",
}


def _md_table(df: pd.DataFrame, digits: int = 3) -> str:
    """A GitHub-markdown table (no extra dependency)."""
    def cell(v):
        if isinstance(v, (float, np.floating)):
            return "" if np.isnan(v) else f"{v:.{digits}f}"
        return str(v).replace("|", "\\|")        # a formula's "(1 | participant)" in a cell
    lines = ["| " + " | ".join(map(str, df.columns)) + " |",
             "|" + "|".join("---" for _ in df.columns) + "|"]
    lines += ["| " + " | ".join(cell(v) for v in row) + " |" for row in df.itertuples(index=False)]
    return "\n".join(lines)


def sessions_markdown(log) -> list:
    """Every session and why it was or was not analysed; trials with the skin out of range."""
    cols = ["participant", "session", "condition", "device_id", "firmware_image_id", "complete",
            "n_done", "n_planned", "analysed", "reason"]
    table = log.sessions[[c for c in cols if c in log.sessions.columns]].copy()
    for c in ("device_id", "firmware_image_id"):          # shown when any session records them
        if c in table.columns and not table[c].astype(str).str.len().any():
            table = table.drop(columns=c)
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


def report_markdown(r: AnalysisResult, data_dir, n_boot: int, level: float, seed: int) -> str:
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
        *_condition_lines(log),
        "## Summary", "", r.summary, "",
        "![Figure 9](figure9.png)", "",
        *_fidelity_section(r),
        "## Counts", "", _md_table(counts), "",
        "### Excluded from inference", "", _md_table(log.exclusion_counts()), "",
    ]
    parts += sessions_markdown(log)
    parts += _missing_section(r)
    parts += _not_read_section(log)
    parts += model_decisions_markdown(r.extras.get("model_decisions", pd.DataFrame()), _md_table)
    if log.warnings:
        parts += ["### Problems in the logs (worked around)", ""]
        parts += [f"- {w}" for w in log.warnings] + [""]
    parts += [
        "## Proportion correct (Figure 9)", "",
        "Intervals (`boot_low/high`): Wilson at the effective sample size that a "
        "participant-cluster bootstrap implies (participants resampled within group; the design "
        "effect measures how much one person's answers hang together). Wilson intervals, which "
        "treat trials as independent and covered only 0.92 of the true proportions over 200 "
        "clustered datasets per scenario, are not shown; they are in `proportions.csv` as "
        "`wilson_low/high` (trial-independent).", "",
        _md_table(props.drop(columns=["boot_se"] + [c for c in ("wilson_low", "wilson_high")
                                                    if c in props])), "",
        "## GEE: logit, participant clusters, exchangeable, bias-reduced covariance", "",
        f"Formula: `{r.gee.formula}`" + (f" (requested `{r.gee.requested}`)" if r.gee.simplified
                                          else "")
        + ". Treatment coding: each coefficient is relative to group A, real samples, 1#; "
          "`group[T.B]` is group B - A with real sample 1# only. The group comparisons the "
          "paper asks about are the contrasts and named tests below.", "",
        _md_table(r.gee.table) if not r.gee.table.empty else "_not estimable_", "",
        *_statistics_sections(r, pct),
        "## Confusion matrices", "", "![confusion](confusion.png)", "",
        "Counts in `confusion.csv` (stimulus × response per group and mode).", "",
        "## Files and columns", "",
        ", ".join(f"`{p.name}`" for p in r.files.values()), "",
        "Machine tables are at full precision; `codebook.json` gives every column's unit and "
        "meaning, `settings.json` the run's settings and package versions. `wide.csv` has one "
        "row per participant and one column per condition; `cell_counts.csv` the (k, n) counts "
        "per participant and cell for a binomial GLMM in R or JASP.", "",
    ]
    parts += [f"- `{k}`: {v}" for k, v in COLUMN_MEANINGS.items()]
    return "\n".join(parts) + "\n"


def _condition_lines(log) -> list[str]:
    """The one condition analysed (display backend / contact model), and the others found."""
    label = getattr(log, "condition", "")
    if not label:
        return []
    backend, contact = label.split("/", 1)
    others = log.sessions.get("condition", pd.Series(dtype=str))
    others = sorted(set(others[(others != label)].dropna()))
    text = (f"Condition analysed: display backend `{backend}`, contact model `{contact}` "
            f"(`--condition {label}`; every test below is within this condition).")
    if others:
        text += (f" Sessions of other conditions ({', '.join(f'`{o}`' for o in others)}) are not "
                 f"pooled with it: analyse them with their own `--condition`.")
    return [text, ""]


def _not_read_section(log) -> list[str]:
    """Session folders found but not read as a session (a copy read once, no trial rows)."""
    table = getattr(log, "not_read", None)
    if table is None or table.empty:
        return []
    return ["### Session folders not read", "",
            f"{len(table)} folder(s) under the data folder were not read as a session of their own "
            "(their trials are not missing from the tables above unless listed there):", "",
            *[f"- `{row.path}`: {row.reason}" for row in table.itertuples()], ""]


def _fidelity_section(r: AnalysisResult) -> list[str]:
    """Display fidelity: real vs simulated, averaged (with the equivalence test) and per sample."""
    from .fidelity import fidelity_paragraph

    f = r.fidelity
    parts = ["## Display fidelity: are simulated samples recognised as well as real ones?", "",
             fidelity_paragraph(f, r.equivalence_margin_pp, r.equivalence_margin_source), ""]
    if f is None or f.empty:
        return parts
    parts += [
        f"Margin: +-{r.equivalence_margin_pp:g} percentage points of proportion correct "
        f"({r.equivalence_margin_source}; why this default: docs/analysis.md). Rows: real - "
        "simulated; `estimate` log odds ratio (Wald interval, reference distribution in "
        "`interval`), `difference` difference of mean proportions (delta method), TOST on the "
        "averaged rows (`tost_p_value` < 0.05 and the 90 % interval inside the margin: "
        "equivalent). Per-sample rows: `p_holm` over the 8 group x sample contrasts of the same "
        "model (over those with a p-value). GEE rows are population-averaged; mixed-model rows are for a typical participant "
        "and come from the model `note` names.", "",
        _md_table(f[f["role"] == "averaged"].drop(
            columns=["compares", "basis", "role", "roughness_id", "p_holm", "note"])), ""]
    notes = sorted({n for n in f["note"].astype(str) if n and n != "nan"})
    parts += [f"- {n}" for n in notes] + ([""] if notes else [])
    per = f[(f["role"] == "per-sample") & (f["model"] == "gee")]
    if not per.empty:
        parts += ["Per sample (GEE; all models' rows in `fidelity.csv`):", "",
                  _md_table(per[["group", "roughness_id", "estimate", "ci_low", "ci_high",
                                 "test", "p_value", "p_holm", "difference",
                                 "difference_ci_low", "difference_ci_high"]]), ""]
    return parts


def _missing_section(r: AnalysisResult) -> list[str]:
    """Scheduled vs answered scored trials per participant, missing ones by reason."""
    m = r.missing
    if m.empty:
        return []
    total = int(m["missing"].sum())
    lead = (f"{int(m['scheduled'].sum())} scored trials were scheduled and "
            f"{int(m['answered'].sum())} answered; {total} have no answer"
            + (": " + ", ".join(f"{int(m[c].sum())} {c}" for c in
                                ("time_out", "no_contact", "fault", "session_ended", "other")
                                if m[c].sum()) if total else "") + ". "
            "Re-run attempts that ended with an answer are not missing. Per trial in "
            "`missing_trials.csv`.")
    partial = m[m["missing"] > 0]
    if not partial.empty:
        lead += (f" {len(partial)} participant(s) with missing trials are kept (the GEE and the "
                 "mixed models use every answered, analysed trial; no complete cases needed): "
                 + ", ".join(f"{r.participant} ({r.answered} of {r.scheduled})"
                             for r in partial.itertuples())
                 + ". The complete-cases sensitivity row of the named tests leaves them out.")
    if "answered_excluded" in m and m["answered_excluded"].sum():
        lead += (f" {int(m['answered_excluded'].sum())} answered trial(s) are left out of the "
                 "models for another reason (`all_trials.csv`, column `exclusion`).")
    shown = m[m["missing"] > 0] if total else m.iloc[:0]
    return ["### Missing data (scheduled scored trials without an answer)", "", lead, "",
            (_md_table(shown) if not shown.empty else "_every scheduled scored trial was answered_"),
            ""]


def _agreement_comparison_md(table) -> list[str]:
    """Per-participant IT, kappa and Hu: means with studentized bootstrap intervals, A - B with
    the union of the studentized and Welch intervals, tested by Welch's t."""
    if table is None or table.empty:
        return []
    return ["Per participant (each participant's own confusion matrix per mode; participants "
            "are the units): mean per group x mode with a studentized (bootstrap-t) interval "
            "on the participants' values, and group A - B with the union of the stratified "
            "studentized bootstrap interval and Welch's t interval, tested by Welch's t "
            "(Welch-Satterthwaite df; `agreement_participants.csv` has every participant's "
            "values). The values are bounded and skewed (12 trials each): t intervals alone "
            "covered 0.93-0.95 (400 simulated studies at 13 + 17 and 20 + 8; "
            "benchmarks/README.md has these intervals' coverage).", "",
            _md_table(table.drop(columns=["interval"])), ""]


def _unmeasured_dropped(table: pd.DataFrame) -> pd.DataFrame:
    """``table`` without the interval columns whose coverage was never measured.

    report.md prints only intervals the recovery benchmark measured
    (benchmarks/bench_recovery.py); the others stay in the machine CSVs.
    """
    return table.drop(columns=[c for c in ("ci_low", "ci_high", "po_ci_low", "po_ci_high")
                               if c in table])


def _statistics_sections(r: AnalysisResult, pct: str) -> list[str]:
    """The report's statistics sections (models, named tests, chance, psychophysics)."""
    return _model_sections(r, pct) + _test_sections(r) + _psychophysics_section(r)


def _model_sections(r: AnalysisResult, pct: str) -> list[str]:
    """The mixed logits (intercepts; random slope) and the variational Bayes comparison."""
    parts = []
    if r.glmm is not None and r.glmm.formula is not None:
        conv = r.glmm.convergence
        parts += [
            "## Mixed logit: participant random intercepts, maximum likelihood", "",
            f"Formula: `{r.glmm.formula}` + `(1 | participant)`"
            + (f" (requested `{r.glmm.requested}`)" if r.glmm.simplified else "")
            + f". {conv['method']}: {'converged' if conv['optimiser_success'] else 'NOT converged'} "
            f"after {conv['iterations']} iterations ({conv['function_evaluations']} evaluations; "
            f"status {conv['optimiser_status']}, \"{conv['optimiser_message']}\"), largest "
            f"|gradient| {conv['max_abs_gradient']:.1e}, log-likelihood "
            f"{conv['log_likelihood']:.3f}, Hessian "
            f"{'positive definite' if conv['hessian_positive_definite'] else 'NOT positive definite'}. "
            f"Fixed effects: Wald {pct} intervals (log odds, for a typical participant); "
            f"participant SD: profile-likelihood interval (cut-off F(1, participants - 2), the "
            f"small-sample analogue of chi2(1)); ICC on the latent (logistic) scale "
            f"sigma^2 / (sigma^2 + pi^2/3). Coverage of these intervals was measured "
            f"(docs/analysis.md); the estimates agree with R's lme4::glmer (tests).", "",
            _md_table(r.glmm.table), ""]
    sl = r.glmm_slope
    if sl is not None and sl.notes:
        parts += ["### Random-slope model: fallbacks and convergence", "",
                  *[f"- {n}" for n in sl.notes],
                  f"- {r.mixed_choice.reason}" if r.mixed_choice is not None else "", ""]
    if sl is not None and sl.formula is not None:
        conv = sl.convergence
        parts += [
            "### With a random slope for mode: `(1 + mode | participant)`", "",
            f"Does the real-vs-simulated difference vary between participants? {conv['method']}: "
            f"{'converged' if conv['optimiser_success'] else 'NOT converged'} after "
            f"{conv['iterations']} iterations, log-likelihood {conv['log_likelihood']:.3f}. "
            f"Fixed effects with Wald intervals (t(participants - 2)); the two SDs and the "
            f"correlation with profile-likelihood intervals (cut-off F(1, participants - 2); an "
            f"SD's lower end 0 and a correlation's end +-1 where the profile never rises that "
            f"far); `lrt_slope` is the likelihood-ratio test against the intercept-only model "
            f"(p from the 50:50 chi2(1)/chi2(2) mixture). Coverage of these intervals was "
            f"measured over 200 datasets per scenario (docs/analysis.md, \"Measured coverage\"): "
            f"with a true random slope 0.945-0.963 for every one; when the true slope SD is 0 the "
            f"slope SD's interval covers 0.965-0.975, at or above the 0.97 edge (conservative at "
            f"the boundary).", "",
            _md_table(sl.table[~sl.table["term"].str.contains(":")]), "",
            "Interaction terms: `glmm_slope.csv`.", ""]
    if r.bayes.formula is not None:
        parts += ["## Mean-field variational Bayes (comparison only)", "",
                  "Posterior SDs of mean-field VB are 3-4.5x too small; not used for inference.", "",
                  _md_table(r.bayes.table.drop(columns=[c for c in ("cri_low", "cri_high")
                                                        if c in r.bayes.table])),
                  "Its credible intervals are in `bayes.csv` only.", ""]
    return parts


def _test_sections(r: AnalysisResult) -> list[str]:
    """The named tests, the group contrasts and the tests against chance."""
    parts = []
    t = r.tests
    if not t.empty:
        show = t.drop(columns=["basis"])
        parts += [
            "## Named tests: primary, omnibus, per-sample (Holm), interaction", "",
            "Primary test: group A vs B with real samples, averaged over the four samples (the "
            "paper's claim), GEE Wald test. The omnibus test (all per-sample A-B differences zero "
            "at once) comes before the per-sample tests, whose p-values are Holm-adjusted over "
            "both modes (`p_holm`); only adjusted results are named in the summary. `estimate` is "
            "on the log-odds scale; `difference` is the same comparison as a difference of mean "
            "proportions (averaged rows: the mean of the four samples' proportions, not expit of "
            "the mean log odds). The interaction compares the A-B gap with real and with "
            "simulated samples.", "",
            _md_table(show), ""]
    c = r.contrasts
    if not c.empty:
        parts += ["## Group contrasts (A vs B within each mode)", "",
                  "roughness_id 0 = averaged over the four samples: log odds ratio of the mean log "
                  "odds, `difference_A_minus_B` a difference of mean proportions. GEE rows are "
                  "population-averaged; GLMM rows (in `contrasts.csv`) are for a typical "
                  "participant. `compares` says what each row compares.", "",
                  _md_table(c[c["model"] == "gee"].drop(columns=["compares"])), ""]
    else:
        parts += ["## Group contrasts (A vs B within each mode)", "", "_no group term_", ""]
    if not r.chance.empty:
        ch = r.chance.drop(columns=["compares"])
        parts += ["## Against chance (0.25)", "",
                  "One-sample t-test of the participants' proportions correct against 0.25 "
                  "(participants are the units), per cell and per group x mode; `p_holm` adjusts "
                  "within each family.", "", _md_table(ch), ""]
    return parts


def _psychophysics_section(r: AnalysisResult) -> list[str]:
    """Information transfer, Hu, kappa, ordinal agreement, covariates, force, response times."""
    parts = []
    ex = r.extras
    if ex:
        parts += ["## Psychophysics: information transfer, Hu, kappa, ordinal, covariates, "
                  "response times", "",
                  "Information transfer in bits (plug-in and Miller-Madow bias-corrected), Cohen's "
                  "kappa and the mean of Wagner's unbiased hit rates per group x mode (point "
                  "estimates):", "", _md_table(ex["agreement"]), "",
                  *_agreement_comparison_md(ex.get("agreement_comparison")),
                  "Ordinal agreement (samples are ordered): Spearman rank correlation of stimulus "
                  "and response (pooled; mean of participants' own, t-test across participants) "
                  "and the proportional-odds slope per sample step (participant-cluster-robust "
                  "SE; its interval, whose coverage was not measured, is in `ordinal.csv` "
                  "only):", "", _md_table(_unmeasured_dropped(ex["ordinal"])), "",
                  "Covariates (GEE, bias-reduced): skin thickness as a continuous predictor beside "
                  "the 800 um split, trial position, and log response time (speed-accuracy):", "",
                  _md_table(_unmeasured_dropped(ex["covariates"])) if not ex["covariates"].empty
                  else "_none estimable_", "(Their intervals, not measured for coverage, are in "
                  "`covariates.csv` only.)",
                  "", "Contact force the display measured (mean summed force over each "
                  "contact, `contact_force_N`; Eq. 5's R depends on it), per group x mode; the "
                  "covariates above include it when it varies:", "",
                  _md_table(ex["force"]) if not ex.get("force", pd.DataFrame()).empty
                  else "_not logged (sessions older than the contact-force column)_",
                  "", "Median response times by group, mode, sample and correctness are in "
                  "`rt.csv`; Wagner's Hu per sample in `hu.csv`.", ""]
    return parts
