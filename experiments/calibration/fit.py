"""Estimate per-sample contact resistances R_k and a shared skin thickness L from contact traces.

Least squares (:func:`scipy.optimize.least_squares`, trust-region reflective) on the exact
model of :mod:`experiments.calibration.model`, parameters in log space (log R_k, log L) with
bounds, the analytic Jacobian from the Laplace domain, a few starting values of L.  Optionally
the initial skin temperature is fitted too (°C, linear): one T_S0 shared by all traces, or one
per trace (the skin is rewarmed between touches and never to exactly the same temperature; a
radiation thermometer sees the surface, a little cooler than the tissue underneath).

A fit is *refused* (:class:`CalibrationRefused`, the reasons in words) when the optimiser did
not converge, a parameter ends at a bound, the Jacobian is rank-deficient or ill-conditioned,
or a profile likelihood does not close within the bounds (a flat profile: the data do not
determine the parameter).  Intervals: profile likelihood (default) or parametric bootstrap,
see :mod:`experiments.calibration.intervals`. The problem itself (residuals, Jacobian, bounds) is
:mod:`experiments.calibration.problem`; the planner's view of the contact
:mod:`experiments.calibration.planning` (both re-exported here).
"""
from __future__ import annotations

import contextlib
import math
import time
from dataclasses import dataclass, field

import numpy as np

from experiments.calibration.errors import CalibrationError, CalibrationRefused
from experiments.calibration.model import ContactSetup
# the problem and the planning live in their own modules; re-exported here
from experiments.calibration.planning import (GEOMETRY_RANK, plan_calibration_scene,  # noqa: F401
                                              plan_calibration, planned_setup)
from experiments.calibration.problem import BOUNDS, SKIN_TEMPERATURE_MODES, FitProblem

__all__ = ["FitProblem", "CalibrationFit", "Parameter", "fit_traces", "BOUNDS", "SKIN_TEMPERATURE_MODES",
           "plan_calibration", "planned_setup",
           "MAX_CONDITION", "BOUND_TOLERANCE", "INTERVALS"]

#: Condition number of the scaled Jacobian above which a fit is refused (not identifiable).
MAX_CONDITION = 1e6
#: A log-parameter within this distance of its bound "is at the bound".
BOUND_TOLERANCE = 1e-3


@dataclass(frozen=True)
class Parameter:
    """One fitted parameter: estimate, interval and how it is stored.

    Attributes
    ----------
    name : str
        ``"R[<sample>]"``, ``"L"``, ``"T_S0"`` (shared) or ``"T_S0[<trace>]"`` (per trace,
        numbered from 1 in the order of the traces).
    kind : str
        ``"resistance"`` (m² K/W), ``"skin_thickness"`` (m), ``"skin_temperature"`` (°C).
    value, low, high : float
        Estimate and interval, SI (°C for temperatures).
    standard_error_log : float
        Wald standard error of log(value) (of the value itself for T_S0).
    sample : str or None
    """

    name: str
    kind: str
    value: float
    low: float = float("nan")
    high: float = float("nan")
    standard_error_log: float = float("nan")
    sample: str | None = None
    roughness_um: float | None = None
    roughness_id: int | None = None


@dataclass
class CalibrationFit:
    """A reported calibration: estimates, intervals, residuals and the checks that passed.

    Attributes
    ----------
    parameters : list of Parameter
    sigma_C : float, °C
        Residual standard deviation (the noise estimate used for the intervals).
    interval_method : str
        ``"profile"`` (profile likelihood) or ``"bootstrap"`` (parametric).
    level : float
        Coverage probability of the intervals.
    diagnostics : dict
        Condition number, singular values, optimiser status, residual lag-1 autocorrelation,
        elapsed time, ... (JSON-ready).
    """

    problem: FitProblem
    coordinates: np.ndarray
    parameters: list
    sigma_C: float
    interval_method: str
    level: float
    diagnostics: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)

    def parameter(self, name: str) -> Parameter:
        for p in self.parameters:
            if p.name == name:
                return p
        raise KeyError(name)

    @property
    def skin_thickness(self) -> Parameter:
        return self.parameter("L")

    def resistances(self) -> list:
        """The R_k parameters, in sample order."""
        return [p for p in self.parameters if p.kind == "resistance"]

    def predicted(self) -> np.ndarray:
        """Model readings at the optimum (°C), concatenated over traces."""
        return self.problem.predict(self.coordinates)

    def residuals(self) -> np.ndarray:
        return self.problem.residuals(self.coordinates)


