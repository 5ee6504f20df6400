r"""The scene planner for a display-driven skin: layered skin and perfusion, kept or neglected.

A display imposes a surface history g(t) on the skin (through the finger-pad resistance R);
the receptor temperature is linear in g: :math:`u(t) = \int_0^t S'(t-\tau) h(\tau)\,d\tau +
S(t) h(0)`, h = g - T_S0, S the skin's step response at the receptor. Two models of the skin
differ by :math:`\Delta u = \int h\, d\Delta S`, so for every t

.. math:: |\Delta u(t)| \le \sup|h| \cdot \mathrm{TV}_{[0,t]}(\Delta S)
          \quad\text{and}\quad |\Delta u(t)| \le \sup|\Delta S| \cdot (|h(0)| + \mathrm{TV}(h)).

:func:`plan_display` evaluates the step responses of the full model (the physics the caller
states: :data:`stimuli.layered.TISSUES`' epidermis and dermis, Pennes perfusion) and of each
cheaper candidate at the planner's ~20 probe times (one shared cheap inversion plan), and bounds the
candidate's error by the smaller of the two right-hand sides, with the total variation and the
sup of Delta S taken over the probes, times :data:`stimuli.planner.SAFETY` (between probes the
step responses are smooth and their difference single-humped; the factor covers the probes
missing the extreme), plus both inversions' bounds. ``tests/stimuli/test_display_planner.py``
evaluates planned and full models over a grid of skins and histories and asserts the error is
within the tolerance -- a wrong bound fails there.

Before evaluating (``screen=True``, the default): perfusion is neglected when its closed-form
bound (:func:`stimuli.planner.perfusion_factor` x sup|h|, the maximum principle) fits the
tolerance, and the layers are kept when their quasi-steady effect under the drive is several
tolerances (:func:`_layers_matter`) or a Laplace-domain lower bound of their effect is
(:func:`_layers_lower_bound`: exact kernels and the history's exact transform at a real s);
each was checked against the evaluation in the tests. The
probes' inversion is the scene planner's cheap one (each value within
:data:`stimuli.planner.PROBE_INVERSION_ERROR`, added to the bounds).

Effects are dropped in the order perfusion, then layers; the cheapest model, homogeneous skin
without perfusion, is :func:`stimuli.skin_response`'s exact solution (a few ms for 20 s at
1 kHz); a kept effect is computed by :func:`stimuli.layered.layered_skin_response` (exact).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .exact import INVERSION_ERROR
from .layered import LayeredTransform, layer_rows, layered_skin_response, skin_layers
from .materials import material as _material
from .planner import PROBE_INVERSION_ERROR, SAFETY, Decision, probe_plan
from .planner_bounds import LAYER_LAPLACE_ST, real_point, perfusion_factor

__all__ = ["DisplayPlan", "plan_display", "planned_skin_response"]


@dataclass(frozen=True)
class DisplayPlan:
    """The planner's answer for a display-driven skin: kept effects, decisions, bound (K)."""

    layered: bool
    perfusion: bool
    decisions: tuple
    bound_K: float
    tolerance_K: float

    def describe(self) -> str:
        parts = ["exact", "display-driven", "layered skin" if self.layered else "homogeneous skin"]
        if self.perfusion:
            parts.append("perfusion")
        return ", ".join(parts)

    def to_dict(self) -> dict:
        """JSON-ready, like :meth:`stimuli.planner.Plan.to_dict`."""
        return {"model": self.describe(), "method": "exact", "layered": self.layered,
                "perfusion": self.perfusion, "bound_K": self.bound_K,
                "tolerance_K": self.tolerance_K, "quantity": "receptor (display-driven)",
                "decisions": [d.to_dict() for d in self.decisions]}


def _step(layers, depth, resistance, ip):
    """The step response S at the probe times of inversion plan ``ip``."""
    tr = LayeredTransform(layers, _material("copper"), 0.0)     # the material is not used
    return np.concatenate([[0.0], ip.apply(tr.display_kernel(ip.s, depth, resistance) / ip.s)])


def _bound(dS, h_sup, h0, h_tv, perr=0.0):
    """The smaller right-hand side of the module's two bounds; ``perr``: each probe value of
    both step responses within ``perr`` of the exact one (the value at 0 is exact), so every
    probe of dS within 2 perr and each of its steps within 4 perr."""
    tv = float(np.sum(np.abs(np.diff(dS)))) + 4.0 * perr * (dS.size - 1)
    return min(h_sup * tv, (float(np.max(np.abs(dS))) + 2.0 * perr) * (abs(h0) + h_tv))


