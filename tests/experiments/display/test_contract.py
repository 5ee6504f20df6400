"""The Display contract, run against every installed backend.

Every backend the registry loads by itself (:data:`~experiments.display.registry.
BUILTIN_MODULES` and the ``thermocue.displays`` entry points), and the worked example of
``CONTRIBUTING.md`` (:mod:`example_backend`), is opened through the registry from the example
URLs it states, and then called the way the session, the PsychoPy plugin and the command line
call it: info and status in the neutral types, capabilities, a short profile uploaded and
played (polled, then run to its end), heartbeat, is_awake, abort, close. An example URL with
``{port}`` runs on a real pseudo-terminal served by the matching emulator (:data:`PORT_SERVERS`).
A backend with no example runnable here fails, with the reason; it is not skipped.
"""
from __future__ import annotations

import json
import math
import os
import select
import signal
import subprocess
import sys
from importlib.metadata import entry_points

import numpy as np
import pytest

import example_backend
from experiments.display.base import Capabilities, Display, ProfileReceipt
from experiments.display.registry import (BUILTIN_MODULES, ENTRY_POINT_GROUP, backends,
                                          open_display)
from experiments.display.trial_recording import TrialRecording
from experiments.display.types import STATES, DeviceEvent, DeviceInfo, Status, Telemetry

#: For a ``{port}`` example: the command that serves a stand-in device of that backend on a pty
#: (it prints the pty's path).
PORT_SERVERS = {
    "serial": ["emulator"],
    "tcs2": ["emulator", "--model", "tcs2"],
}


def installed_backends() -> list:
    """The backends the registry loads by itself, and the worked example."""
    modules = set(BUILTIN_MODULES) | {ep.value.split(":")[0]
                                      for ep in entry_points(group=ENTRY_POINT_GROUP)}
    found = [cls for cls in backends() if cls.__module__ in modules]
    return found + [example_backend.ExamplePad]


def _cases():
    cases = []
    for cls in installed_backends():
        urls = [url for url, _ in cls.example_urls] or [None]
        for url in urls:
            # a served port: a second interpreter and a real-time device (~5 s and more)
            marks = [pytest.mark.slow] if url and "{port}" in url else []
            cases.append(pytest.param(cls, url, id=f"{cls.scheme}:{url}", marks=marks))
    return cases


