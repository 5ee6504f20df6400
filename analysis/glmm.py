"""Mixed logit by maximum likelihood: participant random intercepts, adaptive Gauss-Hermite.

The model (a generalised linear mixed model, GLMM) for participant :math:`i`,
trial :math:`j`:

.. math::

    \\operatorname{logit} P(y_{ij} = 1 \\mid b_i) = x_{ij}\\beta + \\sigma b_i,
    \\qquad b_i \\sim N(0, 1).

Each participant's likelihood is an integral over :math:`b_i`, computed by
adaptive Gauss-Hermite quadrature [1]_ (nodes centred on the mode of the
participant's integrand and scaled by its curvature; ``n_agq = 1`` is the
Laplace approximation), the same approximation as R's ``lme4::glmer(...,
nAGQ = n)`` [2]_. The marginal log-likelihood is maximised over
:math:`(\\beta, \\sigma)`, :math:`\\sigma \\ge 0`, by ``scipy.optimize``
(L-BFGS-B, gradient from the quadrature's posterior expectations).

Intervals (what their coverage was measured for: ``benchmarks/bench_recovery.py``):

- fixed effects: Wald, from the inverse of the observed information of
  :math:`(\\beta, \\sigma)` (as lme4 does), on the log-odds scale;
- the participant SD :math:`\\sigma`: profile likelihood (the deviance rises
  by :math:`\\chi^2_{1,0.95}`), lower end 0 when the profile never rises that far
  towards 0; the latent-scale ICC :math:`\\sigma^2/(\\sigma^2 + \\pi^2/3)` and its
  interval are the same interval transformed.

This replaces mean-field variational Bayes (``fit_bayes``), whose posterior SDs
were 3-4.5 times smaller than these standard errors.

References
----------
.. [1] J. C. Pinheiro, D. M. Bates, "Approximations to the log-likelihood function
   in the nonlinear mixed-effects model", J. Comput. Graph. Stat. 4 (1995) 12-35.
.. [2] D. Bates, M. Mächler, B. Bolker, S. Walker, "Fitting linear mixed-effects
   models using lme4", J. Stat. Softw. 67 (2015) 1-48.
"""
from __future__ import annotations

import functools
import warnings
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import optimize, special, stats
from threadpoolctl import threadpool_limits

from .design import design_matrices
from .errors import ModelWarning
from .models import (FORMULA, ModelFit, accept_candidate, candidate_formulas, fit_trouble,
                     refuse_separated, model_data, reference_df, reference_p, reference_quantile)

__all__ = ["fit_glmm", "GLMMData", "glmm_deviance", "ICC_LATENT_VARIANCE"]

#: Residual variance of the standard logistic distribution (latent-scale ICC).
ICC_LATENT_VARIANCE = np.pi ** 2 / 3
_SIGMA_MAX = 20.0


# --------------------------------------------------------------------------- shared by the ML fits
#: Columns of the ML mixed models' tables (:func:`fit_glmm`, :func:`analysis.glmm_slope.fit_glmm_slope`).
ML_COLUMNS = ["term", "log_odds", "se", "statistic", "p_value", "ci_low", "ci_high", "interval",
              "test"]


def ml_wald(theta, hess, p: int, res):
    """The ML fits' Wald step on the deviance's Hessian ``hess`` (deviance = -2 log L).

    Returns ``(cov_full, beta, cov, se, why)``: the covariance 2 H^-1 of every parameter (NaN
    when H is singular), the ``p`` fixed effects ``theta[:p]``, their covariance and SEs, and
    why the fit is rejected (None when accepted; see :func:`analysis.models.accept_candidate`).
    """
    try:
        cov_full = 2.0 * np.linalg.inv(hess)
    except np.linalg.LinAlgError:
        cov_full = np.full(np.shape(hess), np.nan)
    beta, cov = theta[:p], cov_full[:p, :p]
    se = np.sqrt(np.diag(cov))
    why = None if res.success else f"did not converge ({res.message})"
    return cov_full, beta, cov, se, why or fit_trouble(beta, se)


