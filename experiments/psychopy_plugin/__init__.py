"""thermocue's PsychoPy plugin: the thermal display as a device, and a "Thermal cue" component.

Installed with ``pip install thermocue[gui]``; PsychoPy finds both through the package's entry
points (``psychopy.hardware`` and ``psychopy.experiment.components``, see pyproject.toml).
PsychoPy is imported only here, in :mod:`.device` and :mod:`.component` (lazily below):
:mod:`.clock_sync`, :mod:`.profiles` and :mod:`.cue` do without it. See docs/psychopy-plugin.md.
"""
from __future__ import annotations

from .clock_sync import ClockMap, SyncBurst
from .cue import ThermalCue

__all__ = ["ThermalCue", "ThermalCueDevice", "ContactResponse", "ThermalCueComponent",
           "ClockMap", "SyncBurst"]


def __getattr__(name):
    if name in ("ThermalCueDevice", "ContactResponse"):
        from . import device
        return getattr(device, name)
    if name == "ThermalCueComponent":
        from .component import ThermalCueComponent
        return ThermalCueComponent
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
