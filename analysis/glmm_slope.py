"""Mixed logit with a random intercept and a random slope for mode, by maximum likelihood.

The model adds to :mod:`analysis.glmm`'s a per-participant effect of simulated vs
real samples: for participant :math:`i`

.. math::

    \\operatorname{logit} P(y_{ij} = 1 \\mid b_i) = x_{ij}\\beta + z_{ij}^T \\Lambda b_i,
    \\qquad z_{ij} = (1, [\\text{mode}_{ij} = \\text{simulated}]),\\ b_i \\sim N(0, I_2),

with :math:`\\Lambda` lower triangular (lme4's :math:`\\theta` parametrisation,
:math:`\\Sigma = \\Lambda\\Lambda^T`): R's ``(1 + mode | participant)``. Each
participant's 2-D integral is done by adaptive Gauss-Hermite quadrature on a
tensor grid (``n_agq`` nodes per axis, centred on the mode and scaled by the
Cholesky factor of the curvature; ``n_agq = 1`` is the Laplace approximation, what
``lme4::glmer`` uses for vector random effects).

Reported: fixed effects with Wald intervals (inverse observed information of
:math:`(\\beta, \\theta)`, t(m - 2) quantiles), the two SDs and their correlation with
profile-likelihood intervals (the deviance re-minimised over every other parameter, in the
parametrisation :math:`\\Lambda = [[s_0, 0], [s_1 \\sin\\varphi, s_1 \\cos\\varphi]]`,
correlation :math:`\\sin\\varphi`, rises by the F(1, m - 2) cut-off as for
:mod:`analysis.glmm`'s SD), and a likelihood-ratio test of the random slope against the
intercept-only model (its null distribution on the boundary is the 50:50 mixture of
:math:`\\chi^2_1` and :math:`\\chi^2_2` [1]_). Mode contrasts (real - simulated, the
interaction) take their SE from the CR2 (Bell-McCaffrey [2]_) participant-cluster sandwich of the
fixed effects (:func:`participant_sandwich`, :attr:`analysis.models.ModelFit.cov_robust`) and
their df from :func:`analysis.small_sample.bell_mccaffrey_df` (each participant's
information, :attr:`analysis.models.ModelFit.cluster_info`): the mode-slope SD's ML estimate
is biased low at 30 participants, and the model-based SEs of those contrasts inherit that.
Coverage of all these intervals is measured by
``benchmarks/bench_recovery.py`` (``--scenario slope``, ``--slope-model``; docs/analysis.md).

References
----------
.. [1] S. G. Self, K.-Y. Liang, "Asymptotic properties of maximum likelihood estimators
   and likelihood ratio tests under nonstandard conditions", J. Am. Stat. Assoc. 82
   (1987) 605-610.
.. [2] R. M. Bell, D. F. McCaffrey, "Bias reduction in standard errors for linear regression
   with multi-stage samples", Survey Methodology 28 (2002) 169-181.
"""
from __future__ import annotations

import numpy as np
import pandas as pd
from scipy import optimize, special, stats
from threadpoolctl import threadpool_limits

from .glmm import ML_COLUMNS, GLMMData, fd_gradient, fd_hessian, ml_wald, wald_table
from .glmm_slope_deviance import SD_BOUND, inner_on, lambda_matrix, slope_deviance
from .glmm_slope_profile import (PROFILE_ENDS, SHARE_ORDER, PROFILED_TERMS, fill_profiles,
                                 profile_modes, profile_end, profile_intervals)
from .small_sample import leverage_adjustments
from .design import design_matrices
from .models import (FORMULA, ModelFit, accept_candidate, candidate_formulas, refuse_separated,
                     model_data, reference_df, reference_quantile)

__all__ = ["fit_glmm_slope", "slope_deviance", "participant_sandwich"]


def slope_data(formula: str, data_t: pd.DataFrame):
    """Design of the slope model: ``(y, x, data, z)`` with ``data`` the counts per participant
    and distinct design row (:class:`analysis.glmm.GLMMData`) and ``z`` its random-effect
    design ``(1, simulated)`` per row. ``data_t``: :func:`analysis.models.model_data`."""
    y, x = design_matrices(formula, data_t)
    sim = (data_t["mode"] == "simulated").to_numpy(float)
    data = GLMMData.from_trials(y, np.column_stack([x.to_numpy(), sim]), data_t["participant"])
    z = np.column_stack([np.ones(len(data.k)), data.x[:, -1]])
    return y, x, GLMMData(data.x[:, :-1], data.k, data.n, data.person, data.m), z