def wald_table(terms, beta, se, df, q) -> pd.DataFrame:
    """Fixed effects with Wald ratios, p-values and intervals against t(``df``) (``q`` its
    two-sided quantile; normal without ``df``)."""
    return pd.DataFrame({"term": terms, "log_odds": beta, "se": se, "statistic": beta / se,
                         "p_value": reference_p(beta / se, df),
                         "ci_low": beta - q * se, "ci_high": beta + q * se,
                         "interval": f"Wald, t({df:g})" if df else "Wald",
                         "test": f"Wald t({df:g})" if df else "Wald z (normal)"})


def profile_cut(level: float, df) -> float:
    """A profile interval's deviance cut-off: F(1, df)(level), chi2_1(level) without ``df``."""
    return stats.f.ppf(level, 1, df) if df else stats.chi2.ppf(level, 1)


def profile_upper(excess, value_hat: float, hi_try: float, bound: float) -> float:
    """A profile interval's upper end: ``hi_try`` doubled (up to ``bound``) until the deviance
    ``excess`` over the cut-off is positive, then Brent's root; inf if it never rises so far."""
    while excess(hi_try) < 0 and hi_try < bound:
        hi_try = min(2 * hi_try, bound)
    return optimize.brentq(excess, value_hat, hi_try, xtol=2e-5, rtol=1e-6) \
        if excess(hi_try) > 0 else np.inf


@dataclass
class GLMMData:
    """Binomial counts per participant and distinct design row.

    Attributes
    ----------
    x : ndarray, shape (rows, p)
    k, n : ndarray, shape (rows,)
        Correct answers and trials.
    person : ndarray of int, shape (rows,)
        Participant index 0..m-1.
    m : int
        Participants.
    """

    x: np.ndarray
    k: np.ndarray
    n: np.ndarray
    person: np.ndarray
    m: int

    @property
    def onehot(self) -> np.ndarray:
        """(m, rows) indicator of each row's participant: sums rows per participant fast."""
        cached = self.__dict__.get("_onehot")
        if cached is None:
            cached = np.zeros((self.m, len(self.person)))
            cached[self.person, np.arange(len(self.person))] = 1.0
            self.__dict__["_onehot"] = cached
        return cached

    @classmethod
    def from_trials(cls, y, x, participant) -> "GLMMData":
        """Aggregate Bernoulli trials (``y`` 0/1, design ``x``) into counts per participant/row."""
        x = np.asarray(x, float)
        codes, people = pd.factorize(pd.Series(participant).astype(str), sort=True)
        frame = pd.DataFrame(x)
        key = pd.factorize(pd.Series(list(zip(codes, *[frame[c] for c in frame.columns]))))[0]
        order = np.unique(key, return_index=True)[1]
        k = np.bincount(key, weights=np.asarray(y, float))
        n = np.bincount(key).astype(float)
        return cls(x[order], k, n, codes[order], len(people))


def logsumexp_rows(a: np.ndarray) -> np.ndarray:
    """``scipy.special.logsumexp(a, axis=1, keepdims=True)`` of a 2-D array, the same bits.

    The same arithmetic as SciPy's (1.17) for finite rows: the row maximum taken out, the other
    terms' ``exp`` summed, ``log1p`` of that sum over the count of tied maxima, plus
    ``log(count)`` and the maximum; without its array-API bookkeeping, which cost more than the
    sums in the mixed models' quadrature (called ~1,500 times per fit). A row whose result is
    not finite goes to SciPy itself.
    """
    a_max = a.max(axis=1, keepdims=True)
    tied = a == a_max
    count = tied.sum(axis=1, keepdims=True, dtype=a.dtype)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.exp(np.where(tied, -np.inf, a) - a_max).sum(axis=1, keepdims=True)
        s = np.where(s == 0, s, s / count)
        out = np.log1p(s) + np.log(count) + a_max
    if not np.all(np.isfinite(out)):
        return special.logsumexp(a, axis=1, keepdims=True)
    return out


