"""Shared fixtures: an X server for the GUI tests, and the display under test.

``--display URL`` (default ``emulator://``): the thermal display the hardware tests drive (a
device path such as ``/dev/ttyUSB0``, a pty, or any pyserial URL); the option lives here, in the
rootdir conftest, so that it works for whole-suite runs as well as for
``pytest tests/experiments/display --display /dev/ttyUSB0``. Fixture: ``display_url``
(tests/experiments/display/conftest.py adds ``display`` and ``sim_display``).

``xvfb`` (session scope) starts ``Xvfb -screen 0 1280x1024x24 -nolisten tcp`` on a free display
number (``-displayfd``, so parallel runs do not collide), points ``DISPLAY`` at it and ``HOME``
at a temporary folder holding ``.asoundrc`` with ``pcm.!default { type null }`` (PsychoPy writes
``~/.psychopy3``; the sounddevice cue plays to ALSA's null device). Tests marked ``gui`` use it;
they are skipped, with the reason, only when Xvfb itself is not installed.
"""
from __future__ import annotations

import os
import select
import shutil
import subprocess
import sys
import time

import pytest

DISPLAY_DEFAULT = "emulator://"


def pytest_addoption(parser):
    parser.addoption("--display", action="store", default=DISPLAY_DEFAULT, metavar="URL",
                     help="pyserial URL or device path of the thermal display for the hardware "
                          "tests (default emulator://: the in-process emulator, virtual clock)")


@pytest.fixture
def display_url(request) -> str:
    """The display under test; the default emulator runs on a virtual clock for speed."""
    url = request.config.getoption("--display")
    if url == DISPLAY_DEFAULT:
        return "emulator://?clock=virtual&seed=20261122"
    return url


@pytest.fixture(autouse=True)
def _fault_events_forgotten():
    """Each test starts as a new host process would: no ``@T`` fault event of an ``emulator://``
    URL has fired yet (experiments.emulators.thermocue.faults: once per URL per process)."""
    yield
    faults = sys.modules.get("experiments.emulators.thermocue.faults")
    if faults is not None:
        faults.forget_fired()


def _start_xvfb():
    read_fd, write_fd = os.pipe()
    proc = subprocess.Popen(
        ["Xvfb", "-displayfd", str(write_fd), "-screen", "0", "1280x1024x24", "-nolisten", "tcp"],
        pass_fds=(write_fd,), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    os.close(write_fd)
    number = b""
    deadline = time.monotonic() + 15.0
    try:
        while not number.endswith(b"\n"):
            left = deadline - time.monotonic()
            if left <= 0 or proc.poll() is not None:
                raise RuntimeError("Xvfb did not start: "
                                   + (proc.stderr.read().decode(errors="replace")[-500:]
                                      if proc.poll() is not None else "no display number in 15 s"))
            ready, _, _ = select.select([read_fd], [], [], left)
            if ready:
                chunk = os.read(read_fd, 64)
                if not chunk:
                    raise RuntimeError("Xvfb closed -displayfd without a display number")
                number += chunk
    except BaseException:
        proc.kill()
        proc.wait()
        raise
    finally:
        os.close(read_fd)
    return proc, f":{int(number.strip())}"


@pytest.fixture(scope="session")
def xvfb(tmp_path_factory):
    """An X display for GUI tests; yields the environment (``DISPLAY``, ``HOME``) to use."""
    if shutil.which("Xvfb") is None:
        pytest.skip("Xvfb is not installed (apt-get install xvfb; .ci/run installs it)")
    home = tmp_path_factory.mktemp("home")
    (home / ".asoundrc").write_text("pcm.!default { type null }\n")
    proc, display = _start_xvfb()
    saved = {k: os.environ.get(k) for k in ("DISPLAY", "HOME")}
    os.environ["DISPLAY"] = display
    os.environ["HOME"] = str(home)
    try:
        yield {"DISPLAY": display, "HOME": str(home)}
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
        proc.terminate()
        try:
            proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        if proc.stderr is not None:
            proc.stderr.close()
