"""The emulator on a real pty for the plugin tests, its JSON log stamped with PsychoPy's clock.

``serve_stamped`` runs ``thermocue emulator`` (``experiments.hardware.pty_server``) in a
subprocess whose log records also carry ``host_s``: ``psychopy.clock.getTime()`` at the moment
the emulator wrote the record, inside the 10 ms tick that made it. A CONTACT state change is
therefore stamped with the device time (``t_s``) and PsychoPy's time of the same tick: the
ground truth the clock mapping is measured against.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from contextlib import contextmanager
from pathlib import Path

REPO = Path(__file__).resolve().parents[3]
P01 = REPO / "participants" / "examples" / "P01.json"

_STAMPED_SERVER = r"""
import sys
from psychopy.clock import getTime
from experiments.hardware import protocol_emulator, pty_server

class StampedLog(protocol_emulator.JsonLog):
    def __call__(self, rec):
        super().__call__(dict(rec, host_s=getTime()))

pty_server.JsonLog = StampedLog
sys.exit(pty_server.main(sys.argv[1:]))
"""


def read_log(path: Path) -> list[dict]:
    out = []
    if path.exists():
        for line in path.read_text(encoding="utf-8").splitlines():
            try:
                out.append(json.loads(line))
            except ValueError:
                pass                      # a line being written
    return out


@contextmanager
def serve_stamped(tmp_path: Path, *args: str):
    """Yield ``(pty_link, log_path)``; SIGTERM at the end writes the log's stop record."""
    link, log = tmp_path / "thermal-pty", tmp_path / "emulator.jsonl"
    proc = subprocess.Popen([sys.executable, "-c", _STAMPED_SERVER, "--link", str(link),
                             "--log", str(log), *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 30
        while not link.exists():
            if proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError("emulator did not start: " + (
                    proc.stderr.read() if proc.poll() is not None else "no pty in 30 s"))
            time.sleep(0.05)
        yield str(link), log
    finally:
        stop_emulator(proc)


def stop_emulator(proc) -> None:
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    for fh in (proc.stdout, proc.stderr):
        if fh is not None:
            fh.close()


def xdotool_key(env: dict, key: str, title: str = "^PsychoPy$") -> None:
    subprocess.run(["xdotool", "search", "--sync", "--name", title, "windowfocus", "--sync",
                    "key", "--delay", "30", key], env=env, timeout=15, check=True,
                   capture_output=True)


def gui_env(xvfb: dict) -> dict:
    env = {**os.environ, **xvfb}
    env["PYTHONPATH"] = str(REPO) + os.pathsep + env.get("PYTHONPATH", "")
    return env