def participant_scores(theta, data: GLMMData, z, n_agq: int = 5) -> np.ndarray:
    """Each participant's score of the marginal log-likelihood for the fixed effects, (m, p).

    The quadrature's posterior expectation of the complete-data score (as the gradient of
    :func:`slope_deviance`, on the log-likelihood scale), kept per participant; the random-effect
    parameters are held at ``theta[-3:]``.
    """
    theta = np.asarray(theta, float)
    beta = theta[:-3]
    _, _, eta_q, post = inner_on(data, data.x @ beta, z, lambda_matrix(theta[-3:]), n_agq)
    resid = data.k[:, None] - data.n[:, None] * special.expit(eta_q)
    per_row = np.einsum("rq,rq->r", post[data.person], resid)
    return data.onehot @ (data.x * per_row[:, None])


def participant_sandwich(theta, data: GLMMData, z, n_agq: int = 5, groups=None,
                         adjustment: str = "CR2"):
    """Bias-reduced participant-cluster sandwich covariance of the fixed effects.

    With :math:`s_i` participant *i*'s score for :math:`\\beta` at the estimate and
    :math:`A_i = \\partial s_i / \\partial \\beta` (central differences, ``theta``'s
    random-effect parameters held fixed), :math:`A = \\sum_i A_i`:

    .. math::

        V = A^{-1} \\Big[\\sum_i \\tilde s_i \\tilde s_i^T\\Big] A^{-1}, \\qquad
        \\tilde s_i = (I - A_i A^{-1})^{-a} s_i,

    :math:`a = 1` (``adjustment="MD"``) or :math:`a = 1/2` (``"CR2"``); see
    :func:`adjusted_scores`. With :math:`a = 1` it is the Mancl-DeRouen correction
    :math:`(I - H_{ii})^{-1}` of :func:`analysis.fit_gee`'s sandwich (push-through identity),
    here for the mixed model's estimating equations; linearised,
    :math:`A^{-1}(I - A_i A^{-1})^{-1} s_i` is the change of the estimate when participant *i*
    is left out: the one-step delete-one-participant jackknife
    (``tests/analysis/test_fidelity.py`` compares it with 30 real refits). With
    :math:`a = 1/2` it is Bell and McCaffrey's CR2, unbiased when the working model is right.
    Neither relies on the fitted random-effect SDs (the slope SD's ML estimate is biased low).

    Parameters
    ----------
    groups : array_like, optional
        Each participant's group (participant index order of ``data``). Given, the sum over
        participants is also split by group (as :func:`analysis.small_sample.group_covariances`
        splits the GEE's), for the df of :func:`analysis.small_sample.row_df`.
    adjustment : {"MD", "CR2"}
        The leverage adjustment of each participant's score.

    Returns
    -------
    ndarray, shape (p, p)
        On the same scale as the model's Wald covariance (log odds). With ``groups``:
        ``(V, {g: (V_g, m_g)})``, ``V`` the sum of the ``V_g``.
    """
    s, a_i = score_parts(theta, data, z, n_agq)
    if groups is None:
        return _sandwich_sum(s, a_i, np.zeros(len(s)), adjustment)[0]
    return _sandwich_sum(s, a_i, groups, adjustment)


def _sandwich_sum(s, a_i, groups, adjustment: str):
    """``(V, {g: (V_g, m_g)})`` from the scores and their derivatives."""
    a_inv = np.linalg.inv(a_i.sum(axis=0))
    s_tilde = adjusted_scores(s, a_i, adjustment)
    groups = np.asarray(groups)
    parts = {}
    for g in np.unique(groups):
        sg = s_tilde[groups == g]
        parts[str(g)] = (a_inv @ (sg.T @ sg) @ a_inv, int(len(sg)))
    return sum(w for w, _ in parts.values()), parts