def _start_values(problem: FitProblem, skin_thickness_guess: float | None) -> list[np.ndarray]:
    """A few starting points: Eq. 5's R for each sample (if roughness known), several L."""
    from stimuli import contact_resistance
    r0 = []
    for s in problem.samples:
        tr = next(t for t in problem.traces if t.sample == s)
        if tr.roughness_um is not None and math.isfinite(tr.roughness_um) and tr.roughness_um >= 0:
            r0.append(float(contact_resistance(tr.roughness_um * 1e-6)))
        else:
            r0.append(1e-3)
    ls = [skin_thickness_guess] if skin_thickness_guess else []
    ls += [0.5e-3, 1.0e-3, 2.0e-3]
    starts = []
    for L in ls:
        v = r0 + [L]
        if problem.skin_temperature_mode == "shared":
            v.append(float(np.median([t.skin_temperature_C for t in problem.traces])))
        elif problem.skin_temperature_mode == "per-trace":
            v += [t.skin_temperature_C for t in problem.traces]
        starts.append(np.clip(problem.to_coordinates(v), problem.lower + 1e-6, problem.upper - 1e-6))
    return starts


def _identifiability(problem: FitProblem, res, sigma: float) -> tuple[list, dict]:
    """Reasons to refuse (list of str) and what was measured."""
    reasons = []
    diag = {"optimizer_status": int(res.status), "optimizer_message": str(res.message),
            "nfev": int(res.nfev)}
    if res.status <= 0:
        reasons.append(f"the optimiser did not converge ({res.message.strip()})")
    x = res.x
    for i, name in enumerate(problem.names):
        if x[i] - problem.lower[i] < BOUND_TOLERANCE or problem.upper[i] - x[i] < BOUND_TOLERANCE:
            which = "lower" if x[i] - problem.lower[i] < BOUND_TOLERANCE else "upper"
            val = problem.to_natural(x)[i]
            reasons.append(f"{name} = {val:.4g} is at its {which} bound: the data do not determine it "
                           f"within the physically allowed range")
    dof = problem.n_obs - problem.n_params
    diag["degrees_of_freedom"] = int(dof)
    if dof < 10:
        reasons.append(f"only {dof} degrees of freedom ({problem.n_obs} samples for "
                       f"{problem.n_params} parameters)")
    J = problem.jacobian(x) / max(sigma, 1e-12)
    sv = np.linalg.svd(J, compute_uv=False)
    cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else float("inf")
    diag["singular_values"] = [float(v) for v in sv]
    diag["condition_number"] = cond
    rank = int(np.sum(sv > sv[0] * 1e-10)) if sv[0] > 0 else 0
    diag["jacobian_rank"] = rank
    if rank < problem.n_params:
        reasons.append(f"the Jacobian has rank {rank} < {problem.n_params} parameters: some "
                       f"parameters cannot be told apart")
    elif cond > MAX_CONDITION:
        reasons.append(f"the Jacobian's condition number is {cond:.3g} > {MAX_CONDITION:g}: the "
                       f"parameters are not identifiable from these traces")
    return reasons, diag


def _single_threaded_blas():
    """Limit BLAS to one thread while fitting (if threadpoolctl is installed).

    The trust-region solver takes an SVD of the tall Jacobian at every step; on a busy
    2-core machine OpenBLAS's threads made each 2000 x 9 SVD 13 ms instead of 1 ms.
    """
    global _BLAS_CONTROLLER
    if _BLAS_CONTROLLER is None:
        try:
            from threadpoolctl import ThreadpoolController
            _BLAS_CONTROLLER = ThreadpoolController()      # inspecting the libraries is the slow part
        except ImportError:            # pragma: no cover - optional speed-up only
            _BLAS_CONTROLLER = False
    if _BLAS_CONTROLLER is False:      # pragma: no cover
        return contextlib.nullcontext()
    return _BLAS_CONTROLLER.limit(limits=1, user_api="blas")


