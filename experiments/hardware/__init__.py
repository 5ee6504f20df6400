"""The thermal display: serial protocol, pyserial driver, and a device emulator.

Importing this package registers it with pyserial, so ``serial.serial_for_url("emulator://")``
opens the in-process emulator (:mod:`experiments.hardware.protocol_emulator`). The protocol is
written down in ``docs/display-protocol.md``.
"""
from __future__ import annotations

import serial as _serial

if "experiments.hardware" not in _serial.protocol_handler_packages:
    _serial.protocol_handler_packages.append("experiments.hardware")

from .safety import SafetyLimits  # noqa: E402
from .messages import DeviceInfo, DeviceEvent, Status, Telemetry  # noqa: E402
from .driver import ContactEvent, ThermalDisplay, TrialRecording, open_display  # noqa: E402

__all__ = ["open_display", "ThermalDisplay", "SafetyLimits", "Telemetry", "ContactEvent",
           "TrialRecording", "DeviceInfo", "DeviceEvent", "Status"]
