r"""The scene planner: the cheapest model whose every neglected effect stays within the tolerance.

:func:`plan` starts from the scene's full model (every effect it states, :meth:`Scene.full_model`)
and drops effects one at a time, most expensive first (the pad's sensor lag, perfusion, the
slab's support, the slab itself, the skin's layers), then tries the paper's closed form (Eq. 7,
when the question is the material-side interface of homogeneous skin on a half-space). A drop is
kept when the model without it still agrees with the full model within the tolerance.

How the error is bounded (cheaply, and checked)
-----------------------------------------------
* The full model and each candidate are evaluated at ~20 probe times (the first three samples,
  geometric and uniform times to the end) with one shared, cheap :class:`stimuli.exact.InversionPlan`
  (``PROBE_NODES`` = 12 nodes per window instead of 24, each probe value within
  ``PROBE_INVERSION_ERROR`` x |Delta T| of the exact one); the candidate's error is ``SAFETY`` (1.5)
  x (its largest difference from the full model there + both probe inversions' bounds), plus both
  production inversions' bounds. Between probes the temperatures are smooth, monotone or
  single-humped; the factor covers the probes missing the worst time. The test
  ``tests/stimuli/test_planner.py`` evaluates planned and full models at every sample of a grid of
  scenes and asserts the error is within the tolerance -- a bound that is wrong fails there.
* The sensor lag is not evaluated: a first-order lag of tau changes a signal by at most
  tau sup |dT/dt|, with the sup over the profile's sampled slopes (a jump at contact counts as
  its slope over the first sample); it applies to the interface quantities (what a sensor reads)
  and is "not applicable" to the receptor.
* Perfusion is first bounded in closed form (:func:`perfusion_bound`, the maximum principle),
  then, if that is too loose, in the Laplace domain (:func:`perfusion_laplace_bound`: a majorant
  that grows in time, bounded by its transform at a real s); when either fits the tolerance it
  is neglected without evaluating anything, and the model without it becomes the reference of
  the later drops, its bound added to their errors.
* Screens (``screen=True``, production) keep an effect without evaluating it when it certainly
  matters: a warmed-through slab (:func:`_warmed_through`) and, at the receptor, layered skin
  whose quasi-steady effect is ``LAYER_SCREEN`` tolerances (:func:`_layers_matter`) or whose
  effect is at least ``LAYER_LOWER_SCREEN`` tolerances by a Laplace-domain lower bound
  (:func:`_effect_lower_bound`, exact transforms at a real s). Keeping
  is always safe; the tests check that every screened keep is an evaluated keep. With these,
  a cold layered, perfused scene is planned in ~0.07 of one exact evaluation
  (benchmarks/README.md). ``screen=False`` (``thermocue explain``) evaluates every effect.

The decisions (each effect: kept or neglected, the error its neglect causes, why) travel with
every profile (``TargetProfile.parameters["plan"]``, hence the session's events) and are
printed by ``thermocue explain``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .exact import INVERSION_ERROR, WINDOW_RATIO, InversionPlan
from .layered import BLOOD_HEAT_CAPACITY, layer_rows
from .properties import Material
from .scene import Model, Scene, evaluate

__all__ = ["plan", "planned_temperature", "plan_line", "Plan", "Decision", "SAFETY", "EFFECTS",
           "perfusion_bound", "perfusion_laplace_bound"]

#: Factor on the probe error for the times between probes (checked by the planner's grid test).
SAFETY = 1.5

#: Contour nodes per window of the probes' own inversion (production: 24). About a third of the
#: transform evaluations (52 instead of 150 for a 20 s scene at 1 kHz): the probes' cost is the
#: complex arithmetic at the nodes.
PROBE_NODES = 12

#: Bound on the absolute error of the probes' inversion (``PROBE_NODES``) of a function bounded
#: by 1 (theta). Measured against the production inversion (itself within ``INVERSION_ERROR`` of
#: mpmath) on every model the planner compares, over a grid of scenes: at most 1.7e-7
#: (``tests/stimuli/test_planner.py::test_probe_inversion_error_bound``); stated with a margin.
PROBE_INVERSION_ERROR = 1e-6

#: Effects, in the order they are tried for dropping.
EFFECTS = ("sensor", "perfusion", "support", "slab", "layered", "closed_form")


@dataclass(frozen=True)
class Decision:
    """One effect: ``included`` or neglected, ``bound_K`` = the error neglecting it causes (or
    would cause) at this scene, ``note`` = why, in words."""

    effect: str
    included: bool
    bound_K: float
    note: str

    def to_dict(self) -> dict:
        # JSON has no NaN (caches and session events are strict): an unevaluated bound is None
        return {"effect": self.effect, "included": self.included,
                "bound_K": None if math.isnan(self.bound_K) else self.bound_K, "note": self.note}


@dataclass(frozen=True)
class Plan:
    """The planner's answer: the model, each decision, and the planned model's error bound (K)."""

    scene: Scene
    model: Model
    full_model: Model
    decisions: tuple
    bound_K: float
    probe_times: np.ndarray

    def evaluate(self, t=None):
        """The scene's quantity with the planned model, °C."""
        return evaluate(self.scene, self.model, t)

    def to_dict(self) -> dict:
        """JSON-ready: the model, every decision, the bound and the tolerance."""
        return {"model": self.model.describe(), "method": self.model.method,
                "geometry": self.model.geometry, "layered": self.model.layered,
                "perfusion": self.model.perfusion, "sensor": self.model.sensor,
                "bound_K": self.bound_K, "tolerance_K": self.scene.tolerance_K,
                "quantity": self.scene.quantity,
                "decisions": [d.to_dict() for d in self.decisions]}

    def lines(self) -> list:
        """Human-readable explanation, one line each."""
        s = self.scene
        out = [f"scene: {s.quantity} over {s.duration_s:g} s at {s.rate_Hz:g} Hz, tolerance "
               f"{s.tolerance_K:g} K",
               f"model: {self.model.describe()} (bound {self.bound_K:.3g} K against the full "
               f"model: {self.full_model.describe()})"]
        for d in self.decisions:
            state = "kept     " if d.included else "neglected"
            out.append(f"  {state} {d.effect:<11s} {d.bound_K:10.3g} K  {d.note}")
        return out