def score_parts(theta, data: GLMMData, z, n_agq: int = 5):
    """Each participant's score ``s`` (m, p) and its derivative for the fixed effects ``A_i``
    (m, p, p; central differences, symmetrised), the random-effect parameters held fixed."""
    theta = np.asarray(theta, float)
    p = len(theta) - 3
    s = participant_scores(theta, data, z, n_agq)
    a_i = np.empty((data.m, p, p))
    for j in range(p):
        h = 1e-4 * max(1.0, abs(theta[j]))
        up, down = theta.copy(), theta.copy()
        up[j] += h
        down[j] -= h
        a_i[:, :, j] = (participant_scores(up, data, z, n_agq)
                        - participant_scores(down, data, z, n_agq)) / (2 * h)
    return s, (a_i + np.transpose(a_i, (0, 2, 1))) / 2


def adjusted_scores(s, a_i, adjustment: str = "CR2") -> np.ndarray:
    """Leverage-adjusted participant scores ``(I - A_i A^-1)^-a s_i``, (m, p).

    ``"CR2"`` (a = 1/2): Bell and McCaffrey's bias-reduced linearisation
    (:func:`analysis.small_sample.leverage_adjustments`), unbiased under the working model.
    ``"MD"`` (a = 1): Mancl and DeRouen's correction, which over-corrects: its variance is
    about ``1 / (1 - h)`` too large for a participant of leverage ``h`` (8/7 in a group of 8).
    """
    power = {"MD": 1.0, "CR2": 0.5}[adjustment]
    adjust = leverage_adjustments(-np.asarray(a_i, float), power)
    return np.einsum("iab,ib->ia", adjust, np.asarray(s, float))


def _person_groups(data_t: pd.DataFrame) -> np.ndarray:
    """Each participant's group, in :class:`analysis.glmm.GLMMData`'s participant order
    (participant labels as text, sorted)."""
    first = data_t.groupby(data_t["participant"].astype(str), sort=True)["group"].first()
    return first.astype(str).to_numpy()


def _objective(data, z, n_agq):
    if n_agq < 5:
        def fun(t):
            dev = lambda u: slope_deviance(u, data, z, n_agq)
            return dev(t), fd_gradient(dev, np.asarray(t, float))
        return fun
    return lambda t: slope_deviance(t, data, z, n_agq, grad=True)


def _hessian(theta, data, z, n_agq):
    if n_agq >= 5:
        g = lambda t: slope_deviance(t, data, z, n_agq, grad=True)[1]
    else:
        g = lambda t: fd_gradient(lambda u: slope_deviance(u, data, z, n_agq), t)
    return fd_hessian(g, theta)




def fit_glmm_slope(trials: pd.DataFrame, formula: str = FORMULA, *, level: float = 0.95,
                   n_agq: int = 5, intercept_fit: ModelFit | None = None,
                   profile: bool = True, sd_cutoff: str = "F", submit=None) -> ModelFit:
    """Mixed logit with participant random intercepts and random mode slopes (ML).

    Parameters
    ----------
    trials : pandas.DataFrame
        Analysable trials (both modes).
    formula : str
        Fixed effects; the same fallbacks as :func:`analysis.fit_gee`.
    level : float
        Confidence level of the fixed effects' Wald intervals.
    n_agq : int
        Gauss-Hermite nodes per axis (1 = Laplace, as lme4 for vector random effects).
    intercept_fit : ModelFit, optional
        The intercept-only model (:func:`analysis.glmm.fit_glmm`); when its fixed effects
        are the same as this fit's, gives the likelihood-ratio test of the slope.
    profile : bool
        Profile-likelihood intervals of the two SDs and the correlation (cut-off
        F(1, participants - 2) at ``level``, as the intercept-only model's SD); else
        point estimates only.
    sd_cutoff : {"F", "chi2"}
        The profile cut-off: F(1, m - 2) (default) or chi2_1 (lme4's
        ``confint(method = "profile")``, used by the cross-check).
    submit : callable, optional
        ``submit(function, *args)`` returning an object with ``result()`` (a future) or None
        (:meth:`analysis.worker.AnalysisWorker.submit`): the profile intervals are then computed
        there while the caller goes on, the fit's ``pending`` holds the future, and
        :func:`complete_profiles` fills them in (the same numbers; None: computed here).

    Returns
    -------
    ModelFit
        ``kind`` ``"glmm-slope"``; ``table``: fixed effects (Wald) then
        ``sd_intercept``, ``sd_mode_slope``, ``corr_intercept_slope`` with profile
        intervals (an SD's lower end 0, a correlation's end +-1, where the profile never
        rises to the cut-off) and, with ``intercept_fit``, ``lrt_slope`` (statistic in
        ``log_odds``, mixture p-value in ``p_value``); ``result`` holds the
        convergence details.
    """
    # one BLAS thread: L-BFGS-B's small BLAS calls spin threads, 10x slower on a busy machine
    with threadpool_limits(1):
        return _fit_glmm_slope_impl(trials, formula, level=level, n_agq=n_agq,
                                    intercept_fit=intercept_fit, profile=profile,
                                    sd_cutoff=sd_cutoff, submit=submit)