def plan_display(skin, depth: float, resistance: float, duration_s: float, rate_Hz: float,
                 h, *, tolerance: float, layered: bool = False,
                 perfusion_per_s: float = 0.0, screen: bool = True) -> DisplayPlan:
    """The cheapest model of a display-driven skin within ``tolerance`` (module docstring).

    Parameters
    ----------
    skin : Skin
    depth : float, m
        From the core (the receptors: ``skin.dermis``).
    resistance : float, m^2 K/W
        Finger-pad resistance (0: the surface temperature imposed on the skin).
    duration_s, rate_Hz : float
        The history's span and sampling (for the probe times).
    h : ndarray, K
        The surface history relative to the initial skin temperature.
    tolerance : float, K
    layered, perfusion_per_s : bool, float
        The full model's physics (as :class:`stimuli.scene.Scene`).
    screen : bool
        Decide without evaluating where a closed form or a screen can (as
        :func:`stimuli.planner.plan`): perfusion by :func:`stimuli.planner.perfusion_factor`
        x sup|h| when that fits the tolerance; the layers kept by :func:`_layers_matter`.
        ``False``: every effect evaluated at the probes.

    Returns
    -------
    DisplayPlan
    """
    perfused = float(perfusion_per_s) > 0.0
    decisions, current = [], (bool(layered), perfused)
    if not (layered or perfused):
        decisions.append(Decision("perfusion", False, 0.0, "none stated"))
        decisions.append(Decision("layered", False, 0.0, "none stated"))
        return DisplayPlan(False, False, tuple(decisions), 0.0, float(tolerance))
    # the scene planner's cheap probe inversion (PROBE_NODES per window, one dense product); its
    # error on a step response (bounded by 1) is within PROBE_INVERSION_ERROR
    # (tests/stimuli/test_display_planner.py::test_display_probe_inversion_error_bound)
    probes, ip = probe_plan(float(duration_s), float(rate_Hz), cheap=True)
    h = np.asarray(h, dtype=float)
    h_sup, h0 = float(np.max(np.abs(h))), float(h[0])
    inv = 2 * INVERSION_ERROR * max(h_sup, 1.0)
    w = float(perfusion_per_s) if perfused else None
    err, offset, ref = 0.0, 0.0, None
    for effect in ("perfusion", "layered"):
        if effect == "perfusion" and not current[1]:
            decisions.append(Decision("perfusion", False, 0.0, "none stated"))
            continue
        if effect == "layered" and not current[0]:
            decisions.append(Decision("layered", False, 0.0, "none stated"))
            continue
        note = ("Pennes perfusion of the dermis" if effect == "perfusion" else
                "epidermis and dermis properties (else Table 1's homogeneous skin)")
        if screen and effect == "perfusion":
            b = perfusion_factor(skin, bool(layered), w, None, float(duration_s)) * h_sup
            if b + inv <= float(tolerance):      # neglected without evaluating anything
                decisions.append(Decision(effect, False, b, note + "; bounded in closed form "
                                          "(maximum principle), not evaluated"))
                current, err, offset = (current[0], False), b + inv, b
                continue
        if screen and effect == "layered":
            why = _layers_matter(skin, depth, resistance, float(duration_s), float(rate_Hz), h,
                                 float(tolerance))
            if why is None and ref is None:
                need = LAYER_LOWER_SCREEN * float(tolerance) + offset
                low = _layers_lower_bound(skin, depth, resistance, float(rate_Hz), h, w if current[1]
                                          else None, need)
                if low >= need:
                    why = (f"kept without evaluation: its effect is at least {low - offset:.3g} K "
                           f"(Laplace-domain lower bound, >= {LAYER_LOWER_SCREEN:g} x the tolerance)")
            if why is not None:
                decisions.append(Decision(effect, True, math.nan, why))
                continue
        if ref is None:     # the full model, or without perfusion when its closed form dropped it
            ref = _step(skin_layers(skin, layered=bool(layered), perfusion=w if current[1] else None),
                        depth, resistance, ip)
            h_tv = float(np.sum(np.abs(np.diff(h))))
        cand = (current[0], False) if effect == "perfusion" else (False, current[1])
        val = _step(skin_layers(skin, layered=cand[0], perfusion=w if cand[1] else None),
                    depth, resistance, ip)
        b = SAFETY * _bound(val - ref, h_sup, h0, h_tv, PROBE_INVERSION_ERROR) + inv
        if offset:
            b += offset
        if b <= float(tolerance):
            decisions.append(Decision(effect, False, b, note))
            current, err = cand, b
        else:
            decisions.append(Decision(effect, True, b, note))
    return DisplayPlan(current[0], current[1], tuple(decisions), float(err), float(tolerance))