def _probe_times(scene: Scene) -> np.ndarray:
    T, dt = scene.duration_s, 1.0 / scene.rate_Hz
    first = dt * np.arange(1, 4)
    geo = np.geomspace(min(4 * dt, T), T, 10)
    uni = np.linspace(T / 8, T, 8)
    t = np.unique(np.concatenate([first, geo, uni]))
    return t[(t > 0) & (t <= T)]


@lru_cache(maxsize=32)
def _probes(duration_s: float, rate_Hz: float, cheap: bool = False):
    """Probe times and their inversion plan, shared by every scene of that duration and rate.

    ``cheap``: ``PROBE_NODES`` per window, error within ``PROBE_INVERSION_ERROR`` (the scene
    planner's); else the production inversion, within ``INVERSION_ERROR`` (the display planner's).
    """
    t = _probe_times(Scene(duration_s=duration_s, rate_Hz=rate_Hz))
    t.setflags(write=False)
    if cheap:
        return t, _DensePlan(InversionPlan(t, nodes=PROBE_NODES, window_ratio=WINDOW_RATIO))
    return t, InversionPlan(t)


class _DensePlan:
    """An :class:`InversionPlan` of a few times applied as one complex matrix product.

    The same sums as ``plan.apply`` (``Im sum_k c_k exp(s_k t_j) f_k`` over each time's window),
    with the windows laid side by side in one (times x nodes) matrix that is zero outside each
    time's window: one call instead of one per window (the probes' times are few).
    """

    def __init__(self, plan: InversionPlan):
        self.s = plan.s
        self.shape = plan.shape
        W = np.zeros((plan._n, plan.s.size), dtype=complex)
        k = plan._k
        for i, j, a, c, basis in plan._windows:
            if basis[0] != "full":
                raise ValueError("_DensePlan: expected a few times per window")
            W[plan._order[i:j], a:a + k] = (basis[1] + 1j * basis[2]) * c
        self._W = W

    def apply(self, fs):
        return (self._W @ np.asarray(fs)).imag.reshape(self.shape)


def _with(model: Model, **changes) -> Model:
    """``dataclasses.replace`` for a :class:`Model` (a few times cheaper: the planner's hot path)."""
    d = {"method": model.method, "geometry": model.geometry, "layered": model.layered,
         "perfusion": model.perfusion, "sensor": model.sensor}
    d.update(changes)
    return Model(**d)


def _drop(model: Model, effect: str, scene: Scene) -> Model | None:
    """The model without ``effect``, or None when it does not hold it."""
    if effect == "perfusion" and model.perfusion:
        return _with(model, perfusion=False)
    if effect == "support" and model.geometry == "slab-on-support":
        return _with(model, geometry="slab")
    if effect == "slab" and model.geometry == "slab":
        return _with(model, geometry="half-space")
    if effect == "layered" and model.layered:
        return _with(model, layered=False)
    if effect == "closed_form" and model.method == "exact" and model.geometry == "half-space" \
            and not model.layered and not model.perfusion and scene.quantity == "interface_material":
        return _with(model, method="eq7")
    return None


_NOTES = {
    "perfusion": "Pennes perfusion of the dermis",
    "support": "the half-space the slab rests on",
    "slab": "the sample's finite thickness (else a half-space)",
    "layered": "epidermis and dermis properties (else Table 1's homogeneous skin)",
    "closed_form": "exact inversion (else the paper's printed Eq. 7)",
}


