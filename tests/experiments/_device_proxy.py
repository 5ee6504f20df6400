"""A hostile device for attacks: ``thermocue emulator`` on a pty, and the frame-rewriting proxy.

:class:`FrameProxy` (``experiments.emulators.thermocue.frame_proxy``) rewrites the emulator's
frames; :func:`start_emulator` and :func:`stop` run the emulator in its own process. Used by the
attack tests of the display's safety (delivery evidence, reply checks, exclusive links).
"""
from __future__ import annotations

import select
import signal
import subprocess
import sys

import pytest

from experiments.emulators.thermocue.frame_proxy import FrameProxy

__all__ = ["FrameProxy", "start_emulator", "stop"]


def start_emulator(tmp_path, *args):
    """``thermocue emulator`` in its own process on a pty; return (process, pty path)."""
    proc = subprocess.Popen([sys.executable, "-m", "experiments.emulators.pty_server",
                             "--log", str(tmp_path / "emulator.jsonl"), *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    r, _, _ = select.select([proc.stdout], [], [], 30)
    if not r:
        proc.kill()
        pytest.fail("the emulator printed no pty path within 30 s")
    return proc, proc.stdout.readline().strip()


def stop(proc):
    proc.send_signal(signal.SIGTERM)
    try:
        proc.wait(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
