"""What a psychophysics reviewer asks for: information transfer, Hu, kappa, ordinal, covariates, RTs.

Per group × mode, from the pooled 4 × 4 stimulus-response confusion matrix
:math:`n_{ij}` (:math:`N` trials):

- **information transfer** [1]_ :math:`T = \\sum_{ij} \\frac{n_{ij}}{N}
  \\log_2 \\frac{n_{ij} N}{n_{i\\cdot} n_{\\cdot j}}` bits, and the same with the
  Miller-Madow small-sample bias correction [2]_: the plug-in estimate is biased
  upwards by about :math:`(R-1)(C-1)/(2N\\ln 2)` bits (R, C: non-empty rows and
  columns), which is subtracted (floored at 0); ``relative`` divides by the
  stimulus entropy (2 bits for four equiprobable samples);
- **Wagner's unbiased hit rate** [3]_ :math:`H_u = n_{ii}^2/(n_{i\\cdot} n_{\\cdot i})`
  per sample, with its chance value :math:`p_c = n_{i\\cdot} n_{\\cdot i}/N^2`;
- **Cohen's kappa** :math:`(p_o - p_e)/(1 - p_e)`.

These are descriptive point estimates (no interval is printed for them).

Ordinal (the samples are ordered 1# < 2# < 3# < 4#): the Spearman rank correlation of
stimulus and response, pooled and as the mean of the participants' own
correlations (with a one-sample *t*-test across participants, so the clustering
is respected), and a proportional-odds (cumulative logit) slope of the response
on the stimulus rank (statsmodels' ``OrderedModel``, participant-cluster-robust SE).

Covariates (GEE, participant clusters, exchangeable, bias-reduced covariance):
skin thickness as a continuous predictor (per 100 µm) beside the 800 µm split; trial
position within the session (per 10 trials: order and practice); log response time
(the speed-accuracy relation).

References
----------
.. [1] G. A. Miller, P. E. Nicely, "An analysis of perceptual confusions among some
   English consonants", J. Acoust. Soc. Am. 27 (1955) 338-352.
.. [2] G. A. Miller, "Note on the bias of information estimates", in Information
   Theory in Psychology, Free Press (1955) 95-100.
.. [3] H. L. Wagner, "On measuring performance in category judgment studies of
   nonverbal behavior", J. Nonverbal Behav. 17 (1993) 3-28.
"""
from __future__ import annotations

import functools
import warnings

import numpy as np
import pandas as pd
from scipy import special, stats

from . import statsmodels_engine
from .design import patsy_frame

statsmodels_engine.load()   # before this module's statsmodels models: patsy, no formulaic

__all__ = ["information_transfer", "confusion_counts", "agreement_table", "hu_table", "ordinal_table",
           "covariate_table", "force_table", "rt_table"]


def information_transfer(counts) -> dict:
    """Information transferred by a confusion matrix, plug-in and bias-corrected (bits).

    Parameters
    ----------
    counts : array_like, shape (R, C)
        Stimulus (rows) × response (columns) counts.

    Returns
    -------
    dict
        ``it_bits`` (plug-in), ``it_bits_corrected`` (Miller-Madow, floored at
        0), ``stimulus_entropy_bits``, ``relative_it`` (corrected / stimulus entropy).

    Examples
    --------
    A perfect 4-alternative identification transfers 2 bits:

    >>> round(information_transfer(np.eye(4) * 100)["it_bits"], 12)
    2.0
    """
    n = np.asarray(counts, float)
    total = n.sum()
    rows, cols = n.sum(axis=1), n.sum(axis=0)
    nz = n > 0
    it = float(np.sum(n[nz] / total * np.log2(n[nz] * total / np.outer(rows, cols)[nz])))
    r, c = int((rows > 0).sum()), int((cols > 0).sum())
    corrected = max(0.0, it - (r - 1) * (c - 1) / (2 * total * np.log(2)))
    ps = rows[rows > 0] / total
    h = float(-np.sum(ps * np.log2(ps)))
    return {"it_bits": it, "it_bits_corrected": corrected, "stimulus_entropy_bits": h,
            "relative_it": corrected / h if h > 0 else np.nan}