def plan(scene: Scene, *, screen: bool = True) -> Plan:
    """The cheapest model of ``scene`` within its tolerance (see the module docstring).

    Parameters
    ----------
    scene : Scene
    screen : bool
        Keep, without evaluating it, a slab that is certainly warmed through over the scene
        (D < sqrt(alpha_M t_end) / 2: its back is felt within the scene, by kelvins on metals);
        keeping an effect is always safe, so this only saves the planner's time. Its decision then
        has ``bound_K = nan``. Likewise layered skin at the receptor (:func:`_layers_matter`), and
        perfusion neglected by its closed form (:func:`perfusion_bound`) when that fits.
        ``False`` evaluates every effect (``thermocue explain``).

    Returns
    -------
    Plan

    Examples
    --------
    >>> from stimuli.scene import Scene
    >>> p = plan(Scene(quantity="receptor", perfusion_per_s=1.25e-3, tolerance_K=0.3))
    >>> p.model.describe()                  # the 3 mm slab matters, perfusion does not
    'exact, slab, homogeneous skin'
    >>> [(d.effect, d.included) for d in p.decisions]
    [('sensor', False), ('perfusion', False), ('slab', True)]
    """
    return _plan(_resolved(scene), bool(screen))


def _resolved(scene: Scene) -> Scene:
    """The scene with Eq. 5 and the material names resolved once (evaluations repeat them)."""
    # the scene was validated when it was made; these are values derived from it, so the copy is
    # not validated again (Scene.replace would: ~10 us of the planner's ~60 us on a cold scene)
    out = object.__new__(Scene)
    out.__dict__.update(scene.__dict__)
    for k, v in (("resistance", scene.contact_resistance),
                 ("material", _half_space(scene)),
                 ("support", None if scene.support is None else scene.support_object())):
        object.__setattr__(out, k, v)
    return out


_PERFUSION_NOTE = "bounded in closed form (maximum principle), not evaluated"
_PERFUSION_LAPLACE_NOTE = ("bounded in the Laplace domain (maximum principle, a majorant that grows "
                           "in time), not evaluated")


def perfusion_bound(scene: Scene, skin=None) -> float:
    r"""A closed-form bound (K) on what Pennes perfusion changes over the scene, any quantity.

    With perfusion the deficit u = 1 - theta obeys rho c u_t = (k u_x)_x - w rho_b c_b u in the
    perfused layers (arterial blood at the core temperature). The difference d >= 0 between the
    models without and with perfusion obeys the unperfused, coupled (skin, contact resistance,
    sample) equations with the heat source w rho_b c_b u >= 0 and zero initial and core values.
    By the maximum principle (comparison with supersolutions):

    * u <= u_top in the perfused layers: 0 <= theta <= 1 everywhere, so the skin's surface
      deficit is <= 1, and the steady deficit of the skin with its surface held at the material's
      temperature, u_ss(x) = (series resistance core..x) / (the skin's), is a supersolution of
      the perfused skin; it grows with x, so u <= u_top = u_ss(P), P the top of the perfused
      layers (the dermis; the surface for perfused homogeneous skin);
    * d <= m_max u_top t (m = w rho_b c_b / (rho c)), a function of t alone: a supersolution in
      the skin, across the contact (no flux) and in the sample (no source);
    * d <= S(L) = integral_0^L Q (P - min(x, P)) / k(x) dx, Q = w rho_b c_b u_top: the steady
      temperature of the skin heated by Q in its perfused layers, held at 0 at the core and
      insulated at the surface (the sample held at S(L)) -- a steady supersolution.

    So |Delta T| <= min(m_max u_top T, S(L)) |T_S0 - T_M0| at every time up to T = ``duration_s``
    and for every quantity (receptor, interfaces). Table 1's layered skin at 0.4 L under
    1.25e-3 /s: 0.0058 K at 15.5 K (u_top = 0.44, the dermis's S(L)); perfused homogeneous skin of
    650 um: 0.048 K. ``tests/stimuli/test_planner.py`` compares it with the effect the exact
    models compute on hard cases. Returns 0 when the scene states no perfusion.

    Examples
    --------
    >>> round(perfusion_bound(Scene(layered=True, perfusion_per_s=1.25e-3)), 4)
    0.0058
    """
    if not scene.perfusion_per_s > 0:
        return 0.0
    dT = abs(scene.skin_temperature_C - scene.material_temperature_C)
    return perfusion_factor(scene.skin if skin is None else skin, scene.layered,
                            scene.perfusion_per_s, scene.hypodermis_m, scene.duration_s) * dT


