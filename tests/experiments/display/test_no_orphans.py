"""No orphans: a host killed with SIGKILL or SIGHUP takes its children with it.

A real host (a second Python process) opens ``qemu-firmware://`` -- QEMU running the C firmware
and the heartbeat helper on its pty -- or starts a pty server the way the display benchmark does,
prints its children's PIDs and waits. The test kills the host each way and then scans ``/proc``
for any process whose parent was the host, and for the children it named. Before
``popen_tied`` (``PR_SET_PDEATHSIG``), QEMU survived both, reparented to PID 1.
"""
from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[3]

QEMU_HOST = r"""
import sys, time, threading
from experiments.display import open_display
box = []
t = threading.Thread(target=lambda: box.append(open_display("qemu-firmware://")))
t.start(); t.join()                 # opened in a thread that has ended: the children must stay
d = box[0]
print(d.qemu.pid, d.link._hb_proc.proc.pid, flush=True)
time.sleep(600)
"""

PTY_HOST = r"""
import time
from experiments.bench.display import _start_emulator
proc, path = _start_emulator("--clock", "virtual")
print(proc.pid, flush=True)
time.sleep(600)
"""


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            state = fh.read().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def _children_of(ppid: int) -> list:
    out = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as fh:
                fields = fh.read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == ppid and fields[0] != "Z":
            out.append(int(entry))
    return out


def _survivors(script: str, sig: int) -> tuple:
    host = subprocess.Popen([sys.executable, "-c", script], cwd=REPO, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        line = host.stdout.readline()
        assert line.strip(), host.stderr.read()
        pids = [int(p) for p in line.split()]
        assert all(_alive(p) for p in pids)
        assert set(pids) <= set(_children_of(host.pid))
        host.send_signal(sig)
        host.wait(timeout=10)
        deadline = time.monotonic() + 5.0       # the kernel's signal, then the child's exit
        while time.monotonic() < deadline and any(_alive(p) for p in pids):
            time.sleep(0.05)
        return [p for p in pids if _alive(p)], pids
    finally:
        if host.poll() is None:
            host.kill()
            host.wait()


def _reap(pids):
    for p in pids:
        try:
            os.kill(p, signal.SIGKILL)
        except OSError:
            pass


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("qemu-system-arm") is None, reason="qemu-system-arm missing")
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGHUP], ids=["SIGKILL", "SIGHUP"])
def test_qemu_and_heartbeat_helper_die_with_their_host(sig):
    left, pids = _survivors(QEMU_HOST, sig)
    _reap(left)
    assert left == [], f"survived {signal.Signals(sig).name} of the host: {left} of {pids}"


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGHUP], ids=["SIGKILL", "SIGHUP"])
def test_pty_server_dies_with_its_host(sig):
    left, pids = _survivors(PTY_HOST, sig)
    _reap(left)
    assert left == [], f"survived {signal.Signals(sig).name} of the host: {left} of {pids}"