#: The layers are kept without evaluation when their quasi-steady effect is this many tolerances.
LAYER_SCREEN = 4.0


def _layers_matter(skin, depth, resistance, duration_s, rate_Hz, h, tolerance):
    """Why layered skin certainly matters at ``depth`` under the history ``h`` (screen), or None.

    A drive held at |h| >= H over the last two diffusion times of the skin (2 L^2 / alpha, Table
    1's skin) leaves the skin quasi-steady: the deficit at ``depth`` is about its share of the
    skin's series resistance below it (d/k_d / (d/k_d + (L - d)/k_e) with the layers, depth / L
    without) times the surface's share r / (r + R_pad) of H. When the two models differ by
    ``LAYER_SCREEN`` tolerances the layers are kept without evaluation (keeping is safe; it only
    saves the planner's time). ``tests/stimuli/test_display_planner.py`` checks on a grid that
    every screened keep is an evaluated keep.
    """
    from .layered import layer_rows
    L = skin.thickness
    window = 2.0 * L * L / skin.diffusivity
    if duration_s < window:
        return None
    n = int(round(window * rate_Hz)) + 1
    H = float(np.min(np.abs(h[-n:])))
    est = []
    for layered in (True, False):
        rows = layer_rows(skin, layered=layered)
        r = [row[0] / row[1] for row in rows]
        below, lo = 0.0, 0.0
        for (thick, k, *_rest) in rows:
            below += (min(depth, lo + thick) - lo) / k if depth > lo else 0.0
            lo += thick
        est.append(below / sum(r) * sum(r) / (sum(r) + resistance))
    effect = abs(est[0] - est[1]) * H
    if effect < LAYER_SCREEN * tolerance:
        return None
    return (f"kept without evaluation: the quasi-steady deficit at the receptor differs by "
            f"{effect:.3g} K with the layers (>= {LAYER_SCREEN:g} x the tolerance)")


def display_kernel_real(skin, layered: bool, perfusion, depth: float, resistance: float,
                        s: float) -> float:
    """:meth:`stimuli.layered.LayeredTransform.display_kernel` at a real s > 0, in plain floats."""
    r, Zs = real_point(layer_rows(skin, layered=layered, perfusion=perfusion), s, depth)
    return r / (Zs + resistance)


@lru_cache(maxsize=16)
def _weights(n: int, rate_Hz: float, a: float) -> np.ndarray:
    """W with W . h = sum_{i < n} (h_{i+1} - h_i) exp(-s t_i), t_i = i / rate_Hz,
    s = a / (n / rate_Hz), for n + 1 samples h (read-only, shared)."""
    e = np.exp(-(a * rate_Hz / n) * (np.arange(n) / rate_Hz))
    w = np.empty(n + 1)
    w[0] = -e[0]
    w[1:n] = e[:-1] - e[1:]
    w[n] = e[-1]
    w.setflags(write=False)
    return w


def _history_transform(h: np.ndarray, rate_Hz: float, a: float) -> float:
    """L[h](s) at s = a / T of the history as the models take it (piecewise linear between the
    samples, from h[0] at 0+; held at h[-1] after T = (len(h) - 1) / rate_Hz):
    h0 / s + (1 - e^{-s dt}) / (s^2 dt) sum_i (h_{i+1} - h_i) e^{-s t_i}."""
    n = h.size - 1
    dt = 1.0 / rate_Hz
    s = a / (n * dt)
    # einsum, not np.dot: a BLAS dot of this length may wake BLAS threads (ms on a busy machine)
    return h[0] / s + (-math.expm1(-s * dt)) / (s * s * dt) * float(
        np.einsum("i,i->", h, _weights(n, rate_Hz, a)))


