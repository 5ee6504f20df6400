"""``analyze(data_dir, out_dir)``: every table, the figures and ``report.md`` in one call."""
from __future__ import annotations

import json
from dataclasses import dataclass
import warnings
from pathlib import Path
from typing import Callable

import numpy as np
import pandas as pd
from threadpoolctl import threadpool_limits

from sessionfiles.atomicfile import output_file

from .agreement_participants import agreement_comparison, participant_agreement
from .confusion import confusion_matrices
from .errors import LogError
from .worker import AnalysisWorker
from .load import TrialLog, load_trials
from .exports import (cell_counts, check_codebook, codebook, run_settings, wide_table,
                      write_csv)
from .glmm import fit_glmm
from .fidelity import equivalence_margin, fidelity_paragraph, mode_contrasts
from .glmm_slope import fit_glmm_slope
from .glmm_slope_profile import complete_profiles
from .mixed_choice import choose_mixed
from .inference import (averaged_contrast, chance_tests, holm, interaction_test,
                        omnibus_group_test, primary_test)
from .missing import missing_summary, missing_trials
from .model_decisions import model_decisions
from .models import (FORMULA, ModelFit, fit_bayes, fit_gee, group_contrasts, lone_group,
                     lone_group_reason, reference_quantile)
from .wording import df_text
from .proportions import cell_proportions, participant_summary
from .result import AnalysisResult
from .psychophysics import (agreement_table, covariate_table, force_table, hu_table, ordinal_table,
                            rt_table)
# report.md and the summary live in their own modules; re-exported (tests read the private two)
from .report_markdown import COLUMN_MEANINGS, sessions_markdown, report_markdown  # noqa: F401
from .summary import tests_summary, plain_summary  # noqa: F401

__all__ = ["AnalysisResult", "analyze", "plain_summary", "COLUMN_MEANINGS"]


def _write_text(path: Path, text: str) -> None:
    """A text output, whole or not at all (:func:`sessionfiles.atomicfile.output_file`)."""
    with output_file(path) as fh:
        fh.write(text)


def _write_csv(df: pd.DataFrame, path: Path) -> Path:
    # Booleans one way, as in trials.csv: 1/0 (not True/False next to 0/1 columns); full precision.
    flags = [c for c in df.columns if df[c].dtype == bool]
    if flags:
        df = df.assign(**{c: df[c].astype(int) for c in flags})
    return write_csv(df, path)


def _t_label(df) -> str:
    """The reference distribution of a Wald ratio, named: ``Wald t(df)`` or ``Wald z (normal)``
    (a Welch-Satterthwaite df with one decimal: ``Wald t(11.3)``)."""
    return f"Wald t({df_text(df)})" if df else "Wald z (normal)"


def tests_table(gee: ModelFit, glmm: ModelFit | None, contrasts: pd.DataFrame,
                trials: pd.DataFrame, level: float = 0.95,
                mixed_note: str = "") -> pd.DataFrame:
    """The named tests (rows: primary, omnibus, per-sample with Holm, interaction).

    Parameters
    ----------
    gee : ModelFit
    glmm : ModelFit or None
        The mixed model of the interaction row (:func:`analysis.mixed_choice.choose_mixed`:
        the random-slope model when it was fitted with the full formula).
    contrasts : pandas.DataFrame
        From :func:`analysis.group_contrasts` (GEE rows used).
    trials : pandas.DataFrame
    level : float
    mixed_note : str
        Why that mixed model (goes into the row's ``note``).

    Returns
    -------
    pandas.DataFrame
        ``role, test, model, compares, estimate, se, ci_low, ci_high, interval, statistic, df,
        p_value, p_holm, difference, difference_ci_low, difference_ci_high, basis, note``.
        ``test`` names the reference distribution (``Wald t(28)``, ``Wald F(8, 22)``); ``df``
        is its (denominator) degrees of freedom, empty for the normal.
    """
    rows = []
    first = primary_test(contrasts)
    if first is not None:
        rows.append(_contrast_row("primary", first, gee.df))
    if gee.formula is not None:
        rows += _omnibus_rows(gee, trials)
    if not contrasts.empty:
        per = contrasts[(contrasts["model"] == "gee") & (contrasts["roughness_id"] > 0)]
        adjusted = holm(per["p_value"].to_numpy(float))
        rows += [_contrast_row("per-sample", r, gee.df, a)
                 for (_, r), a in zip(per.iterrows(), adjusted)]
    for fit in (gee, glmm):
        if fit is not None and fit.formula is not None:
            rows += _interaction_rows(fit, trials, level, mixed_note)
    return _withhold_lone_group_tests(pd.DataFrame(rows, columns=TESTS_COLUMNS), trials)


