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

from .framing import Frame
from .pad_physics import _dot

try:
    from . import _tick
except ImportError:                     # not built: no C compiler at install time
    _tick = None
else:
    # numpy's dot itself, past its __array_function__ dispatcher (the same function, the same
    # product: the dispatcher only looks for overrides, and the skin's arrays are plain ndarrays)
    _tick.configure(Frame, getattr(_dot, "_implementation", _dot))

__all__ = ["AVAILABLE", "enabled", "read_ticks"]

#: Whether the extension is built.
AVAILABLE = _tick is not None
#: Whether :func:`read_ticks` is used (tests switch it off to compare with Python's ticks).
enabled = AVAILABLE and os.environ.get("THERMOCUE_PYTHON_TICK", "") != "1"


def read_ticks(device, frames: list, budget: int) -> tuple[int, int]:
    """Tick ``device`` until ``frames`` (its ``direct`` list) holds something, at most ``budget``
    ticks, then up to two more while it is not IDLE; return (compiled ticks, Python ticks)."""
    return _tick.read_ticks(device, frames, budget)
