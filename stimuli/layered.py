r"""Layered, perfused skin touching a material: the exact Laplace-domain solution.

The skin is a stack of tissues from the isothermal core (x = 0, held at T_S0) to the surface
(x = L): e.g. hypodermis, dermis, epidermis. Each tissue i has its conductivity k_i, volumetric
heat capacity rho_i c_i and a Pennes blood perfusion w_i (1/s, arterial blood at the core
temperature T_S0). The material behind a contact resistance R is a half-space, a slab of
thickness D with an insulated back, or a slab on a support half-space (another material).

In the deficit u = 1 - theta (theta = (T - T_M0) / (T_S0 - T_M0)) the perfusion term is
homogeneous: rho c u_t = k u_xx - w rho_b c_b u, u(0) = 0, u(x, 0) = 0, so with
q_i = sqrt((s + m_i) / alpha_i), m_i = w_i rho_b c_b / (rho_i c_i) and the characteristic
impedance z_i = 1 / (k_i q_i) every layer is a transmission line [1]_:

.. math::

   Z_\text{top} = \frac{Z_\text{bottom} + z\tanh(qh)}{1 + (Z_\text{bottom}/z)\tanh(qh)},
   \qquad Z_\text{core} = 0,

   \hat F(s) = \frac{1/s}{R + Z_S(s) + Z_M(s)},\quad
   Z_M = z_M\ \text{(half-space)},\quad
   Z_M = z_M\frac{1 + z_M Y\tanh(q_M D)}{z_M Y + \tanh(q_M D)}\ \text{(slab on a load } Y\text{)}

with Y = 0 for an insulated back and Y = k_b q_b for a support half-space. The deficit at a
depth x inside layer j is F times the product of the layers' flux ratios above it
(:math:`Q_b/Q_t = 1/(\cosh(qh)(1 + (Z_b/z)\tanh(qh)))`) and
:math:`\cosh(q\xi)(Z_b + z\tanh(q\xi))` at height xi above the layer's bottom. Every
hyperbolic function is written with ``exp(-2 q ...)`` factors (|.| <= 1 because Re q >= 0), so
nothing overflows on an inversion contour; the transforms are inverted on the same hyperbolic
Bromwich contour as :mod:`stimuli.exact` (absolute error <= 1e-12 in theta).

With one layer, no perfusion and no support this is exactly :class:`stimuli.laplace.ContactTransform`.

References
----------
.. [1] H. S. Carslaw, J. C. Jaeger, Conduction of Heat in Solids, 2nd ed., 1959, §3.8 and
   §12.8 (composite slabs); H. H. Pennes, J. Appl. Physiol. 1 (1948) 93-122 (perfusion).
.. [2] S. C. Jiang, N. Ma, H. J. Li, X. X. Zhang, "Effects of thermal properties and geometrical
   dimensions on skin burn injuries", Burns 28 (2002) 713-717, Table 1 (tissue properties,
   perfusion 1.25e-3 1/s, blood 1060 kg/m^3 and 3770 J/(kg K)).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .errors import ModelInputError
from .exact import INVERSION_ERROR, InversionPlan
from .properties import Material, Skin, ThermalProperties, check_positive

__all__ = ["Tissue", "TISSUES", "BLOOD_HEAT_CAPACITY", "LayeredTransform", "LayeredContact",
           "layered_skin_response",
           "skin_layers"]

#: rho_b c_b of blood, J/(m^3 K) (1060 kg/m^3 x 3770 J/(kg K), Jiang et al. [2]_).
BLOOD_HEAT_CAPACITY = 1060.0 * 3770.0


@dataclass(frozen=True)
class Tissue(ThermalProperties):
    """One skin layer (SI).

    Parameters
    ----------
    thickness : float, m
    conductivity : float, W/(m K)
    density : float, kg/m^3
    specific_heat : float, J/(kg K)
    perfusion : float, 1/s
        Pennes blood perfusion rate w (m^3 of blood per m^3 of tissue per s), >= 0.
    name : str
    """

    thickness: float
    conductivity: float
    density: float
    specific_heat: float
    perfusion: float = 0.0
    name: str = ""

    def __post_init__(self):
        w = f"Tissue({self.name!r})"
        for n in ("thickness", "conductivity", "density", "specific_heat"):
            object.__setattr__(self, n, check_positive(w, n, getattr(self, n)))
        try:
            p = float(self.perfusion)
        except (TypeError, ValueError):
            p = float("nan")
        if not (math.isfinite(p) and 0.0 <= p <= 1.0):
            raise ModelInputError(f"{w}: perfusion: expected 0 <= w <= 1 1/s (physiological: "
                                  f"~1e-3), got {self.perfusion!r}")
        object.__setattr__(self, "perfusion", p)

    @property
    def sink_rate(self) -> float:
        """m = w rho_b c_b / (rho c), 1/s: the perfusion's decay rate of a temperature deficit."""
        return self.perfusion * BLOOD_HEAT_CAPACITY / (self.density * self.specific_heat)

    @property
    def pennes_length(self) -> float:
        """sqrt(k / (w rho_b c_b)), m (inf without perfusion): the depth perfusion acts over."""
        return math.inf if self.perfusion == 0 else math.sqrt(
            self.conductivity / (self.perfusion * BLOOD_HEAT_CAPACITY))

    def with_thickness(self, thickness: float) -> "Tissue":
        return Tissue(thickness, self.conductivity, self.density, self.specific_heat,
                      self.perfusion, self.name)

    def with_perfusion(self, perfusion: float) -> "Tissue":
        return Tissue(self.thickness, self.conductivity, self.density, self.specific_heat,
                      perfusion, self.name)