def _contrast_row(role: str, r, model_df, p_holm=np.nan) -> dict:
    """A primary or per-sample row of :func:`tests_table` from a contrast row ``r``; its df is
    the contrast's own, else the model's (``model_df``)."""
    df = r["df"] if "df" in r and pd.notna(r["df"]) else model_df
    return {"role": role, "test": _contrast_test(r, df), "model": r["model"],
            "compares": r["compares"],
            "estimate": r["log_odds_ratio_A_vs_B"], "se": r["se"], "ci_low": r["ci_low"],
            "ci_high": r["ci_high"], "interval": _interval_label(df),
            "statistic": r["log_odds_ratio_A_vs_B"] / r["se"] if r["se"] else np.nan,
            "df": df if df else np.nan, "p_value": r["p_value"], "p_holm": p_holm,
            "difference": r["difference_A_minus_B"], "difference_ci_low": r["difference_low"],
            "difference_ci_high": r["difference_high"], "basis": r["basis"],
            "note": ("per-sample GEE of this sample's trials alone: the full model could not "
                     "be fitted" if str(r["basis"]).startswith("per-sample") else "")}


def _omnibus_rows(gee: ModelFit, trials: pd.DataFrame) -> list[dict]:
    """The omnibus row of :func:`tests_table`: the test, or why it was not done (none without
    a df)."""
    omni = omnibus_group_test(gee, trials)
    if omni["reason"]:
        return [{"role": "omnibus", "test": omni["reason"], "model": "gee",
                 "compares": omni["hypothesis"], "basis": f"model: {gee.formula}", "note": ""}]
    if not omni["df"]:
        return []
    return [{"role": "omnibus", "test": f"Wald F({omni['df']}, "
             f"{df_text(omni['df_denominator'])}), {omni['method']}, from Wald "
             f"chi2 = {omni['chi2']:.3f}",
             "model": "gee", "compares": omni["hypothesis"], "statistic": omni["f"],
             "df": omni["df"], "p_value": omni["p_value"],
             "basis": f"model: {gee.formula}", "note": ""}]


def _interaction_rows(fit: ModelFit, trials, level, mixed_note: str) -> list[dict]:
    """The mode x group interaction row of :func:`tests_table` from one fit (none when its
    estimate is not finite)."""
    it = interaction_test(fit, trials, level=level)
    if it["reason"]:
        return [{"role": "interaction", "test": it["reason"], "model": fit.kind,
                 "compares": it["compares"], "interval": "none (see test)",
                 "basis": f"model: {fit.formula}", "note": ""}]
    if not np.isfinite(it["log_odds"]):
        return []
    scale = "population-averaged" if fit.kind == "gee" else "typical participant (u = 0)"
    return [{"role": "interaction", "test": _t_label(it["df"]), "model": fit.kind,
             "compares": it["compares"] + f"; proportions {scale}",
             "estimate": it["log_odds"], "se": it["se"], "ci_low": it["ci_low"],
             "ci_high": it["ci_high"],
             "interval": _interval_label(it["df"]) + (
                 "; SE the CR2 participant sandwich, Bell-McCaffrey df"
                 if fit.cov_robust is not None else ""),
             "statistic": it["log_odds"] / it["se"],
             "df": it["df"] if it["df"] else np.nan, "p_value": it["p_value"],
             "difference": it["difference_of_differences"],
             "difference_ci_low": it["dd_low"], "difference_ci_high": it["dd_high"],
             "basis": f"model: {fit.formula}"
                      + (" + (1 + mode | participant)" if fit.kind == "glmm-slope"
                         else " + (1 | participant)" if fit.kind == "glmm" else ""),
             "note": mixed_note if fit.kind != "gee" else "; ".join(fit.notes)}]


#: Rows of :func:`tests_table` that compare group A with group B.
GROUP_COMPARISON_ROLES = ("primary", "omnibus", "per-sample", "interaction")


