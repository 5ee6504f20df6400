"""The thermal display as a PsychoPy device, over the emulator on a real pty.

PsychoPy's own DeviceManager creates it (through the installed entry point and through the
alias), its responses are PsychoPy ``BaseResponse`` objects with the device's time stamps, and
their place on PsychoPy's clock is checked against the emulator's own log, stamped with
PsychoPy's clock in the tick that detected the contact.
"""
from __future__ import annotations

import importlib.metadata
import json
import math
import os
import subprocess
import sys
import time

import numpy as np
import pytest

from _plugin_helpers import on_time_host_s, read_log, serve_stamped, unexplained_refusal
from experiments.psychopy_plugin.clock_sync import ClockMap


T = np.arange(0, 2.0001, 0.01)
PROFILE = np.round(32.0 - 3.0 * np.sqrt(T / 2.0), 2)     # 32 -> 29 °C, 8.5 °C/s over 0.1 s


@pytest.fixture(scope="module")
def emulator(tmp_path_factory):
    with serve_stamped(tmp_path_factory.mktemp("emu")) as (link, log):
        yield link, log


@pytest.fixture
def manager():
    from psychopy import plugins
    from psychopy.hardware import DeviceManager
    plugins.activatePlugins()
    yield DeviceManager
    for name in list(DeviceManager.devices):
        if name.startswith("thermal"):
            DeviceManager.removeDevice(name)


def test_the_entry_points_are_installed():
    eps = {(e.group, e.name): e.value
           for e in importlib.metadata.distribution("thermocue").entry_points}
    assert eps[("psychopy.hardware", "ThermalCueDevice")] == \
        "experiments.psychopy_plugin.device:ThermalCueDevice"
    assert eps[("psychopy.experiment.components", "ThermalCueComponent")] == \
        "experiments.psychopy_plugin.component:ThermalCueComponent"


def test_activated_plugins_expose_device_and_component(manager):
    import psychopy.hardware
    from psychopy import plugins
    from psychopy.experiment.components import getAllComponents

    from experiments.psychopy_plugin.component import ThermalCueComponent
    from experiments.psychopy_plugin.device import ThermalCueDevice
    assert "thermocue" in plugins.listPlugins("loaded")
    assert psychopy.hardware.ThermalCueDevice is ThermalCueDevice
    assert getAllComponents()["ThermalCueComponent"] is ThermalCueComponent
    assert "experiments.psychopy_plugin.device.ThermalCueDevice" in manager.deviceClasses


def test_device_manager_opens_it_by_entry_point_name_and_by_alias(manager, emulator):
    from experiments.psychopy_plugin.device import ThermalCueDevice
    link, _ = emulator
    dev = manager.addDevice(deviceClass="psychopy.hardware.ThermalCueDevice",
                            deviceName="thermal", url=link, protocol="roughness_recognition")
    assert isinstance(dev, ThermalCueDevice) and manager.getDevice("thermal") is dev
    assert dev.isAwake()
    assert dev.limits.max_C == 42.0 and dev.display.status().neutral_C == 32.0
    # the same physical port, named by the pty's real path or as a profile dict
    assert dev.isSameDevice({"url": os.path.realpath(link)})
    assert not dev.isSameDevice({"url": "emulator://"})
    assert dev.getDeviceProfile()["deviceName"] == "Thermal display EMU-0001"
    manager.removeDevice("thermal")              # closes the port: a second host may open it
    dev2 = manager.addDevice(deviceClass="thermocue", deviceName="thermal2", url=link)
    assert dev2.isSameDevice(dev) and dev2.isAwake()


def test_a_bad_url_is_reported_by_the_device_manager(manager):
    from psychopy.hardware.exceptions import ManagedDeviceError
    with pytest.raises(ManagedDeviceError, match="expected a display URL"):
        manager.addDevice(deviceClass="thermocue", deviceName="thermal_bad",
                          url="emulator://?colour=blue", protocol="roughness_recognition")


