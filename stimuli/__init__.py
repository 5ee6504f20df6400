"""Thermal model of a fingertip touching a material.

The contract (docs/design.md, docs/internal-contracts.md): :class:`Skin`,
:class:`Material`, :func:`material`, :func:`contact_resistance` (Eq. 5),
:class:`Contact` (methods "exact", "paper", "paper-as-printed", "numerical"),
:func:`skin_response` and :func:`target_profile` (display-driven model).

The names below are loaded on first use (PEP 562), so that ``stimuli.paper``, the paper's
constants (standard library only), can be imported without numpy and scipy: the command line
reads its ``choices=`` from it and stays fast. ``from stimuli import Skin`` works as before.
"""
from __future__ import annotations

import importlib
import importlib.util

#: Public name -> submodule defining it.
_EXPORTS = {
    "ModelInputError": "errors", "ModelRangeWarning": "errors",
    "Material": "properties", "Skin": "properties",
    "MATERIALS": "materials", "MATERIAL_SOURCES": "materials",
    "PAPER_SAMPLE_THICKNESS": "materials", "material": "materials",
    "contact_resistance": "roughness",
    "METHODS": "contact", "Contact": "contact", "MethodInfo": "contact",
    "skin_response": "display_response",
    "TargetProfile": "target", "target_profile": "target",
}

__all__ = [
    "ModelInputError", "ModelRangeWarning", "Skin", "Material", "MATERIALS", "MATERIAL_SOURCES",
    "PAPER_SAMPLE_THICKNESS", "material", "contact_resistance", "Contact", "MethodInfo", "METHODS",
    "skin_response", "TargetProfile", "target_profile",
]


def __getattr__(name: str):
    """Load a public name's submodule on first use; a submodule by its name (``stimuli.scene``)."""
    if name in _EXPORTS:
        value = getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
    elif importlib.util.find_spec(f"{__name__}.{name}") is not None:
        value = importlib.import_module(f".{name}", __name__)
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))
