"""The TCS II emulator's commands, one by one, through the tcs2emu:// pyserial URL."""
from __future__ import annotations

import pytest
import serial

import experiments.emulators.tcs2  # noqa: F401  (registers tcs2emu://)
from experiments.display.tcs2 import commands as cmd
from experiments.emulators.tcs2.device import Tcs2Device, parse_faults
from experiments.display.tcs2.profile_compiler import Segment


@pytest.fixture
def port():
    p = serial.serial_for_url("tcs2emu://?clock=virtual", timeout=0.05)
    yield p
    p.close()


def ask(p, c):
    p.write((c + "\r").encode())
    return p.read(4096).decode().split("\r\n")[:-1]


def test_identity_help_and_parameters(port):
    assert ask(port, "?") == ["TCS"]
    about = cmd.parse_help(ask(port, "H"))
    assert about["firmware"].startswith("012") and about["probe_id"]
    assert cmd.parse_parameters(ask(port, "P")[0]) == {
        "neutral_C": 32.0, "max_C": 50.0, "zones": (1, 2, 3, 4, 5), "profile_zones": (),
        "trigger_in": False}


def test_settings_are_held_as_sent(port):
    for c in ("Om420", "N355", "S10100", "Ue10100", "Ose"):
        assert ask(port, c) == []
    p = cmd.parse_parameters(ask(port, "P")[0])
    assert p == {"neutral_C": 35.5, "max_C": 42.0, "zones": (1, 3), "profile_zones": (1, 3),
                 "trigger_in": True}
    assert ask(port, "Osd") == [] and not cmd.parse_parameters(ask(port, "P")[0])["trigger_in"]


def test_out_of_range_and_unknown_commands_are_answered_with_an_error(port):
    assert ask(port, "N450")[0].startswith("ERR")
    assert ask(port, "Om700")[0].startswith("ERR")
    assert ask(port, "C0650")[0].startswith("ERR") or ask(port, "C0650") == []
    assert ask(port, "Zz")[0].startswith("ERR unknown")


def test_C_is_limited_by_the_maximum(port):
    ask(port, "Om400")
    ask(port, "C0450")
    dev = port.device
    assert dev.C == [400] * 5


def test_profile_written_read_back_and_played(port):
    segs = (Segment(50, 300), Segment(100, 300), Segment(25, 320))
    ask(port, "F")                             # no display between stimulations ...
    ask(port, "Ob")                            # ... but 100 Hz during them
    assert ask(port, cmd.fmt_profile((1, 2, 3, 4, 5), segs)) == []
    ask(port, cmd.fmt_profile_enable((1, 2, 3, 4, 5)))
    back = cmd.parse_profile_lines(ask(port, "Ur"))
    assert back[1] == (True, ((50, 300), (100, 300), (25, 320)))
    port.write(b"L\r")
    lines = []
    while True:
        data = port.read(65536)
        if not data:
            break
        lines += data.decode().split("\r\n")[:-1]
    assert len(lines) == 175                   # 1.75 s of 100 Hz lines, then silence
    temps = [cmd.parse_temperatures(x) for x in lines]
    assert abs(temps[100][1] - 30.0) < 0.1       # on the plateau
    assert cmd.parse_errors(ask(port, "Q")[0]) == (0,) * 6


def test_E_and_Oe_resolutions(port):
    e = cmd.parse_temperatures(ask(port, "E")[0])
    oe = cmd.parse_temperatures(ask(port, "Oe")[0])
    assert len(e) == len(oe) == 6 and abs(e[1] - oe[1]) < 0.06


def test_abort_returns_to_neutral_and_follow_mode(port):
    ask(port, "F")
    ask(port, "C0300")
    ask(port, "Od")
    port.read(100)
    for _ in range(20):
        port.device.tick()
    assert abs(port.device.temps[0] - 30.0) < 0.05
    ask(port, "A")
    for _ in range(20):
        port.device.tick()
    assert abs(port.device.temps[0] - 32.0) < 0.05


def test_the_fault_grammar():
    faults, drop, cap = parse_faults("zone@2:5.5:4,drop=0.01,om_cap=40")
    assert faults[0].kind == "zone" and faults[0].stim == 2 and faults[0].at_s == 5.5
    assert faults[0].arg == 4 and drop == 0.01 and cap == 40.0
    for bad in ("zap@1", "zone@0:1", "drop=2", "zone@1:1:9"):
        with pytest.raises(ValueError):
            parse_faults(bad)
    with pytest.raises(serial.SerialException):
        serial.serial_for_url("tcs2emu://?colour=red")


def test_zone_error_sticks_the_zone_and_shows_in_Q():
    dev = Tcs2Device("zone@1:0.05:2")
    dev.feed(b"L\r")
    for _ in range(10):
        dev.tick()
    dev.take()
    dev.feed(b"Q\r")
    assert dev.take() == b"002000\r\n"


def test_C_V_D_stimulation_ramps_holds_and_ends(port):
    ask(port, "F")
    ask(port, "Ob")
    for c in ("C0300", "V00100", "R00100", "D01000"):
        ask(port, c)
    assert port.device.C == [300] * 5 and port.device.V == [100] * 5 and port.device.D == [1000] * 5
    port.write(b"L\r")
    lines = []
    while True:
        data = port.read(65536)
        if not data:
            break
        lines += data.decode().split("\r\n")[:-1]
    # 2 °C at 10 °C/s (0.2 s), then 1 s at 30 °C: 120 lines of 10 ms
    assert len(lines) == 120
    assert abs(cmd.parse_temperatures(lines[-1])[1] - 30.0) < 0.05


def test_the_display_between_stimulations_is_1_Hz_and_Oo_prints_nothing(port):
    assert ask(port, "Oo") == []
    for _ in range(300):
        port.device.tick()
    assert len(port.device.take().split(b"\r\n")) - 1 == 3      # Oa is on by default
    ask(port, "F")
    for _ in range(300):
        port.device.tick()
    assert port.device.take() == b""


def test_the_emulator_trigger_input_starts_only_when_enabled(port):
    ask(port, "F")
    ask(port, "#T")
    assert port.device.state == "idle"
    ask(port, "Ose")
    ask(port, "#T")
    assert port.device.state == "stim" and port.device.stim_count == 1