@functools.lru_cache(maxsize=8)
def _hermgauss(n_agq: int):
    """Gauss-Hermite nodes and weights (read-only; computed once per node count)."""
    z, w = np.polynomial.hermite.hermgauss(n_agq)
    z.flags.writeable = w.flags.writeable = False
    return z, w


def _inner(data: GLMMData, eta0, sigma, n_agq):
    """Per participant: log integral, and quadrature nodes/weights (posterior over b).

    Newton's method for each participant's mode starts from the previous evaluation's modes on
    ``data`` (the integrand is log-concave: one mode, reached from anywhere; the warm start
    saves iterations), and from 0 again if that does not settle.
    """
    m = data.m
    warm = data.__dict__.get("_modes")
    for b in ([warm.copy()] if warm is not None and np.all(np.isfinite(warm)) else []) \
            + [np.zeros(m)]:
        for _ in range(50):
            eta = eta0 + sigma * b[data.person]
            p = special.expit(eta)
            g = sigma * np.bincount(data.person, data.k - data.n * p, m) - b
            h = sigma ** 2 * np.bincount(data.person, data.n * p * (1 - p), m) + 1.0
            step = g / h
            b += step
            if np.max(np.abs(step)) < 1e-10:
                break
        else:
            continue
        break
    data.__dict__["_modes"] = b.copy()
    eta = eta0 + sigma * b[data.person]
    p = special.expit(eta)
    h = sigma ** 2 * np.bincount(data.person, data.n * p * (1 - p), m) + 1.0
    s = 1.0 / np.sqrt(h)
    z, w = _hermgauss(n_agq)
    nodes = b[:, None] + np.sqrt(2.0) * s[:, None] * z[None, :]          # (m, q)
    eta_q = eta0[:, None] + sigma * nodes[data.person]                    # (rows, q)
    ll_rows = data.k[:, None] * eta_q - data.n[:, None] * np.logaddexp(0.0, eta_q)
    ll = data.onehot @ ll_rows
    log_terms = ll - nodes ** 2 / 2 + z[None, :] ** 2 + np.log(w)[None, :]
    norm = logsumexp_rows(log_terms)
    log_int = norm[:, 0] + np.log(np.sqrt(2.0) * s) - 0.5 * np.log(2 * np.pi)
    post = np.exp(log_terms - norm)
    return log_int, nodes, eta_q, post


def glmm_deviance(theta, data: GLMMData, n_agq: int = 11, grad: bool = False):
    """-2 × marginal log-likelihood at ``theta = (beta..., sigma)`` (and its gradient).

    Parameters
    ----------
    theta : array_like
        Fixed effects then the random-intercept SD.
    data : GLMMData
    n_agq : int
        Quadrature nodes per participant (1: Laplace).
    grad : bool
        Also return the gradient (the quadrature's posterior expectations of the
        complete-data score, nodes held at their adaptive positions).

    Returns
    -------
    float or (float, ndarray)
    """
    theta = np.asarray(theta, float)
    beta, sigma = theta[:-1], abs(float(theta[-1]))
    eta0 = data.x @ beta
    log_int, nodes, eta_q, post = _inner(data, eta0, sigma, n_agq)
    dev = -2.0 * float(log_int.sum())
    if not grad:
        return dev
    resid = data.k[:, None] - data.n[:, None] * special.expit(eta_q)     # (rows, q)
    wr = post[data.person] * resid                                        # posterior-weighted
    g_beta = data.x.T @ wr.sum(axis=1)
    g_sigma = float(np.sum(wr * nodes[data.person]))
    return dev, -2.0 * np.append(g_beta, g_sigma)


def fd_gradient(fun, t):
    """Central-difference gradient of a scalar function (the Laplace case, see _objective)."""
    g = np.empty(len(t))
    for i in range(len(t)):
        h = 1e-6 * max(1.0, abs(t[i]))
        up, down = t.copy(), t.copy()
        up[i] += h
        down[i] -= h
        g[i] = (fun(up) - fun(down)) / (2 * h)
    return g


