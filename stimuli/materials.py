"""A small table of contact materials with the source of every number.

All entries are half-spaces (``thickness=None``) unless a thickness is asked
for: the paper's stainless-steel samples are 3 mm thick
(:data:`PAPER_SAMPLE_THICKNESS`), pass it explicitly to model them as slabs with
an insulated back. Properties are room-temperature (about 300 K) values.
"""
from __future__ import annotations

from types import MappingProxyType

from .errors import ModelInputError
from .properties import Material

__all__ = ["MATERIALS", "MATERIAL_SOURCES", "PAPER_SAMPLE_THICKNESS", "SKIN_TABLE1", "material"]

#: Thickness of the paper's roughness samples (Sec. 3.1), m.
PAPER_SAMPLE_THICKNESS = 3e-3

_INCROPERA = ("F. P. Incropera, D. P. DeWitt, T. L. Bergman, A. S. Lavine, Fundamentals of Heat "
              "and Mass Transfer, 6th ed., Wiley 2007")

# name: (conductivity W/(m K), density kg/m^3, specific heat J/(kg K), source)
_TABLE = {
    "stainless_steel": (14.9, 7900.0, 447.0,
                        "Table 1 of the paper (beta = 7253.71 W s^1/2/(m^2 K)); matches AISI 304 in "
                        + _INCROPERA + ", Table A.1, except c (Incropera: 477 J/(kg K); the paper's "
                        "447 is kept because Table 1's beta follows from it)"),
    "copper": (401.0, 8933.0, 385.0, _INCROPERA + ", Table A.1, pure copper at 300 K"),
    "aluminium": (237.0, 2702.0, 903.0, _INCROPERA + ", Table A.1, pure aluminum at 300 K"),
    "glass": (1.4, 2500.0, 750.0, _INCROPERA + ", Table A.3, glass, plate (soda lime) at 300 K"),
    "wood": (0.17, 545.0, 2385.0, _INCROPERA + ", Table A.3, hardwood (oak), cross grain, 300 K"),
    "pmma": (0.19, 1190.0, 1470.0,
             "J. E. Mark (ed.), Physical Properties of Polymers Handbook, 2nd ed., Springer 2007, "
             "poly(methyl methacrylate) (acrylic glass) at 298 K"),
    "polystyrene_foam": (0.027, 55.0, 1210.0,
                         _INCROPERA + ", Table A.3, extruded polystyrene insulation (R-12) at 300 K"),
}

#: Skin properties of Table 1 of the paper (lambda, rho, c); :class:`stimuli.Skin` defaults.
SKIN_TABLE1 = (0.34, 1200.0, 3340.0)

#: name -> half-space :class:`Material` (read-only).
MATERIALS = MappingProxyType({
    name: Material(k, rho, c, None, name) for name, (k, rho, c, _src) in _TABLE.items()
})

#: name -> citation of the numbers (read-only).
MATERIAL_SOURCES = MappingProxyType({name: row[3] for name, row in _TABLE.items()})

_ALIASES = {"ss": "stainless_steel", "steel": "stainless_steel", "aluminum": "aluminium",
            "acrylic": "pmma", "foam": "polystyrene_foam", "plastic": "pmma"}


def material(name: str, thickness: float | None = None) -> Material:
    """Look up a material by name.

    Parameters
    ----------
    name : str
        A key of :data:`MATERIALS` (case-insensitive; aliases such as ``"ss"``,
        ``"aluminum"``, ``"foam"``, ``"plastic"`` are accepted).
    thickness : float or None, m
        ``None`` (default) is a half-space; the paper's samples are
        ``PAPER_SAMPLE_THICKNESS`` = 3e-3 m thick (insulated back).

    Returns
    -------
    Material

    Raises
    ------
    ModelInputError
        Unknown name or non-positive thickness.

    Examples
    --------
    >>> material("stainless_steel").conductivity
    14.9
    >>> material("ss", thickness=3e-3).thickness
    0.003
    """
    key = str(name).strip().lower().replace("-", "_").replace(" ", "_")
    key = _ALIASES.get(key, key)
    if key not in MATERIALS:
        raise ModelInputError(
            f"material: name: expected one of {sorted(MATERIALS)}, got {name!r}")
    return MATERIALS[key].with_thickness(thickness)
