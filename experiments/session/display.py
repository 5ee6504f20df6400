"""What the session engine needs of a thermal display, as a typed protocol.

:class:`Display` is the part of :class:`experiments.hardware.driver.ThermalDisplay` the engine
calls (neutral, upload, arm, run a trial, abort, the handshake's ``info``);
:class:`EmulatedDisplay` adds the emulator's scripting (a sample on the bench, the finger)
that the emulated hand uses (:mod:`experiments.responders.hand`). The real driver and the
tests' stand-in display both satisfy them (``tests/experiments/test_session_display.py``);
frames are :class:`experiments.hardware.messages.Telemetry` and recordings
:class:`experiments.hardware.driver.TrialRecording`.
"""
from __future__ import annotations

from typing import Any, Callable, Protocol, runtime_checkable

__all__ = ["Display", "EmulatedDisplay"]


@runtime_checkable
class Display(Protocol):
    """A display the session can run trials on.

    Attributes
    ----------
    info : DeviceInfo or None
        The handshake's answer (``device_id``, ``firmware``, ``capabilities``); logged.
    """

    info: Any

    def set_neutral(self, temperature_C: float) -> Any:
        """Hold the pad at ``temperature_C`` (°C) between trials."""

    def upload_profile(self, times_s, target_C) -> Any:
        """Upload a target profile (s, °C), checked against the safety limits first."""

    def arm(self, mode: str = "playback", force_threshold_N: float = 2.0,
            max_duration_s: float = 20.0) -> Any:
        """Arm for ``"playback"`` of the uploaded profile or ``"record"`` of a real sample."""

    def run_trial(self, timeout_s: float = 30.0,
                  on_telemetry: Callable[[Any], None] | None = None) -> Any:
        """Run the armed trial to its end; each telemetry frame to ``on_telemetry``.

        Returns a :class:`~experiments.hardware.driver.TrialRecording`."""

    def abort(self) -> None:
        """Stop whatever runs (the engine then sets neutral)."""


@runtime_checkable
class EmulatedDisplay(Display, Protocol):
    """A :class:`Display` whose bench is scripted (capability ``"sim"``): the emulator."""

    def sim_sample(self, material: str = "stainless_steel", roughness_m: float = 1.6e-6,
                   thickness_m: float | None = 3e-3, temperature_C: float = 20.0) -> Any:
        """Put a real sample on the emulated bench."""

    def sim_finger(self, press_after_s: float = 0.3, force_N: float = 2.0, hold_s: float = 20.0,
                   skin_thickness_m: float = 650e-6, skin_temperature_C: float = 35.5) -> Any:
        """Press the emulated finger ``press_after_s`` after arming, for ``hold_s``."""
