"""Thermal model of a fingertip touching a material (issue 2).

The contract (DESIGN.md, docs/internal-contracts.md): :class:`Skin`,
:class:`Material`, :func:`material`, :func:`contact_resistance` (Eq. 5),
:class:`Contact` (methods "exact", "paper", "paper-as-printed", "numerical"),
:func:`skin_response` and :func:`target_profile` (display-driven model).
"""
from .errors import ModelInputError, ModelRangeWarning
from .properties import Material, Skin
from .materials import MATERIALS, MATERIAL_SOURCES, PAPER_SAMPLE_THICKNESS, material
from .roughness import contact_resistance
from .contact import METHODS, Contact, MethodInfo

from .display_response import skin_response
from .target import TargetProfile, target_profile

__all__ = [
    "ModelInputError", "ModelRangeWarning", "Skin", "Material", "MATERIALS", "MATERIAL_SOURCES",
    "PAPER_SAMPLE_THICKNESS", "material", "contact_resistance", "Contact", "MethodInfo", "METHODS",
    "skin_response", "TargetProfile", "target_profile",
]