def _withhold_lone_group_tests(table: pd.DataFrame, trials: pd.DataFrame) -> pd.DataFrame:
    """The comparisons of the groups with a group of one participant (:func:`lone_group`): keep
    their estimates, lose their test, interval and p-values, with the reason."""
    lone = lone_group(trials)
    if table.empty or lone is None:
        return table
    rows = table["role"].isin(GROUP_COMPARISON_ROLES)
    table = table.copy()
    table.loc[rows, "test"] = lone_group_reason(lone)
    for col in ("se", "ci_low", "ci_high", "statistic", "df", "p_value", "p_holm",
                "difference_ci_low", "difference_ci_high"):
        if col in table:
            table.loc[rows, col] = np.nan
    if "interval" in table:
        table.loc[rows, "interval"] = "none (see test)"
    return table


def complete_cases_row(trials: pd.DataFrame, missing: pd.DataFrame,
                       level: float = 0.95) -> dict | None:
    """The primary test again on complete cases only (a sensitivity row), or None.

    Returns None when no participant has a missing scored trial (the row would repeat the
    primary test). Otherwise the GEE refitted on the participants with every scheduled scored
    trial answered, and the averaged real-mode A - B contrast.
    """
    if missing.empty or not (missing["missing"] > 0).any():
        return None
    complete = set(missing.loc[missing["missing"] == 0, "participant"].astype(str))
    sub = trials[trials["participant"].astype(str).isin(complete)]
    base = {"role": "sensitivity", "model": "gee",
            "compares": f"primary test on complete cases only ({len(complete)} of "
                        f"{trials['participant'].nunique()} participants: those with every "
                        f"scheduled scored trial answered)", "note": ""}
    if sub.empty or sub["group"].nunique() < 2:
        return {**base, "test": "not estimable", "note": "fewer than two groups left"}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = fit_gee(sub, level=level)
    row = averaged_contrast(fit, "real", level=level) if fit.formula else None
    if row is None:
        return {**base, "test": "not estimable", "note": "; ".join(fit.notes)}
    df = row["df"]
    q = reference_quantile(level, df)
    est, se = row["log_odds_ratio"], row["se"]
    return {**base, "test": _t_label(df), "estimate": est, "se": se, "ci_low": est - q * se,
            "ci_high": est + q * se, "interval": _interval_label(df),
            "statistic": est / se if se else np.nan, "df": df if df else np.nan,
            "p_value": row["p_value"], "difference": row["difference"],
            "difference_ci_low": row["difference_low"], "difference_ci_high": row["difference_high"],
            "basis": f"model: {fit.formula}", "note": "; ".join(fit.notes)}


def _contrast_test(r, df) -> str:
    """The ``test`` of a contrast row: its reference distribution, or why it is not tested."""
    basis = str(r["basis"])
    if not np.isfinite(r["log_odds_ratio_A_vs_B"]):
        return "not tested: " + (basis.split(": ", 1)[1] if basis.startswith("not estimable")
                                 else basis)
    if not (np.isfinite(r["se"]) and r["se"] > 0):
        return "not tested: the standard error is zero (no variation to test against)"
    return _t_label(df)


def _interval_label(df) -> str:
    return f"Wald, t({df_text(df)})" if df else "Wald, normal"


#: Columns of :func:`tests_table`.
TESTS_COLUMNS = ["role", "test", "model", "compares", "estimate", "se", "ci_low", "ci_high",
                 "interval", "statistic", "df", "p_value", "p_holm", "difference",
                 "difference_ci_low", "difference_ci_high", "basis", "note"]