#: Literature properties per tissue (thickness is a placeholder, set by :func:`skin_layers`):
#: Jiang et al. [2]_ Table 1 (epidermis 0.24 W/(m K), 1200 kg/m^3, 3590 J/(kg K), no perfusion;
#: dermis 0.45, 1200, 3300, 1.25e-3 1/s; subcutaneous fat 0.19, 1000, 2674, 1.25e-3 1/s).
TISSUES = {
    "epidermis": Tissue(1e-4, 0.24, 1200.0, 3590.0, 0.0, "epidermis"),
    "dermis": Tissue(1e-3, 0.45, 1200.0, 3300.0, 1.25e-3, "dermis"),
    "hypodermis": Tissue(2e-3, 0.19, 1000.0, 2674.0, 1.25e-3, "hypodermis"),
}


def skin_layers(skin: Skin, *, layered: bool = True, perfusion: float | None = None,
                hypodermis: float | None = None) -> tuple:
    """The tissue stack (core to surface) of a :class:`Skin`.

    Parameters
    ----------
    skin : Skin
        Thickness L and receptor depth d (the epidermis is L - d thick).
    layered : bool
        True: dermis 0..d and epidermis d..L with :data:`TISSUES`' properties; False: one
        layer with the skin's own (Table 1) properties.
    perfusion : float or None, 1/s
        Perfusion of the perfused layers (dermis, hypodermis; every layer if not ``layered``);
        None: 0 (no perfusion).
    hypodermis : float or None, m
        Add a hypodermis of this thickness below the dermis (the core moves deeper).
    """
    if hypodermis is not None:
        check_positive("skin_layers", "hypodermis", hypodermis)
    return tuple(Tissue(*row) for row in layer_rows(skin, layered=layered, perfusion=perfusion,
                                                     hypodermis=hypodermis))


def layer_rows(skin: Skin, *, layered: bool = True, perfusion: float | None = None,
               hypodermis: float | None = None) -> list:
    """:func:`skin_layers` as plain tuples (thickness, conductivity, density, specific_heat,
    perfusion, name), unvalidated: for the scene planner's closed forms (no Tissue to build)."""
    w = 0.0 if perfusion is None else float(perfusion)
    if not layered:
        rows = [(skin.thickness, skin.conductivity, skin.density, skin.specific_heat, w, "skin")]
    else:
        d, e = TISSUES["dermis"], TISSUES["epidermis"]
        rows = [(skin.dermis, d.conductivity, d.density, d.specific_heat, w, d.name),
                (skin.epidermis, e.conductivity, e.density, e.specific_heat, e.perfusion, e.name)]
    if hypodermis is not None:
        h = TISSUES["hypodermis"]
        rows.insert(0, (float(hypodermis), h.conductivity, h.density, h.specific_heat, w, h.name))
    return rows


