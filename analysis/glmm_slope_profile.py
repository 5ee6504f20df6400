"""Profile-likelihood intervals of the random-slope model's two SDs and their correlation
(:mod:`analysis.glmm_slope`), as six separate ends.

Each end (:func:`profile_end`) re-minimises the deviance over every other parameter, in the
parametrisation ``Lambda = [[s0, 0], [s1 sin phi, s1 cos phi]]``, until it has risen by the
F(1, m - 2) cut-off. Each starts from the fit's conditional modes, so the ends are the same
numbers in any order and in any process: ``analyze``'s forked worker takes them from the front
(:data:`SHARE_ORDER`) and the analysis, once its own tables are done, takes back those not yet
handed over (:func:`complete_profiles`).

At a singular fit (correlation estimated at +-1, or an SD at 0) the profile over an SD can have
more than one minimum. A warm start from a degenerate point stays there (the correlation's
bound, or an SD of 0 where the correlation has no effect, is a local minimum), while a minimum
with the correlation inside (-1, 1) can be lower. Missing it makes the deviance look higher than
it is and the interval too narrow: on 40 generated 15 + 15 studies without a slope (24 with the
correlation at +-1) 37 SD ends were off, upper ends up to 37 % too low, lower ends up to 18 %
too high (``benchmarks/bench_profile_boundary.py``). :func:`profile_end`'s ``off_boundary`` looks there too.
"""
from __future__ import annotations

import numpy as np
import pandas as pd
from scipy import optimize
from threadpoolctl import threadpool_limits

from .glmm import fd_gradient, profile_cut, profile_upper
from .glmm_slope_deviance import SD_BOUND, last_modes, slope_deviance
from .models import ModelFit

__all__ = ["complete_profiles", "is_singular", "lowest_deviance", "point_bounds", "profile_end",
           "profile_intervals", "PROFILE_ENDS", "RESTARTS", "SHARE_ORDER"]


def _sd_params(t):
    """lme4's theta ``(l11, l21, l22)`` -> ``(sd_intercept, sd_slope, phi)``, corr = sin(phi)."""
    return np.array([abs(t[0]), np.hypot(t[1], t[2]), np.arctan2(t[1], max(t[2], 0.0))])


def _sd_objective(data, z, n_agq, p, fixed_index, fixed_value):
    """Deviance and gradient over ``(beta, sd0, sd1, phi)`` with one of the last three fixed.

    ``Lambda = [[sd0, 0], [sd1 sin phi, sd1 cos phi]]``: the correlation is ``sin phi``, smooth
    up to +-1 (a profile over the correlation needs no Fisher transform that blows up there).
    """
    def full(u):
        return np.insert(np.asarray(u, float), p + fixed_index, fixed_value)

    def theta_of(u):
        v = full(u)
        s0, s1, phi = v[p:]
        return np.append(v[:p], [s0, s1 * np.sin(phi), s1 * np.cos(phi)])

    if n_agq < 5:           # the posterior-expectation gradient is not accurate: differences
        def fun_fd(u):
            dev = lambda w: slope_deviance(theta_of(w), data, z, n_agq)
            return dev(u), fd_gradient(dev, np.asarray(u, float))
        return fun_fd

    def fun(u):
        v = full(u)
        s0, s1, phi = v[p:]
        dev, g = slope_deviance(theta_of(u), data, z, n_agq, grad=True)
        gt = g[p:]
        jac = np.array([[1.0, 0.0, 0.0],
                        [0.0, np.sin(phi), np.cos(phi)],
                        [0.0, s1 * np.cos(phi), -s1 * np.sin(phi)]])
        gv = np.append(g[:p], jac @ gt)
        return dev, np.delete(gv, p + fixed_index)
    return fun


#: When a profile point is optimised a second time, from the estimate, after its warm start
#: (from the nearest point already computed) lands above the cut-off: ``"far-side"`` only when
#: that nearest point was itself above the cut-off, outside the interval (a warm start from
#: there can stop in a worse local minimum, which would make the interval too narrow; from a
#: point inside it the warm start is lme4's own walk outward from the estimate); ``"always"``
#: every time (the rule before 2026-11-29: twice the optimisations of an SD's upper end).
#: ``benchmarks/bench_profile_restart.py`` compares the two on generated studies.
RESTARTS = ("far-side", "always")


class _BackOnTheBound(Exception):
    """A start off a degenerate covariance went back onto one (:func:`_leave_degenerate`)."""


def is_singular(theta, tol: float = 1e-4) -> bool:
    """Whether a random-slope fit is singular, as lme4's ``isSingular``: a diagonal element of
    the covariance's Cholesky factor (``theta = (beta..., l11, l21, l22)``) below ``tol`` (an
    SD at 0, or the correlation at +-1)."""
    return bool(min(abs(theta[-3]), abs(theta[-1])) < tol)


def point_bounds(p: int, which: int) -> list:
    """L-BFGS-B's bounds of a profile point ``(beta..., the other SD, phi)``: ``p`` fixed effects
    free, the SDs in [0, SD_BOUND], phi in [-pi/2, pi/2], the profiled parameter ``which``
    (0, 1, 2: ``sd_intercept``, ``sd_mode_slope``, phi) left out."""
    bounds = [(None, None)] * p + [(0.0, SD_BOUND), (0.0, SD_BOUND), (-np.pi / 2, np.pi / 2)]
    del bounds[p + which]
    return bounds


