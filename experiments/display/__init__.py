"""The thermal display: the backend registry, the serial protocol, its driver, and emulators.

Displays are opened only through :func:`open_display` (:mod:`.registry`), which picks the
backend by the URL's scheme; every backend is a :class:`Display` (:mod:`.display_base`).

Importing this package registers it with pyserial, so ``serial.serial_for_url("emulator://")``
opens the in-process emulator (:mod:`experiments.hardware.protocol_emulator`). The protocol is
written down in ``docs/display-protocol.md``. The names below are imported on first use (PEP 562),
so a module of the package that needs only the standard library (the emulator's command-line
options) does not pull in numpy and the driver.
"""
from __future__ import annotations

import importlib

import serial as _serial

if "experiments.hardware" not in _serial.protocol_handler_packages:
    _serial.protocol_handler_packages.append("experiments.hardware")

#: public name -> the module that defines it
_EXPORTS = {"SafetyLimits": "safety", "DeviceInfo": "messages", "DeviceEvent": "messages",
            "Status": "messages", "Telemetry": "messages", "ContactEvent": "trial_recording",
            "TrialRecording": "trial_recording", "ThermalDisplay": "driver",
            "EmulatorDisplay": "driver", "open_display": "registry", "backends": "registry",
            "backend_for": "registry", "Display": "display_base", "EmulatedDisplay": "display_base",
            "Capabilities": "display_base", "ProfileReceipt": "display_base"}

__all__ = ["open_display", "backends", "backend_for", "Display", "EmulatedDisplay", "Capabilities",
           "ProfileReceipt", "ThermalDisplay", "EmulatorDisplay", "SafetyLimits", "Telemetry",
           "ContactEvent", "TrialRecording", "DeviceInfo", "DeviceEvent", "Status"]


def __getattr__(name: str):
    if name in _EXPORTS:
        value = getattr(importlib.import_module(f"{__name__}.{_EXPORTS[name]}"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
