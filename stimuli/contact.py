"""`Contact`: the fingertip touching a material, with temperatures by several methods."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .errors import ModelInputError
from .exact import INVERSION_ERROR, invert_laplace
from .laplace import ContactTransform
from .properties import Material, Skin

__all__ = ["Contact", "MethodInfo", "METHODS"]

#: The methods ``method=`` accepts: name -> evaluator ``f(contact, quantity, x, t)`` returning
#: theta (like ``scipy.integrate``'s ``METHODS = {'RK23': RK23, ...}``); filled in below the class.
METHODS: dict = {}

#: What ``tolerance=`` tries, cheapest first (``thermocue bench model``, 20 s at 1 kHz:
#: exact ~1.5 x the printed Eq. 7, the corrected series ~15-30 x, so the
#: corrected "paper" forms are never the cheapest adequate choice; "paper-as-printed"
#: is only a single closed-form term for the interface (Eq. 7) and psi (Eq. 8)).
_BY_COST = ("paper-as-printed", "exact")
_SINGLE_TERM = ("interface_material", "psi")


@dataclass(frozen=True)
class MethodInfo:
    """What a `Contact` evaluation used (returned with ``full_output=True``).

    ``method``: the method name; ``error_bound``: K for temperatures,
    dimensionless for psi -- the exact method's 1e-12 |T_S0 - T_M0|, the
    probe estimate when ``tolerance=`` chose a closed form, ``nan`` when a
    closed form was asked for directly (unknown); ``quantity``: what was computed.
    """

    method: str
    error_bound: float
    quantity: str


class Contact:
    r"""A fingertip skin of initial temperature T_S0 touching a material at T_M0.

    Parameters
    ----------
    skin : Skin
    material : Material
        A half-space (``thickness=None``) or a slab with an insulated back.
    resistance : float, m^2 K / W
        Contact resistance R (>= 0; e.g. :func:`stimuli.contact_resistance`).
    skin_temperature : float, degC
        Initial skin temperature T_S0 (also the temperature held at x = 0).
    material_temperature : float, degC
        Initial material temperature T_M0.

    Notes
    -----
    Coordinates: x from the skin's inner boundary; the skin is 0 <= x <= L, the
    thermoreceptors at x = d (``skin.dermis``), the material x >= L.

    Every evaluator takes ``method=`` (see :data:`METHODS`):

    ``"exact"`` (default)
        Numerical inversion of the exact Laplace-domain solution
        (:mod:`stimuli.exact`), absolute error <= 1e-12 in theta.
    ``"paper"``
        The paper's closed forms with the printed errors corrected
        (:mod:`stimuli.paper_forms`); exact for R = 0, approximate for R > 0
        (constant gamma). Half-space materials only.
    ``"paper-as-printed"``
        The paper's formulas as printed: interface = Eq. 7, skin = Eq. 3a,
        material = Eq. 3b, recognizing profile = Eq. 8. Half-space only.
    ``"numerical"``
        The finite-volume solver in :mod:`stimuli.finite_volume`, if present.

    and ``tolerance=`` (K; dimensionless for the recognizing profile): when
    given, ``method`` is ignored and the cheapest method whose estimated error
    on the requested quantity, depth and time range is below ``tolerance`` is
    used: the single-term printed Eq. 7 / Eq. 8 where they are good enough,
    else "exact" (which is faster than the corrected series). ``full_output=True`` returns
    ``(values, info)`` with the choice and its error bound in ``info`` (a :class:`MethodInfo`),
    like SciPy's ``full_output`` habit; without it every evaluator returns the values only.
    The closed forms' error is estimated by comparing them with ``"exact"`` on
    at most 24 probe times spanning the requested ones (so a cheap method is
    not guaranteed below ``tolerance`` between probes, but it is checked where
    its error is largest for monotone profiles). Only the requested depth is
    ever computed.

    At t = 0 the initial temperatures are returned, except exactly at the
    interface with R = 0, where the contact temperature (the t -> 0+ limit,
    (beta_S T_S0 + beta_M T_M0) / (beta_S + beta_M)) is returned.

    Examples
    --------
    >>> from stimuli import Skin, material
    >>> c = Contact(Skin(650e-6), material("stainless_steel"), 0.0, 36.0, 20.0)
    >>> c.interface_temperature([0.0, 1.0, 20.0]).round(3).tolist()
    [22.218, 22.224, 24.566]
    >>> T, info = c.receptor_temperature([1.0, 20.0], tolerance=0.01, full_output=True)
    >>> T.round(3).tolist(), info.method
    ([28.883, 29.113], 'exact')
    >>> T, info = c.interface_temperature([1.0, 20.0], tolerance=2.0, full_output=True)
    >>> T.round(3).tolist()   # printed Eq. 7 is enough
    [22.222, 23.283]
    >>> info.method, round(info.error_bound, 2)
    ('paper-as-printed', 1.28)
    """

    def __init__(self, skin: Skin, material: Material, resistance: float,
                 skin_temperature: float, material_temperature: float):
        if not isinstance(skin, Skin):
            raise ModelInputError(f"Contact: skin: expected a stimuli.Skin, got {skin!r}")
        if not isinstance(material, Material):
            raise ModelInputError(f"Contact: material: expected a stimuli.Material, got {material!r}")
        r = _finite("resistance", resistance)
        if r < 0 or r > 1.0:
            raise ModelInputError(
                f"Contact: resistance: expected 0 <= R <= 1 m^2 K/W, got {resistance!r}")
        self.skin = skin
        self.material = material
        self.resistance = r
        self.skin_initial = _finite("skin_temperature", skin_temperature)
        self.material_initial = _finite("material_temperature", material_temperature)
        for name, v in (("skin_temperature", self.skin_initial),
                        ("material_temperature", self.material_initial)):
            if v < -273.15:   # Contact is also used in theta units (1, 0): only the impossible is refused
                raise ModelInputError(f"Contact: {name}: expected >= -273.15 °C (absolute zero), got {v!r}")
        self._transform = ContactTransform.from_contact(skin, material, r)

    def __repr__(self):
        return (f"Contact(skin={self.skin!r}, material={self.material!r}, resistance={self.resistance!r}, "
                f"skin_temperature={self.skin_initial!r}, material_temperature={self.material_initial!r})")

    # -- public evaluators ----------------------------------------------------
    def interface_temperature(self, t, side: str = "material", method: str = "exact", tolerance=None,
                              full_output: bool = False):
        """Interface temperature, degC.

        Parameters
        ----------
        t : array_like, s
            Times since contact (>= 0).
        side : {"material", "skin"}
            x = L+ (the paper's Eq. 7, what a sensor on the sample reads) or x = L-.
            They differ by R times the heat flux; equal for R = 0.
        method : str
            A key of :data:`METHODS`.
        tolerance : float, K, optional
        full_output : bool
            Also return the :class:`MethodInfo` of the evaluation.

        Returns
        -------
        ndarray, degC, shape of ``t``
            And, with ``full_output=True``, the :class:`MethodInfo` as a second item.
        """
        if side not in ("material", "skin"):
            raise ModelInputError(f"Contact.interface_temperature: side: expected 'material' or 'skin', got {side!r}")
        q = "interface_material" if side == "material" else "interface_skin"
        return self._temperature(q, self.skin.thickness, t, method, tolerance, full_output)

    def skin_temperature(self, x, t, method: str = "exact", tolerance=None, full_output: bool = False):
        """Skin temperature at depth ``x`` (m from the inner boundary, 0 <= x <= L), degC."""
        x = self._depth(x, 0.0, self.skin.thickness, "x")
        return self._temperature("skin", x, t, method, tolerance, full_output)

    def material_temperature(self, x, t, method: str = "exact", tolerance=None,
                             full_output: bool = False):
        """Material temperature at ``x`` (m, L <= x [<= L + D]), degC."""
        hi = math.inf if self.material.thickness is None else self.skin.thickness + self.material.thickness
        x = self._depth(x, self.skin.thickness, hi, "x")
        return self._temperature("material", x, t, method, tolerance, full_output)

    def receptor_temperature(self, t, method: str = "exact", tolerance=None, full_output: bool = False):
        """Temperature at the thermoreceptors, x = d, degC."""
        return self._temperature("skin", self.skin.dermis, t, method, tolerance, full_output)

    def recognizing_profile(self, t, method: str = "exact", tolerance=None, full_output: bool = False):
        r"""psi(t) = (T_S0 - T_S(d, t)) / (T_S0 - T_M0), Eq. 8's quantity, dimensionless in [0, 1]."""
        if self.skin_initial == self.material_initial:
            raise ModelInputError("Contact: material_temperature: expected a value different from "
                                  f"skin_temperature for psi, got {self.material_initial!r}")
        tt = self._times(t)
        out, info = self._run("psi", self.skin.dermis, tt, method, tolerance, scale=1.0)
        return (out, info) if full_output else out

    # -- machinery ------------------------------------------------------------
    def theta(self, quantity: str, x: float, t, method: str = "exact"):
        """Dimensionless theta = (T - T_M0) / (T_S0 - T_M0) (psi for ``quantity="psi"``).

        ``quantity``: "skin", "material", "interface_skin", "interface_material", "psi".
        """
        tt = self._times(t)
        return self._evaluate(quantity, x, tt, method)

    def _temperature(self, quantity, x, t, method, tolerance, full_output=False):
        tt = self._times(t)
        dT = self.skin_initial - self.material_initial
        th, info = self._run(quantity, x, tt, method, tolerance, scale=abs(dT))
        out = self.material_initial + dT * th
        return (out, info) if full_output else out

    def _run(self, quantity, x, tt, method, tolerance, scale):
        if tolerance is not None:
            tol = _finite("tolerance", tolerance)
            if tol <= 0:
                raise ModelInputError(f"Contact: tolerance: expected a number > 0, got {tolerance!r}")
            method, bound = self._choose(quantity, x, tt, tol, scale)
        else:
            bound = self._bound(method, quantity, x, tt, scale)
        out = self._evaluate(quantity, x, tt, method)
        return out, MethodInfo(method, bound, quantity)

    def _bound(self, method, quantity, x, tt, scale):
        if method == "exact":
            return INVERSION_ERROR * scale
        return math.nan  # unknown unless estimated (use tolerance=)

    def _choose(self, quantity, x, tt, tol, scale):
        probe = _probe_times(tt)
        ref = None
        for m in _BY_COST:
            if m == "exact":
                if INVERSION_ERROR * scale <= tol:
                    return m, INVERSION_ERROR * scale
                break
            if quantity not in _SINGLE_TERM or not self._closed_form_ok(m):
                continue
            if probe.size == 0:
                return m, 0.0
            if ref is None:
                ref = self._evaluate(quantity, x, probe, "exact")
            err = float(np.max(np.abs(self._evaluate(quantity, x, probe, m) - ref))) * scale
            if err + INVERSION_ERROR * scale <= tol:
                return m, err + INVERSION_ERROR * scale
        raise ModelInputError(f"Contact: tolerance: expected >= {INVERSION_ERROR * scale:.1e} "
                              f"(the exact method's bound), got {tol!r}")

    def _closed_form_ok(self, method):
        return self.material.thickness is None

    def _evaluate(self, quantity, x, tt, method):
        try:
            evaluate = METHODS[method]
        except (KeyError, TypeError):
            raise ModelInputError(f"Contact: method: expected one of {list(METHODS)}, "
                                  f"got {method!r}") from None
        return evaluate(self, quantity, x, tt)

    def _paper(self, quantity, x, tt, printed=False):
        """The paper's closed forms (:mod:`stimuli.paper_forms`), corrected or as printed."""
        method = "paper-as-printed" if printed else "paper"
        if not self._closed_form_ok(method):
            raise ModelInputError(
                f"Contact: method: {method!r} is a half-space closed form; got a material slab "
                f"(thickness={self.material.thickness!r} m); use 'exact' or 'numerical'")
        from . import paper_forms
        return paper_forms.evaluate(self._paper_params(), quantity, x, tt, printed=printed)

    def _paper_as_printed(self, quantity, x, tt):
        return self._paper(quantity, x, tt, printed=True)

    def _paper_params(self):
        from .paper_forms import PaperParameters
        tr = self._transform
        return PaperParameters(tr.L, tr.alpha_s, tr.beta_s, self.skin.conductivity, tr.alpha_m,
                               tr.beta_m, tr.R)

    def _numerical(self, quantity, x, tt):
        """Delegate to :func:`stimuli.finite_volume.solve_contact` (imported lazily)."""
        try:
            from .finite_volume import solve_contact
        except ImportError:  # pragma: no cover - depends on the colleague's module
            raise ModelInputError("Contact: method: 'numerical' needs stimuli.finite_volume") from None
        L = self.skin.thickness
        if quantity.startswith("interface"):
            depth, side = L, quantity.split("_")[1]
        else:
            depth, side = float(x), ("material" if quantity == "material" else "skin")
        # theta directly: T_S0 = 1, T_M0 = 0
        th = np.asarray(solve_contact(self.skin, self.material, self.resistance, 1.0, 0.0, tt,
                                      depth=depth, side=side), dtype=float)
        return 1.0 - th if quantity == "psi" else th

    def _exact(self, quantity, x, tt):
        tr = self._transform
        out = np.empty_like(tt)
        pos = tt > 0
        zero_val = self._initial_theta(quantity, x)
        out[~pos] = zero_val
        if not np.any(pos):
            return out
        if quantity in ("skin", "interface_skin", "psi"):
            xx = tr.L if quantity == "interface_skin" else float(x)
            deficit = invert_laplace(lambda s: tr.skin_deficit(s, xx), tt[pos])
            out[pos] = deficit if quantity == "psi" else 1.0 - deficit
        elif quantity in ("material", "interface_material"):
            xx = tr.L if quantity == "interface_material" else float(x)
            out[pos] = invert_laplace(lambda s: tr.material_rise(s, xx), tt[pos])
        else:
            raise ModelInputError(f"Contact: quantity: unknown {quantity!r}")
        return out

    def _initial_theta(self, quantity, x):
        """theta at t = 0 (the t -> 0+ contact value at the interface when R = 0)."""
        L = self.skin.thickness
        at_interface = quantity.startswith("interface") or (quantity in ("skin", "material") and x == L)
        if at_interface and self.resistance == 0.0:
            bs, bm = self._transform.beta_s, self._transform.beta_m
            return bs / (bs + bm)
        if quantity == "psi":
            return 0.0
        if quantity in ("skin", "interface_skin"):
            return 1.0
        return 0.0

    @staticmethod
    def _times(t):
        tt = np.asarray(t, dtype=float)
        if not np.all(np.isfinite(tt)) or np.any(tt < 0):
            raise ModelInputError(f"Contact: t: expected finite times >= 0 s, got {t!r}")
        return tt

    @staticmethod
    def _depth(x, lo, hi, name):
        try:
            v = float(x)
        except (TypeError, ValueError):
            raise ModelInputError(f"Contact: {name}: expected one depth in m, got {x!r}") from None
        if not (lo <= v <= hi):
            raise ModelInputError(f"Contact: {name}: expected {lo!r} <= x <= {hi!r} m, got {x!r}")
        return v


METHODS.update({"exact": Contact._exact, "paper": Contact._paper,
                "paper-as-printed": Contact._paper_as_printed, "numerical": Contact._numerical})


def _finite(name, value):
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ModelInputError(f"Contact: {name}: expected a number, got {value!r}") from None
    if not math.isfinite(v):
        raise ModelInputError(f"Contact: {name}: expected a finite number, got {value!r}")
    return v


def _probe_times(tt):
    pos = np.unique(tt[tt > 0])
    if pos.size <= 24:
        return pos
    return np.unique(np.concatenate([pos[[0, -1]], np.geomspace(pos[0], pos[-1], 22)]))