def lowest_deviance(data, z, theta, n_agq, modes, which: int, value: float,
                    correlations=(-0.997, -0.68, 0.0, 0.68, 0.997)) -> float:
    """The deviance at ``value`` of parameter ``which``, minimised from the estimate with the
    correlation started at each of ``correlations`` (the conditional modes from ``modes`` each
    time), the lowest kept: a many-start reference for :func:`profile_end`'s search (its tests
    and ``benchmarks/bench_profile_boundary.py``), several times its cost."""
    p = len(theta) - 3
    hat = np.append(theta[:p], _sd_params(theta[-3:]))
    bounds = point_bounds(p, which)
    best = np.inf
    for corr in correlations:
        start = hat.copy()
        start[-1] = np.arcsin(corr)
        data.__dict__["_slope_modes"] = np.array(modes, float)
        res = _minimise(_sd_objective(data, z, n_agq, p, which, float(value)),
                        np.delete(start, p + which), bounds)
        best = min(best, res.fun)
    return best


def _minimise(objective, start, bounds):
    return optimize.minimize(objective, start, jac=True, method="L-BFGS-B", bounds=bounds,
                             options={"maxiter": 500, "ftol": 1e-11, "gtol": 1e-5})


def _degenerate(x) -> bool:
    """Whether a profile point ``x = (beta..., the other SD, phi)`` has the correlation at +-1
    or the other SD at 0 (where the correlation does nothing)."""
    return _at_one(x[-1]) or x[-2] < 1e-6


def _at_one(phi) -> bool:
    """Whether the correlation ``sin(phi)`` is +-1 to 1e-6 (an optimiser stops short of the
    bound of ``phi``, within ~1e-3: the correlation is flat in ``phi`` there)."""
    return 1.0 - abs(np.sin(phi)) < 1e-6


def _leave_degenerate(objective, stuck, other_sd_hat: float, bounds):
    """``stuck`` (an optimisation that stopped at a degenerate covariance) optimised again with
    the correlation started at 0 and the other SD at no less than its estimate (or 1e-3); None
    once it steps back onto the correlation's bound within 0.01 of ``stuck``'s deviance: on its
    way back to that minimum, not worth finishing (~20 evaluations instead of 40-80)."""
    def watched(u):
        out = objective(u)
        if abs(out[0] - stuck.fun) < 1e-2 and _at_one(u[-1]):
            raise _BackOnTheBound
        return out
    start = np.append(stuck.x[:-2], [max(stuck.x[-2], other_sd_hat, 1e-3), 0.0])
    try:
        return _minimise(watched, start, bounds)
    except _BackOnTheBound:
        return None


def profile_end(data, z, theta, dev_min, n_agq, level, df, which, side, modes=None,
                restart: str = "far-side", off_boundary: bool = True) -> float:
    """One end of the profile-likelihood interval of ``sd_intercept`` (``which`` 0),
    ``sd_mode_slope`` (1) or the correlation (2), as :func:`analysis.glmm._profile_sigma`: the
    lower (``side`` 0) or upper (1) value where the deviance, re-minimised over every other
    parameter, has risen by F(1, df)(level) (chi2_1 without ``df``). An SD's lower end is 0,
    and a correlation's end is -1 or 1, when the profile never rises that far.

    Each end is computed on its own: the conditional modes start from ``modes`` (the fit's,
    :func:`profile_intervals`) and the optimisations from the estimate or from this end's own
    earlier profile points, so the six ends are the same numbers in any order, in any process
    (:func:`complete_profiles` shares them between the analysis's worker and its caller).
    ``restart``: when a point is optimised again from the estimate (:data:`RESTARTS`).
    ``off_boundary``: at a singular fit (lme4's ``isSingular``, to 1e-4), an SD's point that
    lands above the cut-off at a degenerate covariance is optimised again with the correlation
    started at 0 (:func:`_leave_degenerate`; why: the module's docstring), the lower deviance
    kept (False: the rule before 2026-11-29, for ``benchmarks/bench_profile_boundary.py``).
    """
    if restart not in RESTARTS:
        raise ValueError(f"restart: expected one of {RESTARTS}, got {restart!r}")
    data.__dict__["_slope_modes"] = None if modes is None else np.array(modes, float)
    cut = profile_cut(level, df)
    p = len(theta) - 3
    hat = np.append(theta[:p], _sd_params(theta[-3:]))
    value_hat = hat[p + which]
    bounds = point_bounds(p, which)
    start_hat = np.delete(hat, p + which)
    done: dict = {float(value_hat): (-cut, start_hat)}
    singular = is_singular(theta)

    def excess(v):
        v = float(v)
        if v not in done:
            near = min(done, key=lambda w: abs(w - v))
            # warm start from the nearest point; if that lands above the cut-off, also from the
            # estimate (:data:`RESTARTS`: a warm start from the far side can stop in a worse
            # local minimum)
            inside = done[near][0] < 0 if restart == "far-side" else near == value_hat
            objective = _sd_objective(data, z, n_agq, p, which, v)
            best = None
            for start in (done[near][1], start_hat):
                res = _minimise(objective, start, bounds)
                if best is None or res.fun < best.fun:
                    best = res
                if best.fun - dev_min < cut or inside:
                    break
            if (off_boundary and singular and which != 2 and best.fun - dev_min >= cut
                    and _degenerate(best.x)):
                # a local minimum that a warm start from it never leaves (``off_boundary``)
                res = _leave_degenerate(objective, best, start_hat[-2], bounds)
                if res is not None and res.fun < best.fun:
                    best = res
            done[v] = (best.fun - dev_min - cut, best.x)
        return done[v][0]

    def zeta(v):
        # the signed root of the deviance's rise, less the cut-off's: the same sign and root as
        # ``excess`` but nearly linear in ``v`` (lme4's profile zeta), so Brent's method needs
        # fewer profile points (each an optimisation over every other parameter)
        return np.sqrt(max(excess(v) + cut, 0.0)) - np.sqrt(cut)

    with threadpool_limits(1), np.errstate(all="ignore"):
        if which == 2:                      # phi: corr = sin(phi) in [-1, 1]
            edge = (-np.pi / 2, np.pi / 2)[side]
            if excess(edge) <= 0:
                return float(np.sin(edge))
            a, b = sorted((value_hat, edge))
            return float(np.sin(optimize.brentq(zeta, a, b, xtol=1e-4)))
        if side == 0:
            if value_hat <= 1e-6 or excess(0.0) <= 0:
                return 0.0
            return optimize.brentq(zeta, 0.0, value_hat, xtol=2e-5, rtol=1e-6)
        return profile_upper(zeta, value_hat, max(2 * value_hat, 0.5), SD_BOUND)