def _objective(data, n_agq, fixed_sigma=None, exact=False):
    """Deviance and gradient over (beta, sigma), or over beta with sigma fixed.

    With few nodes (``n_agq < 7``, e.g. Laplace) the quadrature's posterior-expectation
    gradient ignores how the adaptive nodes move and L-BFGS-B's line search fails; the
    gradient is then taken by central differences (``exact=True`` forces that too).
    """
    fd = exact or n_agq < 7

    def full(t):
        if fixed_sigma is not None:
            t = np.append(t, fixed_sigma)
        return t

    def fun(t):
        if fd:
            dev = lambda u: glmm_deviance(full(u), data, n_agq)
            return dev(t), fd_gradient(dev, np.asarray(t, float))
        d, g = glmm_deviance(full(t), data, n_agq, grad=True)
        return d, (g if fixed_sigma is None else g[:-1])
    return fun


def _minimise(data, start, n_agq, fixed_sigma=None):
    # profile points (fixed sigma) need the deviance to ~1e-6, not the estimates to 1e-7
    options = {"maxiter": 500, "ftol": 1e-13, "gtol": 1e-7} if fixed_sigma is None else \
        {"maxiter": 500, "ftol": 1e-11, "gtol": 1e-5}
    bounds = None if fixed_sigma is not None else \
        [(None, None)] * (len(start) - 1) + [(0.0, _SIGMA_MAX)]
    res = optimize.minimize(_objective(data, n_agq, fixed_sigma), start, jac=True,
                            method="L-BFGS-B", bounds=bounds, options=options)
    if not res.success:      # polish with central-difference gradients from where it stopped
        first = res
        res = optimize.minimize(_objective(data, n_agq, fixed_sigma, exact=True), res.x, jac=True,
                                method="L-BFGS-B", bounds=bounds, options=options)
        res.nit += first.nit
        res.nfev += first.nfev
    return res


def _hessian(theta, data, n_agq):
    """Central differences of the gradient, symmetrised (deviance scale)."""
    if n_agq < 7:       # second differences of the deviance itself (see _objective)
        return _hessian_fd(theta, data, n_agq)
    return fd_hessian(lambda t: glmm_deviance(t, data, n_agq, True)[1], theta, sd_last=True)


def fd_hessian(grad, theta, *, sd_last: bool = False):
    """Central differences of ``grad`` (steps 1e-4 max(1, |theta_i|)), symmetrised.

    ``sd_last``: the last parameter is an SD (>= 0): where its step would cross 0 the difference
    is one-sided. Shared by :func:`fit_glmm` and :func:`analysis.glmm_slope.fit_glmm_slope`.
    """
    p = len(theta)
    hess = np.empty((p, p))
    for i in range(p):
        step = 1e-4 * max(1.0, abs(theta[i]))
        up, down = theta.copy(), theta.copy()
        up[i] += step
        down[i] -= step
        if sd_last and i == p - 1 and down[i] < 0:        # sigma at the boundary: one-sided
            down[i] = theta[i]
            hess[i] = (grad(up) - grad(down)) / step
            continue
        hess[i] = (grad(up) - grad(down)) / (2 * step)
    return (hess + hess.T) / 2


def _hessian_fd(theta, data, n_agq):
    p = len(theta)
    f = lambda t: glmm_deviance(t, data, n_agq)
    h = np.array([1e-4 * max(1.0, abs(v)) for v in theta])
    if theta[-1] < h[-1]:
        theta = theta.copy()
        theta[-1] = h[-1]           # sigma at the boundary: difference just inside
    hess = np.empty((p, p))
    f0 = f(theta)
    for i in range(p):
        for j in range(i, p):
            ei, ej = np.zeros(p), np.zeros(p)
            ei[i], ej[j] = h[i], h[j]
            if i == j:
                hess[i, i] = (f(theta + ei) - 2 * f0 + f(theta - ei)) / h[i] ** 2
            else:
                hess[i, j] = hess[j, i] = (f(theta + ei + ej) - f(theta + ei - ej)
                                           - f(theta - ei + ej) + f(theta - ei - ej)) / (4 * h[i] * h[j])
    return hess


