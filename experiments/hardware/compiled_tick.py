"""The emulated firmware's steady ticks, compiled: optional, and the same doubles as Python's.

:meth:`Device.step <experiments.hardware.device.Device.step>` is the firmware's tick and its
reference. A simulated session spends most of its time there (about 900 ticks a trial, each a
telemetry frame), so the C extension ``experiments/hardware/_tick.c`` transcribes the ticks that
change no state -- no event, no transition, no log, no safety trip, no fault hook -- with the same
arithmetic in the same order (IEEE doubles, no fused multiply-add; the skin's product is numpy's
own ``dot``, called as the Python tick calls it) and hands every other tick to ``Device.step``.
``tests/experiments/hardware/test_compiled_tick.py`` checks the two tick for tick, state and
frames, bit for bit.

It is used only by :meth:`Serial.read_frames
<experiments.hardware.protocol_emulator.Serial.read_frames>`, the in-process virtual clock with
no fault injected; a real clock, a pty, a fault spec or a stall run the Python tick. Built by
``pip install`` when a C compiler is there (``scripts/setup`` installs one); without it, or with
the environment variable ``THERMOCUE_PYTHON_TICK=1``, every tick is Python's (the same logs,
about 3 times slower).
"""
from __future__ import annotations

import os
import warnings

from . import device_constants as k
from .device import Device
from .framing import Frame
from .messages import Mode, Msg, State, TELEMETRY
from .pad_physics import CONTACT_AREA_M2, KELVIN, FingerScript, FingerSkin, PadPlant, _dot

__all__ = ["AVAILABLE", "enabled", "read_ticks", "why_not"]

#: The Python methods the C file transcribes: an object whose class or instance has another
#: one (a subclass, a test's spy) ticks in Python.
ORIGINALS = (Device.step, Device._sample_reading, PadPlant.step, FingerSkin.step,
             FingerSkin.surface_C, FingerScript.force)
#: The numbers the C file writes as literals, checked against these when it is loaded.
CONSTANTS = dict(
    TICK_US=k.TICK_US, HARD_MIN_C=k.HARD_MIN_C, SETPOINT_MAX_C=k.SETPOINT_MAX_C,
    HARD_RATE_C_PER_S=k.HARD_RATE_C_PER_S, WATCHDOG_MS=k.WATCHDOG_MS,
    RATE_WINDOW_TICKS=k.RATE_WINDOW_TICKS, RATE_SLACK_C=k.RATE_SLACK_C,
    READY_BAND_C=k.READY_BAND_C, RELEASE_MS=k.RELEASE_MS, OVERTEMP_C=k.OVERTEMP_C,
    HEATSINK_MAX_C=k.HEATSINK_MAX_C, STUCK_SAMPLES=k.STUCK_SAMPLES,
    CONTACT_AREA_M2=CONTACT_AREA_M2, KELVIN=KELVIN, TELEMETRY_SIZE=TELEMETRY.size,
    MSG_TELEMETRY=int(Msg.TELEMETRY),
    **{f"SHARE{i}": v for i, v in enumerate(FingerScript.SHARES)},
    **{st.name: int(st) for st in State}, **{md.name: int(md) for md in Mode})

#: Why the compiled tick is not used (None when it is).
why_not: str | None = None
try:
    from . import _tick
except ImportError:                     # not built: no C compiler at install time
    _tick = None
    why_not = ("experiments/hardware/_tick.c is not built (no C compiler at `pip install`?); "
               "scripts/setup installs one")
else:
    try:
        # numpy's dot itself, past its __array_function__ dispatcher (the same function, the
        # same product: the dispatcher only looks for overrides, and the skin's arrays are
        # plain ndarrays)
        _tick.configure(Frame, getattr(_dot, "_implementation", _dot), ORIGINALS, CONSTANTS)
    except ValueError as exc:           # the firmware's numbers changed, the C file did not
        why_not = str(exc)
        warnings.warn(f"the emulator runs Python's ticks: {exc}", RuntimeWarning, stacklevel=2)

#: Whether the extension is built and agrees with the Python firmware's numbers.
AVAILABLE = why_not is None
if AVAILABLE and os.environ.get("THERMOCUE_PYTHON_TICK", "") == "1":
    why_not = "THERMOCUE_PYTHON_TICK=1"
#: Whether :func:`read_ticks` is used (tests switch it off to compare with Python's ticks).
enabled = why_not is None


def read_ticks(device, frames: list, budget: int) -> tuple[int, int]:
    """Tick ``device`` until ``frames`` (its ``direct`` list) holds something, at most ``budget``
    ticks, then up to two more while it is not IDLE; return (compiled ticks, Python ticks)."""
    return _tick.read_ticks(device, frames, budget)
