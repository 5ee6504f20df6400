"""The paper's questions as named tests: primary test, omnibus, Holm, interaction, chance.

- **Primary test** (the paper's claim, §3.2): group A vs group B with *real*
  samples, averaged over the four samples (mean log odds), from the GEE
  (population-averaged; bias-reduced sandwich covariance), two-sided Wald.
- **Omnibus test** before any per-sample test: all per-sample A - B log odds
  ratios zero at once: the Wald :math:`\\chi^2` (q = 8 degrees of freedom) with
  the Hotelling-type small-sample correction for a sandwich covariance from
  m clusters [2]_, :math:`F = \\chi^2 (m - q) / (q (m - 1)) \\sim F(q, m - q)`.
  Uncorrected, the 8-df Wald test rejected 18-21 % of null datasets with 30
  participants; corrected, 3.5 % (benchmarks/bench_recovery.py). For the GEE (whose
  sandwich splits by group) the F uses each group's own covariance instead
  (:func:`analysis.small_sample.omnibus_f`, Nel-van der Merwe): the pooled F(q, m - q)
  rejected 0.07-0.26 with 20 + 8 and 24 + 6 participants. Every both-groups contrast
  refers to t with its Welch-Satterthwaite df (:func:`analysis.small_sample.row_df`).
- **Per-sample tests**: the per-sample A - B rows with Holm-adjusted p-values
  [1]_ (the family is all per-sample rows of both modes).
- **Group × mode interaction**: the A - B difference with real samples minus
  that with simulated samples (the paper: the gap is smaller with simulated
  samples), on the log-odds scale and as a difference of differences of mean
  proportions (delta method).
- **Against chance** (0.25, one of four samples): per cell and per group × mode,
  a one-sample *t*-test of the participants' proportions correct (participants
  are the units, so answers of one person are not counted as independent),
  with Holm-adjusted p-values within each family.

References
----------
.. [1] S. Holm, "A simple sequentially rejective multiple test procedure",
   Scand. J. Statist. 6 (1979) 65-70.
.. [2] W. Pan, M. M. Wall, "Small-sample adjustments in using the sandwich variance
   estimator in generalized estimating equations", Stat. Med. 21 (2002) 1429-1441.
"""
from __future__ import annotations

import numpy as np
import pandas as pd
from scipy import special, stats

from .design import design_rows
from .models import (ModelFit, contrast_se, design_gap, has_group_by_roughness, model_data,
                     reference_p, reference_quantile)
from .small_sample import omnibus_f, row_df

__all__ = ["holm", "omnibus_group_test", "interaction_test", "chance_tests", "primary_test",
           "averaged_contrast", "CHANCE"]

#: Chance level of a four-alternative identification.
CHANCE = 0.25


def holm(p) -> np.ndarray:
    """Holm's step-down adjusted p-values (NaN entries left out and kept NaN).

    The same values as ``statsmodels.stats.multitest.multipletests(p, method="holm")`` on the
    finite entries (the tests compare them), without its ``gc.collect()`` per call (0.1 s each).

    Parameters
    ----------
    p : array_like
        Unadjusted p-values.

    Returns
    -------
    ndarray
        Adjusted p-values, same order.

    Examples
    --------
    >>> holm([0.01, 0.04, 0.03]).round(3).tolist()
    [0.03, 0.06, 0.06]
    """
    p = np.asarray(p, float)
    out = np.full(p.shape, np.nan)
    ok = np.isfinite(p)
    if ok.any():
        q = p[ok]
        order = np.argsort(q, kind="stable")
        # the k-th smallest times (n - k), running maximum, capped at 1
        stepped = np.maximum.accumulate(q[order] * np.arange(len(q), 0, -1))
        adjusted = np.empty_like(q)
        adjusted[order] = np.minimum(stepped, 1.0)
        out[ok] = adjusted
    return out


def primary_test(contrasts: pd.DataFrame) -> pd.Series | None:
    """The primary test's row: GEE, real samples, averaged over the four samples."""
    if contrasts.empty:
        return None
    row = contrasts[(contrasts["model"] == "gee") & (contrasts["mode"] == "real")
                    & (contrasts["roughness_id"] == 0)]
    return None if row.empty else row.iloc[0]


