"""Thermal properties of the skin and of a contacted material (SI units)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from .errors import ModelInputError

__all__ = ["Skin", "Material", "ThermalProperties", "check_positive"]


def check_positive(where: str, name: str, value, *, allow_none: bool = False) -> float | None:
    """Return ``float(value)`` if it is finite and > 0, else raise :class:`ModelInputError`."""
    if value is None and allow_none:
        return None
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ModelInputError(f"{where}: {name}: expected a positive number, got {value!r}") from None
    if not (math.isfinite(v) and v > 0.0):
        raise ModelInputError(f"{where}: {name}: expected a finite number > 0, got {value!r}")
    return v


class ThermalProperties:
    """``diffusivity`` and ``effusivity`` of anything with ``conductivity``, ``density`` and
    ``specific_heat`` (SI): the skin, a material, a skin layer."""

    __slots__ = ()

    @property
    def diffusivity(self) -> float:
        """alpha = lambda / (rho c), m^2/s."""
        return self.conductivity / (self.density * self.specific_heat)

    @property
    def effusivity(self) -> float:
        """beta = sqrt(lambda rho c), W s^1/2 / (m^2 K) (the paper's "thermal contact coefficient")."""
        return math.sqrt(self.conductivity * self.density * self.specific_heat)


@dataclass(frozen=True)
class Skin(ThermalProperties):
    """The fingertip skin: a slab 0 < x < L held at its initial temperature at x = 0.

    Parameters
    ----------
    thickness : float, m
        Total thickness L (dermis + epidermis). The paper's groups: 650e-6 and 1000e-6.
    dermis : float or None, m
        Dermis thickness d; the thermoreceptors sit at x = d, i.e. under an
        epidermis L - d thick. ``None`` means ``0.6 * thickness``.
    conductivity : float, W/(m K)
        lambda_S, Table 1 of [1]_: 0.34.
    density : float, kg/m^3
        rho_S, Table 1: 1200.
    specific_heat : float, J/(kg K)
        c_S, Table 1: 3340.

    Raises
    ------
    ModelInputError
        A non-positive or non-finite value, or ``dermis`` not within (0, thickness).

    References
    ----------
    .. [1] "How the Skin Thickness and Thermal Contact Resistance Influence
       Thermal Tactile Perception", Table 1.

    Examples
    --------
    >>> skin = Skin(650e-6)
    >>> round(skin.dermis * 1e6, 6), round(skin.epidermis * 1e6, 6)
    (390.0, 260.0)
    >>> round(skin.effusivity, 2)   # Table 1 prints 1167.36
    1167.36
    """

    thickness: float
    dermis: float | None = None
    conductivity: float = 0.34
    density: float = 1200.0
    specific_heat: float = 3340.0

    def __post_init__(self):
        w = "Skin"
        L = check_positive(w, "thickness", self.thickness)
        if L > 0.05:
            raise ModelInputError(f"{w}: thickness: expected metres (a few 1e-4), got {self.thickness!r}")
        if L < 10e-6:
            raise ModelInputError(f"{w}: thickness: expected at least 10 µm (1e-5 m; the stratum "
                                  f"corneum alone is thicker), got {self.thickness!r}")
        object.__setattr__(self, "thickness", L)
        d = 0.6 * L if self.dermis is None else check_positive(w, "dermis", self.dermis)
        if not d < L:
            raise ModelInputError(
                f"{w}: dermis: expected 0 < dermis < thickness ({L!r} m), got {self.dermis!r}")
        object.__setattr__(self, "dermis", d)
        for name in ("conductivity", "density", "specific_heat"):
            object.__setattr__(self, name, check_positive(w, name, getattr(self, name)))

    @property
    def epidermis(self) -> float:
        """Epidermis thickness L - d, m."""
        return self.thickness - self.dermis


@dataclass(frozen=True)
class Material(ThermalProperties):
    """A contacted material: a half-space (``thickness=None``) or a slab with an insulated back.

    Parameters
    ----------
    conductivity : float, W/(m K)
    density : float, kg/m^3
    specific_heat : float, J/(kg K)
    thickness : float or None, m
        Slab thickness D; ``None`` is a half-space (the default everywhere).
    name : str
        Label only (not used in computations).

    Examples
    --------
    >>> steel = Material(14.9, 7900.0, 447.0, name="stainless_steel")
    >>> round(steel.effusivity, 2)   # Table 1 prints 7253.71
    7253.71
    >>> steel.thickness is None
    True
    """

    conductivity: float
    density: float
    specific_heat: float
    thickness: float | None = None
    name: str = field(default="", compare=True)

    def __post_init__(self):
        w = f"Material({self.name!r})" if self.name else "Material"
        for n in ("conductivity", "density", "specific_heat"):
            object.__setattr__(self, n, check_positive(w, n, getattr(self, n)))
        object.__setattr__(self, "thickness", check_positive(w, "thickness", self.thickness, allow_none=True))
        if not isinstance(self.name, str):
            raise ModelInputError(f"{w}: name: expected a string, got {self.name!r}")

    alpha = ThermalProperties.diffusivity
    beta = ThermalProperties.effusivity

    def with_thickness(self, thickness: float | None) -> "Material":
        """A copy as a slab of ``thickness`` m (``None``: half-space)."""
        return Material(self.conductivity, self.density, self.specific_heat, thickness, self.name)


Skin.alpha = Skin.diffusivity
Skin.beta = Skin.effusivity
