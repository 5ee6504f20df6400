"""Degrees of freedom that reflect unequal groups (one concept).

The GEE's bias-reduced (Mancl-DeRouen) sandwich is a sum over participants. In the
``group * mode * sample`` model a contrast of the groups splits into group A's part and group
B's part, each summing only that group's participants: ``V = V_A + V_B``. With 20 + 8
participants most of the variance of an A - B contrast rests on the 8, and t(m - 2) = t(26)
treats it as if it rested on 28 (the omnibus F(8, m - 8) rejected 14 % of null datasets, the
both-groups real - simulated row covered 0.931). Here every both-groups row gets the
Welch-Satterthwaite df of its own variance,

    df = (V_A + V_B)^2 / (V_A^2 / (m_A - 1) + V_B^2 / (m_B - 1)),

which is m - 2 when the two parts are equal in balanced groups and approaches m_g - 1 when one
group's part dominates; and the omnibus test the Nel-van der Merwe multivariate analogue
(:func:`omnibus_f`). :func:`group_covariances` rebuilds statsmodels' bias-reduced sandwich
cluster by cluster (the same loop as ``GEE._bc_covmat``), split by group; their sum equals
``res.cov_params()`` (checked in the tests).

References
----------
.. [1] B. L. Welch, "The generalization of 'Student's' problem when several different
   population variances are involved", Biometrika 34 (1947) 28-35.
.. [2] D. G. Nel, C. A. van der Merwe, "A solution to the multivariate Behrens-Fisher
   problem", Commun. Statist. Theory Methods 15 (1986) 3719-3735.
"""
from __future__ import annotations

import numpy as np

__all__ = ["group_covariances", "welch_df", "omnibus_f", "row_df"]


def group_covariances(res, cluster_group: dict) -> dict | None:
    """The bias-reduced sandwich of a fitted statsmodels GEE, split by group.

    Parameters
    ----------
    res : statsmodels GEEResults
        Fitted with ``cov_type="bias_reduced"``.
    cluster_group : dict
        Participant (the GEE's group label) -> group ("A" or "B").

    Returns
    -------
    dict or None
        ``{"A": (W_A, m_A), "B": (W_B, m_B)}``: each group's part of the covariance (sum
        ``W_A + W_B`` = the sandwich) and its participant count; None when a cluster's
        correction cannot be computed.
    """
    model = res.model
    sf = getattr(model, "scaling_factor", 1) or 1
    cov_naive = np.asarray(res.cov_naive) / sf
    scale = model.estimate_scale()
    parts: dict = {}
    for i, label in enumerate(model.group_labels):
        expval, lpr = model.cached_means[i]
        resid = model.endog_li[i] - expval
        dmat = model.mean_deriv(model.exog_li[i], lpr)
        sdev = np.sqrt(model.family.variance(expval))
        solved = model.cov_struct.covariance_matrix_solve(expval, i, sdev, (dmat,))
        if solved is None:
            return None
        vinv_d = solved[0] / scale
        hmat = (vinv_d @ cov_naive @ dmat.T).T
        aresid = np.linalg.solve(np.eye(len(resid)) - hmat, resid)
        solved = model.cov_struct.covariance_matrix_solve(expval, i, sdev, (aresid,))
        if solved is None:
            return None
        score = dmat.T @ solved[0] / scale
        g = cluster_group[label]
        total, m = parts.get(g, (0.0, 0))
        parts[g] = (total + np.outer(score, score), m + 1)
    return {g: (cov_naive @ b @ cov_naive * sf, m) for g, (b, m) in parts.items()}


def welch_df(parts: dict, lvec) -> float:
    """Welch-Satterthwaite df of ``lvec @ beta`` from :func:`group_covariances`' parts.

    NaN when a group with a share of the variance has a single participant, or when the
    variance is zero.
    """
    lvec = np.asarray(lvec, float)
    pieces = [(float(lvec @ w @ lvec), m) for w, m in parts.values()]
    total = sum(v for v, _ in pieces)
    if not total > 0:
        return np.nan
    shares = [(v, m) for v, m in pieces if v > 1e-14 * total]
    if any(m < 2 for _, m in shares):
        return np.nan
    if len(shares) == 1:                     # one group's contrast: exactly m_g - 1
        return float(shares[0][1] - 1)
    return float(total * total / sum(v * v / (m - 1) for v, m in shares))


