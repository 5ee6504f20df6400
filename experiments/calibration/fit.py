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
see :mod:`experiments.calibration.intervals`.
"""
from __future__ import annotations

import contextlib
import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares

from experiments.calibration.errors import CalibrationError, CalibrationRefused
from experiments.calibration.model import ContactSetup, ResponseGrid
from experiments.calibration.trace import ContactTrace

__all__ = ["FitProblem", "CalibrationFit", "Parameter", "fit_traces", "BOUNDS", "SKIN_TEMPERATURE_MODES",
           "plan_calibration", "planned_setup",
           "MAX_CONDITION", "BOUND_TOLERANCE"]

#: Bounds of the fitted parameters (SI; T_S0 in °C).  L: the participant schema's hard range.
BOUNDS = {"resistance": (1e-6, 0.1), "skin_thickness": (100e-6, 5e-3), "skin_temperature": (20.0, 42.0)}
#: How the initial skin temperature enters the fit.
SKIN_TEMPERATURE_MODES = ("none", "shared", "per-trace")
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


class FitProblem:
    """The residuals and Jacobian of a set of traces, in the fit's coordinates.

    Coordinates ``p``: ``log R_k`` for each sample (in order of first appearance),
    ``log L``, then ``T_S0`` (°C): one if ``fit_skin_temperature="shared"``, one per trace if
    ``"per-trace"``.

    Parameters
    ----------
    traces : sequence of ContactTrace
    setup : ContactSetup
        The contact as stated (reported with the fit).
    fit_skin_temperature : {"none", "shared", "per-trace"} or bool
        Fit the initial skin temperature instead of using the traces' values (``True`` is
        ``"shared"``, ``False`` is ``"none"``).
    model : stimuli.scene.Model, optional
        The scene planner's model of this contact (:func:`plan_calibration`): the readings are
        computed with ``setup`` reduced to it. None: the exact model of ``setup``.
    """

    def __init__(self, traces, setup: ContactSetup, fit_skin_temperature="none", model=None):
        traces = list(traces)
        if not traces:
            raise CalibrationError("calibration: traces: expected at least one contact trace, got none")
        for tr in traces:
            if not isinstance(tr, ContactTrace):
                raise CalibrationError(f"calibration: traces: expected ContactTrace objects, got {tr!r}")
        self.traces = traces
        self.setup = setup
        #: the planner's model (:class:`stimuli.scene.Model`) the grids evaluate, or None (exact
        #: model of ``setup``); ``forward_setup`` is ``setup`` reduced to it (:func:`planned_setup`)
        self.model = model
        self.forward_setup = setup if model is None else planned_setup(setup, model)
        mode = {True: "shared", False: "none", None: "none"}.get(fit_skin_temperature, fit_skin_temperature)
        if mode not in SKIN_TEMPERATURE_MODES:
            raise CalibrationError(f"calibration: fit_skin_temperature: expected one of "
                                   f"{SKIN_TEMPERATURE_MODES}, got {fit_skin_temperature!r}")
        self.skin_temperature_mode = mode
        self.fit_skin_temperature = mode != "none"
        self.n_ts0 = {"none": 0, "shared": 1, "per-trace": len(traces)}[mode]
        self.samples: list[str] = []
        for tr in traces:
            if tr.sample not in self.samples:
                self.samples.append(tr.sample)
        self.k = len(self.samples)
        self.index = [self.samples.index(tr.sample) for tr in traces]
        ts0_names = {"none": [], "shared": ["T_S0"],
                     "per-trace": [f"T_S0[{i + 1}]" for i in range(len(traces))]}[mode]
        self.names = [f"R[{s}]" for s in self.samples] + ["L"] + ts0_names
        self.kinds = ["resistance"] * self.k + ["skin_thickness"] + ["skin_temperature"] * self.n_ts0
        self.n_params = len(self.names)
        self.n_obs = sum(tr.n for tr in traces)
        self.y = np.concatenate([tr.temperature_C for tr in traces])
        lo, hi = [], []
        for kind in self.kinds:
            a, b = BOUNDS[kind]
            if kind == "skin_temperature":
                a = max(a, max(tr.material_temperature_C for tr in traces) + 0.5)
                lo.append(a), hi.append(b)
            else:
                lo.append(math.log(a)), hi.append(math.log(b))
        self.lower, self.upper = np.array(lo), np.array(hi)
        self.n_evaluations = 0
        grids: dict = {}
        self.grids = []
        for tr in traces:           # traces sampled at the same times share one grid
            key = (tr.n, tr.time_s.tobytes())
            if key not in grids:
                grids[key] = ResponseGrid(tr.time_s, self.forward_setup)
            self.grids.append(grids[key])

    # -- coordinates -------------------------------------------------------------------
    def to_natural(self, p) -> np.ndarray:
        """SI values (°C for T_S0) of the coordinates ``p``."""
        p = np.asarray(p, dtype=float)
        out = np.exp(np.minimum(p, 700.0))
        if self.n_ts0:
            out[self.k + 1:] = p[self.k + 1:]
        return out

    def to_coordinates(self, values) -> np.ndarray:
        v = np.asarray(values, dtype=float)
        out = np.log(np.maximum(v, 1e-300))
        if self.n_ts0:
            out[self.k + 1:] = v[self.k + 1:]
        return out

    # -- model -----------------------------------------------------------------------
    def predict(self, p, jacobian: bool = False):
        """Model readings (°C) for all traces, concatenated; optionally the Jacobian."""
        p = np.asarray(p, dtype=float)
        nat = self.to_natural(p)
        L = nat[self.k]
        out = np.empty(self.n_obs)
        jac = np.zeros((self.n_obs, self.n_params)) if jacobian else None
        i0 = 0
        self.n_evaluations += 1
        for j, (tr, k, grid) in enumerate(zip(self.traces, self.index, self.grids)):
            i1 = i0 + tr.n
            R = nat[k]
            col = None if not self.n_ts0 else self.k + 1 + (j if self.n_ts0 > 1 else 0)
            ts0 = tr.skin_temperature_C if col is None else nat[col]
            dT = ts0 - tr.material_temperature_C
            if jacobian:
                th, d_r, d_l = grid.response(R, L, derivatives=True)
                jac[i0:i1, k] = dT * R * d_r
                jac[i0:i1, self.k] = dT * L * d_l
                if col is not None:
                    jac[i0:i1, col] = th
            else:
                th = grid.response(R, L)
            out[i0:i1] = tr.material_temperature_C + dT * th
            i0 = i1
        return (out, jac) if jacobian else out

    def residuals(self, p) -> np.ndarray:
        return self.predict(p) - self.y

    def jacobian(self, p) -> np.ndarray:
        return self.predict(p, jacobian=True)[1]

    def solve(self, p0, fixed: dict | None = None, max_nfev: int = 200):
        """Least squares from ``p0``; ``fixed`` maps coordinate index -> value held fixed.

        Returns
        -------
        scipy.optimize.OptimizeResult
            With ``x`` the full coordinate vector (fixed entries included) and ``cost`` =
            SSR / 2.
        """
        fixed = dict(fixed or {})
        free = [i for i in range(self.n_params) if i not in fixed]
        full = np.array(p0, dtype=float)
        for i, v in fixed.items():
            full[i] = v

        def expand(q):
            x = full.copy()
            x[free] = q
            return x

        cache = {}

        def fun(q):
            key = q.tobytes()
            if key not in cache:
                cache.clear()
                y, j = self.predict(expand(q), jacobian=True)
                cache[key] = (y - self.y, j[:, free])
            return cache[key][0]

        def jac(q):
            fun(q)
            return cache[q.tobytes()][1]

        q0 = np.clip(full[free], self.lower[free] + 1e-9, self.upper[free] - 1e-9)
        res = least_squares(fun, q0, jac=jac, bounds=(self.lower[free], self.upper[free]),
                            method="trf", x_scale="jac", xtol=1e-10, ftol=1e-12, gtol=1e-10,
                            max_nfev=max_nfev)
        res.x = expand(res.x)
        return res


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
        Compute the readings with the scene planner's model of the contact (issue 12; planned once
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


def _fit_traces(traces, setup, *, fit_skin_temperature, skin_thickness_guess, interval, level,
                bootstrap_samples, seed, max_nfev, skin_temperature_sd_C=None, plan_model=True,
                _replanned=None):
    from experiments.calibration.intervals import bootstrap_intervals, profile_intervals

    if interval not in ("profile", "bootstrap"):
        raise CalibrationError(f"calibration: interval: expected 'profile' or 'bootstrap', got {interval!r}")
    if not 0.5 <= level < 1.0:
        raise CalibrationError(f"calibration: level: expected a probability in [0.5, 1), got {level!r}")
    setup = setup or ContactSetup()
    t_start = time.perf_counter()
    problem = FitProblem(traces, setup, fit_skin_temperature)
    forward, forward_record = None, None
    if plan_model:
        # the forward model is the planner's (issue 12): the scene planned once, at the start values'
        # R and L and the traces' own white-noise level as tolerance; checked at the fitted values below
        start = problem.to_natural(_start_values(problem, skin_thickness_guess)[0])
        noise = float(np.median([tr.noise_C for tr in problem.traces]))
        forward, forward_record = plan_calibration(problem.traces, setup, start[0], start[problem.k], noise)
        if forward is not None:
            problem = FitProblem(traces, setup, fit_skin_temperature, model=forward.model)
    best = None
    for p0 in _start_values(problem, skin_thickness_guess):
        res = problem.solve(p0, max_nfev=max_nfev)
        if best is None or res.cost < best.cost - 1e-12:
            best = res
    ssr = 2.0 * best.cost
    dof = problem.n_obs - problem.n_params
    sigma = math.sqrt(ssr / max(dof, 1))
    reasons, diag = _identifiability(problem, best, sigma)
    r = problem.residuals(best.x)
    diag["residual_sd_C"] = sigma
    diag["residual_lag1_autocorrelation"] = float(np.corrcoef(r[:-1], r[1:])[0, 1]) if r.size > 2 else 0.0
    diag["n_observations"] = int(problem.n_obs)
    diag["n_traces"] = len(problem.traces)
    if reasons:
        raise CalibrationRefused("calibration refused: " + "; ".join(reasons), reasons, diag)

    J = problem.jacobian(best.x)
    cov = sigma ** 2 * np.linalg.inv(J.T @ J)
    se = np.sqrt(np.diag(cov))
    if interval == "profile":
        which = range(problem.k + 1 + (problem.n_ts0 if problem.n_ts0 == 1 else 0))
        lows, highs, flat = profile_intervals(problem, best.x, ssr, se, level, which=which)
    else:
        lows, highs, flat = bootstrap_intervals(problem, best.x, sigma, level, bootstrap_samples, seed)
    if flat:
        diag["flat"] = flat
        raise CalibrationRefused("calibration refused: " + "; ".join(flat), flat, diag)
    nat = problem.to_natural(best.x)
    params = []
    for i, (name, kind) in enumerate(zip(problem.names, problem.kinds)):
        sample = problem.samples[i] if kind == "resistance" else None
        tr = next((t for t in problem.traces if t.sample == sample), None) if sample else None
        params.append(Parameter(
            name=name, kind=kind, value=float(nat[i]), low=float(lows[i]), high=float(highs[i]),
            standard_error_log=float(se[i]), sample=sample,
            roughness_um=tr.roughness_um if tr else None, roughness_id=tr.roughness_id if tr else None))
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
        if _GEOMETRY_RANK.get(check.get("geometry"), -1) > _GEOMETRY_RANK[used]:
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
        diag["forward_model"] = {"planned": forward_record, "evaluated": problem.forward_setup.describe(),
                                 "note": "the fit's readings are computed with the planned model" + (
                                     " (Eq. 7 is within the tolerance; its exact half-space transform "
                                     "is evaluated, which gives the fit's derivatives)"
                                     if forward.model.method == "eq7" else "")}
    else:
        if _replanned is not None:
            note, forward_record = _replanned
        else:
            note = ("not planned: the exact model of the stated setup" if forward_record is None
                    else forward_record.get("note", ""))
        diag["forward_model"] = {"planned": forward_record, "evaluated": problem.forward_setup.describe(),
                                 "note": note}
    diag["elapsed_s"] = time.perf_counter() - t_start
    diag["model_evaluations"] = problem.n_evaluations
    return fit


def _check_misspecification(fit, skin_temperature_sd_C):
    """Warn when a plausible misspecification moves an estimate beyond its interval (issue 12);
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
    fit.diagnostics["plan"] = _plan_calibration_scene(fit)