# one BLAS thread: the models' many small BLAS calls spin idle threads (10x slower when busy)
@threadpool_limits.wrap(limits=1)
def analyze(data_dir, out_dir, *, n_boot: int = 2000, level: float = 0.95, seed: int = 20261122,
            bayes: bool = False, mixed: bool = True,
            progress: Callable[[str], None] | None = None,
            sessions: str = "first",
            equivalence_margin_pp: float | None = None,
            condition: str | None = None,
            before_write: Callable | None = None, executor=None,
            loaded: TrialLog | None = None, figure9: bool = True) -> AnalysisResult:
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
    equivalence_margin_pp : float, optional
        Margin of the real-vs-simulated equivalence test, percentage points of proportion
        correct; None: the protocol's ``[analysis] equivalence_margin_pp``, else 10
        (:func:`analysis.fidelity.equivalence_margin`).
    condition : str, optional
        ``BACKEND/CONTACT``: analyse the sessions of that display backend and contact model
        only (:func:`analysis.conditions.choose_condition`); sessions of two conditions without
        it are refused, never pooled.
    before_write : callable, optional
        Called once, with no argument, just before the first output is written (the command
        line's :meth:`sessionfiles.atomicfile.OutputFolder.begin`: a refused or failed analysis
        leaves an earlier run's outputs as they were). Every output is written whole
        (temporary file, then renamed over the old one).
    executor : optional
        Workers for the independent steps (the figures, the random-slope model's profile
        intervals): anything with ``submit(function, *args)`` returning a future with
        ``result()``, such as a running ``dask.distributed.Client`` (each of its workers
        that runs a step then holds ~190 MiB more). Default: a forked worker where that is safe, else this process
        (:class:`analysis.worker.AnalysisWorker`). The same files and numbers either way.
    loaded : TrialLog, optional
        ``data_dir``'s sessions already read by :func:`analysis.load.load_trials` with the same
        ``sessions`` and ``condition`` (``reproduce figure9`` reads its study once for this
        analysis and its receptor-depth fit); default: read here. Not changed here.
    figure9 : bool
        Draw ``figure9.png`` / ``.pdf`` (default); False leaves them to the caller
        (``reproduce figure9`` draws its own in their place, the claims beside the sessions).

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
    with AnalysisWorker(executor=executor) as worker:   # figures drawn while the models fit
        worker.warm_up()               # matplotlib imported there while the logs are read here
        log, trials, margin_pp, margin_source = _load(data_dir, sessions, condition,
                                                      equivalence_margin_pp, say, loaded)
        say(f"{log.trials['participant'].nunique()} participants, {len(trials)} analysable "
            f"trials; proportions with {n_boot} bootstrap resamples")
        proportions = cell_proportions(trials, level=level, n_boot=n_boot, seed=seed)
        participants = participant_summary(trials)
        confusion = confusion_matrices(trials)
        worker.draw(proportions, confusion, figure9=figure9)
        fits = _fit_models(trials, level=level, seed=seed, mixed=mixed, bayes=bayes, say=say,
                           submit=worker.submit)
        contrasts = _contrasts(fits, trials, level)
        say("tests: primary, omnibus, Holm, interaction, real vs simulated, chance; missing data; "
            "psychophysics")
        choice = choose_mixed(fits.glmm if mixed else None, fits.slope if mixed else None)
        tests = tests_table(fits.gee, choice.contrasts, contrasts, trials, level, choice.reason)
        missing_rows = missing_trials(log.trials, log.sessions)
        missing = missing_summary(log.trials, log.sessions, missing_rows)
        sensitivity = complete_cases_row(trials, missing, level)
        if sensitivity is not None:
            tests = pd.concat([tests, pd.DataFrame([sensitivity], columns=TESTS_COLUMNS)],
                              ignore_index=True)
        fidelity = _fidelity(fits.gee, choice, trials, margin_pp, level)
        _holm_per_model(contrasts)
        chance = chance_tests(trials, level=level)
        extras = _extras(trials, log, level)
        complete_profiles(fits.slope)          # the slope's profile intervals, from the worker
        summary = plain_summary(log, proportions, confusion, fits.gee, fits.bayes, contrasts,
                                fits.glmm, tests,
                                fidelity=fidelity_paragraph(fidelity, margin_pp, margin_source),
                                choice=choice)
        say(f"writing figures and tables to {out}")
        if before_write is not None:
            before_write()
        tables = {"proportions": proportions, "participants": participants, "confusion": confusion,
                  "gee": fits.gee.table, "glmm": fits.glmm.table, "glmm_slope": fits.slope.table,
                  "contrasts": contrasts, "tests": tests, "fidelity": fidelity, "chance": chance,
                  "missing": missing, "missing_trials": missing_rows, **extras}
        files, book = _write_outputs(out, log, trials, worker, tables, fits, bayes)
        files["settings"] = out / "settings.json"
        _write_text(files["settings"], json.dumps(_settings(
            data_dir, out, n_boot, level, seed, mixed, bayes, fits, choice, margin_pp,
            margin_source, book), indent=2))
        result = AnalysisResult(log=log, proportions=proportions, participants=participants,
                                confusion=confusion, gee=fits.gee, bayes=fits.bayes,
                                contrasts=contrasts, summary=summary, files=files, glmm=fits.glmm,
                                tests=tests, chance=chance, missing=missing, extras=extras,
                                glmm_slope=fits.slope, fidelity=fidelity,
                                equivalence_margin_pp=margin_pp,
                                equivalence_margin_source=margin_source, mixed_choice=choice)
        files["report"] = out / "report.md"
        _write_text(files["report"], report_markdown(result, data_dir, n_boot, level, seed))
        return result


@dataclass
class _Fits:
    """The four model fits of one analysis (a model not requested: an empty ``ModelFit``)."""

    gee: ModelFit
    glmm: ModelFit
    slope: ModelFit
    bayes: ModelFit


def _load(data_dir, sessions, condition, margin_pp, say, loaded=None):
    """Step 1: the trials (refusing an empty analysis) and the equivalence margin."""
    if loaded is None:
        say(f"loading sessions under {data_dir}")
        log = load_trials(data_dir, sessions=sessions, condition=condition)
    elif loaded.policy != sessions:
        raise ValueError(f"loaded: expected sessions chosen by the {sessions!r} policy, got "
                         f"{loaded.policy!r}")
    else:
        log = loaded
    trials = log.analysable
    if trials.empty:
        raise LogError(f"{data_dir}: status: expected at least one ok, non-familiarisation trial, "
                       f"got none of {len(log.trials)} rows")
    analysed_folders = log.sessions.loc[log.sessions["analysed"], "path"]
    margin_pp, margin_source = equivalence_margin(analysed_folders, margin_pp)
    return log, trials, margin_pp, margin_source


def _fit_models(trials, *, level, seed, mixed, bayes, say, submit=None) -> _Fits:
    """Step 2: each model fitted once (the later steps reuse these fits)."""
    say("fitting the GEE (bias-reduced covariance)")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")       # fallbacks are recorded in the notes
        gee = fit_gee(trials, level=level)
        if mixed:
            say("fitting the mixed logit (ML, adaptive Gauss-Hermite, profile interval of the SD)")
            glmm = fit_glmm(trials, level=level)
            say("fitting the mixed logit with a random slope for mode (5x5 nodes)")
            slope = fit_glmm_slope(trials, glmm.formula or FORMULA, level=level,
                                   intercept_fit=glmm, submit=submit)
        else:
            glmm = ModelFit(kind="glmm", formula=None, requested=FORMULA, table=pd.DataFrame(),
                            notes=["GLMM: not requested"])
            slope = ModelFit(kind="glmm-slope", formula=None, requested=FORMULA,
                             table=pd.DataFrame(), notes=[])
        if bayes:
            say("fitting the mean-field Bayesian mixed logit (comparison only)")
            bfit = fit_bayes(trials, level=level, seed=seed)
        else:
            bfit = ModelFit(kind="bayes", formula=None, requested=FORMULA, table=pd.DataFrame(),
                            notes=[])
    return _Fits(gee=gee, glmm=glmm, slope=slope, bayes=bfit)


def _contrasts(fits: _Fits, trials, level) -> pd.DataFrame:
    """Step 3: the A - B contrasts per cell from the GEE, then the mixed and Bayesian fits."""
    contrasts = group_contrasts(fits.gee, trials, level=level)
    for fit, label in ((fits.glmm, "glmm"),
                       (fits.bayes, "bayes-vb (mean-field: intervals too narrow)")):
        if fit.formula is None:
            continue
        extra = group_contrasts(fit, trials, level=level)
        extra["model"] = label
        if fit.kind == "bayes":
            extra["p_value"] = np.nan
        contrasts = pd.concat([contrasts, extra], ignore_index=True) if not contrasts.empty \
            else extra
    return contrasts


def _fidelity(gee, choice, trials, margin_pp, level) -> pd.DataFrame:
    """Step 4: real vs simulated from the GEE, then from the chosen mixed model."""
    fidelity = mode_contrasts(gee, trials, margin_pp=margin_pp, level=level)
    if choice.contrasts is not None:
        more = mode_contrasts(choice.contrasts, trials, margin_pp=margin_pp, level=level)
        more["note"] = choice.reason
        fidelity = pd.concat([fidelity, more], ignore_index=True)
    return fidelity


def _holm_per_model(contrasts: pd.DataFrame) -> None:
    """Step 5: Holm over each model's per-sample contrasts (``p_holm``, in place; none for the
    variational Bayes rows, which carry no p-value)."""
    if contrasts.empty:
        return
    contrasts["p_holm"] = np.nan
    for model in contrasts["model"].unique():
        sel = (contrasts["model"] == model) & (contrasts["roughness_id"] > 0)
        if model.startswith("bayes"):
            continue
        contrasts.loc[sel, "p_holm"] = holm(contrasts.loc[sel, "p_value"].to_numpy(float))


def _extras(trials, log: TrialLog, level) -> dict:
    """Step 6: the psychophysical tables (agreement, Hu, ordinal, covariates, RT, force) and the
    sessions' model decisions."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        per_person = participant_agreement(trials)
        return {"agreement": agreement_table(trials), "hu": hu_table(trials),
                "agreement_participants": per_person,
                "agreement_comparison": agreement_comparison(per_person, level=level),
                "ordinal": ordinal_table(trials, level=level),
                "covariates": covariate_table(trials, level=level), "rt": rt_table(trials),
                "force": force_table(trials),
                "model_decisions": model_decisions(log.sessions.loc[log.sessions["analysed"],
                                                                    "path"])}


def _write_outputs(out: Path, log: TrialLog, trials, worker: AnalysisWorker, tables: dict,
                   fits: _Fits, bayes: bool) -> tuple[dict, dict]:
    """Step 7: the figures, every CSV (``tables`` by name, then the exports), the convergence
    details and the codebook; returns the files written, by name, and the codebook."""
    files = worker.write(out)
    for name, table in tables.items():
        files[name] = _write_csv(table, out / f"{name}.csv")
    files.update({
        "wide": _write_csv(wide_table(trials), out / "wide.csv"),
        "cell_counts": _write_csv(cell_counts(trials), out / "cell_counts.csv"),
        "exclusions": _write_csv(log.exclusion_counts(), out / "exclusions.csv"),
        "sessions": _write_csv(log.sessions, out / "sessions.csv"),
        "trials": _write_csv(log.trials, out / "all_trials.csv"),
    })
    if bayes:
        files["bayes"] = _write_csv(fits.bayes.table, out / "bayes.csv")
    glmm, slope = fits.glmm, fits.slope
    if glmm.formula is not None:
        files["glmm_convergence"] = out / "glmm_convergence.json"
        _write_text(files["glmm_convergence"], json.dumps(
            {**glmm.convergence, "formula": glmm.formula, "notes": glmm.notes,
             "random_slope_model": {**(slope.convergence or {}), "formula": slope.formula,
                                    "notes": slope.notes}}, indent=2))
    book = codebook(files)
    files["codebook"] = out / "codebook.json"
    _write_text(files["codebook"], json.dumps(book, indent=2, ensure_ascii=False))
    return files, book


def _settings(data_dir, out: Path, n_boot, level, seed, mixed, bayes, fits: _Fits, choice,
              margin_pp, margin_source, book) -> dict:
    """Step 8: what ``settings.json`` records of this run."""
    return run_settings(
        data_dir=str(data_dir), out_dir=str(out), n_boot=n_boot, level=level, seed=seed,
        mixed=mixed, bayes=bayes, gee_formula=fits.gee.formula, glmm_formula=fits.glmm.formula,
        requested_formula=FORMULA, glmm_method=(fits.glmm.convergence or {}).get("method"),
        primary_test="GEE Wald t(participants - 2) of the A-B log odds ratio averaged over samples, real mode",
        multiplicity="Holm over the per-sample A-B tests (both modes); Holm over the 8 "
                     "per-sample real - simulated tests",
        equivalence_margin_pp=margin_pp, equivalence_margin_source=margin_source,
        mixed_model_for_mode_contrasts=(choice.contrasts.kind if choice.contrasts is not None
                                        else None),
        undocumented_columns=check_codebook(book))