def _profile_sigma(data, theta, dev_min, n_agq, level, se_sigma=np.nan, df=None):
    """Profile-likelihood interval of sigma: where the deviance has risen by the cut-off.

    The cut-off is chi2_1(level), or with ``df`` its small-sample analogue F(1, df)(level)
    (the square of the t(df) quantile the Wald intervals use).

    Each profile point re-maximises over the fixed effects (warm-started from the nearest
    point already computed); the ends are found by Brent's method, bracketed first by the
    Wald interval on log sigma.
    """
    cut = profile_cut(level, df)
    sigma_hat, beta_hat = float(theta[-1]), theta[:-1]
    done: dict = {}

    def excess(s):
        s = float(s)
        if s not in done:
            near = min(done, key=lambda v: abs(v - s)) if done else None
            start = done[near][1] if near is not None else beta_hat
            res = _minimise(data, start, n_agq, fixed_sigma=s)
            done[s] = (res.fun - dev_min - cut, res.x)
        return done[s][0]

    z = stats.norm.ppf(0.5 + level / 2)
    spread = np.exp(z * se_sigma / sigma_hat) if sigma_hat > 1e-6 and np.isfinite(se_sigma) \
        else 2.0
    spread = min(max(spread, 1.2), 10.0)
    if sigma_hat <= 1e-6 or excess(0.0) <= 0:
        low = 0.0
    else:
        lo_try = sigma_hat / spread
        while excess(lo_try) < 0 and lo_try > 1e-3:
            lo_try /= 2
        low = 0.0 if excess(lo_try) < 0 else \
            optimize.brentq(excess, lo_try, sigma_hat, xtol=2e-5, rtol=1e-6)
    high = profile_upper(excess, sigma_hat, max(sigma_hat * spread, 0.3), _SIGMA_MAX)
    return low, high


def fit_glmm(trials: pd.DataFrame, formula: str = FORMULA, *, level: float = 0.95,
             n_agq: int = 11, profile: bool = True, sd_cutoff: str = "F") -> ModelFit:
    """Maximum-likelihood mixed logit with a random intercept per participant.

    Parameters
    ----------
    trials : pandas.DataFrame
        Analysable trials.
    formula : str
        Fixed-effects formula; on separation or non-convergence the same simpler
        formulas as :func:`analysis.fit_gee` are tried.
    level : float
        Confidence level, 0–1.
    n_agq : int
        Adaptive Gauss-Hermite nodes (1 = Laplace).
    profile : bool
        Profile-likelihood interval for the participant SD (else Wald on log SD).
    sd_cutoff : {"F", "chi2"}
        The profile interval's cut-off: ``"F"`` (default) F(1, m - 2) at ``level``, m
        participants, the small-sample analogue of ``"chi2"``, chi2_1 (lme4's
        ``confint(method = "profile")``). Measured coverage over 200 datasets of 30
        participants per scenario: chi2 0.92 and 0.96, F 0.93 and 0.965 (docs/analysis.md).

    Returns
    -------
    ModelFit
        ``kind`` ``"glmm"``; ``table``: ``term, log_odds, se, z, p_value, ci_low,
        ci_high, interval`` (fixed effects: Wald; then ``participant_sd`` with
        its profile interval and ``icc_latent``); ``params``/``cov`` are the
        fixed effects and their covariance; ``convergence`` (in
        ``result``) holds the optimiser's status, iterations, function
        evaluations, final gradient norm, deviance, log-likelihood, sigma and ICC.
    """
    # one BLAS thread: L-BFGS-B's small BLAS calls spin threads, 10x slower on a busy machine
    with threadpool_limits(1):
        return _fit_glmm_impl(trials, formula, level=level, n_agq=n_agq, profile=profile,
                              sd_cutoff=sd_cutoff)


