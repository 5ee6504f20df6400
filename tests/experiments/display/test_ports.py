"""``thermocue displays``: ``serial`` and ``tcs2`` are available only when pyserial lists a USB
serial port (``experiments/display/ports.py``).

This machine has no USB serial device; the ports pyserial would list when one is plugged in are
built with pyserial's own ``ListPortInfo`` and handed to the code in place of the scan.
"""
from __future__ import annotations

from serial.tools import list_ports, list_ports_common

from experiments.cli import main
from experiments.display import ports


def usb_port(device, vid=0x0403, pid=0x6001, description="FT232R USB UART"):
    info = list_ports_common.ListPortInfo(device, skip_link_detection=True)
    info.vid, info.pid, info.description = vid, pid, description
    return info


def legacy_port(device="/dev/ttyS0"):
    return list_ports_common.ListPortInfo(device, skip_link_detection=True)   # no vid: not USB


def test_nothing_plugged_in_is_not_available_with_the_reason(monkeypatch, capsys):
    monkeypatch.setattr(list_ports, "comports", lambda *a, **k: [legacy_port()])
    assert ports.usb_serial_ports() == []
    assert main(["displays"]) == 0
    out = capsys.readouterr().out
    assert ("serial  (not available here: no USB serial port found (pyserial list_ports): connect "
            "the display's USB-serial cable") in out
    assert "tcs2  (not available here: no USB serial port found" in out and "TCS II" in out
    assert "emulator  (available)" in out


def test_a_usb_serial_port_makes_serial_and_tcs2_available(monkeypatch, capsys):
    monkeypatch.setattr(list_ports, "comports",
                        lambda *a, **k: [legacy_port(), usb_port("/dev/ttyACM0", 0x1234, 1, "TCS")])
    assert ports.usb_serial_ports() == [("/dev/ttyACM0", "TCS")]
    assert main(["displays"]) == 0
    out = capsys.readouterr().out
    assert "\nserial  (available)" in out and "\ntcs2  (available)" in out


def test_the_real_scan_here_gives_a_list_and_a_matching_answer():
    found = ports.usb_serial_ports()
    ok, reason = ports.port_availability("x")
    assert ok == bool(found) and (reason == "") == ok
