"""Every link is exclusive: a second program opening a display's link is refused in one line.

Two programs on one link read each other's replies and telemetry, and the second may set limits
or a neutral temperature under the first (a 44 °C neutral under a session run at 42 °C). Each
backend the registry knows is opened for real (the emulator's pty server, the TCS II emulator's
pty, the firmware under QEMU) and a second program then opens the same link.
"""
from __future__ import annotations

import subprocess
import sys
import threading

import pytest

from _device_proxy import start_emulator, stop
from experiments.display import open_display
from experiments.display.registry import backends
from experiments.display.safety import SafetyLimits


#: How each scheme's link is served for this test; emulator:// has no link another program
#: could open (each open builds its own device inside the opening process).
NO_SHARED_LINK = {"emulator"}


def _second_opener(path: str) -> subprocess.CompletedProcess:
    """Another program (a new Python process) opening ``path`` as a display, as a user would."""
    code = ("import sys\nfrom experiments.display import open_display\n"
            "from experiments.errors import DisplayError\n"
            "try:\n    open_display(sys.argv[1]).close()\nexcept DisplayError as e:\n"
            "    print(e, file=sys.stderr); sys.exit(1)\n")
    return subprocess.run([sys.executable, "-c", code, path], capture_output=True, text=True,
                          timeout=60)


def _assert_refused(path: str) -> None:
    r = _second_opener(path)
    assert r.returncode == 1, (r.stdout, r.stderr)
    assert "in use by another program" in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr


def _serial(tmp_path):
    proc, path = start_emulator(tmp_path)
    try:
        with open_display(path) as first:
            _assert_refused(path)
            assert first.status().state == "IDLE"       # the first keeps its link
    finally:
        stop(proc)


def _tcs2(tmp_path):
    from experiments.emulators.pty_server import serve_tcs2
    link = tmp_path / "tcs2"
    ready, stopping = threading.Event(), threading.Event()
    th = threading.Thread(target=serve_tcs2, kwargs=dict(link=str(link), speed=1.0,
                                                         announce=lambda p: ready.set(),
                                                         stop=stopping.is_set), daemon=True)
    th.start()
    assert ready.wait(10)
    try:
        with open_display(f"tcs2://{link}", SafetyLimits()) as first:
            _assert_refused(f"tcs2://{link}")
            _assert_refused(str(link))                   # the thermocue driver on it: refused too
            assert first.status().state == "IDLE"
    finally:
        stopping.set()
        th.join(5)


def _qemu(tmp_path):
    from experiments.display.thermocue.qemu_firmware import QemuFirmwareDisplay
    ok, why = QemuFirmwareDisplay.availability()
    if not ok:
        pytest.skip(why)
    with open_display("qemu-firmware://", SafetyLimits(max_C=42.0)) as first:
        _assert_refused(first.pty)
        assert first.status().neutral_C == 32.0          # nobody set it under us


SERVE = {"serial": _serial, "tcs2": _tcs2, "qemu-firmware": _qemu}


@pytest.mark.slow
# every backend the installation registers (the contract test's worked example, a test module
# that registers itself when imported, is not one: it has no link of its own)
@pytest.mark.parametrize("scheme", sorted(b.scheme for b in backends()
                                          if b.__module__.startswith("experiments.")))
def test_a_second_program_on_any_backends_link_is_refused(scheme, tmp_path):
    if scheme in NO_SHARED_LINK:
        # each open is its own device in its own process: two opens never share a link
        with open_display(f"{scheme}://?clock=virtual") as a, open_display(f"{scheme}://?clock=virtual") as b:
            a.set_neutral(33.0)
            assert b.status().neutral_C == 32.0
        return
    assert scheme in SERVE, f"backend {scheme!r} is new: add how its link is served to this test"
    SERVE[scheme](tmp_path)