def test_available_devices_lists_without_opening():
    # importing the device (and activating plugins) must not enumerate, let alone open, ports
    code = ("import serial.tools.list_ports as lp, serial.tools.list_ports_linux as lpl\n"
            "def boom(*a, **k):\n    raise SystemExit('ports probed at import')\n"
            "lp.comports = lpl.comports = boom\n"
            "from psychopy import plugins\nplugins.activatePlugins()\n"
            "import experiments.psychopy_plugin.device as d\n"
            "print(d.ThermalCueDevice.__name__)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-1500:]
    assert out.stdout.strip().endswith("ThermalCueDevice")
    from experiments.psychopy_plugin.device import ThermalCueDevice
    profiles = ThermalCueDevice.getAvailableDevices()
    assert profiles[0]["url"] == "emulator://"
    assert all(p["deviceClass"].endswith("ThermalCueDevice") for p in profiles)


def test_available_devices_list_every_backend_of_the_registry(monkeypatch):
    """Each scheme the display registry knows (the thermocue protocol, its emulator, the TCS II,
    the firmware under QEMU where QEMU is installed) is listed with a URL the registry routes to
    that backend; a serial port the system lists appears once per backend that takes a port."""
    import shutil
    from types import SimpleNamespace

    import serial.tools.list_ports as lp

    from experiments.display.registry import backend_for, backends
    from experiments.psychopy_plugin.device import ThermalCueDevice
    port = SimpleNamespace(device="/dev/ttyUSB7", hwid="USB VID:PID=0403:6001", description="FT232R")
    legacy = SimpleNamespace(device="/dev/ttyS0", hwid="n/a", description="n/a")
    monkeypatch.setattr(lp, "comports", lambda *a, **k: [port, legacy])
    profiles = ThermalCueDevice.getAvailableDevices()
    urls = [p["url"] for p in profiles]
    assert urls[0] == "emulator://"
    assert {"emulator://", "tcs2://emulator", "/dev/ttyUSB7", "tcs2:///dev/ttyUSB7"} <= set(urls)
    assert not any("ttyS0" in u for u in urls)
    assert ("qemu-firmware://" in urls) == (shutil.which("qemu-system-arm") is not None)
    schemes = {b.scheme for b in backends()}
    assert {"serial", "emulator", "tcs2", "qemu-firmware"} <= schemes
    listed = {p["scheme"] for p in profiles}
    assert listed == schemes if shutil.which("qemu-system-arm") else listed == schemes - {"qemu-firmware"}
    for p in profiles:        # each URL reaches the backend it is listed under (nothing opened)
        assert backend_for(p["url"]).scheme == p["scheme"], p
        assert p["description"] == backend_for(p["url"]).description


def test_contact_and_release_are_responses_on_psychopy_time(manager, tmp_path):
    """Its own emulator: the log's stop record and tick times (written when the emulator stops)
    say how late a starved emulator ran, which is what a refused clock map must rest on."""
    with serve_stamped(tmp_path) as (link, log):
        dev = manager.addDevice(deviceClass="thermocue", deviceName="thermal", url=link,
                                protocol="roughness_recognition")
        called = []
        dev.registerCallback(lambda r: r.kind == "contact", called.append, args=["contact!"])
        dev.uploadProfile(T, PROFILE)
        dev.resetClockMap()
        dev.syncClock()
        dev.arm(forceThreshold_N=2.0, maxDuration_s=10.0)
        dev.display.sim_finger(press_after_s=0.2, force_N=2.5, hold_s=0.8)   # released before the end
        deadline = time.monotonic() + 15
        while not dev.dispatchMessages() and time.monotonic() < deadline:
            time.sleep(1 / 60)
        rec = dev.finishTrial()
        dev.syncClock()
        manager.removeDevice("thermal")
    assert rec.status == "ok" and rec.end_reason == "released"
    kinds = [(r.kind, r.value) for r in dev.responses]
    assert kinds == [("contact", True), ("release", False)]
    contact, release = dev.responses
    assert contact.device_time_s == rec.contact_time_s and contact.force_N >= 2.0
    assert release.device_time_s - contact.device_time_s == pytest.approx(rec.duration_s, abs=1e-6)
    assert called == ["contact!"]
    assert '"kind": "contact"' in contact.getJSON()
    # PsychoPy time of the contact: the emulator logged the tick that saw it on the same clock
    records = read_log(log)
    truth = [r for r in records if r.get("why") == "contact"][-1]
    assert truth["t_s"] == pytest.approx(contact.device_time_s, abs=1e-6)
    # response.t was mapped with the first burst; the precise figure is test_plugin_timing's.
    # A map may refuse (no time, NaN) only for what a starved emulator's stale replies explain.
    max_late_ms = records[-1]["max_late_ms"]
    first = ClockMap.from_bursts(dev.firstBurst)
    if first.unmapped is None:
        assert contact.t == pytest.approx(first.to_host(contact.device_time_s), abs=1e-9)
    else:
        assert math.isnan(contact.t) and unexplained_refusal(first.unmapped, max_late_ms) is None
    if dev.clockMap.unmapped is not None:
        assert unexplained_refusal(dev.clockMap.unmapped, max_late_ms) is None, max_late_ms
        return
    # the contact tick's time on the emulator's own schedule (it may have run late)
    scheduled = on_time_host_s(json.loads((tmp_path / "ticks.json").read_text()),
                               contact.device_time_s)
    assert abs(dev.toPsychopyTime(contact.device_time_s) - scheduled) < 0.03


def test_neutral_stops_a_profile_that_plays(manager, emulator):
    link, log = emulator
    dev = manager.addDevice(deviceClass="thermocue", deviceName="thermal", url=link,
                            protocol="roughness_recognition")
    dev.uploadProfile(T, PROFILE)
    dev.arm(forceThreshold_N=2.0, maxDuration_s=10.0)
    dev.display.sim_finger(press_after_s=0.1, force_N=2.5, hold_s=5.0)
    deadline = time.monotonic() + 10
    while not dev.responses and time.monotonic() < deadline:
        dev.dispatchMessages()
        time.sleep(0.01)
    assert dev.responses and dev.responses[0].kind == "contact"
    assert dev.neutral() is True
    assert dev.display.status().state == "IDLE"
    assert [r for r in read_log(log) if r.get("event") == "state"][-1]["why"] == "abort"
    rec = dev.finishTrial()
    assert rec.status == "aborted"


def test_a_serial_device_path_that_is_not_there(manager, tmp_path):
    from psychopy.hardware.exceptions import ManagedDeviceError
    missing = str(tmp_path / "ttyUSB0")          # a device path, as /dev/ttyUSB0 is on a lab PC
    with pytest.raises(ManagedDeviceError, match="no such device"):
        manager.addDevice(deviceClass="thermocue", deviceName="thermal_missing", url=missing,
                          protocol="roughness_recognition")
    plain = tmp_path / "notes.txt"
    plain.write_text("not a terminal")
    with pytest.raises(ManagedDeviceError, match="not one"):
        manager.addDevice(deviceClass="thermocue", deviceName="thermal_file", url=str(plain),
                          protocol="roughness_recognition")