def _tanh(a):
    """(tanh(a / 2), exp(-a)) for Re a >= 0, without overflow (expm1 for small a)."""
    e = np.exp(-a)
    return -np.expm1(-a) / (1.0 + e), e


class LayeredTransform:
    """Laplace-domain kernels of a layered, perfused skin on a material (all SI, theta units).

    Parameters
    ----------
    layers : sequence of Tissue
        From the core (x = 0) to the surface (x = L = sum of thicknesses).
    material : Material
        A half-space (``thickness=None``) or a slab of ``thickness`` D.
    resistance : float, m^2 K/W
    support : Material or None
        The half-space a slab rests on (None: insulated back). Ignored for a half-space.
    """

    def __init__(self, layers, material: Material, resistance: float, support: Material | None = None):
        self.layers = tuple(layers)
        if not self.layers or not all(isinstance(t, Tissue) for t in self.layers):
            raise ModelInputError(f"LayeredTransform: layers: expected Tissue objects, got {layers!r}")
        self.tops = np.cumsum([t.thickness for t in self.layers])
        self.L = float(self.tops[-1])
        self.R = float(resistance)
        self.alpha_m, self.k_m, self.D = material.diffusivity, material.conductivity, material.thickness
        self.support = None if (support is None or self.D is None) else (support.diffusivity,
                                                                         support.conductivity)

    # -- pieces ------------------------------------------------------------------
    def _layer_nodes(self, s):
        """Per layer: q, z, tanh(q h), exp(-2 q h), exp(-q h) (computed once per evaluation)."""
        out = []
        for t in self.layers:
            q = np.sqrt((s + t.sink_rate) / t.diffusivity)
            qh = q * t.thickness
            eh = np.exp(-qh)
            e = eh * eh
            out.append((q, 1.0 / (t.conductivity * q), -np.expm1(-2.0 * qh) / (1.0 + e), e, eh))
        return out

    def _impedances(self, s, nodes):
        """Z at the bottom of each layer and at the surface (core Z = 0)."""
        Z = np.zeros_like(s)
        bottoms = []
        for q, z, th, _e, _eh in nodes:
            bottoms.append(Z)
            Z = (Z + z * th) / (1.0 + (Z / z) * th)
        return bottoms, Z

    def _material(self, s):
        qm = np.sqrt(s / self.alpha_m)
        zm = 1.0 / (self.k_m * qm)
        if self.D is None:
            return qm, zm, None, zm
        Y = 0.0 if self.support is None else self.support[1] * np.sqrt(s / self.support[0])
        th = _tanh(2.0 * qm * self.D)[0]
        return qm, zm, Y, zm * (1.0 + zm * Y * th) / (zm * Y + th)

    def _flux(self, s, Zs, Zm):
        return 1.0 / (s * (self.R + Zs + Zm))

    def skin_ratio(self, s, x, nodes=None, bottoms=None):
        """u(x) / F: the skin deficit at depth x per unit surface flux (transform)."""
        s = np.asarray(s, dtype=complex)
        if nodes is None:
            nodes = self._layer_nodes(s)
            bottoms, _ = self._impedances(s, nodes)
        j = int(np.searchsorted(self.tops, x, side="left"))
        j = min(j, len(self.layers) - 1)
        ratio = np.ones_like(s)
        for i in range(len(self.layers) - 1, j, -1):          # layers above j, top down
            q, z, th, e, eh = nodes[i]
            ratio = ratio * 2.0 * eh / (1.0 + e) / (1.0 + (bottoms[i] / z) * th)
        q, z, th, e, _eh = nodes[j]
        h = self.layers[j].thickness
        xi = x - (self.tops[j] - h)
        th_xi, exi = _tanh(2.0 * q * xi)
        cosh_ratio = np.exp(-q * (h - xi)) * (1.0 + exi) / (1.0 + e)
        return ratio * cosh_ratio * (bottoms[j] + z * th_xi) / (1.0 + (bottoms[j] / z) * th)

    def surface_impedance(self, s):
        """Z_S(s): the skin stack seen from its surface (Dirichlet core)."""
        s = np.asarray(s, dtype=complex)
        return self._impedances(s, self._layer_nodes(s))[1]

    def skin_deficit(self, s, x):
        """Transform of 1 - theta_S(x, t), 0 <= x <= L."""
        s = np.asarray(s, dtype=complex)
        nodes = self._layer_nodes(s)
        bottoms, Zs = self._impedances(s, nodes)
        F = self._flux(s, Zs, self._material(s)[3])
        return F * self.skin_ratio(s, x, nodes, bottoms)

    def material_rise(self, s, x):
        """Transform of theta_M(x, t), x >= L (x <= L + D for a slab)."""
        s = np.asarray(s, dtype=complex)
        Zs = self.surface_impedance(s)
        qm, zm, Y, Zm = self._material(s)
        F = self._flux(s, Zs, Zm)
        eta = x - self.L
        if self.D is None:
            return F * zm * np.exp(-qm * eta)
        th, e = _tanh(2.0 * qm * self.D)
        th_r, er = _tanh(2.0 * qm * (self.D - eta))
        cosh_ratio = np.exp(-qm * eta) * (1.0 + er) / (1.0 + e)
        return F * cosh_ratio * (1.0 + zm * th_r * Y) / (Y + th / zm)

    def display_kernel(self, s, x, pad_resistance=0.0):
        """u(x) / g: the skin's response (transform, per unit surface-step transform g) when a
        surface at g drives it through ``pad_resistance`` (0: Dirichlet)."""
        s = np.asarray(s, dtype=complex)
        nodes = self._layer_nodes(s)
        bottoms, Zs = self._impedances(s, nodes)
        return self.skin_ratio(s, x, nodes, bottoms) / (Zs + pad_resistance)


