"""Group comparisons: a logit GEE and a Bayesian mixed logit, and per-roughness contrasts.

Both models explain ``correct`` (0/1) by ``group * mode * C(roughness_id)``:

- :func:`fit_gee`: a marginal (population-averaged) logit fitted by generalised estimating
  equations [1]_ with participants as clusters, an exchangeable working correlation and the
  bias-reduced (Mancl-DeRouen [2]_) sandwich covariance, which corrects the robust covariance's
  downward bias with few (here 30) clusters.
- :func:`fit_bayes`: a conditional logit with a random intercept per participant, ``statsmodels``'
  ``BinomialBayesMixedGLM`` fitted by mean-field variational Bayes (``fit_vb``). Its posterior
  SDs ignore the correlation between terms and are too small for correlated (interaction)
  terms; the report's inference (contrasts, p-values) therefore comes from the GEE.

With 3 repetitions per cell a cell may have every answer right or wrong; the
saturated model then has no finite estimate (separation) or does not converge.
Both fits then fall back, in order, to ``group * mode + C(roughness_id)`` and
``group + mode + C(roughness_id)``, and :attr:`ModelFit.notes` says so.

References
----------
.. [1] K.-Y. Liang, S. L. Zeger, "Longitudinal data analysis using generalized
   linear models", Biometrika 73 (1986) 13-22.
.. [2] L. A. Mancl, T. A. DeRouen, "A covariance estimator for GEE with improved
   small-sample properties", Biometrics 57 (2001) 126-134.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy import sparse, special, stats

from . import statsmodels_engine
from .design import design_matrices, design_rows
from .errors import ModelWarning
from .small_sample import group_covariances, row_df

statsmodels_engine.load()   # before this module's statsmodels models: patsy, no formulaic

__all__ = ["FORMULA", "ModelFit", "fit_gee", "fit_bayes", "group_contrasts", "model_data",
           "lone_group", "lone_group_reason"]

#: The model the analysis fits (group x mode x sample).
FORMULA = "correct ~ group * mode * C(roughness_id)"
_MAX_ABS_COEF = 10.0       # |log odds| beyond this means a separated (infinite) estimate
_MAX_SE = 20.0


@dataclass
class ModelFit:
    """A fitted model and what it took to fit it.

    Attributes
    ----------
    kind : str
        ``"gee"`` or ``"bayes"``.
    formula : str
        The formula actually fitted (``None`` if nothing could be fitted).
    requested : str
        The formula asked for.
    table : pandas.DataFrame
        GEE: ``term, log_odds, se, z, p_value, ci_low, ci_high``; Bayes:
        ``term, posterior_mean, posterior_sd, cri_low, cri_high`` (log odds;
        ``participant_sd`` last, on the SD scale).
    notes : list of str
        Fallbacks and warnings, in plain words.
    params, cov : ndarray
        Estimates and their covariance (Bayes: diagonal of posterior variances).
    design_info : patsy.DesignInfo
        For building design rows of new data (contrasts).
    result : object
        The statsmodels result (GEE, Bayes); None for the maximum-likelihood mixed models.
    df : float or None
        Degrees of freedom of the Wald intervals and p-values (participants - 2,
        :func:`reference_df`); None: normal.
    convergence : dict or None
        The maximum-likelihood mixed models' optimiser report (method, success, status,
        message, iterations, evaluations, largest gradient, log-likelihood, Hessian
        definiteness); None for the GEE and Bayes fits (their ``result`` says it).
    theta, cov_full : ndarray or None
        The mixed models' full parameter vector (fixed effects, then the random-effect
        parameters) and its covariance; None for the others.
    cov_robust : ndarray or None
        The random-slope model's CR2 (Bell-McCaffrey bias-reduced) participant-cluster
        sandwich covariance of the fixed effects (:func:`analysis.glmm_slope.participant_sandwich`),
        the SE of its mode contrasts (:func:`contrast_se`); None for the others.
    cluster_info : ndarray or None
        With ``cov_robust``: each participant's information for the fixed effects, (m, p, p),
        the working covariance of the participant scores behind the Bell-McCaffrey df of those
        contrasts (:func:`analysis.small_sample.row_df`).
    """

    kind: str
    formula: str | None
    requested: str
    table: pd.DataFrame
    notes: list = field(default_factory=list)
    params: np.ndarray | None = None
    cov: np.ndarray | None = None
    design_info: object = None
    result: object = None
    df: float | None = None
    convergence: dict | None = None
    theta: np.ndarray | None = None
    cov_full: np.ndarray | None = None
    cov_robust: np.ndarray | None = None
    #: The GEE's sandwich split by group, ``{g: (W_g, m_g)}`` (:mod:`analysis.small_sample`).
    cov_by_group: dict | None = None
    cluster_info: np.ndarray | None = None
    #: Table rows still being computed elsewhere (a future; the random-slope model's profile
    #: intervals, :func:`analysis.glmm_slope_profile.complete_profiles` fills them in); None: complete.
    pending: object = None
    #: Design rows built by :func:`analysis.design.design_rows`, by (group, mode, sample).
    built_rows: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def quantile(self, level: float) -> float:
        """Two-sided critical value: t with :attr:`df` degrees of freedom (normal if None)."""
        return reference_quantile(level, self.df)

    def p_value(self, ratio) -> np.ndarray:
        """Two-sided p-value of estimate / SE against t(:attr:`df`) (normal if None)."""
        return reference_p(ratio, self.df)

    @property
    def simplified(self) -> bool:
        """True if a simpler formula than the requested one was fitted."""
        return self.formula != self.requested


def contrast_se(fit: ModelFit, lvec) -> float:
    """Standard error of the linear combination ``lvec @ fit.params`` used by mode contrasts.

    ``sqrt(l' V l)`` with the model's covariance; for a fit that carries a participant
    sandwich (:attr:`ModelFit.cov_robust`, the random-slope model) that sandwich's: CR2
    (Bell-McCaffrey bias-reduced linearisation), referred to t with the Bell-McCaffrey df
    (:func:`analysis.small_sample.row_df`). It does not rest on the fitted random-effect SDs
    (the slope SD's ML estimate is biased low at 30 participants: the model-based intervals
    covered 0.92 under a random slope). The rule before, the larger of the model-based SE and
    the Mancl-DeRouen sandwich, made the per-group rows cover 0.96-0.99 (docs/analysis.md).
    """
    lvec = np.asarray(lvec, float)
    cov = fit.cov_robust if fit.cov_robust is not None else fit.cov
    return float(np.sqrt(max(float(lvec @ cov @ lvec), 0.0)))


def reference_df(data: pd.DataFrame) -> float | None:
    """Degrees of freedom of the Wald intervals and tests: participants - 2.

    Notes
    -----
    The group comparisons are between participants: with m participants in two groups a
    sandwich or likelihood SE carries about m - 2 degrees of freedom, and Wald intervals with
    normal quantiles covered 0.92-0.94 (interaction, averaged contrasts) over 200 datasets of
    30 participants; with t(m - 2) quantiles 0.94-0.97 for every contrast family
    (benchmarks/bench_recovery.py, docs/analysis.md).
    """
    m = data["participant"].nunique()
    return float(m - 2) if m > 2 else None


def reference_quantile(level: float, df: float | None) -> float:
    """``t_{df}`` (or normal) quantile for a two-sided interval at ``level``."""
    return float(stats.t.ppf(0.5 + level / 2, df) if df else stats.norm.ppf(0.5 + level / 2))


def reference_p(ratio, df: float | None):
    """Two-sided p-value of ``ratio`` against ``t_{df}`` (or normal)."""
    ratio = np.abs(np.asarray(ratio, float))
    return 2 * (stats.t.sf(ratio, df) if df else stats.norm.sf(ratio))


def model_data(trials: pd.DataFrame) -> pd.DataFrame:
    """The columns the models use, typed (correct int, roughness_id int, strings).

    Parameters
    ----------
    trials : pandas.DataFrame
        Analysable trials.

    Returns
    -------
    pandas.DataFrame
        ``participant, group, mode, roughness_id, correct``.
    """
    data = pd.DataFrame({
        "participant": trials["participant"].astype(str).to_numpy(),
        "group": trials["group"].astype(str).to_numpy(),
        "mode": trials["mode"].astype(str).to_numpy(),
        "roughness_id": trials["roughness_id"].astype(int).to_numpy(),
        "correct": trials["correct"].astype(int).to_numpy(),
    })
    return data


def candidate_formulas(data: pd.DataFrame, formula: str, notes: list, kind: str) -> list[str]:
    """The requested formula, then the fallbacks (factors with one level left out)."""
    present = [f for f, col in (("group", "group"), ("mode", "mode"),
                                ("C(roughness_id)", "roughness_id")) if data[col].nunique() > 1]
    dropped = [f for f in ("group", "mode", "C(roughness_id)") if f not in present]
    if dropped:
        notes.append(f"{kind}: only one level of {', '.join(dropped)} in the data: left out")
        out = ["correct ~ " + (" * ".join(present) if present else "1")]
    else:
        out = [formula]
    if len(present) == 3:
        more = ["correct ~ group * mode + C(roughness_id)", "correct ~ group + mode + C(roughness_id)"]
    else:
        more = ["correct ~ " + " + ".join(present)] if present else []
    return out + [m for m in more if m not in out]


def _separated_cells(data: pd.DataFrame) -> list[str]:
    rate = data.groupby(["group", "mode", "roughness_id"])["correct"].mean()
    bad = rate[(rate == 0) | (rate == 1)]
    return [f"{g}/{m}/{r}# ({'all correct' if v == 1 else 'none correct'})"
            for (g, m, r), v in bad.items()]


def fit_trouble(params, se) -> str | None:
    if not (np.all(np.isfinite(params)) and np.all(np.isfinite(se))):
        return "non-finite estimates"
    if np.max(np.abs(params)) > _MAX_ABS_COEF or np.max(se) > _MAX_SE:
        return "estimates drifting to infinity (separation)"
    return None


def _fit_trouble(category) -> bool:
    """True for the statsmodels warning classes that mean a fit is not to be trusted.

    Classified by class, not by message text (:mod:`statsmodels.tools.sm_exceptions`):
    ``ConvergenceWarning`` (GEE's "Singular matrix encountered in GEE update", VB's "VB
    fitting did not converge"), ``IterationLimitWarning``, ``SingularMatrixWarning``,
    ``PerfectSeparationWarning`` (the GLM that starts a GEE) and ``HessianInversionWarning``.
    """
    from statsmodels.tools import sm_exceptions as sme

    return issubclass(category, (sme.ConvergenceWarning, sme.IterationLimitWarning,
                                 sme.SingularMatrixWarning, sme.PerfectSeparationWarning,
                                 sme.HessianInversionWarning))


def refuse_separated(kind: str, candidate: str, data: pd.DataFrame, notes: list) -> bool:
    """True, with a note, when ``candidate`` is the full formula and a cell is separated."""
    if candidate != FORMULA:
        return False
    cells = _separated_cells(data)
    if cells:
        notes.append(f"{kind}: {candidate!r} not estimable: complete separation in cell(s) "
                     f"{', '.join(cells)}; trying a simpler formula")
    return bool(cells)


def accept_candidate(kind: str, candidate: str, formula: str, why: str | None, notes: list) -> bool:
    """One rung of the fallback ladder every model shares: ``why`` (the fit's trouble, or
    None) rejects ``candidate`` with a note; an accepted simpler formula is noted and warned."""
    if why:
        notes.append(f"{kind}: {candidate!r} {why}; trying a simpler formula")
        return False
    if candidate != formula:
        notes.append(f"{kind}: fitted the simpler {candidate!r} instead of {formula!r}")
        # stacklevel 3: the caller of the fitting function, as before this helper existed
        warnings.warn("; ".join(notes), ModelWarning, stacklevel=3)
    return True


def fit_gee(trials: pd.DataFrame, formula: str = FORMULA, *, level: float = 0.95) -> ModelFit:
    """Logit GEE with participant clusters, exchangeable correlation, bias-reduced covariance.

    Parameters
    ----------
    trials : pandas.DataFrame
        Analysable trials.
    formula : str
        Patsy formula; on separation or non-convergence simpler ones are tried.
    level : float
        Confidence level of the table's intervals, 0–1.

    Returns
    -------
    ModelFit
        ``table`` has one row per term (log odds). ``formula`` is ``None`` and
        the table empty if no formula could be fitted.
    """
    # the genmod modules alone: statsmodels.api imports all of statsmodels (0.4 s)
    from statsmodels.genmod import cov_struct, families
    from statsmodels.genmod.generalized_estimating_equations import GEE

    data = model_data(trials)
    notes: list = []
    df = reference_df(data)
    z = reference_quantile(level, df)
    for candidate in candidate_formulas(data, formula, notes, "GEE"):
        if refuse_separated("GEE", candidate, data, notes):
            continue
        y, x = design_matrices(candidate, data)
        why = None
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                model = GEE(y, x, groups=data["participant"], family=families.Binomial(),
                               cov_struct=cov_struct.Exchangeable())
                res = model.fit(cov_type="bias_reduced", maxiter=100)
            except (np.linalg.LinAlgError, ValueError, ZeroDivisionError) as exc:
                res, why = None, f"failed ({exc})"
        if res is None and why is None:        # statsmodels returns None when it gives up
            why = "failed (" + "; ".join(str(w.message) for w in caught) + ")"
        if res is not None:
            trouble = [str(w.message) for w in caught if _fit_trouble(w.category)]
            params = np.asarray(res.params)
            se = np.asarray(res.bse)
            why = "; ".join(trouble) if (trouble or not res.converged) else fit_trouble(params, se)
            if not res.converged and not trouble:
                why = "did not converge"
        if not accept_candidate("GEE", candidate, formula, why, notes):
            continue
        # statsmodels' res.pvalues / res.conf_int() refer the Wald ratio to the normal; the
        # table refers it to t(participants - 2) (reference_df), so only the ratio is theirs
        ratio = np.asarray(res.tvalues)
        table = pd.DataFrame({"term": x.columns, "log_odds": params, "se": se,
                              "statistic": ratio, "p_value": reference_p(ratio, df),
                              "ci_low": params - z * se, "ci_high": params + z * se,
                              "test": f"Wald t({df:g})" if df else "Wald z (normal)"})
        return ModelFit(kind="gee", formula=candidate, requested=formula, table=table,
                        notes=notes, params=params, cov=np.asarray(res.cov_params()),
                        design_info=x.design_info, result=res, df=df,
                        cov_by_group=group_covariances(
                            res, dict(zip(data["participant"], data["group"]))))
    notes.append("GEE: no formula could be fitted")
    warnings.warn("; ".join(notes), ModelWarning, stacklevel=2)
    return ModelFit(kind="gee", formula=None, requested=formula, table=pd.DataFrame(
        columns=["term", "log_odds", "se", "statistic", "p_value", "ci_low", "ci_high", "test"]),
        notes=notes)


def fit_bayes(trials: pd.DataFrame, formula: str = FORMULA, *, level: float = 0.95,
              seed: int = 20261122) -> ModelFit:
    """Bayesian mixed logit with a random intercept per participant (``fit_vb``).

    Parameters
    ----------
    trials : pandas.DataFrame
        Analysable trials.
    formula : str
        Fixed-effects formula; on non-convergence simpler ones are tried.
    level : float
        Credible level of the table's intervals (normal approximation), 0–1.
    seed : int
        Seed of the optimiser's random starting values.

    Returns
    -------
    ModelFit
        ``table`` rows: fixed effects (log odds) then ``participant_sd`` (the
        random intercepts' SD, log-odds scale; its interval from the
        log-SD posterior). Priors: statsmodels' defaults, N(0, 2²) on fixed
        effects and N(0, 1²) on the log SD.
    """
    from statsmodels.genmod.bayes_mixed_glm import BinomialBayesMixedGLM

    data = model_data(trials)
    notes: list = []
    z = stats.norm.ppf(0.5 + level / 2)
    people = pd.Categorical(data["participant"])
    exog_vc = sparse.csr_matrix((np.ones(len(data)), (np.arange(len(data)), people.codes)),
                                shape=(len(data), len(people.categories)))
    ident = np.zeros(len(people.categories), dtype=int)
    for candidate in candidate_formulas(data, formula, notes, "Bayes"):
        y, x = design_matrices(candidate, data)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                model = BinomialBayesMixedGLM(y, x.to_numpy(), exog_vc, ident,
                                              fep_names=list(x.columns), vcp_names=["participant"])
                res = model.fit_vb(rng=np.random.RandomState(seed))
                why = None
            except (np.linalg.LinAlgError, ValueError, FloatingPointError) as exc:
                res, why = None, f"failed ({exc})"
        if res is not None:
            if not res.optim_retvals.success or any(_fit_trouble(w.category) for w in caught):
                why = "did not converge (VB optimiser)"
            else:
                why = fit_trouble(res.fe_mean, res.fe_sd)
        if not accept_candidate("Bayes", candidate, formula, why, notes):
            continue
        mean, sd = np.asarray(res.fe_mean), np.asarray(res.fe_sd)
        table = pd.DataFrame({"term": x.columns, "posterior_mean": mean, "posterior_sd": sd,
                              "cri_low": mean - z * sd, "cri_high": mean + z * sd})
        lm, ls = float(res.vcp_mean[0]), float(res.vcp_sd[0])
        table.loc[len(table)] = ["participant_sd", np.exp(lm), np.nan, np.exp(lm - z * ls),
                                 np.exp(lm + z * ls)]
        return ModelFit(kind="bayes", formula=candidate, requested=formula, table=table,
                        notes=notes, params=mean, cov=np.diag(sd ** 2),
                        design_info=x.design_info, result=res)
    notes.append("Bayes: no formula could be fitted")
    return ModelFit(kind="bayes", formula=None, requested=formula, table=pd.DataFrame(
        columns=["term", "posterior_mean", "posterior_sd", "cri_low", "cri_high"]), notes=notes)


def group_contrasts(fit: ModelFit, trials: pd.DataFrame, *, level: float = 0.95) -> pd.DataFrame:
    """Group A vs group B within each mode and roughness, from a fitted model.

    Parameters
    ----------
    fit : ModelFit
        From :func:`fit_gee` (or :func:`fit_bayes`: mean-field intervals, too narrow).
    trials : pandas.DataFrame
        Analysable trials (for the modes and roughness levels present).
    level : float
        Confidence level, 0–1.

    Returns
    -------
    pandas.DataFrame
        ``model, mode, roughness_id, log_odds_ratio_A_vs_B, se, ci_low, ci_high,
        odds_ratio_A_vs_B, p_value, p_correct_A, p_correct_B,
        difference_A_minus_B, difference_low, difference_high, basis, compares``
        (probabilities are fractions 0–1; GEE probabilities are population averages,
        GLMM ones those of a typical participant). ``compares`` says in words what
        each row compares. One row
        per mode × roughness, then one per mode averaged over roughness
        (``roughness_id`` 0: the mean log odds over the four samples; its
        ``p_correct_A/B`` are the mean of the four samples' probabilities, so
        ``difference_A_minus_B`` is a difference of mean proportions).
        Empty if the model has no group term. ``basis`` says where a row comes
        from: the fitted model, or -- when the fitted formula has no group ×
        roughness term (a fallback after separation) -- a GEE of that sample's
        trials alone (``correct ~ group``), or "not estimable" when a group
        answered that sample all right or all wrong (log odds NaN). A Bayes fit
        without that term gives only the averaged rows. With a group of one participant
        (:func:`lone_group`) every row keeps its estimates and has no SE, interval or p-value;
        ``basis`` says why.

    Notes
    -----
    With design rows :math:`x_A, x_B` the log odds ratio is
    :math:`(x_A - x_B)\\hat\\beta` with variance :math:`(x_A-x_B) V (x_A-x_B)^T`;
    the probability difference uses the delta method with gradient
    :math:`p_A(1-p_A)x_A - p_B(1-p_B)x_B`.
    """
    columns = CONTRAST_COLUMNS
    if fit.formula is None or "group" not in fit.formula:
        return pd.DataFrame(columns=columns + ["compares"])
    data = model_data(trials)
    if set(data["group"]) != {"A", "B"}:
        return pd.DataFrame(columns=columns + ["compares"])
    z = fit.quantile(level)
    beta, cov = fit.params, fit.cov
    rows = []
    roughness = sorted(data["roughness_id"].unique())
    design_rows(fit, ["A", "B"], sorted(data["mode"].unique()), roughness)  # all at once
    # A fitted formula without the group x roughness interaction gives every sample the same
    # log odds ratio; per-sample rows then come from a GEE of that sample's trials alone.
    per_sample = has_group_by_roughness(fit)
    for mode in sorted(data["mode"].unique()):
        specs = [(r, [r]) for r in roughness] + [(0, roughness)]
        for label, levels in specs:
            if label != 0 and not per_sample:
                cell = data[(data["mode"] == mode) & (data["roughness_id"] == label)]
                if fit.kind == "gee":
                    rows.append([fit.kind, mode, label, *_sample_gee_contrast(cell, z, fit.df),
                                 fit.df])
                continue
            xa, xb = (design_rows(fit, [g], [mode], levels) for g in ("A", "B"))
            df = row_df(fit, xa.mean(axis=0) - xb.mean(axis=0), se_from_cov=True)
            rows.append([fit.kind, mode, label,
                         *log_odds_contrast(xa, xb, beta, cov, reference_quantile(level, df), df),
                         f"model: {fit.formula}", df])
    out = pd.DataFrame(rows, columns=columns)
    out["compares"] = [_compares(r.mode, r.roughness_id, fit.kind) for r in out.itertuples()]
    for mode in out["mode"].unique():          # a group without this mode: no A - B in it
        gap = design_gap(data, modes=[mode])
        if gap:
            sel = out["mode"] == mode
            out.loc[sel, CONTRAST_COLUMNS[3:-2]] = np.nan
            out.loc[sel, "basis"] = f"not estimable: {gap}"
    lone = lone_group(data)
    if lone is not None:               # estimates only: no SE the data can support
        out[["se", "ci_low", "ci_high", "p_value", "difference_low", "difference_high"]] = np.nan
        out["basis"] = out["basis"].astype(str) + "; " + lone_group_reason(lone)
    return out


#: Columns of :func:`group_contrasts`.
CONTRAST_COLUMNS = ["model", "mode", "roughness_id", "log_odds_ratio_A_vs_B", "se", "ci_low",
                    "ci_high", "odds_ratio_A_vs_B", "p_value", "p_correct_A", "p_correct_B",
                    "difference_A_minus_B", "difference_low", "difference_high", "basis", "df"]


def _compares(mode: str, roughness_id: int, kind: str) -> str:
    scale = ("population-averaged" if kind == "gee" else "for a typical participant (u = 0)")
    if roughness_id == 0:
        return (f"group A - group B, {mode} samples: mean over 1#-4# of the log odds "
                f"(log odds ratio); difference of the mean {scale} proportions correct")
    return (f"group A - group B, {mode} sample {roughness_id}#: log odds ratio; "
            f"difference of {scale} proportions correct")


def log_odds_contrast(xa, xb, beta, cov, z, df=None) -> list:
    """Group A vs B: log odds ratio, its SE, interval, odds ratio, p-value, both probabilities
    and their difference with a delta-method interval.

    ``xa``, ``xb`` are design rows (1-D) or matrices with one row per sample to average over:
    the log odds ratio is that of the mean log odds, the probabilities are the mean of the
    samples' probabilities (a difference of mean proportions, not of expit(mean log odds)).
    """
    xa, xb = np.atleast_2d(xa), np.atleast_2d(xb)
    diff = xa.mean(axis=0) - xb.mean(axis=0)
    est, se = float(diff @ beta), float(np.sqrt(diff @ cov @ diff))
    qa, qb = special.expit(xa @ beta), special.expit(xb @ beta)
    pa, pb = float(qa.mean()), float(qb.mean())
    grad = (qa * (1 - qa)) @ xa / len(xa) - (qb * (1 - qb)) @ xb / len(xb)
    dse = float(np.sqrt(grad @ cov @ grad))
    return [est, se, est - z * se, est + z * se, np.exp(est),
            float(reference_p(est / se, df)) if se > 0 else np.nan, pa, pb,
            pa - pb, pa - pb - z * dse, pa - pb + z * dse]


def design_gap(data: pd.DataFrame, groups=("A", "B"), modes=None) -> str:
    """What the design lacks for a contrast over ``groups`` x ``modes`` (``""``: nothing).

    A group without trials in a mode (a TCS II session has simulated blocks only) leaves that
    group x mode cell of the model unidentified: any contrast using it is not estimable, and
    saying so beats a number the data do not hold. ``modes`` defaults to the modes present.
    """
    modes = sorted(data["mode"].unique()) if modes is None else list(modes)
    cells = data[["group", "mode"]].drop_duplicates().astype(str)
    have = set(zip(cells["group"], cells["mode"]))
    present = set(cells["group"])
    for g in groups:
        if g not in present:
            return f"no trials of group {g}"
        for m in modes:
            if (g, m) not in have:
                return f"group {g} has no {m} trials"
    return ""


def lone_group(trials: pd.DataFrame) -> tuple[str, int] | None:
    """The group (A before B) with fewer than two participants, and its count; None if none.

    Such a group has no between-participant variance of its own: a comparison of the groups
    would take its SE from the other group alone and read far surer than it is, so the
    comparisons of the groups carry estimates only (:func:`group_contrasts`,
    :func:`analysis.report.tests_table`).
    """
    if "group" not in trials or trials.empty:
        return None
    counts = trials.groupby("group")["participant"].nunique()
    for g in ("A", "B"):
        if g in counts.index and counts[g] < 2:
            return g, int(counts[g])
    return None


def lone_group_reason(lone: tuple[str, int]) -> str:
    """Why the comparisons of the groups are not tested (the ``test`` text of their rows)."""
    g, n = lone
    return (f"not tested: group {g} has {n} participant (a comparison of the groups needs at "
            f"least 2 in each: no between-participant variance in group {g})")


def has_group_by_roughness(fit: ModelFit) -> bool:
    names = [t.name() for t in fit.design_info.terms]
    return any("group" in n and "roughness_id" in n for n in names)


def _sample_gee_contrast(cell: pd.DataFrame, z: float, df=None) -> list:
    """Group A vs B on one sample's trials: ``correct ~ group`` GEE (participant clusters).

    Returns the contrast columns after ``roughness_id`` (see :func:`group_contrasts`). When a
    group answered all right or all wrong there is no finite log odds ratio: the model columns
    and intervals are NaN and ``p_correct_A/B`` are the observed proportions.
    """
    # the genmod modules alone: statsmodels.api imports all of statsmodels (0.4 s)
    from statsmodels.genmod import cov_struct, families
    from statsmodels.genmod.generalized_estimating_equations import GEE

    pa = float(cell.loc[cell["group"] == "A", "correct"].mean())
    pb = float(cell.loc[cell["group"] == "B", "correct"].mean())
    nan = [np.nan] * 6
    if cell["group"].nunique() < 2 or not np.isfinite(pa + pb):
        return nan + [pa, pb, pa - pb, np.nan, np.nan, "per-sample GEE: one group missing"]
    if pa in (0.0, 1.0) or pb in (0.0, 1.0):
        return nan + [pa, pb, pa - pb, np.nan, np.nan,
                      "not estimable: a group answered all right or all wrong"]
    x = pd.DataFrame({"Intercept": 1.0, "group[T.B]": (cell["group"] == "B").astype(float)})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = GEE(cell["correct"].to_numpy(float), x, groups=cell["participant"].to_numpy(),
                     family=families.Binomial(),
                     cov_struct=cov_struct.Exchangeable()).fit(cov_type="bias_reduced")
    xa, xb = np.array([1.0, 0.0]), np.array([1.0, 1.0])
    return [*log_odds_contrast(xa, xb, np.asarray(res.params), np.asarray(res.cov_params()), z, df),
            "per-sample GEE: correct ~ group"]
