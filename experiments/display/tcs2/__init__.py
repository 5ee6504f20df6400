"""A QST.Lab TCS II thermode as a thermocue display.

:mod:`.profile_compiler` turns a target profile into the device's linear segments with a stated
error; :mod:`.commands` formats and parses its ASCII commands; :mod:`.link` reads and writes
them as lines; :mod:`.url` reads a ``tcs2://`` URL; :mod:`.backend` is the display backend of
``tcs2://PORT`` and :mod:`.trial` one armed trial on it; :mod:`.device` is a TCS II in software,
served by :mod:`.protocol_tcs2emu` (the ``tcs2emu://`` pyserial URL, ``tcs2://emulator``) and
:mod:`.pty_server` (``thermocue emulator --model tcs2``). See ``docs/tcs2.md``.
"""
from __future__ import annotations

import serial as _serial

# pyserial imports ``protocol_<scheme>`` from these packages: tcs2emu:// is the emulator
if "experiments.hardware.tcs2" not in _serial.protocol_handler_packages:
    _serial.protocol_handler_packages.append("experiments.hardware.tcs2")
