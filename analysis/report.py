"""``analyze(data_dir, out_dir)``: every table, the figures and ``report.md`` in one call."""
from __future__ import annotations

import json
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
import pandas as pd
from threadpoolctl import threadpool_limits

from .confusion import confusion_matrices
from .errors import LogError
from .figures import plot_confusion, plot_figure9
from .load import TrialLog, load_trials
from .exports import (cell_counts, check_codebook, codebook, run_settings, wide_table,
                      write_csv)
from .glmm import fit_glmm
from .glmm_slope import fit_glmm_slope
from .inference import chance_tests, holm, interaction_test, omnibus_group_test, primary_test
from .missing import missing_summary, missing_trials
from .model_decisions import model_decisions, model_decisions_markdown
from .models import FORMULA, ModelFit, fit_bayes, fit_gee, group_contrasts
from .proportions import cell_proportions, participant_summary
from .psychophysics import (agreement_table, covariate_table, force_table, hu_table, ordinal_table,
                            rt_table)

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
        The GEE and the (demoted, optional) mean-field Bayesian mixed logit.
    glmm : ModelFit
        The mixed logit by maximum likelihood (random intercepts, adaptive
        Gauss-Hermite; :func:`analysis.glmm.fit_glmm`).
    glmm_slope : ModelFit
        The same with a random slope for mode (:func:`analysis.glmm_slope.fit_glmm_slope`).
    tests : pandas.DataFrame
        The named tests: primary, omnibus, per-sample (Holm), interaction.
    chance : pandas.DataFrame
        Tests against chance per cell and per group × mode.
    missing : pandas.DataFrame
        Per participant: scheduled vs answered scored trials, missing ones by reason.
    extras : dict of str to pandas.DataFrame
        Information transfer and kappa, Hu, ordinal, covariates, response times.
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
    glmm: ModelFit | None = None
    tests: pd.DataFrame = field(default_factory=pd.DataFrame)
    chance: pd.DataFrame = field(default_factory=pd.DataFrame)
    missing: pd.DataFrame = field(default_factory=pd.DataFrame)
    extras: dict = field(default_factory=dict)
    glmm_slope: ModelFit | None = None


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
                  gee: ModelFit, bayes: ModelFit, contrasts: pd.DataFrame,
                  glmm: ModelFit | None = None, tests: pd.DataFrame | None = None) -> str:
    """A few sentences a reader without statistics can follow.

    Parameters
    ----------
    log, proportions, confusion, gee, bayes, contrasts, glmm, tests
        As computed by :func:`analyze`. Only Holm-adjusted per-sample results are
        named as significant.

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
    out += _tests_summary(contrasts, tests)
    if glmm is not None and glmm.formula is not None:
        t = glmm.table.set_index("term")
        sd, icc = t.loc["participant_sd"], t.loc["icc_latent"]
        out.append(f"The mixed logit (maximum likelihood, participant random intercepts) puts the "
                   f"spread between participants at SD {sd['log_odds']:.2f} on the log-odds scale "
                   f"(95 % profile interval {sd['ci_low']:.2f}-{sd['ci_high']:.2f}; latent-scale "
                   f"ICC {icc['log_odds']:.2f}, {icc['ci_low']:.2f}-{icc['ci_high']:.2f}).")
    notes = gee.notes + (glmm.notes if glmm is not None else []) + bayes.notes
    if notes:
        out.append("Model notes:\n" + "\n".join(f"- {n}" for n in notes))
    return "\n\n".join(out)


def _tests_summary(contrasts: pd.DataFrame, tests: pd.DataFrame | None) -> list[str]:
    """Primary test, omnibus, Holm-adjusted per-sample results, interaction: in words."""
    out = []
    if tests is None or tests.empty:
        return out
    by_role = {role: sel for role, sel in tests.groupby("role")}
    if "primary" in by_role:
        r = by_role["primary"].iloc[0]
        out.append(f"Primary test (the paper's claim: group A vs B with real samples, averaged "
                   f"over the four samples; GEE Wald test): log odds ratio {r.estimate:+.2f} "
                   f"(95 % CI {r.ci_low:+.2f} to {r.ci_high:+.2f}), p = {r.p_value:.3f}; "
                   f"difference of mean proportions {100 * r.difference:+.1f} percentage points "
                   f"({100 * r.difference_ci_low:+.1f} to {100 * r.difference_ci_high:+.1f}).")
    if "omnibus" in by_role:
        r = by_role["omnibus"].iloc[0]
        out.append(f"Omnibus test of any group difference on any sample ({r.test.split(': ')[1]}"
                   f", small-sample F = {r.statistic:.2f}): p = {r.p_value:.3f}.")
    per = by_role.get("per-sample")
    if per is not None and not per.empty:
        missing = per[per["p_value"].isna()]
        if not missing.empty:
            out.append("No group comparison is possible for " + ", ".join(missing["compares"].map(
                lambda c: c.split(",")[1].strip() if "," in c else c))
                + " (a group answered it all right or all wrong).")
        sig = per[per["p_holm"] < 0.05]
        n_tests = int(per["p_value"].notna().sum())
        omnibus = by_role.get("omnibus")
        gate = None if omnibus is None else float(omnibus["p_value"].iloc[0])
        if gate is not None and not gate < 0.05:
            out.append(f"The omnibus test does not reject (p = {gate:.3f}), so no single sample "
                       f"is claimed to differ between the groups (Holm-adjusted per-sample "
                       f"p-values are in tests.csv; the smallest is {per['p_holm'].min():.3f}).")
        elif sig.empty:
            out.append(f"After Holm's adjustment for the {n_tests} per-sample comparisons, no "
                       f"single sample shows a group difference (all adjusted p >= 0.05).")
        else:
            out.append(f"After Holm's adjustment for the {n_tests} per-sample comparisons, the "
                       f"group difference remains for: " + "; ".join(
                           f"{r.compares.split(':')[0]} (adjusted p = {r.p_holm:.3f})"
                           for r in sig.itertuples()) + ".")
        if (per["basis"].astype(str).str.startswith("per-sample")).any():
            out.append("Per-sample group comparisons come from a GEE of each sample's trials "
                       "alone (the full model could not be fitted; see the model notes).")
    inter = by_role.get("interaction")
    if inter is not None and not inter.empty:
        r = inter[inter["model"] == "gee"].iloc[0] if (inter["model"] == "gee").any() \
            else inter.iloc[0]
        if np.isfinite(r.estimate):
            out.append(f"Group x mode interaction (is the A-B gap different with real and simulated "
                       f"samples?): difference of the two A-B log odds ratios {r.estimate:+.2f} "
                       f"(95 % CI {r.ci_low:+.2f} to {r.ci_high:+.2f}), p = {r.p_value:.3f}; as "
                       f"proportions, {100 * r.difference:+.1f} percentage points "
                       f"({100 * r.difference_ci_low:+.1f} to {100 * r.difference_ci_high:+.1f}).")
    return out


def _write_csv(df: pd.DataFrame, path: Path) -> Path:
    # Booleans one way, as in trials.csv: 1/0 (not True/False next to 0/1 columns); full precision.
    flags = [c for c in df.columns if df[c].dtype == bool]
    if flags:
        df = df.assign(**{c: df[c].astype(int) for c in flags})
    return write_csv(df, path)


def tests_table(gee: ModelFit, glmm: ModelFit | None, contrasts: pd.DataFrame,
                trials: pd.DataFrame, level: float = 0.95) -> pd.DataFrame:
    """The named tests (rows: primary, omnibus, per-sample with Holm, interaction).

    Parameters
    ----------
    gee, glmm : ModelFit
    contrasts : pandas.DataFrame
        From :func:`analysis.group_contrasts` (GEE rows used).
    trials : pandas.DataFrame
    level : float

    Returns
    -------
    pandas.DataFrame
        ``role, test, model, compares, estimate, se, ci_low, ci_high, statistic, df,
        p_value, p_holm, difference, difference_ci_low, difference_ci_high, basis``.
    """
    rows = []
    def from_contrast(role, r, p_holm=np.nan):
        return {"role": role, "test": "Wald z", "model": r["model"], "compares": r["compares"],
                "estimate": r["log_odds_ratio_A_vs_B"], "se": r["se"], "ci_low": r["ci_low"],
                "ci_high": r["ci_high"],
                "statistic": r["log_odds_ratio_A_vs_B"] / r["se"] if r["se"] else np.nan,
                "df": 1, "p_value": r["p_value"], "p_holm": p_holm,
                "difference": r["difference_A_minus_B"], "difference_ci_low": r["difference_low"],
                "difference_ci_high": r["difference_high"], "basis": r["basis"]}
    first = primary_test(contrasts)
    if first is not None:
        rows.append(from_contrast("primary", first))
    if gee.formula is not None:
        omni = omnibus_group_test(gee, trials)
        if omni["df"]:
            rows.append({"role": "omnibus", "test": omni["test"] + f": F({omni['df']}, "
                         f"{omni['df_denominator']}) from Wald chi2 = {omni['chi2']:.3f}",
                         "model": "gee", "compares": omni["hypothesis"], "statistic": omni["f"],
                         "df": omni["df"], "p_value": omni["p_value"],
                         "basis": f"model: {gee.formula}"})
    if not contrasts.empty:
        per = contrasts[(contrasts["model"] == "gee") & (contrasts["roughness_id"] > 0)]
        adjusted = holm(per["p_value"].to_numpy(float))
        rows += [from_contrast("per-sample", r, a) for (_, r), a in zip(per.iterrows(), adjusted)]
    for fit in (gee, glmm):
        if fit is None or fit.formula is None:
            continue
        it = interaction_test(fit, trials, level=level)
        if np.isfinite(it["log_odds"]):
            scale = ("population-averaged" if fit.kind == "gee"
                     else "typical participant (u = 0)")
            rows.append({"role": "interaction", "test": "Wald z", "model": fit.kind,
                         "compares": it["compares"] + f"; proportions {scale}",
                         "estimate": it["log_odds"], "se": it["se"], "ci_low": it["ci_low"],
                         "ci_high": it["ci_high"], "statistic": it["log_odds"] / it["se"],
                         "df": 1, "p_value": it["p_value"],
                         "difference": it["difference_of_differences"],
                         "difference_ci_low": it["dd_low"], "difference_ci_high": it["dd_high"],
                         "basis": f"model: {fit.formula}"})
    columns = ["role", "test", "model", "compares", "estimate", "se", "ci_low", "ci_high",
               "statistic", "df", "p_value", "p_holm", "difference", "difference_ci_low",
               "difference_ci_high", "basis"]
    return pd.DataFrame(rows, columns=columns)


# one BLAS thread: the models' many small BLAS calls spin idle threads (10x slower when busy)
@threadpool_limits.wrap(limits=1)
def analyze(data_dir, out_dir, *, n_boot: int = 2000, level: float = 0.95, seed: int = 20261122,
            bayes: bool = False, mixed: bool = True,
            progress: Callable[[str], None] | None = None,
            sessions: str = "first") -> AnalysisResult:
    """Load every session under ``data_dir``, analyse, and write the results to ``out_dir``.

    Parameters
    ----------
    data_dir : str or Path
        The data directory (``DATA/<participant>/<session>/``).
    out_dir : str or Path
        Created if missing. Receives ``figure9.png``, ``confusion.png``,
        ``proportions.csv``, ``participants.csv``, ``confusion.csv``, ``gee.csv``,
        ``glmm.csv``, ``glmm_convergence.json``, ``contrasts.csv``, ``tests.csv``,
        ``chance.csv``, ``missing.csv``, ``missing_trials.csv``, ``agreement.csv``,
        ``hu.csv``, ``ordinal.csv``, ``covariates.csv``, ``rt.csv``,
        ``wide.csv``, ``cell_counts.csv``, ``exclusions.csv``, ``sessions.csv``,
        ``all_trials.csv`` (every logged row, tidy, with its inclusion; not named
        ``trials.csv`` so that an output folder is never taken for a session),
        ``codebook.json``, ``settings.json``, ``report.md`` (and ``bayes.csv``
        when ``bayes``). Machine CSVs are at full precision.
    n_boot : int
        Bootstrap resamples for the cluster intervals.
    level : float
        Confidence level of every interval, 0–1.
    seed : int
        Seed of the bootstrap and of the variational fit.
    bayes : bool
        Also fit the mean-field variational Bayesian mixed logit (demoted: its
        intervals are 3-4.5x too narrow; kept for comparison only).
    mixed : bool
        Fit the maximum-likelihood mixed logit (:func:`analysis.glmm.fit_glmm`).
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
        if mixed:
            say("fitting the mixed logit (ML, adaptive Gauss-Hermite, profile interval of the SD)")
            glmm = fit_glmm(trials, level=level)
            say("fitting the mixed logit with a random slope for mode (5x5 nodes)")
            slope = fit_glmm_slope(trials, glmm.formula or FORMULA, level=level,
                                   intercept_fit=glmm)
        else:
            glmm = ModelFit("glmm", None, FORMULA, pd.DataFrame(), ["GLMM: not requested"])
            slope = ModelFit("glmm-slope", None, FORMULA, pd.DataFrame(), [])
        if bayes:
            say("fitting the mean-field Bayesian mixed logit (comparison only)")
            bfit = fit_bayes(trials, level=level, seed=seed)
        else:
            bfit = ModelFit("bayes", None, FORMULA, pd.DataFrame(), [])
    contrasts = group_contrasts(gee, trials, level=level)
    for fit, label in ((glmm, "glmm"), (bfit, "bayes-vb (mean-field: intervals too narrow)")):
        if fit.formula is None:
            continue
        extra = group_contrasts(fit, trials, level=level)
        extra["model"] = label
        if fit.kind == "bayes":
            extra["p_value"] = np.nan
        contrasts = pd.concat([contrasts, extra], ignore_index=True) if not contrasts.empty \
            else extra
    say("tests: primary, omnibus, Holm, interaction, chance; missing data; psychophysics")
    tests = tests_table(gee, glmm, contrasts, trials, level)
    if not contrasts.empty:
        contrasts["p_holm"] = np.nan
        for model in contrasts["model"].unique():
            sel = (contrasts["model"] == model) & (contrasts["roughness_id"] > 0)
            if model.startswith("bayes"):
                continue
            contrasts.loc[sel, "p_holm"] = holm(contrasts.loc[sel, "p_value"].to_numpy(float))
    chance = chance_tests(trials, level=level)
    missing_rows = missing_trials(log.trials, log.sessions)
    missing = missing_summary(log.trials, log.sessions, missing_rows)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        extras = {"agreement": agreement_table(trials), "hu": hu_table(trials),
                  "ordinal": ordinal_table(trials, level=level),
                  "covariates": covariate_table(trials, level=level), "rt": rt_table(trials),
                  "force": force_table(trials),
                  "model_decisions": model_decisions(log.sessions.loc[log.sessions["analysed"],
                                                                      "path"])}
    summary = plain_summary(log, proportions, confusion, gee, bfit, contrasts, glmm, tests)
    say(f"writing figures and tables to {out}")
    files = {
        "figure9": plot_figure9(proportions, out / "figure9.png"),
        "confusion_png": plot_confusion(confusion, out / "confusion.png"),
        "proportions": _write_csv(proportions, out / "proportions.csv"),
        "participants": _write_csv(participants, out / "participants.csv"),
        "confusion": _write_csv(confusion, out / "confusion.csv"),
        "gee": _write_csv(gee.table, out / "gee.csv"),
        "glmm": _write_csv(glmm.table, out / "glmm.csv"),
        "glmm_slope": _write_csv(slope.table, out / "glmm_slope.csv"),
        "contrasts": _write_csv(contrasts, out / "contrasts.csv"),
        "tests": _write_csv(tests, out / "tests.csv"),
        "chance": _write_csv(chance, out / "chance.csv"),
        "missing": _write_csv(missing, out / "missing.csv"),
        "missing_trials": _write_csv(missing_rows, out / "missing_trials.csv"),
        **{name: _write_csv(table, out / f"{name}.csv") for name, table in extras.items()},
        "wide": _write_csv(wide_table(trials), out / "wide.csv"),
        "cell_counts": _write_csv(cell_counts(trials), out / "cell_counts.csv"),
        "exclusions": _write_csv(log.exclusion_counts(), out / "exclusions.csv"),
        "sessions": _write_csv(log.sessions, out / "sessions.csv"),
        "trials": _write_csv(log.trials, out / "all_trials.csv"),
    }
    if bayes:
        files["bayes"] = _write_csv(bfit.table, out / "bayes.csv")
    if glmm.formula is not None:
        files["glmm_convergence"] = out / "glmm_convergence.json"
        files["glmm_convergence"].write_text(json.dumps(
            {**glmm.result, "formula": glmm.formula, "notes": glmm.notes,
             "random_slope_model": {**(slope.result or {}), "formula": slope.formula,
                                    "notes": slope.notes}}, indent=2), "utf-8")
    book = codebook(files)
    files["codebook"] = out / "codebook.json"
    files["codebook"].write_text(json.dumps(book, indent=2, ensure_ascii=False), "utf-8")
    files["settings"] = out / "settings.json"
    files["settings"].write_text(json.dumps(run_settings(
        data_dir=str(data_dir), out_dir=str(out), n_boot=n_boot, level=level, seed=seed,
        mixed=mixed, bayes=bayes, gee_formula=gee.formula, glmm_formula=glmm.formula,
        requested_formula=FORMULA, glmm_method=(glmm.result or {}).get("method"),
        primary_test="GEE Wald z of the A-B log odds ratio averaged over samples, real mode",
        multiplicity="Holm over the per-sample A-B tests (both modes)",
        undocumented_columns=check_codebook(book)), indent=2), "utf-8")
    result = AnalysisResult(log, proportions, participants, confusion, gee, bfit, contrasts,
                            summary, files, glmm, tests, chance, missing, extras, slope)
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
    parts += _missing_section(r)
    parts += model_decisions_markdown(r.extras.get("model_decisions", pd.DataFrame()), _md_table)
    if log.warnings:
        parts += ["### Problems in the logs (worked around)", ""]
        parts += [f"- {w}" for w in log.warnings] + [""]
    parts += [
        "## Proportion correct (Figure 9)", "",
        "Intervals: participant bootstrap (participants resampled within group; the design "
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


def _missing_section(r: AnalysisResult) -> list[str]:
    """Scheduled vs answered scored trials per participant, missing ones by reason."""
    m = r.missing
    if m.empty:
        return []
    total = int(m["missing"].sum())
    lead = (f"{int(m['scheduled'].sum())} scored trials were scheduled and "
            f"{int(m['answered'].sum())} answered; {total} have no analysable answer"
            + (": " + ", ".join(f"{int(m[c].sum())} {c}" for c in
                                ("time-out", "no contact", "fault", "session ended", "other")
                                if m[c].sum()) if total else "") + ". "
            "Re-run attempts that ended with an answer are not missing. Per trial in "
            "`missing_trials.csv`.")
    shown = m[m["missing"] > 0] if total else m.iloc[:0]
    return ["### Missing data (scheduled scored trials without an answer)", "", lead, "",
            (_md_table(shown) if not shown.empty else "_every scheduled scored trial was answered_"),
            ""]


def _unmeasured_dropped(table: pd.DataFrame) -> pd.DataFrame:
    """``table`` without the interval columns whose coverage was never measured.

    report.md prints only intervals the recovery benchmark measured
    (benchmarks/bench_recovery.py); the others stay in the machine CSVs.
    """
    return table.drop(columns=[c for c in ("ci_low", "ci_high", "po_ci_low", "po_ci_high")
                               if c in table])


def _statistics_sections(r: AnalysisResult, pct: str) -> list[str]:
    """The report's statistics sections (models, named tests, chance, psychophysics)."""
    parts = []
    if r.glmm is not None and r.glmm.formula is not None:
        conv = r.glmm.result
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
    if sl is not None and sl.formula is not None:
        conv = sl.result
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
    ex = r.extras
    if ex:
        parts += ["## Psychophysics: information transfer, Hu, kappa, ordinal, covariates, "
                  "response times", "",
                  "Information transfer in bits (plug-in and Miller-Madow bias-corrected), Cohen's "
                  "kappa and the mean of Wagner's unbiased hit rates per group x mode (point "
                  "estimates):", "", _md_table(ex["agreement"]), "",
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
                  else "_not logged (sessions before issue 12)_",
                  "", "Median response times by group, mode, sample and correctness are in "
                  "`rt.csv`; Wagner's Hu per sample in `hu.csv`.", ""]
    return parts
