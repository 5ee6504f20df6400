"""Uncertainty of a calibration fit: profile likelihood or parametric bootstrap intervals.

Profile likelihood (the default): for each parameter θ_j the profile SSR_j(v) is the least
residual sum of squares with θ_j held at v.  The interval is where

    SSR_j(v) - SSR_min  ≤  σ̂² · F_{1, n-p}(level),   σ̂² = SSR_min / (n - p),

(the likelihood-ratio interval with the noise variance estimated; exact for a linear model).
A profile that stays below that threshold up to a parameter bound is *flat*: the data do
not determine the parameter, and the fit is refused.  Per-trace initial skin temperatures are
nuisance parameters: they get Wald intervals (x̂ ± z·se) instead of profiles, which halves the
cost; their identifiability is still checked (Jacobian rank and condition, bounds).

Parametric bootstrap: refit B synthetic data sets (fitted model + white noise of SD σ̂) and
take percentile intervals; refused if more than 10 % of the refits end at a bound.
"""
from __future__ import annotations

import copy
import math

import numpy as np
from scipy.optimize import brentq
from scipy.stats import f as f_dist
from scipy.stats import norm

__all__ = ["profile_intervals", "bootstrap_intervals", "profile_curve"]


def _natural(problem, j, v):
    return v if problem.kinds[j] == "skin_temperature" else math.exp(v)


def profile_curve(problem, x_hat, j: int, values):
    """SSR with coordinate ``j`` held at each of ``values`` (the others re-optimised)."""
    out, warm = [], np.array(x_hat, dtype=float)
    for v in values:
        res = problem.solve(warm, fixed={j: float(v)})
        warm = res.x
        out.append(2.0 * res.cost)
    return np.array(out)


def profile_intervals(problem, x_hat, ssr_min: float, se, level: float = 0.95, which=None):
    """Profile-likelihood intervals of every parameter.

    Parameters
    ----------
    problem : FitProblem
    x_hat : ndarray
        Optimum (fit coordinates).
    ssr_min : float, °C²
        Residual sum of squares at the optimum.
    se : ndarray
        Wald standard errors in fit coordinates (used only to choose the first steps).
    level : float
    which : sequence of int, optional
        Coordinates to profile (default all); the others get Wald intervals
        (``x̂ ± z·se`` in fit coordinates).

    Returns
    -------
    lows, highs : ndarray
        Interval ends in natural units (m² K/W, m, °C).
    flat : list of str
        One reason per profile that does not close within the bounds (empty if all close).
    """
    dof = problem.n_obs - problem.n_params
    crit = ssr_min / dof * float(f_dist.ppf(level, 1, dof))
    lows = np.full(problem.n_params, np.nan)
    highs = np.full(problem.n_params, np.nan)
    flat = []
    which = range(problem.n_params) if which is None else list(which)
    z = float(norm.ppf(0.5 + level / 2))
    for j in range(problem.n_params):
        if j not in which:
            lo, hi = x_hat[j] - z * se[j], x_hat[j] + z * se[j]
            lows[j], highs[j] = _natural(problem, j, lo), _natural(problem, j, hi)
    for j, name in enumerate(problem.names):
        if j not in which:
            continue
        warm = {"x": np.array(x_hat, dtype=float)}

        def excess(v):
            res = problem.solve(warm["x"], fixed={j: float(v)})
            warm["x"] = res.x
            return 2.0 * res.cost - ssr_min - crit

        for direction, bound, store in ((+1, problem.upper[j], highs), (-1, problem.lower[j], lows)):
            warm["x"] = np.array(x_hat, dtype=float)
            inside = x_hat[j]
            step = max(2.0 * float(se[j]), 1e-3)
            found = None
            for _ in range(40):
                v = x_hat[j] + direction * step
                at_bound = (v - bound) * direction >= 0
                if at_bound:
                    v = bound
                if excess(v) > 0:
                    found = v
                    break
                if at_bound:
                    break
                inside = v
                step *= 2.0
            if found is None:
                lo_b, hi_b = sorted((_natural(problem, j, problem.lower[j]),
                                     _natural(problem, j, problem.upper[j])))
                side = "upper" if direction > 0 else "lower"
                flat.append(f"the profile likelihood of {name} is flat towards its {side} bound "
                            f"(it does not rise by the {level:.0%} threshold within [{lo_b:.3g}, "
                            f"{hi_b:.3g}]): {name} is not identifiable from these traces")
                continue
            warm["x"] = np.array(x_hat, dtype=float)
            a, b = sorted((inside, found))
            root = brentq(excess, a, b, xtol=1e-4, rtol=1e-6, maxiter=50)
            store[j] = _natural(problem, j, root)
    return lows, highs, flat


def bootstrap_intervals(problem, x_hat, sigma: float, level: float = 0.95, samples: int = 200,
                        seed: int = 0):
    """Parametric-bootstrap percentile intervals (see the module docstring).

    Returns
    -------
    lows, highs : ndarray
        Natural units.
    flat : list of str
        Reasons to refuse (too many refits at a bound or failing).
    """
    rng = np.random.default_rng(seed)
    mean = problem.predict(x_hat)
    boot = copy.copy(problem)
    draws, bad = [], 0
    for _ in range(int(samples)):
        boot.y = mean + sigma * rng.standard_normal(mean.size)
        res = boot.solve(x_hat)
        x = res.x
        if res.status <= 0 or np.any(x - problem.lower < 1e-3) or np.any(problem.upper - x < 1e-3):
            bad += 1
        draws.append(problem.to_natural(x))
    draws = np.array(draws)
    a = (1.0 - level) / 2.0
    lows = np.quantile(draws, a, axis=0)
    highs = np.quantile(draws, 1.0 - a, axis=0)
    flat = []
    if bad > 0.1 * samples:
        flat.append(f"{bad} of {samples} bootstrap refits failed or ended at a bound: the parameters "
                    f"are not identifiable from these traces")
    return lows, highs, flat
