"""The engine's Display base: the real driver and the tests' stand-in both satisfy it.

The stand-in (``_session_helpers.ScriptedDisplay``) must keep the driver's contract, or the
engine tests prove nothing about the real display: the same methods, callable the way the
engine calls them, and frames and recordings of the driver's own types.
"""
from __future__ import annotations

import inspect

import numpy as np

from _session_helpers import ScriptedDisplay
from experiments.display import open_display
from experiments.display.thermocue.driver import ThermalDisplay, TrialRecording
from experiments.display.thermocue.messages import Telemetry
from experiments.display.base import Display, EmulatedDisplay

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


def test_the_engine_calls_are_the_abstract_methods():
    # what a backend must implement is exactly what the engine (and the emulated hand) calls
    assert set(EmulatedDisplay.__abstractmethods__) == set(ENGINE_CALLS)
    assert set(Display.__abstractmethods__) == set(ENGINE_CALLS) - {"sim_sample", "sim_finger"}


def test_the_real_driver_satisfies_the_protocol():
    display = open_display("emulator://?clock=virtual")
    try:
        assert isinstance(display, Display) and isinstance(display, EmulatedDisplay)
    finally:
        display.close()
    for name, (args, kwargs) in ENGINE_CALLS.items():   # callable the way the engine calls it
        inspect.signature(getattr(ThermalDisplay, name)).bind(None, *args, **kwargs)


def test_the_stand_in_satisfies_it_and_returns_the_drivers_types():
    display = ScriptedDisplay(script=["ok", "fault", "no_contact"])
    assert isinstance(display, Display) and isinstance(display, EmulatedDisplay)
    for name, (args, kwargs) in ENGINE_CALLS.items():
        inspect.signature(getattr(ScriptedDisplay, name)).bind(None, *args, **kwargs)
    display.arm(mode="record", force_threshold_N=2.0, max_duration_s=5.0)
    for _ in range(3):
        frames = []
        rec = display.run_trial(timeout_s=10.0, on_telemetry=frames.append)
        assert type(rec) is TrialRecording and rec.mode == "record"
        assert frames and all(type(f) is Telemetry for f in frames)


def test_something_without_run_trial_is_not_a_display():
    class Half:
        info = None

        def set_neutral(self, c): ...
        def upload_profile(self, t, y): ...
        def arm(self, **kw): ...
        def abort(self): ...

    assert not isinstance(Half(), Display)