def _fit_glmm_impl(trials: pd.DataFrame, formula: str = FORMULA, *, level: float = 0.95,
                   n_agq: int = 11, profile: bool = True, sd_cutoff: str = "F") -> ModelFit:
    """See the public function."""

    data_t = model_data(trials)
    notes: list = []
    z = stats.norm.ppf(0.5 + level / 2)          # log-SD Wald interval (profile=False)
    df = reference_df(data_t)
    zt = reference_quantile(level, df)           # fixed effects: t(participants - 2)
    columns = ML_COLUMNS
    for candidate in candidate_formulas(data_t, formula, notes, "GLMM"):
        if refuse_separated("GLMM", candidate, data_t, notes):
            continue
        y, x = design_matrices(candidate, data_t)
        data = GLMMData.from_trials(y, x.to_numpy(), data_t["participant"])
        p = x.shape[1]
        start = np.zeros(p + 1)
        ybar = np.clip(y.mean(), 0.02, 0.98)
        start[list(x.columns).index("Intercept") if "Intercept" in x.columns else 0] = \
            np.log(ybar / (1 - ybar))
        start[-1] = 0.5
        with np.errstate(all="ignore"):
            res = _minimise(data, start, n_agq)
            theta = res.x.copy()
            hess = _hessian(theta, data, n_agq)
        cov_full, beta, cov, se, why = ml_wald(theta, hess, p, res)
        if not accept_candidate("GLMM", candidate, formula, why, notes):
            continue
        sigma = float(theta[-1])
        if profile:
            with np.errstate(all="ignore"):
                cut_df = df if sd_cutoff == "F" else None
                low, high = _profile_sigma(data, theta, res.fun, n_agq, level,
                                           np.sqrt(cov_full[-1, -1]), cut_df)
            how = ("profile likelihood, F(1, %g) cut-off" % cut_df if cut_df
                   else "profile likelihood, chi2(1) cut-off")
        else:
            sd_log = np.sqrt(cov_full[-1, -1]) / max(sigma, 1e-12)
            low, high = sigma * np.exp(-z * sd_log), sigma * np.exp(z * sd_log)
            how = "Wald on log SD"
        table = wald_table(x.columns, beta, se, df, zt)
        icc = lambda s: s ** 2 / (s ** 2 + ICC_LATENT_VARIANCE)
        table.loc[len(table)] = ["participant_sd", sigma, np.sqrt(cov_full[-1, -1]), np.nan,
                                 np.nan, low, high, how, ""]
        table.loc[len(table)] = ["icc_latent", icc(sigma), np.nan, np.nan, np.nan, icc(low),
                                 icc(high), how + " (of participant_sd)", ""]
        grad = glmm_deviance(theta, data, n_agq, grad=True)[1]
        convergence = {"method": f"ML, adaptive Gauss-Hermite ({n_agq} nodes), scipy L-BFGS-B",
                       "optimiser_success": bool(res.success), "optimiser_status": int(res.status),
                       "optimiser_message": str(res.message), "iterations": int(res.nit),
                       "function_evaluations": int(res.nfev),
                       "max_abs_gradient": float(np.max(np.abs(grad))),
                       "deviance": float(res.fun), "log_likelihood": float(-res.fun / 2),
                       "participant_sd": sigma, "icc_latent": icc(sigma),
                       "n_participants": int(data.m), "n_trials": int(data.n.sum()),
                       "hessian_positive_definite": bool(np.all(np.linalg.eigvalsh(hess) > 0))}
        return ModelFit(kind="glmm", formula=candidate, requested=formula, table=table[columns],
                        notes=notes, params=beta, cov=cov, design_info=x.design_info, df=df,
                        convergence=convergence, theta=theta, cov_full=cov_full)
    notes.append("GLMM: no formula could be fitted")
    warnings.warn("; ".join(notes), ModelWarning, stacklevel=2)
    return ModelFit(kind="glmm", formula=None, requested=formula,
                    table=pd.DataFrame(columns=columns), notes=notes)