_GEOMETRY_RANK = {"half-space": 0, "slab": 1, "slab-on-support": 2}


def planned_setup(setup: ContactSetup, model) -> ContactSetup:
    """``setup`` reduced to the scene planner's ``model`` (:class:`stimuli.scene.Model`).

    A calibration scene states homogeneous skin, no perfusion, no sensor lag and the sample as a
    half-space or an insulated slab, so the planner's only simplifications are the slab (to a
    half-space) and the exact half-space (to the printed Eq. 7). The half-space is evaluated by
    :class:`ResponseGrid`'s exact transform in both cases: the fit needs dθ/dR and dθ/dL, which
    Eq. 7's printed form does not give, and the exact form is the one Eq. 7 was checked against.
    """
    from dataclasses import replace as _replace
    if model.layered or model.perfusion or model.sensor or model.geometry == "slab-on-support":
        raise CalibrationError(f"calibration: model: the calibration's forward model has homogeneous "
                               f"skin on a half-space or an insulated slab, got {model.describe()!r}")
    d = setup.material.thickness
    if model.geometry == "half-space" and d is not None:
        return _replace(setup, material=setup.material.with_thickness(None))
    if model.geometry == "slab" and d is None:
        raise CalibrationError("calibration: model: a slab model for a half-space sample")
    return setup


