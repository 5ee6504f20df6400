"""A QST.Lab TCS II in software (``docs/tcs2.md``).

:mod:`.device` is the thermode's ASCII protocol and its zones; :mod:`.protocol_tcs2emu` serves
it as the ``tcs2emu://`` pyserial URL (what the TCS II backend's ``tcs2://emulator`` opens), and
:func:`experiments.emulators.pty_server.run_tcs2` on a pty (``thermocue emulator --model tcs2``).
"""
from __future__ import annotations

import serial as _serial

# pyserial imports ``protocol_<scheme>`` from these packages: tcs2emu:// is the emulator
if "experiments.emulators.tcs2" not in _serial.protocol_handler_packages:
    _serial.protocol_handler_packages.append("experiments.emulators.tcs2")