_BLAS_CONTROLLER = None


def fit_traces(traces, setup: ContactSetup | None = None, *, fit_skin_temperature="none",
               skin_thickness_guess: float | None = None, interval: str = "profile",
               level: float = 0.95, bootstrap_samples: int = 200, seed: int = 0,
               max_nfev: int = 200, skin_temperature_sd_C: float | None = None,
               plan_model: bool = True) -> CalibrationFit:
    """Fit R_k per sample and a shared L (and T_S0) to contact traces; refuse if not identifiable.

    Parameters
    ----------
    traces : sequence of ContactTrace
        Traces on one or more samples; traces with the same ``sample`` share R.
    setup : ContactSetup, optional
        Sample material/thickness and sensor placement (default: 3 mm steel, material-side sensor).
    fit_skin_temperature : {"none", "shared", "per-trace"} or bool
        Also fit the initial skin temperature (°C): one shared by all traces, or one per trace.
    skin_thickness_guess : float, m, optional
        Extra starting value of L (e.g. the participant record's).
    interval : {"profile", "bootstrap"}
        Profile likelihood or parametric bootstrap (percentile) intervals.
    level : float
        Interval coverage, e.g. 0.95.
    bootstrap_samples : int
        Number of refits for ``interval="bootstrap"``.
    seed : int
        Seed of the bootstrap's noise.
    max_nfev : int
        Evaluation budget of each least-squares run (exhausting it is non-convergence).
    skin_temperature_sd_C : float, K, optional
        With ``fit_skin_temperature="none"``: the measurement uncertainty (SD) of the given
        skin temperatures, propagated into the intervals (first order, in quadrature). Without
        it, a given T_S0 0.3 K off that would move an estimate beyond its interval is warned
        about (:mod:`experiments.calibration.misspecification`, with the geometry and sensor-lag
        checks).
    plan_model : bool
        Compute the readings with the scene planner's model of the contact (planned once
        per fit at the start values and the traces' white-noise level as tolerance, checked at the
        fitted values and refitted with the stated model when the planner then keeps more).
        ``False``: the exact model of ``setup`` (the reference the planned fit is tested against).

    Returns
    -------
    CalibrationFit

    Raises
    ------
    CalibrationRefused
        Non-convergence, a parameter at a bound, rank-deficient or ill-conditioned
        Jacobian, a profile that does not close within the bounds (``.reasons``).
    CalibrationError
        Bad arguments.
    """
    with _single_threaded_blas():
        return _fit_traces(traces, setup, fit_skin_temperature=fit_skin_temperature,
                           skin_thickness_guess=skin_thickness_guess, interval=interval, level=level,
                           bootstrap_samples=bootstrap_samples, seed=seed, max_nfev=max_nfev,
                           skin_temperature_sd_C=skin_temperature_sd_C, plan_model=plan_model)


def _profile(problem, x, *, ssr, se, level, **_):
    """Profile-likelihood intervals of R_k, L and a shared T_S0 (per-trace T_S0: none)."""
    from experiments.calibration.intervals import profile_intervals
    which = range(problem.k + 1 + (problem.n_ts0 if problem.n_ts0 == 1 else 0))
    return profile_intervals(problem, x, ssr, se, level, which=which)


def _bootstrap(problem, x, *, sigma, level, samples, seed, **_):
    """Parametric-bootstrap intervals (``samples`` refits)."""
    from experiments.calibration.intervals import bootstrap_intervals
    return bootstrap_intervals(problem, x, sigma, level, samples, seed)


#: The interval methods ``interval=`` accepts: name -> ``f(problem, x, *, ssr, sigma, se, level,
#: samples, seed) -> (lows, highs, flat)`` (the ``solve_ivp`` ``METHODS`` shape).
INTERVALS = {"profile": _profile, "bootstrap": _bootstrap}