def averaged_contrast(fit: ModelFit, mode: str = "real", samples=(1, 2, 3, 4),
                      level: float = 0.95) -> dict | None:
    """The primary test's contrast straight from a fit: A - B in ``mode``, averaged over samples.

    The same computation as :func:`analysis.group_contrasts`' ``roughness_id`` 0 row (used by
    :func:`analysis.power_curve`, which needs only this row).

    Returns
    -------
    dict or None
        ``log_odds_ratio, se, p_value, difference, difference_low, difference_high`` (None
        without a group term; the difference's interval by the delta method at ``level``).
    """
    from .models import log_odds_contrast
    if fit.formula is None or "group" not in fit.formula:
        return None
    xa, xb = design_rows(fit, ["A"], [mode], samples), design_rows(fit, ["B"], [mode], samples)
    df = row_df(fit, xa.mean(axis=0) - xb.mean(axis=0), se_from_cov=True)
    v = log_odds_contrast(xa, xb, fit.params, fit.cov, reference_quantile(level, df), df)
    return {"log_odds_ratio": v[0], "se": v[1], "p_value": v[5], "difference": v[8],
            "difference_low": v[9], "difference_high": v[10], "df": df}


def omnibus_group_test(fit: ModelFit, trials: pd.DataFrame) -> dict:
    """Wald test that group A and B do not differ on any sample in any mode.

    Parameters
    ----------
    fit : ModelFit
        A fitted GEE (or GLMM).
    trials : pandas.DataFrame
        Analysable trials.

    Returns
    -------
    dict
        ``test, hypothesis, chi2, df, f, df_denominator, p_value`` (``p_value`` from
        the small-sample F; NaN when the model has no group term).
    """
    data = model_data(trials)
    out = {"test": f"Wald F, small-sample ({fit.kind})", "chi2": np.nan, "df": 0, "f": np.nan,
           "df_denominator": 0, "p_value": np.nan, "reason": "", "method": "",
           "hypothesis": "no A - B difference on any sample in either mode"}
    if fit.formula is None or "group" not in fit.formula or set(data["group"]) != {"A", "B"}:
        out["reason"] = "not tested: " + (design_gap(data) or "no group term in the model")
        return out
    modes = [m for m in sorted(data["mode"].unique()) if not design_gap(data, modes=[m])]
    if not modes:
        out["reason"] = f"not tested: {design_gap(data)}"
        return out
    if len(modes) < data["mode"].nunique():
        out["hypothesis"] += (f" (only {', '.join(modes)}: {design_gap(data)})")
    samples = sorted(data["roughness_id"].unique())
    if not has_group_by_roughness(fit):
        samples = samples[:1]      # the model has one A - B log odds ratio per mode
        out["hypothesis"] += " (the fitted model has no group x sample term: one A - B per mode)"
    xa = design_rows(fit, ["A"], modes, samples)
    xb = design_rows(fit, ["B"], modes, samples)
    lmat = xa - xb
    est = lmat @ fit.params
    v = lmat @ fit.cov @ lmat.T
    rank = np.linalg.matrix_rank(v)
    chi2 = float(est @ np.linalg.pinv(v) @ est)
    m = data["participant"].nunique()
    if m <= rank or rank == 0:
        out.update(chi2=chi2, df=int(rank), reason=f"not tested: {m} participants for a "
                   f"{rank}-df test (the covariance of the A - B differences has rank {rank})")
        return out
    if fit.cov_by_group and len(fit.cov_by_group) == 2:
        nvdm = omnibus_f(fit.params, lmat, fit.cov_by_group)
        if not np.isfinite(nvdm["f"]):
            out.update(chi2=chi2, df=int(rank), reason=f"not tested: too few participants in "
                       f"the smaller group for a {rank}-df test (effective df "
                       f"{nvdm['nu']:.1f})")
            return out
        out.update(chi2=chi2, df=int(rank), f=nvdm["f"], df_denominator=nvdm["df_denominator"],
                   method="Nel-van der Merwe (each group's own covariance)",
                   p_value=float(stats.f.sf(nvdm["f"], rank, nvdm["df_denominator"])))
        return out
    f = chi2 * (m - rank) / (rank * (m - 1))
    out.update(chi2=chi2, df=int(rank), f=f, df_denominator=int(m - rank), method="small-sample",
               p_value=float(stats.f.sf(f, rank, m - rank)))
    return out