def perfusion_factor(skin, layered: bool, perfusion_per_s: float, hypodermis_m, duration_s: float) -> float:
    """min(m u_top T, S(L)) per kelvin of the skin's surface deficit (:func:`perfusion_bound`).

    Also the display-driven planner's bound (:mod:`stimuli.display_planner`): there the surface
    is driven through the pad by h(t), so |u| <= sup|h| in the skin, and the same two
    supersolutions (they carry no flux through the surface) give |Delta u| <= this x sup|h|.
    """
    # (thickness, conductivity, density, specific heat, perfusion, name), core to surface
    layers = layer_rows(skin, layered=layered, perfusion=perfusion_per_s, hypodermis=hypodermis_m)
    # one pass (the planner's cold path): the series resistance and depth up to the top perfused
    # layer (P), the largest m and w; the same sums, in the same order, as written out
    rs = r_top = P = depth = m = w_max = 0.0
    top = -1
    for i, (h, k, rho, c, w, _n) in enumerate(layers):
        rs += h / k
        depth += h
        if w > 0:
            top, r_top, P = i, rs, depth
            m = max(m, w * BLOOD_HEAT_CAPACITY / (rho * c))
            w_max = max(w_max, w)
    u_top = min(1.0, r_top / rs)
    Q = w_max * BLOOD_HEAT_CAPACITY * u_top
    S, lo = 0.0, 0.0
    for h, k, *_ in layers[:top + 1]:            # above P the heat flux is 0: S is flat
        hi = lo + h
        S += Q * ((P - lo) ** 2 - (P - hi) ** 2) / (2.0 * k)
        lo = hi
    return min(m * u_top * duration_s, S)


#: s T of the real Laplace variables tried, in order, by :func:`perfusion_laplace_bound`
#: (the first that fits the tolerance ends the search) and by :func:`_effect_lower_bound`.
PERFUSION_LAPLACE_ST = (0.5, 0.25, 1.0)
LAYER_LAPLACE_ST = (8.0, 4.0, 16.0)

#: The layers are kept without evaluation when a lower bound of their effect
#: (Laplace domain, :func:`_effect_lower_bound`) is at least this many tolerances.
LAYER_LOWER_SCREEN = 2.0


def _real_point(rows, s: float, x: float, perfused: bool = True):
    """The deficit at x (from the core) per unit flux into the surface, and Z_S, of the stack
    ``rows`` (:func:`stimuli.layered.layer_rows`) at a real s > 0, in one pass from the core up.

    :class:`stimuli.layered.LayeredTransform`'s transmission lines (``skin_ratio``,
    ``surface_impedance``) in plain floats: a real s needs no overflow guard, and one pass
    without per-layer lists keeps the planner's cold path short. ``perfused=False`` drops every
    layer's perfusion.
    """
    Z, ratio, inside, lo = 0.0, 1.0, 1.0, 0.0
    found = False
    n = len(rows)
    for i, (h, k, rho, c, w, _name) in enumerate(rows):
        rc = rho * c
        q = math.sqrt((s + (w * BLOOD_HEAT_CAPACITY / rc if perfused and w else 0.0)) * rc / k)
        z = 1.0 / (k * q)
        e = math.exp(-q * h)
        e2 = e * e
        th = (1.0 - e2) / (1.0 + e2)
        den = 1.0 + Z / z * th
        if found:                                   # a layer above x's: its flux ratio
            ratio *= 2.0 * e / (1.0 + e2) / den
        elif x <= lo + h or i == n - 1:             # x's layer (searchsorted "left")
            xi = x - lo
            exi = math.exp(-2.0 * q * xi)
            inside = (math.exp(-q * (h - xi)) * (1.0 + exi) / (1.0 + e2)
                      * (Z + z * (1.0 - exi) / (1.0 + exi)) / den)
            found = True
        lo += h
        Z = (Z + z * th) / den
    return ratio * inside, Z


def _real_material(scene: Scene, geometry: str, s: float) -> float:
    """Z_M of the scene's sample in ``geometry`` at a real s > 0."""
    m = _half_space(scene)
    qm = math.sqrt(s / m.diffusivity)
    zm = 1.0 / (m.conductivity * qm)
    if geometry == "half-space":
        return zm
    th = math.tanh(qm * _slab_thickness(scene))
    Y = 0.0
    if geometry == "slab-on-support":
        sup = scene.support_object()
        Y = sup.conductivity * math.sqrt(s / sup.diffusivity)
    return zm * (1.0 + zm * Y * th) / (zm * Y + th)


def _rows(scene: Scene, model: Model, skin, perfusion: bool | None = None):
    w = scene.perfusion_per_s if (model.perfusion if perfusion is None else perfusion) else None
    return layer_rows(skin, layered=model.layered, perfusion=w, hypodermis=scene.hypodermis_m)


def _real_quantity(scene: Scene, model: Model, skin, s: float, Zm: float | None = None) -> float:
    """The transform, at a real s > 0, of the scene's quantity in theta units under ``model``
    (exact): the skin's deficit 1 - theta at the receptor or surface, the sample's theta
    (``Zm``: the sample's impedance at s when known)."""
    rows = _rows(scene, model, skin)
    L = 0.0
    for row in rows:
        L += row[0]
    r, Zs = _real_point(rows, s, L - scene.receptor_depth if scene.quantity == "receptor" else L)
    if Zm is None:
        Zm = _real_material(scene, model.geometry, s)
    F = 1.0 / (s * (scene.contact_resistance + Zs + Zm))
    if scene.quantity == "interface_material":
        return F * Zm
    return F * r


