"""The engine's Display base: the real driver and the tests' stand-in both satisfy it.

The stand-in (``_session_helpers.ScriptedDisplay``) must keep the driver's contract, or the
engine tests prove nothing about the real display: a subclass of the base, the same methods,
callable the way the engine and the PsychoPy plugin call them, and frames and recordings of
the contract's own types.
"""
from __future__ import annotations

import inspect

import numpy as np

from _session_helpers import ScriptedDisplay
from experiments.display import open_display
from experiments.display.thermocue.driver import ThermalDisplay, TrialRecording
from experiments.display.types import Telemetry
from experiments.display.base import Display, EmulatedDisplay
from experiments.display.tcs2.backend import Tcs2Display

#: The calls the engine (and the emulated hand) make, as (args, kwargs).
ENGINE_CALLS = {
    "set_neutral": ((32.0,), {}),
    "upload_profile": ((np.array([0.0, 1.0]), np.array([32.0, 31.0])), {}),
    "arm": ((), {"mode": "playback", "force_threshold_N": 2.0, "max_duration_s": 5.0}),
    "run_trial": ((), {"timeout_s": 10.0, "on_telemetry": print}),
    "abort": ((), {}),
    "sim_sample": ((), {"material": "stainless_steel", "roughness_m": 1e-6, "thickness_m": 3e-3,
                        "temperature_C": 23.0}),
    "sim_finger": ((), {"press_after_s": 0.3, "force_N": 2.5, "hold_s": 2.0,
                        "skin_thickness_m": 800e-6, "skin_temperature_C": 35.5}),
}
#: ... and the PsychoPy plugin (poll in its frame loop, heartbeat bursts for its clock map),
#: the trial's end (status) and every caller's last call (close).
PLUGIN_CALLS = {
    "poll": ((), {"on_event": print}),
    "heartbeat": ((), {}),
    "status": ((), {}),
    "close": ((), {}),
}


def test_the_callers_calls_are_the_abstract_methods():
    # what a backend must implement is exactly what the engine, the emulated hand and the
    # plugin call (is_awake has a default: one heartbeat)
    calls = set(ENGINE_CALLS) | set(PLUGIN_CALLS)
    assert set(EmulatedDisplay.__abstractmethods__) == calls
    assert set(Display.__abstractmethods__) == calls - {"sim_sample", "sim_finger"}
    for name in ("is_awake", "check_profile_capacity", "check_url", "availability",
                 "capabilities", "example_urls", "open", "declared_capabilities"):
        assert hasattr(Display, name), name


def test_the_real_driver_satisfies_the_protocol():
    display = open_display("emulator://?clock=virtual")
    try:
        assert isinstance(display, Display) and isinstance(display, EmulatedDisplay)
    finally:
        display.close()
    for name, (args, kwargs) in {**ENGINE_CALLS, **PLUGIN_CALLS}.items():   # as callers call it
        inspect.signature(getattr(ThermalDisplay, name)).bind(None, *args, **kwargs)


def test_the_stand_in_satisfies_it_and_returns_the_drivers_types():
    display = ScriptedDisplay(script=["ok", "fault", "no_contact"])
    assert isinstance(display, Display) and isinstance(display, EmulatedDisplay)
    for name, (args, kwargs) in {**ENGINE_CALLS, **PLUGIN_CALLS}.items():
        inspect.signature(getattr(ScriptedDisplay, name)).bind(None, *args, **kwargs)
    display.arm(mode="record", force_threshold_N=2.0, max_duration_s=5.0)
    for _ in range(3):
        frames = []
        rec = display.run_trial(timeout_s=10.0, on_telemetry=frames.append)
        assert type(rec) is TrialRecording and rec.mode == "record"
        assert frames and all(type(f) is Telemetry for f in frames)


def test_a_display_is_one_by_subclassing_only():
    # no structural check: having the methods does not make a class a display, and a backend
    # with sim_* methods is not an EmulatedDisplay unless it says so
    class Lookalike:
        info = None

        def set_neutral(self, c): ...
        def upload_profile(self, t, y): ...
        def arm(self, **kw): ...
        def run_trial(self, **kw): ...
        def abort(self): ...
        def sim_sample(self, **kw): ...
        def sim_finger(self, **kw): ...

    assert not isinstance(Lookalike(), Display) and not issubclass(Lookalike, EmulatedDisplay)
    assert hasattr(Tcs2Display, "sim_finger") and not issubclass(Tcs2Display, EmulatedDisplay)
    assert issubclass(Tcs2Display, Display)

    class Half(Display):          # a subclass that leaves out a declared call is not usable
        def set_neutral(self, c): ...
        def upload_profile(self, t, y): ...
        def arm(self, **kw): ...
        def run_trial(self, **kw): ...
        def abort(self): ...

    try:
        Half()
    except TypeError as exc:
        assert all(n in str(exc) for n in ("close", "heartbeat", "poll", "status"))
    else:
        raise AssertionError("a display without poll, heartbeat, status and close was made")