def interaction_test(fit: ModelFit, trials: pd.DataFrame, *, level: float = 0.95) -> dict:
    """Group × mode: (A - B with real samples) - (A - B with simulated samples).

    Returns
    -------
    dict
        ``compares, log_odds, se, ci_low, ci_high, p_value`` (difference of the
        two averaged log odds ratios) and ``difference_of_differences,
        dd_low, dd_high`` (difference of the two differences of mean
        proportions, 0-1, delta method). NaN without both modes and groups.
    """
    z = fit.quantile(level)
    out = {"model": fit.kind, "compares": "(A - B, real) - (A - B, simulated), averaged over samples",
           "log_odds": np.nan, "se": np.nan, "ci_low": np.nan, "ci_high": np.nan,
           "p_value": np.nan, "difference_of_differences": np.nan, "dd_low": np.nan,
           "dd_high": np.nan, "reason": "", "df": fit.df}
    data = model_data(trials)
    gap = design_gap(data, modes=("real", "simulated"))
    if fit.formula is None or "group" not in fit.formula or "mode" not in fit.formula or gap:
        out["reason"] = "not tested: " + (gap or "the model has no group and mode terms")
        return out
    samples = sorted(data["roughness_id"].unique())
    x = {(g, m): design_rows(fit, [g], [m], samples)
         for g in ("A", "B") for m in ("real", "simulated")}
    sign = {("A", "real"): 1, ("B", "real"): -1, ("A", "simulated"): -1, ("B", "simulated"): 1}
    lvec = sum(s * x[k].mean(axis=0) for k, s in sign.items())
    est, se = float(lvec @ fit.params), contrast_se(fit, lvec)
    out["df"] = row_df(fit, lvec)
    z = reference_quantile(level, out["df"])
    grad = np.zeros_like(lvec)
    dd = 0.0
    for k, s in sign.items():
        q = special.expit(x[k] @ fit.params)
        dd += s * q.mean()
        grad += s * (q * (1 - q)) @ x[k] / len(q)
    dse = contrast_se(fit, grad)
    if not (np.isfinite(se) and se > 0):
        out["reason"] = "not tested: the standard error is zero (no variation to test against)"
        return out
    out.update(log_odds=est, se=se, ci_low=est - z * se, ci_high=est + z * se,
               p_value=float(reference_p(est / se, out["df"])) if se > 0 else np.nan,
               difference_of_differences=dd, dd_low=dd - z * dse, dd_high=dd + z * dse)
    return out


def chance_tests(trials: pd.DataFrame, *, level: float = 0.95) -> pd.DataFrame:
    """Proportion correct against chance (0.25), per cell and per group × mode.

    Parameters
    ----------
    trials : pandas.DataFrame
        Analysable trials.
    level : float
        Confidence level of the *t* interval of the mean participant proportion.

    Returns
    -------
    pandas.DataFrame
        ``family`` ("cell" or "group x mode"), ``group, mode, roughness_id``
        (0 for group × mode), ``n_participants, mean_participant_proportion,
        t_low, t_high, t, df, p_value, p_holm`` (Holm within each family),
        ``compares``.
    """
    data = model_data(trials)
    rows = []
    for family, keys in (("cell", ["group", "mode", "roughness_id"]), ("group x mode", ["group", "mode"])):
        per_person = data.groupby(keys + ["participant"])["correct"].mean().reset_index()
        for key, sel in per_person.groupby(keys):
            key = key if isinstance(key, tuple) else (key,)
            values = sel["correct"].to_numpy(float)
            n = len(values)
            mean = float(values.mean())
            sd = float(values.std(ddof=1)) if n > 1 else np.nan
            if n > 1 and sd > 0:
                se = sd / np.sqrt(n)
                t = (mean - CHANCE) / se
                p = float(2 * stats.t.sf(abs(t), n - 1))
                half = stats.t.ppf(0.5 + level / 2, n - 1) * se
            else:                   # every participant the same: no spread to test against
                t, p, half = np.nan, np.nan, np.nan
            group, mode = key[0], key[1]
            rid = int(key[2]) if family == "cell" else 0
            where = f"{rid}#" if rid else "all samples"
            rows.append({"family": family, "group": group, "mode": mode, "roughness_id": rid,
                         "n_participants": n, "mean_participant_proportion": mean,
                         "t_low": mean - half, "t_high": mean + half, "t": t, "df": n - 1,
                         "p_value": p,
                         "compares": f"group {group}, {mode}, {where}: mean participant "
                                     f"proportion correct vs chance 0.25"})
    out = pd.DataFrame(rows)
    out["p_holm"] = np.nan
    for family in out["family"].unique():
        sel = out["family"] == family
        out.loc[sel, "p_holm"] = holm(out.loc[sel, "p_value"].to_numpy())
    return out