def row_df(fit, lvec, *, se_from_cov: bool = False) -> float | None:
    """The df of ``lvec @ fit.params``: Welch-Satterthwaite from the group parts of the
    variance the row's SE uses, else the fit's own ``df`` (t(m - 2); None: normal).

    - GEE: its SE is the bias-reduced sandwich, split by group (``fit.cov_by_group``): Welch.
      A one-group contrast (a group's real - simulated row) has one part: ``m_g - 1``.
    - Random-slope mixed model: its contrast SE is the larger of the model-based SE and the
      participant sandwich (:func:`analysis.models.contrast_se`). When the sandwich is the
      larger, the row rests on the participants' scores as the GEE's does: Welch from its
      group parts. When the model-based SE is the larger, the row rests on the likelihood of
      all m participants (the random-effect SDs are estimated from both groups): ``m - 2``.
    - ``se_from_cov``: the row's SE is ``sqrt(l' fit.cov l)`` whatever the fit carries (the
      A - B group comparisons): for a mixed model that is the model-based SE, ``m - 2``.
    - Intercept-only mixed model (no sandwich): ``m - 2``. Its per-group rows had
      t(m_g - 1) before, which made them wider than their coverage needs (the 8-person
      group's row covered 150 of 150 datasets at 20 + 8).
    """
    parts = getattr(fit, "cov_by_group", None)
    if not parts or not fit.df:
        return fit.df
    lvec = np.asarray(lvec, float)
    robust = getattr(fit, "cov_robust", None)
    if robust is not None and (se_from_cov
                               or float(lvec @ fit.cov @ lvec) > float(lvec @ robust @ lvec)):
        return fit.df                 # the model-based SE is the one reported
    df = welch_df(parts, lvec)
    return df if np.isfinite(df) else fit.df


def omnibus_f(estimate, lmat, parts: dict) -> dict:
    """Nel-van der Merwe test of ``lmat @ beta = 0`` with group-specific covariances.

    ``T2 = d' S^-1 d`` with ``S = S_A + S_B`` (``S_g = L W_g L'``), effective df
    ``nu = (tr(S^2) + tr(S)^2) / sum_g (tr(S_g^2) + tr(S_g)^2) / (m_g - 1)``, and
    ``F = T2 (nu - q + 1) / (q nu) ~ F(q, nu - q + 1)`` (q the rank of ``S``). In balanced
    groups with equal covariances ``nu`` is about m - 2, close to the Hotelling-type
    F(q, m - q) of one pooled sample.

    Returns
    -------
    dict
        ``chi2`` (= T2), ``q``, ``nu``, ``f``, ``df_denominator`` (NaN entries when
        ``nu - q + 1 < 1``: too few participants in the smaller group for a q-df test; with
        6 in one group and q = 8 its covariance has rank 5 at most).
    """
    lmat = np.atleast_2d(np.asarray(lmat, float))
    d = lmat @ np.asarray(estimate, float)
    s_parts = [(lmat @ w @ lmat.T, m) for w, m in parts.values()]
    s = sum(p for p, _ in s_parts)
    q = int(np.linalg.matrix_rank(s))
    t2 = float(d @ np.linalg.pinv(s) @ d)
    out = {"chi2": t2, "q": q, "nu": np.nan, "f": np.nan, "df_denominator": np.nan}
    denominator = 0.0
    for p, m in s_parts:
        if m < 2:
            return out
        denominator += (np.trace(p @ p) + np.trace(p) ** 2) / (m - 1)
    nu = float((np.trace(s @ s) + np.trace(s) ** 2) / denominator) if denominator > 0 else np.nan
    out["nu"] = nu
    if q == 0 or not np.isfinite(nu) or nu - q + 1 < 1:
        return out          # an F with under 1 denominator df: no usable test
    out.update(f=t2 * (nu - q + 1) / (q * nu), df_denominator=nu - q + 1)
    return out