def confusion_counts(sel: pd.DataFrame) -> np.ndarray:
    """The 4 x 4 stimulus (rows) x response (columns) counts of ``sel``'s trials."""
    s = sel["roughness_id"].to_numpy(float)
    r = sel["response_id"].to_numpy(float)
    keep = ~(np.isnan(s) | np.isnan(r))       # as a groupby: rows without both left out
    m = np.zeros((4, 4))
    np.add.at(m, (s[keep].astype(int) - 1, r[keep].astype(int) - 1), 1.0)
    return m


def agreement_table(trials: pd.DataFrame) -> pd.DataFrame:
    """Information transfer and Cohen's kappa per group × mode.

    Returns
    -------
    pandas.DataFrame
        ``group, mode, n_trials, it_bits, it_bits_corrected, stimulus_entropy_bits,
        relative_it, kappa, mean_hu``.
    """
    rows = []
    for (g, m), sel in trials.groupby(["group", "mode"]):
        n = confusion_counts(sel)
        total = n.sum()
        po = np.trace(n) / total
        pe = float(n.sum(axis=1) @ n.sum(axis=0)) / total ** 2
        hu = hu_values(n)
        rows.append({"group": g, "mode": m, "n_trials": int(total), **information_transfer(n),
                     "kappa": (po - pe) / (1 - pe) if pe < 1 else np.nan,
                     "mean_hu": float(np.nanmean(hu[0]))})
    return pd.DataFrame(rows)


def hu_values(n) -> tuple[np.ndarray, np.ndarray]:
    """Wagner's Hu and its chance value per stimulus (NaN for a sample never presented/named)."""
    n = np.asarray(n, float)
    rows, cols, total = n.sum(axis=1), n.sum(axis=0), n.sum()
    with np.errstate(invalid="ignore", divide="ignore"):
        hu = np.diag(n) ** 2 / (rows * cols)
    hu[(rows == 0)] = np.nan
    hu[(rows > 0) & (cols == 0)] = 0.0
    return hu, rows * cols / total ** 2


def hu_table(trials: pd.DataFrame) -> pd.DataFrame:
    """Wagner's unbiased hit rate per group × mode × sample.

    Returns
    -------
    pandas.DataFrame
        ``group, mode, roughness_id, hit_rate, hu, hu_chance``.
    """
    rows = []
    for (g, m), sel in trials.groupby(["group", "mode"]):
        n = confusion_counts(sel)
        hu, chance = hu_values(n)
        for i in range(4):
            if n[i].sum() == 0:
                continue
            rows.append({"group": g, "mode": m, "roughness_id": i + 1,
                         "hit_rate": n[i, i] / n[i].sum(), "hu": hu[i], "hu_chance": chance[i]})
    return pd.DataFrame(rows)


def ordinal_table(trials: pd.DataFrame, *, level: float = 0.95) -> pd.DataFrame:
    """Stimulus-response rank agreement per group × mode.

    Returns
    -------
    pandas.DataFrame
        ``group, mode, spearman_pooled, mean_participant_spearman, t_p_value, t_df,
        n_participants, po_slope, po_se, po_ci_low, po_ci_high`` (proportional-odds
        log odds of a higher answer per sample step; cluster-robust SE).
    """
    rows = []
    for (g, m), sel in trials.groupby(["group", "mode"]):
        s, r = sel["roughness_id"].to_numpy(float), sel["response_id"].to_numpy(float)
        pooled = float(stats.spearmanr(s, r).statistic) if len(sel) > 2 else np.nan
        per = []
        for _, one in sel.groupby("participant"):
            if one["roughness_id"].nunique() > 1 and one["response_id"].nunique() > 1:
                per.append(float(stats.spearmanr(one["roughness_id"], one["response_id"]).statistic))
        per = np.clip(np.array(per), -0.999, 0.999)
        fz = np.arctanh(per)
        mean = float(np.tanh(fz.mean())) if len(per) else np.nan
        p = float(stats.ttest_1samp(fz, 0.0).pvalue) if len(per) > 1 else np.nan
        t_df = len(per) - 1 if len(per) > 1 else np.nan
        slope, se, low, high = _po_slope(sel, level)
        rows.append({"group": g, "mode": m, "spearman_pooled": pooled,
                     "mean_participant_spearman": mean, "t_p_value": p, "t_df": t_df,
                     "n_participants": len(per), "po_slope": slope, "po_se": se,
                     "po_ci_low": low, "po_ci_high": high})
    return pd.DataFrame(rows)


