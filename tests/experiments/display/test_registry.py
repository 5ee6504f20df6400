"""The display registry: backends by URL scheme, opened only through it, listed by `thermocue displays`."""
from __future__ import annotations

import json

import numpy as np
import pytest

from experiments.cli import main
from experiments.errors import ProtocolError, UserInputError
from experiments.display import (Capabilities, Display, EmulatedDisplay, ThermalDisplay,
                                 backend_for, backends, open_display)
from experiments.display.registry import register, scheme_of
from experiments.emulators.backends import EmulatorDisplay


def test_schemes_of_urls():
    assert scheme_of("/dev/ttyUSB0") == "serial" and scheme_of("COM3") == "serial"
    assert scheme_of("/dev/pts/7") == "serial" and scheme_of("loop://") == "serial"
    assert scheme_of("emulator://?clock=virtual") == "emulator"
    assert scheme_of("TCS2:///dev/ttyACM0") == "tcs2"


def test_the_built_in_backends_are_registered():
    schemes = {cls.scheme for cls in backends()}
    assert {"serial", "emulator"} <= schemes
    assert backend_for("/dev/ttyUSB0") is ThermalDisplay
    assert backend_for("emulator://") is EmulatorDisplay   # through the entry point
    for cls in backends():   # each states what it can do before it is opened
        assert isinstance(cls.declared_capabilities(), Capabilities)
        assert issubclass(cls, Display)


def test_an_unknown_scheme_is_bad_input_listing_the_known_ones():
    with pytest.raises(UserInputError, match=r"no display backend for the scheme 'nosuch'.*emulator://"):
        open_display("nosuch://x")


def test_opening_goes_through_the_backend_and_returns_typed_receipts():
    with open_display("emulator://?clock=virtual") as d:
        assert type(d) is EmulatorDisplay and isinstance(d, EmulatedDisplay)
        caps = d.capabilities
        assert caps.scripted_bench and caps.telemetry_hz == 100 and caps.safe_range_C == (10.0, 44.5)
        t = np.arange(0, 2.0, 0.01)
        y = 32.0 - 0.5 * t + 0.004     # not on the 0.01 °C grid: the receipt says by how much
        r = d.upload_profile(t, y)
        assert (r.points, r.step_s, r.clamped, r.segments) == (200, 0.01, 0, None)
        assert 0.0 < r.max_deviation_C <= 0.005 + 1e-12


class _PlaybackOnly(Display, scheme="test-playback-only"):
    """A backend that can only play profiles (as a thermode without a force plate)."""

    description = "test backend"

    @classmethod
    def declared_capabilities(cls):
        return Capabilities(contact_detection="stimulus_start", force_sensing=False,
                            telemetry_hz=100.0, max_profile_points=2000, min_profile_step_s=0.01,
                            safe_range_C=(20.0, 40.0), max_rate_C_per_s=10.0, modes=("playback",))

    @classmethod
    def open(cls, url, limits=None, **options):
        raise AssertionError("the session must refuse this backend before opening it")

    def set_neutral(self, temperature_C): ...
    def upload_profile(self, times_s, target_C): ...
    def arm(self, mode="playback", force_threshold_N=2.0, max_duration_s=20.0): ...
    def run_trial(self, timeout_s=30.0, on_telemetry=None, on_event=None): ...
    def abort(self): ...


def test_subclassing_registers_and_a_taken_scheme_cannot_be_replaced():
    assert backend_for("test-playback-only://x") is _PlaybackOnly

    class Other(_PlaybackOnly):
        pass

    with pytest.raises(ValueError, match="already taken"):
        register("test-playback-only", Other)


def test_the_session_refuses_a_backend_that_cannot_run_a_block():
    from experiments.protocol import load_protocol
    from experiments.session.setup import open_session_display
    protocol = load_protocol("roughness_recognition")
    with pytest.raises(ProtocolError, match=r"blocks\[\d+\]\.mode: the display backend "
                                            r"test-playback-only:// cannot run 'real' trials"):
        open_session_display(protocol, "test-playback-only://x")


def test_thermocue_displays_lists_each_backend(capsys):
    assert main(["displays"]) == 0
    out = capsys.readouterr().out
    assert "emulator  (available)" in out and "\nserial  (" in out and "\ntcs2  (" in out
    assert "contact detection: force; force sensing: yes; telemetry: 100 Hz" in out
    assert main(["displays", "--json"]) == 0
    rows = {r["scheme"]: r for r in json.loads(capsys.readouterr().out)}
    assert rows["emulator"]["capabilities"]["scripted_bench"] is True
    assert rows["serial"]["capabilities"]["modes"] == ["playback", "record"]
    assert rows["test-playback-only"]["capabilities"]["contact_detection"] == "stimulus_start"