PROFILED_TERMS = ("sd_intercept", "sd_mode_slope", "corr_intercept_slope")
#: The six ends :func:`profile_end` computes, ``(which, side)``, in the order of the table.
PROFILE_ENDS = tuple((which, side) for which in range(3) for side in (0, 1))
#: The order the ends are given to a worker (indices into :data:`PROFILE_ENDS`). An SD's upper
#: end (doubling, then Brent's method, far from the estimate) takes most of the time: 258 and
#: 233 of the six ends' 650 deviance evaluations on a 30-participant study (0.3-0.5 s of CPU
#: each), the lower ends 44 and 53, the correlation's 62. The worker takes them from the front;
#: :func:`complete_profiles` takes back from the end those the worker has not begun
#: (:class:`analysis.worker.Claims`), so one long end goes first and the other last.
SHARE_ORDER = (1, 0, 2, 4, 5, 3)


def profile_intervals(data, z, theta, dev_min, n_agq, level, cut_df, modes=None) -> list:
    """The three profile intervals, ``[(low, high)] * 3`` in the order of ``sd_intercept``,
    ``sd_mode_slope``, ``corr_intercept_slope``: the six :func:`profile_end` calls in turn,
    each from ``modes`` (default: the last modes on ``data``, the fit's)."""
    modes = profile_modes(data) if modes is None else modes
    ends = [profile_end(data, z, theta, dev_min, n_agq, level, cut_df, which, side, modes)
            for which, side in PROFILE_ENDS]
    return _as_intervals(ends)


def _as_intervals(ends: list) -> list:
    """The six ends in the order of :data:`PROFILE_ENDS` as ``[(low, high)] * 3``."""
    return [(ends[i], ends[i + 1]) for i in range(0, len(ends), 2)]


def profile_modes(data):
    """A copy of the last conditional modes on ``data`` (after a fit: the fit's), or None."""
    modes = last_modes(data)
    return None if modes is None else np.array(modes, float)


def fill_profiles(table: pd.DataFrame, ends: list) -> None:
    """Write ``[(low, high)] * 3`` into the rows of :data:`PROFILED_TERMS` of a fit's table."""
    for term, (low, high) in zip(PROFILED_TERMS, ends):
        row = table.index[table["term"] == term][0]
        table.loc[row, ["ci_low", "ci_high"]] = [low, high]


def complete_profiles(fit: ModelFit) -> ModelFit:
    """Collect a random-slope fit's profile intervals computed elsewhere (``fit_glmm_slope``'s
    ``submit``: one job per end) and write them into its table; a complete fit is returned as
    it is. Ends the worker has not begun are taken back and computed here, the last first
    (a job's ``steal()``), while the worker goes on with the first: the caller, done with
    its own work, shares the rest instead of waiting for all of it (the same numbers:
    :func:`profile_end`)."""
    if fit.pending is not None:
        ends = [None] * len(PROFILE_ENDS)
        for i, job in reversed(fit.pending):       # (index into PROFILE_ENDS, job)
            steal = getattr(job, "steal", None)
            if steal is not None:
                ends[i] = steal()
        for i, job in fit.pending:
            if ends[i] is None:
                ends[i] = job.result()
        fill_profiles(fit.table, _as_intervals(ends))
        fit.pending = None
    return fit
