"""How far a plausible misspecification of the calibration model would move its estimates.

The fit assumes a skin temperature (when it is not fitted), a sample geometry and an ideal
sensor. Each plausible error of those assumptions changes the model's readings by dy; to first
order the least-squares estimates then move by dp = (J^T J)^-1 J^T dy (J: the Jacobian at the
estimate, in the fit's coordinates: log R, log L, T_S0). :func:`misspecification_shifts` computes
dp for

* ``skin_temperature``: T_S0 off by ``skin_temperature_error_C`` (0.3 K: a realistic radiation
  thermometer error), only when T_S0 is given rather than fitted;
* ``geometry``: the sample slab ``thickness_factor`` (1.5) times thicker -- a support under it
  and lateral spreading make a real 3 mm sample act thicker than an insulated 3 mm slab (for a
  half-space sample: a 10 mm slab instead);
* ``sensor_lag``: a first-order sensor lag of ``sensor_time_constant_s`` (0.1 s) the model
  ignores (uniformly sampled traces only);

and says which estimate each would move beyond its interval. A shift that leaves an interval
means the interval does not include the model's own uncertainty: the calibration then warns.
With ``skin_temperature_sd_C`` the skin-temperature shift is also propagated into the intervals.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from experiments.calibration.problem import FitProblem

__all__ = ["misspecification_shifts", "MISSPECIFICATIONS"]

#: The plausible errors checked, with their default sizes.
MISSPECIFICATIONS = {"skin_temperature_error_C": 0.3, "thickness_factor": 1.5,
                     "sensor_time_constant_s": 0.1}


def _lagged(problem, y, tau):
    """Each trace's model reading through a first-order sensor of time constant tau (or None)."""
    from stimuli.scene import sensor_lag
    out = np.empty_like(y)
    i0 = 0
    for tr in problem.traces:
        i1 = i0 + tr.n
        t = np.concatenate([[0.0], tr.time_s])
        d = np.diff(t)
        if not np.allclose(d, d[0], rtol=1e-6, atol=0):
            return None
        start = tr.material_temperature_C if problem.setup.sensor.side == "material" else tr.skin_temperature_C
        out[i0:i1] = sensor_lag(t, np.concatenate([[start], y[i0:i1]]), tau)[1:]
        i0 = i1
    return out


def misspecification_shifts(fit, *, skin_temperature_error_C: float = 0.3,
                            thickness_factor: float = 1.5, sensor_time_constant_s: float = 0.1):
    """First-order shifts of the estimates under each plausible misspecification.

    Returns
    -------
    list of dict
        One per misspecification: ``name``, ``size`` (with unit), ``shift`` (parameter name ->
        relative shift for R and L, K for T_S0) and ``beyond`` (the parameters moved out of their
        interval).
    """
    prob = fit.problem
    x = np.asarray(fit.coordinates, dtype=float)
    y, J = prob.predict(x, jacobian=True)
    solve = np.linalg.pinv(J)
    cases = []
    if prob.skin_temperature_mode == "none":
        theta = np.empty_like(y)
        i0 = 0
        for tr in prob.traces:
            i1 = i0 + tr.n
            theta[i0:i1] = (y[i0:i1] - tr.material_temperature_C) / (tr.skin_temperature_C - tr.material_temperature_C)
            i0 = i1
        cases.append(("skin_temperature", f"{skin_temperature_error_C:g} K", theta * skin_temperature_error_C))
    mat = prob.setup.material
    D = mat.thickness
    thicker = mat.with_thickness(10e-3 if D is None else D * thickness_factor)
    other = FitProblem(prob.traces, replace(prob.setup, material=thicker), prob.skin_temperature_mode)
    cases.append(("geometry", f"sample {'10 mm slab' if D is None else f'{thickness_factor:g} x thicker'}",
                  other.predict(x) - y))
    lagged = _lagged(prob, y, sensor_time_constant_s)
    if lagged is not None:
        cases.append(("sensor_lag", f"{sensor_time_constant_s:g} s", lagged - y))
    out = []
    for name, size, dy in cases:
        dp = solve @ dy
        shift, beyond = {}, []
        for i, p in enumerate(fit.parameters):
            if p.kind == "skin_temperature":
                moved = p.value + dp[i]
                shift[p.name] = float(dp[i])
            else:
                moved = p.value * math.exp(dp[i])
                shift[p.name] = float(math.expm1(dp[i]))
            if not (p.low <= moved <= p.high):
                beyond.append(p.name)
        out.append({"name": name, "size": size, "shift": shift, "beyond": beyond, "_dp": dp})
    return out


def propagate_skin_temperature(fit, shifts, sd_C: float, error_C: float, z: float = 1.96):
    """Widen the intervals by the skin-temperature shift scaled to ``sd_C`` (in quadrature)."""
    case = next((c for c in shifts if c["name"] == "skin_temperature"), None)
    if case is None:
        return fit.parameters
    params = []
    for i, p in enumerate(fit.parameters):
        extra = z * abs(case["_dp"][i]) * sd_C / error_C
        if p.kind == "skin_temperature":
            params.append(replace(p, low=p.value - math.hypot(p.value - p.low, extra),
                                  high=p.value + math.hypot(p.high - p.value, extra)))
        else:
            lo = math.log(p.value / p.low)
            hi = math.log(p.high / p.value)
            params.append(replace(p, low=p.value * math.exp(-math.hypot(lo, extra)),
                                  high=p.value * math.exp(math.hypot(hi, extra))))
    return params
