"""The thermocue driver on a TCS II's port (``--display /path`` without ``tcs2://``, or
``thermocue clear-fault``) says so in one line and sends it no binary frame.

Before, the driver's binary HELLO killed the TCS II emulator (UnicodeEncodeError); what the
frames would do to a real TCS II is unknown. The attack: the TCS II emulator on a real pty.
"""
from __future__ import annotations

import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

from experiments.display import open_display
from experiments.display.safety import SafetyLimits
from experiments.emulators.pty_server import serve_tcs2
from experiments.errors import DisplayError


@pytest.fixture
def tcs2_pty(tmp_path):
    link = tmp_path / "tcs2"
    ready, stopping = threading.Event(), threading.Event()
    died = []

    def run():
        try:
            serve_tcs2(link=str(link), speed=4.0, announce=lambda p: ready.set(), stop=stopping.is_set)
        except BaseException as exc:          # the emulator must not die of what the host sent
            died.append(exc)

    th = threading.Thread(target=run, daemon=True)
    th.start()
    assert ready.wait(10)
    yield str(link), died
    stopping.set()
    th.join(5)


def _still_a_working_tcs2(link, died):
    assert not died, died
    t = np.arange(101) * 0.01
    with open_display(f"tcs2://{link}", SafetyLimits()) as d:
        d.upload_profile(t, np.full(t.size, 32.0))
        d.arm()
        assert d.run_trial().status == "ok"


@pytest.mark.slow
def test_the_thermocue_driver_names_a_tcs2_and_leaves_it_working(tcs2_pty):
    link, died = tcs2_pty
    with pytest.raises(DisplayError) as exc:
        open_display(link)
    msg = str(exc.value)
    assert "\n" not in msg and "TCS II" in msg and f"tcs2://{link}" in msg, msg
    _still_a_working_tcs2(link, died)


@pytest.mark.slow
def test_clear_fault_on_a_tcs2_says_it_is_the_wrong_device(tcs2_pty):
    link, died = tcs2_pty
    r = subprocess.run([str(Path(sys.executable).with_name("thermocue")), "clear-fault", link, "--yes"],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 1 and "Traceback" not in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and "TCS II" in r.stderr, r.stderr
    _still_a_working_tcs2(link, died)
