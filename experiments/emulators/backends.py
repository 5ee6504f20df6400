"""The emulators' display backends: registered like any third-party backend.

The ``thermocue.displays`` entry point ``emulator`` (pyproject.toml) names this module; the
display registry loads it on its first lookup, and importing it registers

- ``emulator://[?...]``: :class:`EmulatorDisplay`, the thermocue protocol's driver over the
  in-process emulator (:mod:`.thermocue.protocol_emulator`);
- the pyserial URL handlers ``emulator://`` and ``tcs2emu://`` (importing :mod:`.thermocue` and
  :mod:`.tcs2` adds them to ``serial.protocol_handler_packages``), which the TCS II backend's
  ``tcs2://emulator`` opens.

This is the one module of the emulators that imports the display beyond its wire format: a
backend is a :class:`~experiments.display.base.Display`, wherever it lives.
"""
from __future__ import annotations

import serial

from experiments.display.base import Capabilities
from experiments.display.thermocue.driver import ThermalDisplay
from experiments.errors import UserInputError

from . import tcs2 as _tcs2, thermocue as _thermocue  # noqa: F401  (register the pyserial URLs)

__all__ = ["EmulatorDisplay"]


class EmulatorDisplay(ThermalDisplay, scheme="emulator"):
    """The Python emulator of the thermocue display, in-process (``emulator://[?...]``).

    The fast, fault-injecting model of the device (:mod:`.thermocue.protocol_emulator`): virtual
    or real clock, link faults, a scripted bench (``sim_sample``, ``sim_finger``).
    """

    description = "the Python emulator of the thermocue display, in this process"
    url_grammar = ("emulator://[?faults=SPEC][&clock=real|virtual][&seed=N][&sim=1|0][&log=PATH]"
                   "[&id=ID][&core=py|c]")
    example_urls = (("emulator://", "Thermal display (emulator)"),)

    @classmethod
    def check_url(cls, url: str) -> None:
        from .thermocue.protocol_emulator import parse_url
        try:
            parse_url(url)
        except serial.SerialException as exc:
            raise UserInputError(str(exc)) from None

    @classmethod
    def availability(cls) -> tuple:
        """Always: the emulator runs in this process (no port to plug in)."""
        return True, ""

    @classmethod
    def declared_capabilities(cls) -> Capabilities:
        from .thermocue import device_constants as dc
        return Capabilities(contact_detection="force", force_sensing=True, telemetry_hz=100.0,
                            max_profile_points=dc.MAX_POINTS, min_profile_step_s=dc.MIN_DT_US * 1e-6,
                            safe_range_C=(dc.HARD_MIN_C, dc.SETPOINT_MAX_C),
                            max_rate_C_per_s=dc.HARD_RATE_C_PER_S, modes=("playback", "record"),
                            scripted_bench=True,
                            notes="fault injection (faults=SPEC), virtual clock (clock=virtual)")