class _StandardLogistic(type(stats.logistic)):
    """scipy's standard logistic distribution whose ``cdf`` and ``pdf`` of one array, with no
    location or scale, skip ``rv_continuous``'s argument handling: the same ``_cdf``
    (``expit``) and ``_pdf`` formulas, hence the same doubles (infinite and NaN arguments
    included).  statsmodels' ``OrderedModel`` takes any ``rv_continuous`` as ``distr`` (its
    ``"logit"`` is ``stats.logistic``) and calls ``cdf`` twice per likelihood evaluation of its
    numerical derivatives: the generic handling was half of the ordinal table's time."""

    def cdf(self, x, *args, **kwds):
        if args or kwds:
            return super().cdf(x, *args, **kwds)
        return special.expit(np.asarray(x, dtype=float))

    def pdf(self, x, *args, **kwds):
        if args or kwds:
            return super().pdf(x, *args, **kwds)
        y = -np.abs(np.asarray(x, dtype=float))
        return np.exp(y - 2. * special.log1p(np.exp(y)))


@functools.cache
def _standard_logistic() -> _StandardLogistic:
    """The one :class:`_StandardLogistic` (made on first use: scipy formats a distribution's
    docstring when it is made)."""
    return _StandardLogistic(name="logistic")


def _po_slope(sel: pd.DataFrame, level: float = 0.95) -> tuple[float, float, float, float]:
    """Proportional-odds slope per sample step: estimate, cluster-robust SE and Wald interval
    (statsmodels' ``res.conf_int``; the logit link as :func:`_standard_logistic`)."""
    from statsmodels.miscmodels.ordinal_model import OrderedModel
    nan = (np.nan,) * 4
    y = pd.Series(pd.Categorical(sel["response_id"].astype(int), categories=[1, 2, 3, 4],
                                 ordered=True))
    if y.nunique() < 2:
        return nan
    x = sel[["roughness_id"]].astype(float).reset_index(drop=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            res = OrderedModel(y.cat.remove_unused_categories(), x,
                               distr=_standard_logistic()).fit(
                method="bfgs", disp=False, cov_type="cluster",
                cov_kwds={"groups": pd.factorize(sel["participant"])[0]})
        except (ValueError, np.linalg.LinAlgError, ZeroDivisionError):
            return nan
    low, high = res.conf_int(alpha=1 - level).loc["roughness_id"]
    return (float(res.params["roughness_id"]), float(res.bse["roughness_id"]), float(low),
            float(high))


def _gee_terms(data: pd.DataFrame, formula: str, terms, level: float) -> list[dict]:
    from statsmodels.genmod import cov_struct, families
    from statsmodels.genmod.generalized_estimating_equations import GEE
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            res = GEE.from_formula(formula, "participant", patsy_frame(data),
                                   family=families.Binomial(),
                                   cov_struct=cov_struct.Exchangeable()).fit(cov_type="bias_reduced")
        except (ValueError, np.linalg.LinAlgError, ZeroDivisionError):
            return []
    out = []
    # referred to t(participants - 2), as every other Wald row (statsmodels' own use the normal)
    m = data["participant"].nunique()
    df = float(m - 2) if m > 2 else None
    q = float(stats.t.ppf(0.5 + level / 2, df) if df else stats.norm.ppf(0.5 + level / 2))
    for term, label in terms:
        if term not in res.params.index:
            continue
        b, se = float(res.params[term]), float(res.bse[term])
        ratio = b / se if se > 0 else np.nan
        p = float(2 * (stats.t.sf(abs(ratio), df) if df else stats.norm.sf(abs(ratio))))
        out.append({"model": f"GEE {formula}", "term": term, "meaning": label, "log_odds": b,
                    "se": se, "ci_low": b - q * se, "ci_high": b + q * se,
                    "statistic": ratio, "p_value": p if se > 0 else np.nan,
                    "test": f"Wald t({df:g})" if df else "Wald z (normal)"})
    return out


def covariate_table(trials: pd.DataFrame, *, level: float = 0.95) -> pd.DataFrame:
    """Skin thickness (continuous), trial position and log RT as GEE covariates.

    Returns
    -------
    pandas.DataFrame
        ``model, term, meaning, log_odds, se, ci_low, ci_high, statistic, p_value, test``
        (``test`` names the reference: Wald t(participants - 2)).
    """
    data = pd.DataFrame({
        "participant": trials["participant"].astype(str).to_numpy(),
        "group": trials["group"].astype(str).to_numpy(),
        "mode": trials["mode"].astype(str).to_numpy(),
        "roughness_id": trials["roughness_id"].astype(int).to_numpy(),
        "correct": trials["correct"].astype(int).to_numpy()})
    rows = []
    if "skin_thickness_um" in trials and trials["skin_thickness_um"].notna().all():
        data["thickness_100um"] = trials["skin_thickness_um"].to_numpy(float) / 100.0
        if data["thickness_100um"].nunique() > 1:
            rows += _gee_terms(data, "correct ~ thickness_100um * mode + C(roughness_id)",
                               [("thickness_100um", "log odds per +100 um skin thickness, "
                                                    "real samples"),
                                ("thickness_100um:mode[T.simulated]",
                                 "change of that slope with simulated samples")], level)
    if "trial_index" in trials and data["mode"].nunique() > 1:
        data["position_10"] = trials.groupby(["participant", "session"])["trial_index"] \
            .rank(method="first").to_numpy(float) / 10.0
        rows += _gee_terms(data, "correct ~ group * mode + C(roughness_id) + position_10",
                           [("position_10", "log odds per 10 scored trials later in the session "
                                            "(practice/fatigue)"),
                            ("group[T.B]", "group B - A at real samples, adjusted for position")],
                           level)
    if "contact_force_N" in trials and trials["contact_force_N"].notna().all():
        data["force_N"] = trials["contact_force_N"].to_numpy(float)
        if data["force_N"].std() > 0.01:   # the force varies: Eq. 5's R moves with it
            rows += _gee_terms(data, "correct ~ force_N + group * mode + C(roughness_id)",
                               [("force_N", "log odds per +1 N of measured contact force "
                                            "(adjusted for group x mode)")], level)
    if "rt_s" in trials and trials["rt_s"].notna().all() and (trials["rt_s"] > 0).all():
        data["log_rt"] = np.log(trials["rt_s"].to_numpy(float))
        rows += _gee_terms(data, "correct ~ log_rt + group * mode + C(roughness_id)",
                           [("log_rt", "log odds per unit log response time "
                                       "(speed-accuracy relation)")], level)
    return pd.DataFrame(rows, columns=["model", "term", "meaning", "log_odds", "se", "ci_low",
                                       "ci_high", "statistic", "p_value", "test"])


def force_table(trials: pd.DataFrame) -> pd.DataFrame:
    """The contact force the display measured, per group x mode (``contact_force_N`` of trials.csv).

    Returns
    -------
    pandas.DataFrame
        ``group, mode, n_trials, mean_force_N, sd_force_N, min_force_N, max_force_N`` over the
        trials with a measured force (empty when none has one).
    """
    cols = ["group", "mode", "n_trials", "mean_force_N", "sd_force_N", "min_force_N", "max_force_N"]
    if "contact_force_N" not in trials:
        return pd.DataFrame(columns=cols)
    sel = trials[trials["contact_force_N"].notna()]
    if sel.empty:
        return pd.DataFrame(columns=cols)
    g = sel.groupby(["group", "mode"])["contact_force_N"]
    return pd.DataFrame({"n_trials": g.size(), "mean_force_N": g.mean(), "sd_force_N": g.std(),
                         "min_force_N": g.min(), "max_force_N": g.max()}).reset_index()[cols]


def rt_table(trials: pd.DataFrame) -> pd.DataFrame:
    """Response times by group × mode × sample and correctness.

    Returns
    -------
    pandas.DataFrame
        ``group, mode, roughness_id, correct, n_trials, median_rt_s, q25_rt_s, q75_rt_s``.
    """
    sel = trials[trials["rt_s"].notna()] if "rt_s" in trials else trials.iloc[:0]
    if sel.empty:
        return pd.DataFrame(columns=["group", "mode", "roughness_id", "correct", "n_trials",
                                     "median_rt_s", "q25_rt_s", "q75_rt_s"])
    g = sel.groupby(["group", "mode", "roughness_id", "correct"])["rt_s"]
    return pd.DataFrame({"n_trials": g.size(), "median_rt_s": g.median(),
                         "q25_rt_s": g.quantile(0.25), "q75_rt_s": g.quantile(0.75)}).reset_index()