def _check_interval(interval, level) -> None:
    if interval not in INTERVALS:
        raise CalibrationError(f"calibration: interval: expected "
                               f"{' or '.join(map(repr, INTERVALS))}, got {interval!r}")
    if not 0.5 <= level < 1.0:
        raise CalibrationError(f"calibration: level: expected a probability in [0.5, 1), got {level!r}")


def _planned_problem(traces, setup, fit_skin_temperature, skin_thickness_guess, plan_model):
    """``(problem, forward, forward_record)``: the fit's problem, with the planner's forward
    model when ``plan_model`` (the scene planned once, at the start values' R and L and the
    traces' own white-noise level as tolerance; checked at the fitted values later)."""
    problem = FitProblem(traces, setup, fit_skin_temperature)
    forward, forward_record = None, None
    if plan_model:
        start = problem.to_natural(_start_values(problem, skin_thickness_guess)[0])
        noise = float(np.median([tr.noise_C for tr in problem.traces]))
        forward, forward_record = plan_calibration(problem.traces, setup, start[0], start[problem.k], noise)
        if forward is not None:
            problem = FitProblem(traces, setup, fit_skin_temperature, model=forward.model)
    return problem, forward, forward_record


def _best_solution(problem, skin_thickness_guess, max_nfev):
    """The least-squares solution of lowest cost over the start values."""
    best = None
    for p0 in _start_values(problem, skin_thickness_guess):
        res = problem.solve(p0, max_nfev=max_nfev)
        if best is None or res.cost < best.cost - 1e-12:
            best = res
    return best


def _residual_diagnostics(problem, best, sigma) -> dict:
    """The residuals' diagnostics; CalibrationRefused when the parameters are not identifiable."""
    reasons, diag = _identifiability(problem, best, sigma)
    r = problem.residuals(best.x)
    diag["residual_sd_C"] = sigma
    diag["residual_lag1_autocorrelation"] = float(np.corrcoef(r[:-1], r[1:])[0, 1]) if r.size > 2 else 0.0
    diag["n_observations"] = int(problem.n_obs)
    diag["n_traces"] = len(problem.traces)
    if reasons:
        raise CalibrationRefused("calibration refused: " + "; ".join(reasons), reasons, diag)
    return diag


def _fitted_parameters(problem, x, lows, highs, se) -> list:
    """Each fitted parameter with its interval (and its sample, for a contact resistance)."""
    nat = problem.to_natural(x)
    params = []
    for i, (name, kind) in enumerate(zip(problem.names, problem.kinds)):
        sample = problem.samples[i] if kind == "resistance" else None
        tr = next((t for t in problem.traces if t.sample == sample), None) if sample else None
        params.append(Parameter(
            name=name, kind=kind, value=float(nat[i]), low=float(lows[i]), high=float(highs[i]),
            standard_error_log=float(se[i]), sample=sample,
            roughness_um=tr.roughness_um if tr else None, roughness_id=tr.roughness_id if tr else None))
    return params


def _forward_model(problem, forward, forward_record, replanned) -> dict:
    """The record of the forward model the fit's readings were computed with."""
    if forward is not None:
        return {"planned": forward_record, "evaluated": problem.forward_setup.describe(),
                "note": "the fit's readings are computed with the planned model" + (
                    " (Eq. 7 is within the tolerance; its exact half-space transform "
                    "is evaluated, which gives the fit's derivatives)"
                    if forward.model.method == "eq7" else "")}
    if replanned is not None:
        note, forward_record = replanned
    else:
        note = ("not planned: the exact model of the stated setup" if forward_record is None
                else forward_record.get("note", ""))
    return {"planned": forward_record, "evaluated": problem.forward_setup.describe(), "note": note}