def _layers_lower_bound(skin, depth, resistance, rate_Hz, h, perfusion, need) -> float:
    r"""A lower bound (K) on max_{t <= T} |Delta u| between the homogeneous and the layered skin
    under the history h (``perfusion``: both models' perfusion, or None), from real s.

    With h held after T, |Delta u| <= |u_1| + |u_2| <= sup|h| (S_1(inf) + S_2(inf)) at every
    time (each step response S_i grows from 0 to its steady value, at most the unperfused
    steady share of the resistance below ``depth``, (below) / (r + R)), so M = max over [0, T]
    obeys |L[Delta u](s)| <= M (1 - e^{-sT}) / s + sup|h| (S_1 + S_2)(inf) e^{-sT} / s, with
    L[Delta u](s) = (K_layered - K_homogeneous)(s) L[h](s) exactly (:func:`_history_transform`).
    The largest over s T in :data:`stimuli.planner_bounds.LAYER_LAPLACE_ST` (stopping at ``need``).
    """
    if h.size < 2:
        return -math.inf
    T = (h.size - 1) / rate_Hz
    tail = 0.0                          # sup|h| (S_1 + S_2)(inf)
    for layered in (True, False):
        below, total, lo = 0.0, resistance, 0.0
        for thick, k, *_rest in layer_rows(skin, layered=layered):
            below += (min(depth, lo + thick) - lo) / k if depth > lo else 0.0
            total += thick / k
            lo += thick
        tail += below / total
    tail *= float(np.max(np.abs(h)))
    best = -math.inf
    for a in LAYER_LAPLACE_ST:
        s = a / T
        dK = (display_kernel_real(skin, True, perfusion, depth, resistance, s)
              - display_kernel_real(skin, False, perfusion, depth, resistance, s))
        e = math.exp(-a)
        best = max(best, (s * abs(dK * _history_transform(h, rate_Hz, a)) - tail * e) / (1.0 - e))
        if best >= need:
            break
    return best


#: The layers are kept without evaluation when the lower bound of their effect
#: (:func:`_layers_lower_bound`) is this many tolerances (> 1: neglecting them would certainly
#: break the tolerance; the margin covers the production inversion's error).
LAYER_LOWER_SCREEN = 1.5


def planned_skin_response(skin, t, surface_temperature, initial_temperature: float, *,
                          depth: float | None = None, resistance: float | None = None,
                          tolerance: float | None = None, layered: bool = False,
                          perfusion_per_s: float = 0.0):
    """The display-driven receptor temperature, by the planned model (the production chokepoint).

    Parameters
    ----------
    skin : Skin
    t : array_like, s
        Uniform times from 0.
    surface_temperature : array_like, °C
    initial_temperature : float, °C
    depth : float or None, m
        From the core; None: ``skin.dermis`` (the receptors).
    resistance : float or None, m^2 K/W
    tolerance : float or None, K
        Default :data:`stimuli.scene.PERCEPTUAL_FLOOR_K`.
    layered, perfusion_per_s : bool, float
        The physics as known (the full model).

    Returns
    -------
    T : ndarray, °C
    plan : DisplayPlan
    """
    from .display_response import skin_response
    from .scene import PERCEPTUAL_FLOOR_K
    t = np.asarray(t, dtype=float)
    g = np.asarray(surface_temperature, dtype=float)
    x = skin.dermis if depth is None else float(depth)
    R = 0.0 if resistance is None else float(resistance)
    tol = PERCEPTUAL_FLOOR_K if tolerance is None else float(tolerance)
    dt = float(t[1] - t[0]) if t.size > 1 else 1.0
    rate = 1.0 / dt
    duration = max(round(float(t[-1]) * rate) / rate, dt)
    p = plan_display(skin, x, R, duration, rate, g - float(initial_temperature), tolerance=tol,
                     layered=layered, perfusion_per_s=perfusion_per_s)
    if not (p.layered or p.perfusion):
        T = skin_response(skin, t, g, initial_temperature=initial_temperature, depth=x,
                          resistance=None if R == 0.0 else R)
    else:
        w = float(perfusion_per_s) if p.perfusion else None
        T = layered_skin_response(skin_layers(skin, layered=p.layered, perfusion=w), t, g,
                                  float(initial_temperature), x, R)
    return np.asarray(T, dtype=float), p

