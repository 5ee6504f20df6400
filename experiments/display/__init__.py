"""The thermal display, the host's side: the contract, the backend registry, safety, backends.

Displays are opened only through :func:`open_display` (:mod:`.registry`), which picks the
backend by the URL's scheme; every backend is a :class:`Display` (:mod:`.base`). One subpackage
per backend: :mod:`.thermocue` (the thermocue serial protocol, its driver and the QEMU firmware
runner; the protocol is written down in ``docs/display-protocol.md``) and :mod:`.tcs2` (a
QST.Lab TCS II). The stand-in devices live in :mod:`experiments.emulators`, which this package
never imports: ``emulator://`` registers through the ``thermocue.displays`` entry point like any
third-party backend. The names below are imported on first use (PEP 562), so importing the
package does not pull in numpy and the driver.
"""
from __future__ import annotations

import importlib

#: public name -> the module that defines it
_EXPORTS = {"SafetyLimits": "safety", "DeviceInfo": "types",
            "DeviceEvent": "types", "Status": "types",
            "Telemetry": "types", "ContactEvent": "trial_recording",
            "TrialRecording": "trial_recording", "ThermalDisplay": "thermocue.driver",
            "open_display": "registry", "backends": "registry", "backend_for": "registry",
            "Display": "base", "EmulatedDisplay": "base", "Capabilities": "base",
            "ProfileReceipt": "base", "DisplayURL": "url", "parse_display_url": "registry"}

__all__ = ["open_display", "parse_display_url", "DisplayURL", "backends", "backend_for", "Display", "EmulatedDisplay", "Capabilities",
           "ProfileReceipt", "ThermalDisplay", "SafetyLimits", "Telemetry",
           "ContactEvent", "TrialRecording", "DeviceInfo", "DeviceEvent", "Status"]


def __getattr__(name: str):
    if name in _EXPORTS:
        value = getattr(importlib.import_module(f"{__name__}.{_EXPORTS[name]}"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
