"""Forward model of a measured contact trace: what the temperature sensor reads after contact.

The skin is the slab 0 < x < L of docs/design.md (inner boundary held at T_S0), the sample is a
half-space or a slab of thickness D with an insulated back (the paper's samples: D = 3 mm),
and the contact between them has the effective resistance R.  Where the sensor sits is an
explicit choice (:class:`Sensor`):

``"material"``
    A massless sensor on the sample surface, x = L⁺ (the quantity of Eq. 7).  thermocue
    records real trials through the display's contact sensor, which sits on the sample (the
    emulator models exactly this), so this is the default.
``"skin"``
    A massless sensor on the skin surface, x = L⁻.  The paper's Exp. 1 (Sec. 3.1) glued the
    sensor to the fingertip with cyanoacrylate, so the rough contact was between the sensor
    and the sample and the sensor followed the skin side of it: use this for such data.
``"lumped"``
    A sensor with its own heat capacity per area C (J/(m² K)), joined to the skin by a fixed
    resistance R₁ (glue + half the film) and to the sample by the fitted R (the rough
    contact + the other half of the film); it starts at the skin temperature.

All three are exact: closed forms in the Laplace domain, inverted numerically by
stimuli's Bromwich inversion (:class:`stimuli.exact.InversionPlan`, the same contour as
:mod:`stimuli.contact`) to about 1e-12 of T_S0 − T_M0.  A :class:`ResponseGrid` builds the
plan (contour nodes and exponentials) once per trace's times; each (R, L) then costs one
transform evaluation on windows × 25 nodes and a matrix-vector product, and the
derivatives with respect to R and L (the fit's Jacobian) reuse the same nodes.

Why the transforms are written here rather than taken from :class:`stimuli.laplace.ContactTransform`
(which has the same F(s) for the two massless sides): the fit needs ∂θ/∂R and ∂θ/∂L in the same
pass, the lumped sensor node, and the sample's impedance and √s kept across thousands of (R, L)
evaluations on fixed nodes; ContactTransform recomputes everything per call and has none of these.
The massless sides are checked against stimuli's Contact in the tests.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from experiments.calibration.errors import CalibrationError
from stimuli.exact import NODES as DEFAULT_NODES

__all__ = ["Sensor", "ContactSetup", "ResponseGrid", "SENSOR_SIDES", "sensor_response", "sensor_temperature",
           "DEFAULT_SENSOR_HEAT_CAPACITY", "DEFAULT_SENSOR_SKIN_RESISTANCE"]

SENSOR_SIDES = ("skin", "material", "lumped")

#: Heat capacity per area of a thin-film platinum sensor, J/(m² K): an *assumption*, a
#: 100 µm polyimide film (ρ = 1420 kg/m³, c = 1090 J/(kg K)) -> 155 J/(m² K).  Measure or
#: look up your sensor's value (the paper's Minco S651 is not specified further) and pass it.
DEFAULT_SENSOR_HEAT_CAPACITY = 1420.0 * 1090.0 * 100e-6
#: Resistance skin -> sensor node, m² K/W: an *assumption*, 10 µm of cyanoacrylate
#: (λ ≈ 0.1 W/(m K)) + 50 µm polyimide (λ ≈ 0.12 W/(m K)) -> 5.2e-4 m² K/W.
DEFAULT_SENSOR_SKIN_RESISTANCE = 10e-6 / 0.1 + 50e-6 / 0.12


@dataclass(frozen=True)
class Sensor:
    """Where the contact-temperature sensor sits, and its own thermal mass.

    Parameters
    ----------
    side : {"skin", "material", "lumped"}
        See the module docstring.
    heat_capacity : float, J/(m² K)
        ``"lumped"`` only: ρ c h of the sensor film.
    skin_resistance : float, m² K/W
        ``"lumped"`` only: the fixed resistance between the skin surface and the sensor.

    Raises
    ------
    CalibrationError
        Unknown side, or lumped parameters that are negative or non-finite.
    """

    side: str = "material"
    heat_capacity: float = 0.0
    skin_resistance: float = 0.0

    def __post_init__(self):
        if self.side not in SENSOR_SIDES:
            raise CalibrationError(f"sensor: side: expected one of {SENSOR_SIDES}, got {self.side!r}")
        for name in ("heat_capacity", "skin_resistance"):
            v = float(getattr(self, name))
            if not (math.isfinite(v) and v >= 0.0):
                raise CalibrationError(f"sensor: {name}: expected a finite number ≥ 0, got {v!r}")
            object.__setattr__(self, name, v)
        if self.side != "lumped" and (self.heat_capacity or self.skin_resistance):
            raise CalibrationError(
                f"sensor: heat_capacity: a {self.side!r} sensor is massless; use side='lumped' "
                f"for a sensor with its own heat capacity, got {self.heat_capacity!r}")

    @classmethod
    def lumped(cls, heat_capacity: float = DEFAULT_SENSOR_HEAT_CAPACITY,
               skin_resistance: float = DEFAULT_SENSOR_SKIN_RESISTANCE) -> "Sensor":
        """A sensor with thermal mass between skin and sample (defaults: stated assumptions)."""
        return cls("lumped", heat_capacity, skin_resistance)

    def describe(self) -> str:
        """One line for reports."""
        if self.side == "lumped":
            return (f"lumped sensor between skin and sample (C = {self.heat_capacity:.4g} J/(m² K), "
                    f"skin-sensor R1 = {self.skin_resistance:.4g} m² K/W; the fitted R is sensor-sample)")
        return {"skin": "massless sensor on the skin surface (x = L-)",
                "material": "massless sensor on the sample surface (x = L+)"}[self.side]

    def to_dict(self) -> dict:
        return {"side": self.side, "heat_capacity_J_m2K": self.heat_capacity,
                "skin_resistance_m2K_W": self.skin_resistance}


def _default_skin_properties():
    from stimuli import Skin
    s = Skin(1e-3)
    return (s.conductivity, s.density, s.specific_heat)


def _default_material():
    from stimuli import material
    return material("stainless_steel", thickness=3e-3)


@dataclass(frozen=True)
class ContactSetup:
    """Everything about a calibration contact except the fitted R, L and the temperatures.

    Parameters
    ----------
    material : stimuli.Material
        The sample; ``thickness=None`` is a half-space, otherwise a slab (m) with an
        insulated back.  Default: stainless steel, 3 mm (the paper's samples).
    sensor : Sensor
        Default: ``Sensor("material")``.
    skin_properties : tuple of float
        (conductivity W/(m K), density kg/m³, specific heat J/(kg K)); default Table 1.
    nodes : int
        Contour nodes per time window of the Laplace inversion (:mod:`stimuli.exact`).
    """

    material: object = field(default_factory=_default_material)
    sensor: Sensor = field(default_factory=Sensor)
    skin_properties: tuple = field(default_factory=_default_skin_properties)
    nodes: int = DEFAULT_NODES

    @property
    def sample_thickness(self) -> float | None:
        """Sample thickness D, m (None: half-space)."""
        return self.material.thickness

    def describe(self) -> str:
        d = self.sample_thickness
        thick = "half-space" if d is None else f"slab {d * 1e3:g} mm, insulated back"
        name = getattr(self.material, "name", "") or "material"
        return f"{name} ({thick}); {self.sensor.describe()}"


def _tanh_sech2(z):
    """tanh(z) and sech²(z) for Re z ≥ 0 without overflow."""
    e = np.exp(-2.0 * z)
    tanh = (1.0 - e) / (1.0 + e)
    sech2 = 4.0 * e / (1.0 + e) ** 2
    return tanh, sech2


class ResponseGrid:
    """The sensor response on fixed times, with what does not depend on R and L precomputed.

    A fit evaluates the model at the same times for many (R, L): the Laplace nodes, √s and
    the sample's impedance are computed once here, the skin's tanh terms once per L.

    Parameters
    ----------
    t : array_like, s
        Times since contact, all > 0.
    setup : ContactSetup
    """

    def __init__(self, t, setup: ContactSetup):
        from stimuli.exact import InversionPlan
        t = np.asarray(t, dtype=float)
        if t.ndim != 1 or not np.all(np.isfinite(t) & (t > 0)):
            raise CalibrationError("model: t: expected a 1-D array of finite times > 0 s")
        self.t = t
        self.setup = setup
        self._plan = InversionPlan(t, nodes=int(setup.nodes))
        s = self._plan.s
        k_s, rho_s, c_s = setup.skin_properties
        self._beta_s = math.sqrt(k_s * rho_s * c_s)
        self._sqrt_alpha_s = math.sqrt(k_s / (rho_s * c_s))
        mat = setup.material
        beta_m, alpha_m = mat.effusivity, mat.diffusivity
        self.s = s
        self.rs = np.sqrt(s)                  # principal branch: Re ≥ 0 on the contour
        if mat.thickness is None:
            self.z_m = np.full_like(s, 1.0 / beta_m)
        else:
            e = np.exp(-2.0 * self.rs * (mat.thickness / math.sqrt(alpha_m)))
            self.z_m = (1.0 + e) / (1.0 - e) / beta_m          # coth(q_M D) / beta_M
        self._L = None

    def _skin(self, L: float):
        if self._L != L:
            tanh, sech2 = _tanh_sech2(self.rs * (L / self._sqrt_alpha_s))
            self._z_s = tanh / self._beta_s                                   # Z_S sqrt(s)
            self._dz_s = (self.rs / self._sqrt_alpha_s) * sech2 / self._beta_s   # d z_s / dL
            self._L = L
        return self._z_s, self._dz_s

    def _back(self, F):
        return self._plan.apply(F)

    def response(self, resistance: float, skin_thickness: float, derivatives: bool = False):
        """θ on the grid's times, optionally with ∂θ/∂R and ∂θ/∂L (see :func:`sensor_response`)."""
        R = float(resistance)
        z_s, dz_s = self._skin(float(skin_thickness))
        s, rs, z_m = self.s, self.rs, self.z_m
        side = self.setup.sensor.side
        if side in ("skin", "material"):
            den = R * rs + z_s + z_m
            if side == "skin":
                num = R * rs + z_m
                g = num / (den * s)
                if not derivatives:
                    return self._back(g)
                den2s = den * den * s
                d_r = rs * z_s / den2s
                d_l = -num * dz_s / den2s
            else:
                g = z_m / (den * s)
                if not derivatives:
                    return self._back(g)
                den2s = den * den * s
                d_r = -z_m * rs / den2s
                d_l = -z_m * dz_s / den2s
            return self._back(g), self._back(d_r), self._back(d_l)
        # lumped sensor node: C (s θ - θ0) = A (1/s - θ) - B θ, θ0 = 1 (starts at skin temperature)
        C, R1 = self.setup.sensor.heat_capacity, self.setup.sensor.skin_resistance
        a_den = R1 * rs + z_s
        b_den = R * rs + z_m
        A = rs / a_den
        B = rs / b_den
        tot = C * s + A + B
        g = (C + A / s) / tot
        if not derivatives:
            return self._back(g)
        dg_da = (1.0 / s - g) / tot
        dg_db = -g / tot
        d_r = dg_db * (-s / (b_den * b_den))
        d_l = dg_da * (-rs * dz_s / (a_den * a_den))
        return self._back(g), self._back(d_r), self._back(d_l)


def sensor_response(t, resistance: float, skin_thickness: float, setup: ContactSetup,
                    derivatives: bool = False):
    r"""Dimensionless sensor reading θ(t) = (T - T_M0)/(T_S0 - T_M0) after contact at t = 0.

    Parameters
    ----------
    t : array_like, s
        Times since contact; values ≤ 0 give the reading before contact.
    resistance : float, m² K/W
        Effective contact resistance R (``"lumped"``: sensor-sample).
    skin_thickness : float, m
        Skin thickness L.
    setup : ContactSetup
    derivatives : bool
        Also return ∂θ/∂R, W/(m² K), and ∂θ/∂L, 1/m.

    Returns
    -------
    theta : ndarray
        Or ``(theta, dtheta_dR, dtheta_dL)`` with ``derivatives=True``.

    Notes
    -----
    With :math:`z_S = \tanh(q_S L)/\beta_S`, :math:`z_M = 1/\beta_M` (half-space) or
    :math:`\coth(q_M D)/\beta_M` (slab), :math:`q_i = \sqrt{s/\alpha_i}`:

    .. math:: \hat\theta_{L^-} = \frac{1}{s}\,\frac{R\sqrt s + z_M}{R\sqrt s + z_S + z_M},\qquad
              \hat\theta_{L^+} = \frac{1}{s}\,\frac{z_M}{R\sqrt s + z_S + z_M}

    which is the interface flux F(s) (docs/design.md) multiplied by the material impedance
    (material side) or subtracted through the skin impedance (skin side).  The lumped
    sensor node obeys :math:`C(s\hat\theta - 1) = A(1/s - \hat\theta) - B\hat\theta` with
    :math:`A = \sqrt s/(R_1\sqrt s + z_S)`, :math:`B = \sqrt s/(R\sqrt s + z_M)`; with C = 0
    and R₁ = 0 it reduces to the skin side.

    Examples
    --------
    >>> from stimuli import material
    >>> setup = ContactSetup(material("stainless_steel"), Sensor("material"))
    >>> th = sensor_response([1.0], 0.0, 1.0, setup)   # thick skin, no resistance
    >>> round(float(th[0]), 6)   # beta_S / (beta_S + beta_M) for two half-spaces at early times
    0.138623
    """
    t = np.atleast_1d(np.asarray(t, dtype=float))
    R, L = float(resistance), float(skin_thickness)
    if not (math.isfinite(R) and R >= 0):
        raise CalibrationError(f"model: resistance: expected a finite number ≥ 0 m² K/W, got {R!r}")
    if not (math.isfinite(L) and L > 0):
        raise CalibrationError(f"model: skin_thickness: expected a finite number > 0 m, got {L!r}")
    theta = np.empty_like(t)
    d_r = np.zeros_like(t)
    d_l = np.zeros_like(t)
    before = t <= 0
    after = ~before
    theta[before] = 0.0 if setup.sensor.side == "material" else 1.0
    if np.any(after):
        theta[after], d_r[after], d_l[after] = ResponseGrid(t[after], setup).response(
            R, L, derivatives=True)
    if derivatives:
        return theta, d_r, d_l
    return theta


def sensor_temperature(t, resistance: float, skin_thickness: float, skin_temperature: float,
                       material_temperature: float, setup: ContactSetup):
    """What the sensor reads, °C, at ``t`` s after contact (see :func:`sensor_response`).

    Parameters
    ----------
    t : array_like, s
    resistance : float, m² K/W
    skin_thickness : float, m
    skin_temperature : float, °C
        Initial skin temperature T_S0 (also the inner-boundary temperature).
    material_temperature : float, °C
        Initial sample temperature T_M0.
    setup : ContactSetup

    Returns
    -------
    ndarray, °C
    """
    theta = sensor_response(t, resistance, skin_thickness, setup)
    return material_temperature + (skin_temperature - material_temperature) * theta
