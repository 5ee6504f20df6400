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

The random-slope mixed model's mode contrasts use the CR2 participant sandwich instead, the
bias-reduced linearisation of Bell and McCaffrey [3]_ (:func:`leverage_adjustments`), referred
to t with its Bell-McCaffrey (Satterthwaite) df (:func:`bell_mccaffrey_df`), as R clubSandwich
computes them [4]_. The Mancl-DeRouen correction over-corrects (by about ``1 / (1 - 1/m_g)``
in variance, 8/7 in a group of 8), and taking the larger of it and the model-based SE made the
per-group rows cover 0.963-0.990 at 20 + 8 and 24 + 6, where CR2 with its df covers
0.939-0.963 (300 datasets each, ``benchmarks/mixed_se_rules.py``; docs/analysis.md).

References
----------
.. [1] B. L. Welch, "The generalization of 'Student's' problem when several different
   population variances are involved", Biometrika 34 (1947) 28-35.
.. [2] D. G. Nel, C. A. van der Merwe, "A solution to the multivariate Behrens-Fisher
   problem", Commun. Statist. Theory Methods 15 (1986) 3719-3735.
.. [3] R. M. Bell, D. F. McCaffrey, "Bias reduction in standard errors for linear regression
   with multi-stage samples", Survey Methodology 28 (2002) 169-181.
.. [4] J. E. Pustejovsky, E. Tipton, "Small-sample methods for cluster-robust variance
   estimation and hypothesis testing in fixed effects models", J. Bus. Econ. Stat. 36 (2018)
   672-683.
"""
from __future__ import annotations

import numpy as np

__all__ = ["group_covariances", "welch_df", "omnibus_f", "row_df", "leverage_adjustments",
           "bell_mccaffrey_df"]


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
    """The df of ``lvec @ fit.params``'s t reference, from the variance its SE uses.

    - GEE: its SE is the bias-reduced sandwich, split by group (``fit.cov_by_group``):
      Welch-Satterthwaite (:func:`welch_df`); a one-group contrast (a group's real - simulated
      row) has one part: ``m_g - 1``.
    - Random-slope mixed model: its mode contrasts' SE is the CR2 participant sandwich
      (:func:`analysis.models.contrast_se`): the Bell-McCaffrey df (:func:`bell_mccaffrey_df`
      of ``fit.cluster_info``), about ``m_g - 1`` on a group's row and Welch-like on rows of
      both groups.
    - ``se_from_cov``: the row's SE is ``sqrt(l' fit.cov l)`` whatever the fit carries (the
      A - B group comparisons): for a mixed model that is the model-based SE, ``m - 2``.
    - Intercept-only mixed model (no sandwich), or a slope model whose sandwich could not be
      computed: ``m - 2`` (the model-based SE rests on every participant's likelihood).
    """
    if not fit.df:
        return fit.df
    info = getattr(fit, "cluster_info", None)
    if info is not None and getattr(fit, "cov_robust", None) is not None:
        if se_from_cov:
            return fit.df
        df = bell_mccaffrey_df(info, lvec)
        return df if np.isfinite(df) else fit.df
    parts = getattr(fit, "cov_by_group", None)
    if not parts or se_from_cov and getattr(fit, "cov_robust", None) is not None:
        return fit.df
    df = welch_df(parts, np.asarray(lvec, float))
    return df if np.isfinite(df) else fit.df


def leverage_adjustments(info, power: float = 0.5) -> np.ndarray:
    """Each cluster's leverage adjustment ``(I - F_i F^-1)^-power`` of its score, (m, p, p).

    ``info``: each cluster's information for the fixed effects ``F_i`` (m, p, p), ``F`` their
    sum. ``power`` 1/2 is Bell and McCaffrey's bias-reduced linearisation (CR2) [3]_ in score
    space: for a linear or generalised linear model with residual adjustment
    ``(I - H_ii)^{-1/2}`` on the whitened residuals, ``X_i' f(X_i F^-1 X_i') = f(F_i F^-1) X_i'``
    turns it into this factor on the score ``s_i = X_i' e_i`` (so the CR2 sandwich of a linear
    model equals R clubSandwich's ``vcovCR(type = "CR2")``; ``tests/analysis``). ``power`` 1 is
    the Mancl-DeRouen correction. The non-symmetric power is taken through the symmetric
    ``B_i = F^{-1/2} F_i F^{-1/2}``: ``(I - F_i F^-1)^-a = F^{1/2} (I - B_i)^-a F^{-1/2}``.

    Raises
    ------
    numpy.linalg.LinAlgError
        When ``F`` is not positive definite or a cluster's leverage reaches 1.
    """
    info = np.asarray(info, float)
    w, v = np.linalg.eigh(info.sum(axis=0))
    if not np.all(w > 0):
        raise np.linalg.LinAlgError("the information is not positive definite")
    f_half, f_mhalf = (v * np.sqrt(w)) @ v.T, (v / np.sqrt(w)) @ v.T
    lam, u = np.linalg.eigh(np.eye(len(w))[None] - f_mhalf @ info @ f_mhalf)
    if not np.all(lam > 1e-12):
        raise np.linalg.LinAlgError("a cluster's leverage reaches 1")
    return f_half @ (u * lam[:, None, :] ** -power) @ np.transpose(u, (0, 2, 1)) @ f_mhalf


def bell_mccaffrey_df(info, lvec, adjustments=None) -> float:
    """Bell-McCaffrey (Satterthwaite) df of the CR2 sandwich variance of ``lvec @ beta``.

    The CR2 variance is ``v = sum_i (u_i' s_i)^2`` with ``u_i = T_i' F^-1 l`` (``T_i`` of
    :func:`leverage_adjustments`) and the scores at the estimate ``s_i = s0_i - F_i F^-1
    sum_j s0_j``. Under the working model (``s0_i`` independent, covariance ``F_i``) ``v`` is a
    Gaussian quadratic form with ``G_ik = cov(u_i' s_i, u_k' s_k) = [i = k] u_i' F_i u_i -
    u_i' F_i F^-1 F_k u_k``, ``E v = tr G``, ``var v = 2 ||G||_F^2``, and the df of the
    chi-square matching its first two moments is

        df = tr(G)^2 / ||G||_F^2

    (Bell and McCaffrey 2002 [3]_; Pustejovsky and Tipton 2018 [4]_; R clubSandwich's
    ``coef_test(test = "Satterthwaite")``). ``m_g - 1`` for a contrast resting on one group of
    ``m_g`` clusters with equal information, near the Welch-Satterthwaite df of
    :func:`welch_df` for two groups. NaN when the variance is zero.
    """
    info = np.asarray(info, float)
    if adjustments is None:
        adjustments = leverage_adjustments(info)
    f = info.sum(axis=0)
    u = np.einsum("iba,b->ia", adjustments, np.linalg.solve(f, np.asarray(lvec, float)))
    q = np.einsum("iab,ib->ia", info, u)                       # F_i u_i
    g = np.diag(np.einsum("ia,ia->i", u, q)) - q @ np.linalg.solve(f, q.T)
    total = float(np.trace(g))
    if not total > 0:
        return np.nan
    return total * total / float(np.sum(g * g))


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