def perfusion_laplace_bound(scene: Scene, model: Model, skin=None, tolerance: float = 0.0) -> float:
    r"""A bound (K) on what perfusion changes, from the Laplace transform at a few real s.

    Tighter than :func:`perfusion_bound` where heat leaks out of the skin within the scene (a
    thick skin or a hypodermis: 0.14 K against 0.53 K at the benchmark's scene with 2 mm of
    hypodermis; the exact effect is 0.059 K). The argument (d = the deficit without perfusion
    minus with it, >= 0, as in :func:`perfusion_bound`; ``model`` holds the geometry and layers):

    * d obeys the coupled unperfused equations with the source w rho_b c_b u_p, u_p the perfused
      deficit. u_p <= w_R, the perfused skin alone whose surface is coupled through R to a bath
      at deficit 1 (the sample's theta >= 0): a supersolution. The coupled system's Green's
      function is positive, so d <= d*, its response to the source w rho_b c_b w_R.
    * w_R does not decrease in time (w_R(t + h) >= w_R(t): the same problem from the initial
      data w_R(h) >= 0), so neither does d* (Duhamel with a positive kernel); hence for every
      s > 0, d*(T) e^{-sT} / s <= L[d*](s), i.e. sup_{t <= T} d <= d*(T) <= s e^{sT} L[d*](s).
    * L[d*] in closed form: the unperfused operator differs from the perfused one by exactly the
      source's rho c m, so d* = -w_R + H with H unperfused and grounded at the core; matching the
      contact gives the flux into the sample J = a (Z_0 - Z_p) / (R + Z_M + Z_0), a = 1 / (s (R +
      Z_p)), and d*(x) = (a - J) r_0(x) - a r_p(x) in the skin (r: deficit per unit surface flux;
      Z_0, Z_p: the unperfused and perfused skin's impedances), Z_M J at the sample's surface.

    The smallest over s T in :data:`PERFUSION_LAPLACE_ST` (stopping at the first within
    ``tolerance``), times |T_S0 - T_M0|. ``tests/stimuli/test_planner.py`` compares it with the
    effect the exact models compute on hard cases.
    """
    if not scene.perfusion_per_s > 0:
        return 0.0
    skin = scene.skin if skin is None else skin
    dT = abs(scene.skin_temperature_C - scene.material_temperature_C)
    rows = _rows(scene, model, skin, perfusion=True)
    L = 0.0
    for row in rows:
        L += row[0]
    x = L - scene.receptor_depth if scene.quantity == "receptor" else L
    R, T = scene.contact_resistance, scene.duration_s
    best = math.inf
    for a in PERFUSION_LAPLACE_ST:
        s = a / T
        r_p, Zp = _real_point(rows, s, x, True)
        r_0, Z0 = _real_point(rows, s, x, False)
        Zm = _real_material(scene, model.geometry, s)
        A = 1.0 / (s * (R + Zp))
        J = A * (Z0 - Zp) / (R + Zm + Z0)
        if scene.quantity == "interface_material":
            d = Zm * J
        elif scene.quantity == "interface_skin":
            d = (R + Zm) * J
        else:
            d = (A - J) * r_0 - A * r_p
        best = min(best, s * math.exp(a) * max(d, 0.0) * dT)
        if best <= tolerance:
            break
    return best


def _lower_screen(scene: Scene, ref: Model, cand: Model, skin, tol: float, offset: float):
    """Why dropping ``cand``'s effect from ``ref`` (itself within ``offset`` of the full model)
    certainly breaks the tolerance (screen: the effect kept without evaluation), or None."""
    need = LAYER_LOWER_SCREEN * tol + offset
    low = _effect_lower_bound(scene, ref, cand, skin, need)
    if low < need:
        return None
    return (f"kept without evaluation: its effect is at least {low - offset:.3g} K "
            f"(Laplace-domain lower bound, >= {LAYER_LOWER_SCREEN:g} x the tolerance)")


def _effect_lower_bound(scene: Scene, ref: Model, cand: Model, skin, need: float) -> float:
    r"""A lower bound (K) on max_{t <= T} |cand - ref| (exact models), from real s transforms.

    For Delta = cand - ref in theta units, |Delta| <= 1 at every time (both within [0, 1]), so
    |L[Delta](s)| <= M (1 - e^{-sT}) / s + e^{-sT} / s with M the max over [0, T]:
    M >= (s |L[Delta](s)| - e^{-sT}) / (1 - e^{-sT}). The largest over s T in
    :data:`LAYER_LAPLACE_ST` (stopping once ``need`` is reached), times |T_S0 - T_M0|. Used for
    the layers; perfusion's effect keeps growing after T (its tail bound is too loose to help).
    """
    dT = abs(scene.skin_temperature_C - scene.material_temperature_C)
    best = -math.inf
    for a in LAYER_LAPLACE_ST:
        s = a / scene.duration_s
        Zm = _real_material(scene, ref.geometry, s)
        d = abs(_real_quantity(scene, cand, skin, s, Zm if cand.geometry == ref.geometry else None)
                - _real_quantity(scene, ref, skin, s, Zm))
        e = math.exp(-a)
        best = max(best, (s * d - e) / (1.0 - e) * dT)
        if best >= need:
            break
    return best