def _fit_glmm_slope_impl(trials: pd.DataFrame, formula: str = FORMULA, *, level: float = 0.95,
                         n_agq: int = 5, intercept_fit: ModelFit | None = None,
                         profile: bool = True, sd_cutoff: str = "F", submit=None) -> ModelFit:
    """See the public function."""

    data_t = model_data(trials)
    notes: list = []
    columns = ML_COLUMNS
    df = reference_df(data_t)
    zq = reference_quantile(level, df)
    if data_t["mode"].nunique() < 2:
        notes.append("GLMM slope: one mode only: no mode slope to fit")
        return ModelFit(kind="glmm-slope", formula=None, requested=formula,
                        table=pd.DataFrame(columns=columns), notes=notes)
    for candidate in candidate_formulas(data_t, formula, notes, "GLMM slope"):
        if refuse_separated("GLMM slope", candidate, data_t, notes):
            continue
        y, x, data, z = slope_data(candidate, data_t)
        p = x.shape[1]
        res, theta, hess = _optimise(y, p, data, z, n_agq)
        cov_full, beta, cov, se, why = ml_wald(theta, hess, p, res)
        if not accept_candidate("GLMM slope", candidate, formula, why, notes):
            continue
        cov_robust, by_group, info = _sandwich(theta, data, z, n_agq, data_t, notes)
        table = wald_table(x.columns, beta, se, df, zq)
        cut_df = df if sd_cutoff == "F" else None
        _sd_rows(table, theta, profile, cut_df)
        pending = None
        if profile:
            args = (data, z, theta, res.fun, n_agq, level, cut_df)
            modes = profile_modes(data)
            if submit is not None:
                pending = [(i, submit(profile_end, *args, *PROFILE_ENDS[i], modes))
                           for i in SHARE_ORDER]
                if any(job is None for _, job in pending):  # no worker: all of them here
                    pending = None
            if pending is None:
                fill_profiles(table, profile_intervals(*args, modes))
        loglik = float(-res.fun / 2)
        if intercept_fit is not None and intercept_fit.formula == candidate:
            _lrt_row(table, loglik, intercept_fit.convergence["log_likelihood"])
        return ModelFit(kind="glmm-slope", formula=candidate, requested=formula,
                        table=table[columns], notes=notes, params=beta, cov=cov,
                        design_info=x.design_info, df=df,
                        convergence=_convergence(res, theta, hess, n_agq, loglik), theta=theta,
                        cov_full=cov_full, cov_robust=cov_robust,
                        cov_by_group=by_group if by_group and len(by_group) == 2 else None,
                        cluster_info=info, pending=pending)
    notes.append("GLMM slope: no formula could be fitted")
    return ModelFit(kind="glmm-slope", formula=None, requested=formula,
                    table=pd.DataFrame(columns=columns), notes=notes)


