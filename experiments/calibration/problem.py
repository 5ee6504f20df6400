"""The calibration's least-squares problem: residuals and Jacobian of contact traces in the
fit's coordinates (log R_k, log L, T_S0), with the parameters' bounds.

Fitted by :func:`experiments.calibration.fit.fit_traces`.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.optimize import least_squares

from experiments.calibration.errors import CalibrationError
from experiments.calibration.model import ContactSetup, ResponseGrid
from experiments.calibration.planning import planned_setup
from experiments.calibration.trace import ContactTrace

__all__ = ["FitProblem", "BOUNDS", "SKIN_TEMPERATURE_MODES"]

#: Bounds of the fitted parameters (SI; T_S0 in °C).  L: the participant schema's hard range.
BOUNDS = {"resistance": (1e-6, 0.1), "skin_thickness": (100e-6, 5e-3), "skin_temperature": (20.0, 42.0)}
#: How the initial skin temperature enters the fit.
SKIN_TEMPERATURE_MODES = ("none", "shared", "per-trace")


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
