"""The thermocue display's emulator: the firmware in Python (``docs/display-protocol.md``).

:mod:`.device` ticks the firmware (:mod:`.device_commands`: the host's commands;
:mod:`.device_constants`: its range, rate, timing budget and identity), :mod:`.pad_physics` the
pad and the finger, :mod:`.faults` the injected faults; :mod:`.emulator_core` drives a device on
a real or virtual clock, and :mod:`.protocol_emulator` is the ``emulator://`` pyserial URL.

Importing this package registers it with pyserial, so ``serial.serial_for_url("emulator://")``
opens the in-process emulator.
"""
from __future__ import annotations

import serial as _serial

if "experiments.emulators.thermocue" not in _serial.protocol_handler_packages:
    _serial.protocol_handler_packages.append("experiments.emulators.thermocue")