class LayeredContact:
    """Temperatures of a layered, perfused skin touching a material (exact, Bromwich inversion).

    Parameters
    ----------
    layers : sequence of Tissue
        Core to surface (see :func:`skin_layers`).
    material : Material
    resistance : float, m^2 K/W
    skin_temperature, material_temperature : float, °C
        T_S0 (uniform skin, the core and the arterial blood) and T_M0.
    support : Material or None
        Half-space under a slab material (None: insulated back).

    Examples
    --------
    >>> from stimuli import Skin, material
    >>> c = LayeredContact(skin_layers(Skin(650e-6)), material("stainless_steel"), 6.5e-4, 35.5, 20.0)
    >>> c.temperature("receptor", [1.0, 8.0], x=390e-6).round(2).tolist()
    [32.46, 31.1]
    """

    def __init__(self, layers, material: Material, resistance: float, skin_temperature: float,
                 material_temperature: float, support: Material | None = None):
        self.transform = LayeredTransform(layers, material, resistance, support)
        self.skin_initial = float(skin_temperature)
        self.material_initial = float(material_temperature)

    @property
    def thickness(self) -> float:
        return self.transform.L

    def theta(self, quantity: str, t, x: float | None = None, plan: InversionPlan | None = None):
        """theta at times ``t`` (>= 0) for ``quantity`` in "receptor"/"skin" (at depth ``x``),
        "interface_skin", "interface_material", "material" (at ``x`` >= L)."""
        tr = self.transform
        tt = np.asarray(t, dtype=float)
        if not np.all(np.isfinite(tt)) or np.any(tt < 0):
            raise ModelInputError(f"LayeredContact: t: expected finite times >= 0 s, got {t!r}")
        if quantity in ("receptor", "skin"):
            if x is None or not (0.0 <= float(x) <= tr.L):
                raise ModelInputError(f"LayeredContact: x: expected 0 <= x <= {tr.L!r} m, got {x!r}")
            fn, skin, xx = (lambda s: tr.skin_deficit(s, float(x))), True, float(x)
        elif quantity == "interface_skin":
            fn, skin, xx = (lambda s: tr.skin_deficit(s, tr.L)), True, tr.L
        elif quantity == "interface_material":
            fn, skin, xx = (lambda s: tr.material_rise(s, tr.L)), False, tr.L
        elif quantity == "material":
            hi = math.inf if tr.D is None else tr.L + tr.D
            if x is None or not (tr.L <= float(x) <= hi):
                raise ModelInputError(f"LayeredContact: x: expected {tr.L!r} <= x <= {hi!r} m, got {x!r}")
            fn, skin, xx = (lambda s: tr.material_rise(s, float(x))), False, float(x)
        else:
            raise ModelInputError(f"LayeredContact: quantity: unknown {quantity!r}")
        out = np.empty(tt.shape)
        pos = tt > 0
        at_interface = xx == tr.L
        if at_interface and tr.R == 0.0:
            bs = tr.layers[-1].effusivity
            bm = tr.k_m / math.sqrt(tr.alpha_m)          # the material's effusivity
            out[~pos] = bs / (bs + bm)
        else:
            out[~pos] = 1.0 if skin else 0.0
        if np.any(pos):
            p = plan if plan is not None else InversionPlan(tt[pos])
            v = p.apply(fn(p.s))
            out[pos] = 1.0 - v if skin else v
        return out

    def temperature(self, quantity: str, t, x: float | None = None, plan=None):
        """Temperature, °C (see :meth:`theta`)."""
        dT = self.skin_initial - self.material_initial
        return self.material_initial + dT * self.theta(quantity, t, x, plan)

    def error_bound(self) -> float:
        """Bound on the inversion's absolute error, K."""
        return INVERSION_ERROR * abs(self.skin_initial - self.material_initial)