@pytest.fixture
def served_port(tmp_path):
    procs = []

    def serve(scheme: str) -> str:
        cmd = PORT_SERVERS[scheme]
        proc = subprocess.Popen([sys.executable, "-m", "experiments", *cmd],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        procs.append(proc)
        ready, _, _ = select.select([proc.stdout], [], [], 60)
        assert ready, f"{' '.join(cmd)} printed no pty path within 60 s"
        path = proc.stdout.readline().strip()
        assert path.startswith("/dev/"), (path, proc.stderr.read() if proc.poll() else "")
        return path

    yield serve
    for proc in procs:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def runnable_url(cls, url, serve) -> str:
    """The example as a URL to open here, or a failure naming why there is none."""
    if url is None:
        pytest.fail(f"backend {cls.scheme}:// ({cls.__module__}) states no example_urls: "
                    f"the contract test cannot run it")
    # a {port} example is served here on a pty by a stand-in device (the physical port the
    # backend's availability looks for is not needed); any other URL must be openable as it is
    ok, reason = cls.url_availability(url) if "{port}" not in url else (True, "")
    if not ok:
        pytest.fail(f"backend {cls.scheme}:// cannot be opened here: {reason}")
    if "{port}" in url:
        if cls.scheme not in PORT_SERVERS:
            pytest.fail(f"backend {cls.scheme}:// states only {url!r}, and this test has no "
                        f"stand-in device to serve a port for it (PORT_SERVERS)")
        return url.format(port=serve(cls.scheme))
    return url


def test_every_installed_backend_states_what_the_contract_needs():
    for cls in installed_backends():
        assert issubclass(cls, Display), cls
        assert cls.open.__func__ is not Display.open.__func__, f"{cls.scheme}: open"
        assert isinstance(cls.declared_capabilities(), Capabilities), cls.scheme
        ok, reason = cls.availability()
        assert isinstance(ok, bool) and isinstance(reason, str), cls.scheme
        assert cls.description and cls.url_grammar, cls.scheme
        for url, label in cls.example_urls:
            assert isinstance(url, str) and isinstance(label, str) and label, (cls.scheme, url)
    schemes = {cls.scheme for cls in installed_backends()}
    assert {"serial", "emulator", "tcs2", "qemu-firmware", "example-pad"} <= schemes


def _profile(caps: Capabilities):
    step = max(0.01, caps.min_profile_step_s)
    t = np.arange(0.0, 0.8, step)
    return t, 32.0 + 1.0 * t            # 1 °C/s: inside every backend's rate and range


@pytest.mark.parametrize("cls,url", _cases())
def test_the_contract(cls, url, served_port):
    url = runnable_url(cls, url, served_port)
    d = open_display(url)
    try:
        assert isinstance(d, cls) and isinstance(d, Display)
        # what the device is, in the neutral types
        info = d.info
        assert type(info) is DeviceInfo
        assert info.device_id and info.firmware and info.telemetry_hz > 0
        assert info.hard_min_C < info.hard_max_C and info.max_points > 0 and info.min_dt_s > 0
        assert info.protocol is None or isinstance(info.protocol, int)
        assert info.watchdog_s is None or info.watchdog_s > 0
        st = d.status()
        assert type(st) is Status and st.state == "IDLE" and st.fault is None
        assert st.forces_N is None or len(st.forces_N) == 4
        caps = d.capabilities
        assert isinstance(caps, Capabilities)
        assert d.set_neutral(32.0) == pytest.approx(32.0, abs=0.01)
        # a short profile, uploaded and played as the plugin plays it: poll, then the recording
        t, y = _profile(caps)
        d.check_profile_capacity(t, y)
        receipt = d.upload_profile(t, y)
        assert isinstance(receipt, ProfileReceipt) and receipt.points == t.size
        d.arm(mode="playback", force_threshold_N=2.0, max_duration_s=5.0)
        if "sim" in info.capabilities and hasattr(d, "sim_finger"):
            d.sim_finger(press_after_s=0.1, hold_s=3.0)
        frames, events = [], []
        ended = d.poll(on_telemetry=frames.append, on_event=events.append)
        assert ended in (True, False)
        rec = d.run_trial(timeout_s=15.0, on_telemetry=frames.append, on_event=events.append)
        assert type(rec) is TrialRecording
        assert rec.status == "ok", (rec.fault_code, rec.fault_message)
        assert rec.end_reason == "complete" and rec.contact_time_s is not None
        assert rec.frames > 0 and math.isfinite(rec.tracking_rms_C)
        assert frames and all(type(f) is Telemetry for f in frames)
        assert {f.state for f in frames} <= set(STATES) and "PLAYING" in {f.state for f in frames}
        assert events and all(type(e) is DeviceEvent for e in events)
        kinds = [e.kind for e in events]
        assert "CONTACT" in kinds and kinds[-1] == "END" and events[-1].reason == "complete"
        assert d.poll() is False                       # nothing armed any more
        st = d.status()
        assert type(st) is Status and st.state == "IDLE" and st.end_reason == "complete"
        # alive: heartbeat (the plugin's clock bursts); is_awake answers without raising (one
        # attempt: on a loaded machine a slow reply may make it False)
        assert isinstance(d.heartbeat(), float) and d.is_awake() in (True, False)
        d.abort()
    finally:
        d.close()
    d.close()                                          # a second close is harmless
    assert d.is_awake() is False                       # closed: not awake, and no exception


@pytest.mark.slow
def test_the_worked_example_registers_through_a_real_entry_point(tmp_path):
    # CONTRIBUTING.md's registration: an entry point of thermocue.displays naming the module
    site = tmp_path / "site"
    dist = site / "example_pad-1.0.dist-info"
    dist.mkdir(parents=True)
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: example-pad\nVersion: 1.0\n")
    (dist / "entry_points.txt").write_text(f"[{ENTRY_POINT_GROUP}]\n"
                                           "example-pad = example_backend\n")
    here = os.path.dirname(os.path.abspath(__file__))
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(site), here] + sys.path))
    out = subprocess.run([sys.executable, "-m", "experiments", "displays", "--json"],
                         capture_output=True, text=True, env=env, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    rows = {r["scheme"]: r for r in json.loads(out.stdout)}
    assert rows["example-pad"]["examples"] == ["example-pad://"]
    assert rows["example-pad"]["available"] and rows["example-pad"]["broken"] is None
    assert rows["example-pad"]["capabilities"]["contact_detection"] == "stimulus_start"