def _fit_traces(traces, setup, *, fit_skin_temperature, skin_thickness_guess, interval, level,
                bootstrap_samples, seed, max_nfev, skin_temperature_sd_C=None, plan_model=True,
                _replanned=None):
    _check_interval(interval, level)
    setup = setup or ContactSetup()
    t_start = time.perf_counter()
    problem, forward, forward_record = _planned_problem(traces, setup, fit_skin_temperature,
                                                        skin_thickness_guess, plan_model)
    best = _best_solution(problem, skin_thickness_guess, max_nfev)
    ssr = 2.0 * best.cost
    dof = problem.n_obs - problem.n_params
    sigma = math.sqrt(ssr / max(dof, 1))
    diag = _residual_diagnostics(problem, best, sigma)
    J = problem.jacobian(best.x)
    cov = sigma ** 2 * np.linalg.inv(J.T @ J)
    se = np.sqrt(np.diag(cov))
    lows, highs, flat = INTERVALS[interval](problem, best.x, ssr=ssr, sigma=sigma, se=se,
                                            level=level, samples=bootstrap_samples, seed=seed)
    if flat:
        diag["flat"] = flat
        raise CalibrationRefused("calibration refused: " + "; ".join(flat), flat, diag)
    params = _fitted_parameters(problem, best.x, lows, highs, se)
    warnings = []
    if abs(diag["residual_lag1_autocorrelation"]) > 0.5:
        warnings.append(
            f"residuals are autocorrelated (lag-1 {diag['residual_lag1_autocorrelation']:.2f}): the "
            f"model misses something systematic, so the intervals (which assume white noise) are "
            f"too narrow")
    diag["correlation"] = (cov / np.outer(se, se)).round(4).tolist()
    diag["correlation_parameters"] = list(problem.names)
    fit = CalibrationFit(problem, best.x, params, sigma, interval, level, diag, warnings)
    _check_misspecification(fit, skin_temperature_sd_C)
    if forward is not None:
        check = diag["plan"]
        used = forward.model.geometry
        if GEOMETRY_RANK.get(check.get("geometry"), -1) > GEOMETRY_RANK[used]:
            # at the fitted values the planner keeps what the start values let it drop: refit with it
            return _fit_traces(traces, setup,
                               fit_skin_temperature=fit_skin_temperature,
                               skin_thickness_guess=skin_thickness_guess, interval=interval, level=level,
                               bootstrap_samples=bootstrap_samples, seed=seed, max_nfev=max_nfev,
                               skin_temperature_sd_C=skin_temperature_sd_C, plan_model=False,
                               _replanned=(f"planned at the start values: {used}; at the fitted "
                                           f"values the planner keeps the {check['geometry']}: "
                                           f"refitted with the exact model of the stated setup",
                                           forward_record))
    diag["forward_model"] = _forward_model(problem, forward, forward_record, _replanned)
    diag["elapsed_s"] = time.perf_counter() - t_start
    diag["model_evaluations"] = problem.n_evaluations
    return fit


def _check_misspecification(fit, skin_temperature_sd_C):
    """Warn when a plausible misspecification moves an estimate beyond its interval;
    with ``skin_temperature_sd_C`` (T_S0 given, not fitted) widen the intervals by its effect."""
    from experiments.calibration.misspecification import (MISSPECIFICATIONS, misspecification_shifts,
                                                          propagate_skin_temperature)
    shifts = misspecification_shifts(fit)
    if skin_temperature_sd_C is not None:
        fit.parameters[:] = propagate_skin_temperature(
            fit, shifts, float(skin_temperature_sd_C), MISSPECIFICATIONS["skin_temperature_error_C"])
        fit.diagnostics["skin_temperature_sd_C_propagated"] = float(skin_temperature_sd_C)
        for c in shifts:
            if c["name"] == "skin_temperature":
                c["beyond"] = [p.name for p, d in zip(fit.parameters, c["_dp"])
                               if not (p.low <= (p.value + d if p.kind == "skin_temperature"
                                                 else p.value * math.exp(d)) <= p.high)]
    for c in shifts:
        dp = c.pop("_dp")
        del dp
        if c["beyond"]:
            moved = ", ".join(f"{n} by {c['shift'][n]:+.1%}" if not n.startswith("T_S0")
                              else f"{n} by {c['shift'][n]:+.2f} K" for n in c["beyond"])
            fit.warnings.append(f"a plausible misspecification ({c['name'].replace('_', ' ')}: "
                                f"{c['size']}) would move {moved}, beyond the interval: the "
                                f"intervals do not include the model's own uncertainty")
    fit.diagnostics["misspecification"] = shifts
    fit.diagnostics["plan"] = plan_calibration_scene(fit)