def layered_skin_response(layers, t, surface_temperature, initial_temperature: float, depth: float,
                          resistance: float = 0.0):
    """Temperature at ``depth`` of a layered, perfused skin while a display imposes its surface.

    The display-driven counterpart of :class:`LayeredContact` (and of
    :func:`stimuli.skin_response` for homogeneous skin): the surface history g(t) (piecewise
    linear between the samples, jumping from T_S0 to g(0) at t = 0) drives the skin through
    ``resistance`` (0: imposed on the skin). The step response and its integral come from the
    exact transform u(x)/g = K(s) (:meth:`LayeredTransform.display_kernel`) inverted on the
    Bromwich contour, and are superposed by FFT (:mod:`stimuli._duhamel`), exactly as for
    homogeneous skin.

    Parameters
    ----------
    layers : sequence of Tissue
        Core to surface.
    t : array_like, s
        Uniform times from 0.
    surface_temperature : array_like, °C
    initial_temperature : float, °C
        T_S0 (core, arterial blood, initial skin).
    depth : float, m
        From the core, 0 <= depth <= L.
    resistance : float, m^2 K/W

    Returns
    -------
    ndarray, °C
    """
    from ._duhamel import superpose
    from .materials import material
    t = np.asarray(t, dtype=float)
    g = np.asarray(surface_temperature, dtype=float)
    if t.ndim != 1 or g.shape != t.shape or t.size < 2 or t[0] != 0.0:
        raise ModelInputError("layered_skin_response: t: expected uniform 1-D times from 0, one per "
                              "surface temperature")
    dt = (t[-1] - t[0]) / (t.size - 1)
    if not np.allclose(np.diff(t), dt, rtol=1e-9, atol=0):
        raise ModelInputError("layered_skin_response: t: expected uniform times")
    tr = LayeredTransform(layers, material("copper"), 0.0)      # the material is not used
    if not 0.0 <= depth <= tr.L:
        raise ModelInputError(f"layered_skin_response: depth: expected 0 <= depth <= {tr.L!r} m, got {depth!r}")
    h = g - float(initial_temperature)
    if depth == 0.0:
        return np.full(t.shape, float(initial_temperature))
    R = float(resistance)
    gain = float(tr.display_kernel(np.array([1e-200 + 0j]), depth, R)[0].real)
    S = np.zeros_like(t)
    Rr = np.zeros_like(t)
    plan = InversionPlan(t[1:])
    k = tr.display_kernel(plan.s, depth, R)
    S[1:] = plan.apply(k / plan.s)
    Rr[1:] = plan.apply((k - gain) / (plan.s * plan.s))
    return float(initial_temperature) + superpose(h, dt, S, Rr, gain)