def plan_calibration(traces, setup: ContactSetup, resistance: float, skin_thickness: float,
                     tolerance_K: float):
    """Plan the calibration's contact scene (issue 12): the longest trace's times, its temperatures,
    ``resistance`` and ``skin_thickness``, the sensor's side as the quantity, ``tolerance_K``.

    Returns
    -------
    plan : stimuli.planner.Plan or None
        None for a lumped sensor (not a scene quantity) or a scene the planner refuses.
    record : dict
        :meth:`Plan.to_dict`, or ``{"note": why not planned}``.
    """
    import warnings as _warnings

    from stimuli import ModelInputError
    from stimuli.planner import plan
    from stimuli.scene import Scene
    side = setup.sensor.side
    if side == "lumped":
        return None, {"note": "lumped sensor: not a scene quantity; the fit's exact model"}
    tr = max(traces, key=lambda x: x.duration_s)
    mat = setup.material
    try:
        with _warnings.catch_warnings():
            _warnings.simplefilter("ignore")            # range warnings belong to the traces' loader
            scene = Scene(quantity=f"interface_{side}", duration_s=round(tr.duration_s, 6),
                          rate_Hz=round(tr.n / tr.duration_s, 6), tolerance_K=max(tolerance_K, 1e-6),
                          material=mat.with_thickness(None), resistance=float(resistance),
                          skin_thickness_m=float(skin_thickness),
                          skin_temperature_C=tr.skin_temperature_C,
                          material_temperature_C=tr.material_temperature_C,
                          geometry="half-space" if mat.thickness is None else "slab",
                          sample_thickness_m=mat.thickness or 3e-3)
            p = plan(scene)
            return p, p.to_dict()
    except ModelInputError as exc:
        return None, {"note": f"not planned: {exc}"}


def _plan_calibration_scene(fit):
    """The scene planner's view of the calibration's contact at the fitted values, at the traces' own
    noise level (tolerance = the residual SD), for a massless sensor."""
    prob = fit.problem
    return plan_calibration(prob.traces, prob.setup, fit.resistances()[0].value,
                            fit.skin_thickness.value, fit.sigma_C)[1]