#: The layers are kept without evaluation when their steady effect at the receptor is at least
#: this many tolerances (:func:`_layers_matter`).
LAYER_SCREEN = 4.0


def _layers_matter(scene: Scene, skin=None) -> str | None:
    """Why the scene's layered skin certainly matters at the receptor (screen), or None.

    Once the scene is longer than the skin's diffusion time L^2 / alpha (Table 1's skin), the
    skin is quasi-steady: the receptor's deficit is about its share of the skin's series
    resistance below it -- d/k_d / (d/k_d + (L - d)/k_e) with the layers, d/L without (a
    hypodermis below adds to both) -- times the surface deficit r / (r + R + Z_M), r the skin's
    resistance and Z_M the sample's impedance at s = 1/T (a half-space sqrt(alpha_M T)/k_M, a
    slab's larger by coth(D / sqrt(alpha_M T)), its support in parallel): the end of the scene,
    when a half-space or an insulated slab draws the least. When the two models' estimates differ
    by ``LAYER_SCREEN`` tolerances the layers are kept without evaluating them -- keeping an
    effect is always safe, and at production nodes the layered transform costs the same as the
    homogeneous one, so this only saves the planner's time. ``tests/stimuli/test_planner.py``
    checks on a grid that whenever the screen keeps the layers, evaluating them
    (``screen=False``) keeps them too.
    """
    if scene.quantity != "receptor" or not scene.layered:
        return None
    skin = scene.skin if skin is None else skin
    L = skin.thickness + (scene.hypodermis_m or 0.0)
    T = scene.duration_s
    if T < L * L / skin.diffusivity:
        return None
    m = _half_space(scene)
    ell = math.sqrt(m.diffusivity * T)
    Zm = ell / m.conductivity                                   # half-space at s = 1/T
    if scene.geometry != "half-space":
        x = _slab_thickness(scene) / ell
        Yb = 0.0
        if scene.geometry == "slab-on-support":
            sup = scene.support_object()
            Yb = sup.conductivity / math.sqrt(sup.diffusivity * T)
        th = math.tanh(x)
        Zm = Zm * (1.0 + Zm * Yb * th) / (Zm * Yb + th)
    est = []
    for layered in (True, False):
        r = [h / k for h, k, *_ in layer_rows(skin, layered=layered, hypodermis=scene.hypodermis_m)]
        below = r[:-1] if layered else r[:-1] + [skin.dermis / skin.conductivity]
        rs = sum(r)
        est.append(sum(below) / rs * rs / (rs + scene.contact_resistance + Zm))
    effect = abs(est[0] - est[1]) * abs(scene.skin_temperature_C - scene.material_temperature_C)
    if effect < LAYER_SCREEN * scene.tolerance_K:
        return None
    return (f"kept without evaluation: the receptor's quasi-steady deficit differs by "
            f"{effect:.3g} K with the layers (>= {LAYER_SCREEN:g} x the tolerance)")


def _half_space(scene: Scene) -> Material:
    """The scene's material as a half-space (the resolved scene holds it: no copy to build)."""
    m = scene.material
    if isinstance(m, Material) and m.thickness is None:
        return m
    if isinstance(m, str):
        return _named(m)
    return scene.material_object("half-space")


@lru_cache(maxsize=64)
def _skin(thickness: float, dermis: float):
    """``Scene.skin`` (an immutable :class:`stimuli.properties.Skin`), validated once per value."""
    from .properties import Skin
    return Skin(thickness, dermis=dermis)


@lru_cache(maxsize=64)
def _named(name: str) -> Material:
    """A material by name, as a half-space (immutable: looked up once per name)."""
    from .materials import material
    return material(name)


def _slab_thickness(scene: Scene) -> float:
    """D of the scene's slab, m (as ``scene.material_object("slab").thickness``)."""
    D = scene.sample_thickness_m if scene.effective_thickness_m is None else scene.effective_thickness_m
    return float(D)


def _warmed_through(scene: Scene) -> str | None:
    """Why the scene's slab certainly matters (screen), or None."""
    D = _slab_thickness(scene)
    reach = math.sqrt(_half_space(scene).diffusivity * scene.duration_s)
    if D < 0.5 * reach:
        return (f"kept without evaluation: the {D * 1e3:.3g} mm slab is warmed through "
                f"(sqrt(alpha t) = {reach * 1e3:.3g} mm at {scene.duration_s:g} s)")
    return None


