"""The scene planner's cheap bounds and screens: how much an effect can change the scene's
quantity at most (to neglect it without evaluating it) or at least (to keep it without evaluating
it), from closed forms and from the exact models' Laplace transforms at a few real ``s``.

One concept: the planner's estimates made without an inversion. :mod:`stimuli.planner` uses them
first and falls back to evaluating the models at its probes when they cannot decide;
``tests/stimuli/test_planner.py`` and ``tests/stimuli/test_display_planner.py`` compare every bound
here with the effect the exact models give on grids of hard scenes.
"""
from __future__ import annotations

import math
from functools import lru_cache

from .layered import BLOOD_HEAT_CAPACITY, layer_rows
from .properties import Material
from .scene import Model, Scene


PERFUSION_NOTE = "bounded in closed form (maximum principle), not evaluated"
PERFUSION_LAPLACE_NOTE = ("bounded in the Laplace domain (maximum principle, a majorant that grows "
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


def real_point(rows, s: float, x: float, perfused: bool = True):
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
    m = as_half_space(scene)
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
    r, Zs = real_point(rows, s, L - scene.receptor_depth if scene.quantity == "receptor" else L)
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
        r_p, Zp = real_point(rows, s, x, True)
        r_0, Z0 = real_point(rows, s, x, False)
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


def lower_screen(scene: Scene, ref: Model, cand: Model, skin, tol: float, offset: float):
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
#: this many tolerances (:func:`layers_matter`).
LAYER_SCREEN = 4.0


def layers_matter(scene: Scene, skin=None) -> str | None:
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
    m = as_half_space(scene)
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


def as_half_space(scene: Scene) -> Material:
    """The scene's material as a half-space (the resolved scene holds it: no copy to build)."""
    m = scene.material
    if isinstance(m, Material) and m.thickness is None:
        return m
    if isinstance(m, str):
        return _named(m)
    return scene.material_object("half-space")


@lru_cache(maxsize=64)
def scene_skin(thickness: float, dermis: float):
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


def warmed_through(scene: Scene) -> str | None:
    """Why the scene's slab certainly matters (screen), or None."""
    D = _slab_thickness(scene)
    reach = math.sqrt(as_half_space(scene).diffusivity * scene.duration_s)
    if D < 0.5 * reach:
        return (f"kept without evaluation: the {D * 1e3:.3g} mm slab is warmed through "
                f"(sqrt(alpha t) = {reach * 1e3:.3g} mm at {scene.duration_s:g} s)")
    return None
