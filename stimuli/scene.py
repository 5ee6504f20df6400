r"""A scene: what is asked of the thermal model, and every physical effect as an explicit option.

A :class:`Scene` states the question (which temperature, over which times, to what tolerance)
and the physics as well as it is known (the sample's geometry, the contact force, the receptor
depth, layered skin, perfusion, the pad's sensor lag). A :class:`Model` says which of those
effects a computation keeps; :func:`evaluate` computes the scene's quantity with a model.
:func:`stimuli.planner.plan` picks the cheapest model whose neglected effects stay within the
scene's tolerance.

The options, and why each exists
--------------------------------
``geometry``
    ``"half-space"``; ``"slab"`` (thickness ``sample_thickness_m``, insulated back, the paper's
    3 mm samples); ``"slab-on-support"`` (the slab resting on a half-space of ``support``). The
    3 mm steel slab warms through in about D^2/alpha = 2 s, so over 20 s the slab and the
    half-space differ by several kelvin at the interface.
``effective_thickness_m``
    Lateral spreading. A real 20 x 23 mm sample touched over A = 135 mm^2 (radius
    a = sqrt(A / pi) = 6.6 mm) draws heat from beyond the contact: after t the heat has spread
    sideways about sqrt(alpha_M t) (9 mm for steel at 20 s), so the slab column under the
    finger behaves as a slab whose heat capacity is that of a disc of radius a + sqrt(alpha t),
    i.e. of thickness D (1 + sqrt(alpha_M t) / a)^2 (:func:`lateral_effective_thickness`). This
    is a one-dimensional stand-in chosen by the user (one thickness for the whole contact); it is
    an option, not the default, and it has not been checked against a 2-D axisymmetric solution.
``force_N``
    Contact force: the contact resistance is Eq. 5 at this force (P = F / A), unless
    ``resistance`` is given. 1.5 -> 2.5 N moves the 1# receptor by about 0.5 K at 5 s.
``receptor_depth_m`` / ``receptor_fraction``
    Depth of the thermoreceptors below the skin surface, absolute, or as a fraction of L.
    Default: fraction 0.4, the paper's geometry (receptors at the epidermis-dermis junction,
    the dermis being 0.6 L; :class:`stimuli.Skin`): 260 um for L = 650 um, 400 um for
    1000 um. Cold receptors lie just below the epidermis, about 0.15-0.17 mm deep in hairy skin
    (Hensel [1]_); the glabrous fingertip's epidermis is several times thicker (0.4-0.8 mm
    including the stratum corneum), so a depth proportional to the skin's thickness, at the
    junction, is the paper's reading and ours. The sign of the group effect depends on it (the
    sensitivity table in docs/scene-physics.md).
``layered``, ``hypodermis_m``
    Epidermis (L - d) and dermis (d) with their own properties (:data:`stimuli.layered.TISSUES`)
    instead of Table 1's homogeneous skin; optional hypodermis below (the core moves deeper).
``perfusion_per_s``
    Pennes perfusion of the dermis (and hypodermis), 1/s (1.25e-3 in [2]_). Its length
    sqrt(k / (w rho_b c_b)) is about 9 mm >> 1 mm of skin, so it barely matters over 20 s.
``sensor_time_constant_s``
    The pad's temperature sensor as a first-order lag (time constant tau). The error of
    ignoring it is at most tau max |dT/dt| (a first-order low-pass of x differs from x by at
    most tau sup |x'|); a thermistor bonded under a copper face has tau of order 0.1 s.

References
----------
.. [1] H. Hensel, "Cutaneous thermoreceptors", in A. Iggo (ed.), Handbook of Sensory
   Physiology II, Springer 1973, pp. 79-110 (cold receptors 0.15-0.17 mm below the surface).
.. [2] S. C. Jiang et al., Burns 28 (2002) 713-717.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import asdict, dataclass, replace
from functools import cached_property

import numpy as np

from .errors import ModelInputError, ModelRangeWarning
from .properties import Material, Skin

__all__ = ["Scene", "Model", "evaluate", "QUANTITIES", "GEOMETRIES", "PERCEPTUAL_FLOOR_K",
           "lateral_effective_thickness", "sensor_lag"]

#: What a scene can ask for.
QUANTITIES = ("receptor", "interface_material", "interface_skin")
#: Sample geometries.
GEOMETRIES = ("half-space", "slab", "slab-on-support")

#: The default tolerance, K: the simulated observer's sensory noise on a receptor temperature
#: drop (experiments.participant_model.person.PerceptionParameters.drop_noise_C = 0.3 K, of the order
#: of fingertip cold-detection thresholds for fast changes).
PERCEPTUAL_FLOOR_K = 0.3

#: Physiological skin temperature range (warn outside), and what is refused, °C.
SKIN_RANGE_C = (20.0, 42.0)
SKIN_ABSURD_C = (0.0, 60.0)
#: A material a fingertip touches: warn outside, refuse outside, °C.
MATERIAL_RANGE_C = (0.0, 50.0)
MATERIAL_ABSURD_C = (-40.0, 100.0)


def _number(where, name, value, lo=-math.inf, hi=math.inf, *, allow_none=False):
    if value is None and allow_none:
        return None
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = float("nan")
    if not (math.isfinite(v) and lo <= v <= hi):
        raise ModelInputError(f"{where}: {name}: expected a finite number in [{lo:g}, {hi:g}], got {value!r}")
    return v


def check_temperatures(where: str, skin_C: float, material_C: float) -> None:
    """Refuse absurd initial temperatures, warn about non-physiological ones (°C)."""
    _number(where, "skin_temperature_C", skin_C, *SKIN_ABSURD_C)
    _number(where, "material_temperature_C", material_C, *MATERIAL_ABSURD_C)
    if not SKIN_RANGE_C[0] <= skin_C <= SKIN_RANGE_C[1]:
        warnings.warn(f"{where}: skin_temperature_C: {skin_C!r} °C is outside the physiological "
                      f"{SKIN_RANGE_C[0]:g}-{SKIN_RANGE_C[1]:g} °C the skin properties hold for",
                      ModelRangeWarning, stacklevel=3)
    if not MATERIAL_RANGE_C[0] <= material_C <= MATERIAL_RANGE_C[1]:
        warnings.warn(f"{where}: material_temperature_C: {material_C!r} °C is outside "
                      f"{MATERIAL_RANGE_C[0]:g}-{MATERIAL_RANGE_C[1]:g} °C, where touching is "
                      "harmless and the model's properties hold", ModelRangeWarning, stacklevel=3)


def lateral_effective_thickness(thickness_m: float, alpha_m: float, time_s: float,
                                area_m2: float = 135e-6) -> float:
    """D (1 + sqrt(alpha t) / a)^2, a = sqrt(area / pi): the lateral-spreading stand-in, m.

    Examples
    --------
    >>> round(lateral_effective_thickness(3e-3, 4.2e-6, 20.0) * 1e3, 1)   # 3 mm steel, 20 s
    17.3
    """
    a = math.sqrt(area_m2 / math.pi)
    return thickness_m * (1.0 + math.sqrt(alpha_m * time_s) / a) ** 2


@dataclass(frozen=True)
class Model:
    """Which effects a computation keeps (see :mod:`stimuli.scene`).

    ``method``: "exact" (Bromwich inversion of :mod:`stimuli.layered`'s transform) or "eq7"
    (the paper's printed Eq. 7, interface on a half-space only); ``geometry`` one of
    :data:`GEOMETRIES`; ``layered``, ``perfusion``, ``sensor``: whether those effects are kept.
    """

    method: str = "exact"
    geometry: str = "slab"
    layered: bool = False
    perfusion: bool = False
    sensor: bool = False

    def describe(self) -> str:
        parts = [self.method, self.geometry, "layered skin" if self.layered else "homogeneous skin"]
        if self.perfusion:
            parts.append("perfusion")
        if self.sensor:
            parts.append("sensor lag")
        return ", ".join(parts)


@dataclass(frozen=True)
class Scene:
    """What is needed, and the physics as it is known (every option documented in the module).

    Parameters
    ----------
    quantity : {"receptor", "interface_material", "interface_skin"}
    duration_s, rate_Hz : float
        Times 0, 1/rate, ..., duration (``duration * rate`` whole).
    tolerance_K : float
        Accuracy needed, K (default :data:`PERCEPTUAL_FLOOR_K`).
    material : str or Material
    roughness_m : float
    force_N : float
    resistance : float or None, m^2 K/W
        Overrides Eq. 5 (e.g. a calibrated value).
    skin_thickness_m : float
        L: the depth of the isothermal core (the calibrated "effective core depth").
    receptor_depth_m : float or None
        Below the surface; None: ``receptor_fraction * L``.
    receptor_fraction : float
    skin_temperature_C, material_temperature_C : float
    geometry : {"half-space", "slab", "slab-on-support"}
    sample_thickness_m : float
    support : str or Material or None
        The half-space under the slab for "slab-on-support".
    effective_thickness_m : float or None
        Lateral-spreading stand-in for the slab thickness (see the module notes).
    layered : bool
    hypodermis_m : float or None
    perfusion_per_s : float
    sensor_time_constant_s : float
    """

    quantity: str = "receptor"
    duration_s: float = 20.0
    rate_Hz: float = 1000.0
    tolerance_K: float = PERCEPTUAL_FLOOR_K
    material: object = "stainless_steel"
    roughness_m: float = 12.5e-6
    force_N: float = 2.0
    resistance: float | None = None
    skin_thickness_m: float = 650e-6
    receptor_depth_m: float | None = None
    receptor_fraction: float = 0.4
    skin_temperature_C: float = 35.5
    material_temperature_C: float = 20.0
    geometry: str = "slab"
    sample_thickness_m: float = 3e-3
    support: object = None
    effective_thickness_m: float | None = None
    layered: bool = False
    hypodermis_m: float | None = None
    perfusion_per_s: float = 0.0
    sensor_time_constant_s: float = 0.0

    def __post_init__(self):
        w = "Scene"
        if self.quantity not in QUANTITIES:
            raise ModelInputError(f"{w}: quantity: expected one of {', '.join(QUANTITIES)}, got {self.quantity!r}")
        if self.geometry not in GEOMETRIES:
            raise ModelInputError(f"{w}: geometry: expected one of {', '.join(GEOMETRIES)}, got {self.geometry!r}")
        d = _number(w, "duration_s", self.duration_s, 1e-6, 1e5)
        r = _number(w, "rate_Hz", self.rate_Hz, 1e-3, 1e6)
        if abs(d * r - round(d * r)) > 1e-9 * max(1.0, d * r):
            raise ModelInputError(f"{w}: duration_s: expected a whole number of samples at {r!r} Hz, got {d!r}")
        _number(w, "tolerance_K", self.tolerance_K, 1e-9, 100.0)
        _number(w, "roughness_m", self.roughness_m, 0.0, 1e-2)
        _number(w, "force_N", self.force_N, 1e-3, 100.0)
        _number(w, "resistance", self.resistance, 0.0, 1.0, allow_none=True)
        L = _number(w, "skin_thickness_m", self.skin_thickness_m, 20e-6, 0.05)
        if not 200e-6 <= L <= 5e-3:
            warnings.warn(f"{w}: skin_thickness_m: {L!r} m is outside the 0.2-5 mm of fingertip "
                          "skin", ModelRangeWarning, stacklevel=3)
        _number(w, "receptor_fraction", self.receptor_fraction, 1e-3, 0.999)
        if self.receptor_depth_m is not None:
            _number(w, "receptor_depth_m", self.receptor_depth_m, 1e-7, L * 0.999)
        _number(w, "sample_thickness_m", self.sample_thickness_m, 1e-5, 1.0)
        _number(w, "effective_thickness_m", self.effective_thickness_m, 1e-5, 1.0, allow_none=True)
        _number(w, "hypodermis_m", self.hypodermis_m, 1e-5, 0.05, allow_none=True)
        _number(w, "perfusion_per_s", self.perfusion_per_s, 0.0, 1.0)
        _number(w, "sensor_time_constant_s", self.sensor_time_constant_s, 0.0, 100.0)
        if self.geometry == "slab-on-support" and self.support is None:
            raise ModelInputError(f"{w}: support: expected a material under the slab for "
                                  "geometry 'slab-on-support', got None")
        check_temperatures(w, self.skin_temperature_C, self.material_temperature_C)
        if self.skin_temperature_C == self.material_temperature_C:
            raise ModelInputError(f"{w}: material_temperature_C: expected a value different from "
                                  f"skin_temperature_C, got {self.material_temperature_C!r}")

    # -- derived ---------------------------------------------------------------
    @property
    def times(self) -> np.ndarray:
        n = int(round(self.duration_s * self.rate_Hz))
        return np.arange(n + 1) / self.rate_Hz

    @property
    def receptor_depth(self) -> float:
        """Below the surface, m."""
        return (self.receptor_fraction * self.skin_thickness_m if self.receptor_depth_m is None
                else float(self.receptor_depth_m))

    @property
    def skin(self) -> Skin:
        L = self.skin_thickness_m
        return Skin(L, dermis=L - self.receptor_depth)

    def material_object(self, geometry: str | None = None) -> Material:
        from .materials import material as lookup
        m = self.material if isinstance(self.material, Material) else lookup(self.material)
        geometry = self.geometry if geometry is None else geometry
        if geometry == "half-space":
            return m.with_thickness(None)
        D = self.sample_thickness_m if self.effective_thickness_m is None else self.effective_thickness_m
        return m.with_thickness(D)

    def support_object(self) -> Material | None:
        if self.support is None:
            return None
        from .materials import material as lookup
        return self.support if isinstance(self.support, Material) else lookup(self.support)

    @cached_property
    def contact_resistance(self) -> float:
        """R, m^2 K/W: ``resistance`` or Eq. 5 at ``force_N`` (computed once per scene: the
        planner asks for it several times; a scene is frozen, so it cannot change)."""
        if self.resistance is not None:
            return float(self.resistance)
        from .roughness import contact_resistance
        return float(contact_resistance(self.roughness_m, skin=Skin(self.skin_thickness_m),
                                        material=self.material_object("half-space"),
                                        force=self.force_N))

    def full_model(self) -> Model:
        """Every effect the scene states."""
        return Model("exact", self.geometry, self.layered, self.perfusion_per_s > 0,
                     self.sensor_time_constant_s > 0)

    def to_dict(self) -> dict:
        d = asdict(self)
        for k in ("material", "support"):
            v = getattr(self, k)
            d[k] = v.name if isinstance(v, Material) else v
        return d

    def replace(self, **changes) -> "Scene":
        return replace(self, **changes)


def scene_contact(scene: Scene, model: Model):
    from .layered import LayeredContact, skin_layers
    skin = scene.skin
    layers = skin_layers(skin, layered=model.layered,
                         perfusion=scene.perfusion_per_s if model.perfusion else None,
                         hypodermis=scene.hypodermis_m)
    support = scene.support_object() if model.geometry == "slab-on-support" else None
    return LayeredContact(layers, scene.material_object(model.geometry), scene.contact_resistance,
                          scene.skin_temperature_C, scene.material_temperature_C, support=support)


def evaluate(scene: Scene, model: Model, t=None, *, plan=None) -> np.ndarray:
    """The scene's quantity (°C) with ``model`` at times ``t`` (default: the scene's times).

    ``plan``: an :class:`stimuli.exact.InversionPlan` for the positive times of ``t`` (reuse).
    """
    t = scene.times if t is None else np.asarray(t, dtype=float)
    if model.method == "eq7":
        if scene.quantity != "interface_material" or model.geometry != "half-space" or model.layered \
                or model.perfusion:
            raise ModelInputError("evaluate: model: 'eq7' is the interface temperature of "
                                  f"homogeneous skin on a half-space, got {model.describe()!r}")
        from .contact import Contact
        c = Contact(scene.skin, scene.material_object("half-space"), scene.contact_resistance,
                    scene.skin_temperature_C, scene.material_temperature_C)
        T = c.interface_temperature(t, method="paper-as-printed")
    else:
        c = scene_contact(scene, model)
        x = c.thickness - scene.receptor_depth if scene.quantity == "receptor" else None
        if plan is not None:
            T = np.empty(t.shape)
            pos = t > 0
            T[pos] = c.temperature(scene.quantity, t[pos], x, plan=plan)
            if np.any(~pos):
                T[~pos] = c.temperature(scene.quantity, t[~pos], x)
        else:
            T = c.temperature(scene.quantity, t, x)
    if model.sensor and scene.sensor_time_constant_s > 0:
        T = sensor_lag(t, T, scene.sensor_time_constant_s)
    return T


def sensor_lag(t, x, tau: float) -> np.ndarray:
    """A first-order sensor (time constant ``tau``, s) reading the piecewise-linear ``x(t)``.

    Exact for piecewise-linear input on uniform times from the first one:
    y' = (x - y) / tau, y(t_0) = x(t_0), i.e. y_i - e y_{i-1} = (1 - c) x_i - (e - c) x_{i-1} with
    e = exp(-dt / tau), c = tau (1 - e) / dt.

    Examples
    --------
    >>> t = np.arange(5) * 0.1
    >>> sensor_lag(t, 2.0 * t, 0.1).round(4).tolist()   # a ramp read 0.1 s late, after a transient
    [0.0, 0.0736, 0.2271, 0.41, 0.6037]
    """
    from scipy.signal import lfilter
    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float)
    if x.size < 2:
        return x.copy()
    dt = (t[-1] - t[0]) / (t.size - 1)
    if not (dt > 0 and np.allclose(np.diff(t), dt, rtol=1e-9, atol=0)):
        raise ModelInputError("sensor_lag: t: expected uniform increasing times")
    e = math.exp(-dt / tau)
    c = tau * (-math.expm1(-dt / tau)) / dt
    return x[0] + lfilter([1.0 - c, -(e - c)], [1.0, -e], x - x[0])