def _at_probes(scene: Scene, model: Model, probes: np.ndarray, ip: InversionPlan) -> np.ndarray:
    """:func:`stimuli.scene.evaluate` at the probe times (all > 0), without its per-call checks.

    The same transform and inversion as ``evaluate(scene, model, probes, plan=ip)`` (equal to
    the last bit; ``tests/stimuli/test_planner.py`` checks it), minus the validation of times
    the planner made itself: ~30 % of the planner's cost on a cold multi-effect scene.
    """
    if model.method != "exact":
        return evaluate(scene, model, probes)
    from .scene import _contact
    c = _contact(scene, model)
    tr = c.transform
    if scene.quantity == "interface_material":
        theta = ip.apply(tr.material_rise(ip.s, tr.L))
    else:
        x = c.thickness - scene.receptor_depth if scene.quantity == "receptor" else tr.L
        theta = 1.0 - ip.apply(tr.skin_deficit(ip.s, float(x)))
    T = c.material_initial + (c.skin_initial - c.material_initial) * theta
    if model.sensor and scene.sensor_time_constant_s > 0:      # never for the planner's candidates
        return evaluate(scene, model, probes, plan=ip)
    return T


@lru_cache(maxsize=256)
def _plan(scene: Scene, screen: bool = True) -> Plan:
    full = scene.full_model()
    probes, ip = _probes(scene.duration_s, scene.rate_Hz, cheap=True)
    dT = abs(scene.skin_temperature_C - scene.material_temperature_C)
    inv = INVERSION_ERROR * dT                  # a production evaluation's inversion error
    pinv = PROBE_INVERSION_ERROR * dT           # a probe value's inversion error
    base = _with(full, sensor=False)
    tol = scene.tolerance_K
    decisions = []
    cache = {}
    ref_model, ref_offset = base, 0.0

    def skin():
        if "skin" not in cache:
            L = scene.skin_thickness_m
            cache["skin"] = _skin(L, L - scene.receptor_depth)     # = scene.skin, made once
        return cache["skin"]

    def reference():
        # the model every candidate is compared with: the full model, or the full model without
        # perfusion when its closed-form bound (ref_offset, added to every error) neglected it
        # (never after an evaluation: the sensor's bound evaluates the full model first)
        if "ref" not in cache:
            cache["ref"] = _at_probes(scene, ref_model, probes, ip)
        return cache["ref"]

    # the sensor: tau sup|dT/dt|, analytic
    sensor_bound = 0.0
    if scene.sensor_time_constant_s > 0:
        if scene.quantity == "receptor":
            decisions.append(Decision("sensor", False, 0.0, "not applicable: the receptor is not "
                                      "read by the pad's sensor"))
        else:
            tt = np.concatenate([[0.0], probes])
            T0 = evaluate(scene, base, np.array([0.0]))
            vals = np.concatenate([T0, reference()])
            # each probe value is within pinv of the exact one (the value at 0 is exact)
            rate = float(np.max((np.abs(np.diff(vals)) + 2.0 * pinv) / np.diff(tt)))
            b = scene.sensor_time_constant_s * rate
            keep = b + inv > tol
            if not keep:
                sensor_bound = b
            decisions.append(Decision("sensor", keep, b, f"tau {scene.sensor_time_constant_s:g} s x "
                                      f"max |dT/dt| {rate:.3g} K/s"))
    else:
        decisions.append(Decision("sensor", False, 0.0, "no sensor lag stated"))

    current, current_err, prev = base, 0.0, None
    for effect in EFFECTS[1:]:
        cand = _drop(current, effect, scene)
        if cand is None:
            if effect == "slab" and current.geometry == "slab-on-support":
                decisions.append(Decision("slab", True, math.nan, "kept with its support"))
            continue
        why = _warmed_through(scene) if (screen and effect == "slab") else None
        if why is not None:
            decisions.append(Decision(effect, True, math.nan, why))
            continue
        why = _layers_matter(scene, skin()) if (screen and effect == "layered") else None
        if why is None and screen and effect == "layered":
            why = _lower_screen(scene, ref_model, cand, skin(), tol, ref_offset)
        if why is not None:
            decisions.append(Decision(effect, True, math.nan, why))
            continue
        if screen and effect == "perfusion" and "ref" not in cache:
            b = perfusion_bound(scene, skin())
            err = b + inv + inv + sensor_bound
            if err <= tol:          # neglected by the closed form, without evaluating anything
                decisions.append(Decision(effect, False, b, _NOTES[effect] + "; " + _PERFUSION_NOTE))
                current, current_err, ref_model, ref_offset = cand, err, cand, b
                continue
            # where heat leaks out of the skin within the scene: the Laplace-domain bound
            b = perfusion_laplace_bound(scene, current, skin(), tol - inv - inv - sensor_bound)
            err = b + inv + inv + sensor_bound
            if err <= tol:
                decisions.append(Decision(effect, False, b, _NOTES[effect] + "; " + _PERFUSION_LAPLACE_NOTE))
                current, current_err, ref_model, ref_offset = cand, err, cand, b
                continue
        ref = reference()
        prev = ref if prev is None else prev
        val = _at_probes(scene, cand, probes, ip)
        # probe differences are within 2 pinv of the exact ones (pinv each side; Eq. 7 is exact)
        cand_p = pinv if cand.method == "exact" else 0.0
        step = SAFETY * (float(np.max(np.abs(val - prev))) + pinv + cand_p)
        cand_inv = inv if cand.method == "exact" else 0.0
        err = SAFETY * (float(np.max(np.abs(val - ref))) + pinv + cand_p) + inv + cand_inv + sensor_bound
        if ref_offset:
            err += ref_offset
        if err <= tol:
            decisions.append(Decision(effect, False, step, _NOTES[effect]))
            current, current_err, prev = cand, err, val
        else:
            decisions.append(Decision(effect, True, step, _NOTES[effect]))
    model = _with(current, sensor=full.sensor and sensor_bound == 0.0 and scene.quantity != "receptor")
    bound = max(current_err, sensor_bound + inv)
    return Plan(scene, model, full, tuple(decisions), float(bound), probes)