def _optimise(y, p: int, data, z, n_agq: int):
    """The ML fit by L-BFGS-B (again from its end point if it stopped short): the optimiser's
    result, the estimate and the Hessian of the deviance there."""
    start = np.zeros(p + 3)
    ybar = np.clip(y.mean(), 0.02, 0.98)
    start[0] = np.log(ybar / (1 - ybar))
    start[-3:] = (0.5, 0.0, 0.3)
    bounds = [(None, None)] * p + [(0.0, SD_BOUND), (-SD_BOUND, SD_BOUND), (0.0, SD_BOUND)]
    with np.errstate(all="ignore"):
        res = optimize.minimize(_objective(data, z, n_agq), start, jac=True,
                                method="L-BFGS-B", bounds=bounds,
                                options={"maxiter": 1000, "ftol": 1e-13, "gtol": 1e-7})
        if not res.success:
            first = res
            res = optimize.minimize(_objective(data, z, 1 if n_agq < 5 else n_agq), res.x,
                                    jac=True, method="L-BFGS-B", bounds=bounds,
                                    options={"maxiter": 1000, "ftol": 1e-13, "gtol": 1e-6})
            res.nit += first.nit
        theta = res.x.copy()
        hess = _hessian(theta, data, z, n_agq)
    return res, theta, hess


def _sandwich(theta, data, z, n_agq: int, data_t: pd.DataFrame, notes: list):
    """The CR2 participant sandwich (:func:`participant_sandwich`), split by group, and each
    participant's information for the fixed effects (for the Bell-McCaffrey df of
    :func:`analysis.small_sample.row_df`); ``(None, None, None)`` with a note."""
    try:
        with np.errstate(all="ignore"):
            s, a_i = score_parts(theta, data, z, n_agq)
            cov_robust, by_group = _sandwich_sum(s, a_i, _person_groups(data_t), "CR2")
        if not np.all(np.isfinite(cov_robust)):
            raise np.linalg.LinAlgError("non-finite")
    except np.linalg.LinAlgError:
        notes.append("GLMM slope: the participant sandwich could not be computed (singular "
                     "leverage); mode contrasts use the model-based SE alone")
        return None, None, None
    return cov_robust, by_group, -a_i


def _sd_rows(table: pd.DataFrame, theta, profile: bool, cut_df) -> None:
    """Append the two SDs and their correlation (intervals blank: :func:`fill_profiles`)."""
    lam = lambda_matrix(theta[-3:])
    sigma = lam @ lam.T
    sd0, sd1 = np.sqrt(sigma[0, 0]), np.sqrt(sigma[1, 1])
    corr = sigma[0, 1] / (sd0 * sd1) if sd0 > 0 and sd1 > 0 else np.nan
    how = "point estimate"
    if profile:
        how = (f"profile likelihood, F(1, {cut_df:g}) cut-off" if cut_df
               else "profile likelihood, chi2(1) cut-off")
    for term, value in zip(PROFILED_TERMS, (sd0, sd1, corr)):
        table.loc[len(table)] = [term, value, np.nan, np.nan, np.nan, np.nan, np.nan, how, ""]


def _lrt_row(table: pd.DataFrame, loglik: float, intercept_loglik: float) -> None:
    """Append the likelihood-ratio test of the random slope (50:50 chi2(1)/chi2(2) mixture)."""
    lrt = max(0.0, 2 * (loglik - intercept_loglik))
    pv = 0.5 * stats.chi2.sf(lrt, 1) + 0.5 * stats.chi2.sf(lrt, 2)
    table.loc[len(table)] = ["lrt_slope", lrt, np.nan, np.nan, pv, np.nan, np.nan,
                             "LR test vs intercept only, 50:50 chi2(1)/chi2(2)",
                             "LR, 50:50 chi2(1)/chi2(2) mixture"]


def _convergence(res, theta, hess, n_agq: int, loglik: float) -> dict:
    """The optimiser's report (``glmm_convergence.json``'s ``random_slope_model``)."""
    return {"method": f"ML, adaptive Gauss-Hermite ({n_agq}x{n_agq} nodes), scipy L-BFGS-B",
            "optimiser_success": bool(res.success), "optimiser_status": int(res.status),
            "optimiser_message": str(res.message), "iterations": int(res.nit),
            "function_evaluations": int(res.nfev), "log_likelihood": loglik,
            "theta": theta[-3:].tolist(),
            "hessian_positive_definite": bool(np.all(np.linalg.eigvalsh(hess) > 0))}