def planned_temperature(quantity: str, skin, material, resistance: float, skin_temperature: float,
                        material_temperature: float, t, *, tolerance: float | None = None,
                        **physics):
    """One production call: the scene of a contact, planned, then evaluated at times ``t``.

    The chokepoint the simulated participant and the emulator's finger use instead of building a
    :class:`stimuli.Contact` themselves, so that every production temperature is computed by the
    planned model (:func:`plan`).

    Parameters
    ----------
    quantity : {"receptor", "interface_material", "interface_skin"}
    skin : Skin
        Thickness L and receptor depth (``L - skin.dermis`` below the surface).
    material : Material
        A half-space or a slab (insulated back; ``physics`` may say ``geometry="slab-on-support"``).
    resistance : float, m^2 K/W
    skin_temperature, material_temperature : float, °C
    t : array_like, s
        Times >= 0 (any grid: the plan is made for the scene ``0..max(t)`` at the grid's rate).
    tolerance : float or None, K
        Default :data:`stimuli.scene.PERCEPTUAL_FLOOR_K`.
    **physics
        More :class:`stimuli.scene.Scene` options (``layered``, ``perfusion_per_s``, ...).

    Returns
    -------
    T : ndarray, °C
    plan : Plan or None
        None when the two temperatures are equal (the temperature then stays put).
    """
    from .scene import PERCEPTUAL_FLOOR_K
    t = np.asarray(t, dtype=float)
    if float(skin_temperature) == float(material_temperature):   # nothing flows: nothing to plan
        return np.full(t.shape, float(skin_temperature)), None
    tmax = float(np.max(t)) if t.size else 1.0
    pos = np.unique(t[t > 0])
    dt = float(np.min(np.diff(np.concatenate([[0.0], pos])))) if pos.size else tmax
    rate = 1.0 / dt
    duration = round(tmax * rate) / rate if tmax > 0 else dt
    geometry = physics.pop("geometry", "half-space" if material.thickness is None else "slab")
    scene = Scene(quantity=quantity, duration_s=max(duration, dt), rate_Hz=rate,
                  tolerance_K=PERCEPTUAL_FLOOR_K if tolerance is None else tolerance,
                  material=material.with_thickness(None), resistance=float(resistance),
                  skin_thickness_m=skin.thickness, receptor_depth_m=skin.epidermis,
                  skin_temperature_C=skin_temperature, material_temperature_C=material_temperature,
                  geometry=geometry,
                  sample_thickness_m=3e-3 if material.thickness is None else material.thickness,
                  **physics)
    p = plan(scene)
    if p.model.sensor:
        return evaluate(p.scene, p.model, scene.times)[np.round(t * rate).astype(int)], p
    return evaluate(p.scene, p.model, t), p


def plan_line(plan: dict) -> str:
    """One line saying what a plan (:meth:`Plan.to_dict`, as logged) kept and neglected.

    Examples
    --------
    >>> plan_line({"model": "exact, slab, homogeneous skin", "bound_K": 0.004, "tolerance_K": 0.3,
    ...            "decisions": [{"effect": "sensor", "included": False, "bound_K": 0.0},
    ...                          {"effect": "slab", "included": True, "bound_K": None}]})
    'model exact, slab, homogeneous skin (error <= 0.004 K of 0.3 K); neglected: sensor <= 0 K; kept: slab'
    """
    if not isinstance(plan, dict):
        return "model: not recorded"
    if "sides" in plan:
        return "; ".join(f"side {i + 1}: {plan_line(p)}" for i, p in enumerate(plan["sides"]))
    if not plan.get("decisions"):
        return f"model {plan.get('model', 'not recorded')}" + (
            f" ({plan['note']})" if plan.get("note") else "")
    head = f"model {plan.get('model')}"
    if plan.get("bound_K") is not None and plan.get("tolerance_K") is not None:
        head += f" (error <= {plan['bound_K']:.2g} K of {plan['tolerance_K']:g} K)"
    dropped = [f"{d['effect']} <= {d['bound_K']:.2g} K" if d.get("bound_K") is not None
               else d["effect"] for d in plan["decisions"] if not d.get("included")]
    kept = [d["effect"] for d in plan["decisions"] if d.get("included")]
    return (head + "; neglected: " + (", ".join(dropped) or "nothing")
            + "; kept: " + (", ".join(kept) or "nothing"))
