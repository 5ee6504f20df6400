"""The emulator on a real pty for the plugin tests, its JSON log stamped with PsychoPy's clock.

``serve_stamped`` runs ``thermocue emulator`` (``experiments.emulators.pty_server``) in a
subprocess whose log records also carry ``host_s``: ``psychopy.clock.getTime()`` at the moment
the emulator wrote the record, inside the 10 ms tick that made it. A CONTACT state change is
therefore stamped with the device time (``t_s``) and PsychoPy's time of the same tick: the
ground truth the clock mapping is measured against. A real display counts time on its own
processor; the emulator shares two cores with everything else, so it raises its priority where
the system lets it (root: ``nice -10``), lest its ticks run late and its clock stop being one.
"""
from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import time
from contextlib import contextmanager
from pathlib import Path

from _xkeys import PSYCHOPY_TITLE, send_key

REPO = Path(__file__).resolve().parents[3]
P01 = REPO / "participants" / "examples" / "P01.json"

_STAMPED_SERVER = r"""
import os, sys
try:
    os.nice(-10)        # a device's clock has its own processor: keep the stand-in on time
except OSError:
    pass
import json
from psychopy.clock import getTime
from experiments.emulators import pty_server
from experiments.emulators.thermocue import device, protocol_emulator

class StampedLog(protocol_emulator.JsonLog):
    def __call__(self, rec):
        super().__call__(dict(rec, host_s=getTime()))

ticks = []
_step = device.Device.step
def step(self):
    _step(self)
    ticks.append((self.time_us, getTime()))
device.Device.step = step
pty_server.JsonLog = StampedLog
rc = pty_server.main(sys.argv[2:])
with open(sys.argv[1], "w") as fh:
    json.dump(ticks, fh)
sys.exit(rc)
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
    """Yield ``(pty_link, log_path)``; SIGTERM at the end writes the log's stop record.

    Every tick's device time and PsychoPy time are written to ``ticks.json`` beside the log
    when the emulator stops (:func:`tick_times`).
    """
    link, log = tmp_path / "thermal-pty", tmp_path / "emulator.jsonl"
    proc = subprocess.Popen([sys.executable, "-c", _STAMPED_SERVER, str(tmp_path / "ticks.json"),
                             "--link", str(link), "--log", str(log), *args],
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


def on_time_host_s(ticks, device_s: float, window_s: float = 1.0) -> float:
    """PsychoPy time of device time ``device_s`` on the emulator's own schedule.

    The emulator runs a tick every 10 ms of wall time, but on a loaded machine some run late
    (and it catches up by running several at once); a real device's timer does not. The ticks
    that ran on time lie on the earliest line ``host = device + a``: its value at ``device_s``
    (over ticks within ``window_s``) is when the emulator's schedule put that tick.
    """
    near = [(d * 1e-6, h) for d, h in ticks if abs(d * 1e-6 - device_s) <= window_s]
    return min(h - d for d, h in near) + device_s


def unexplained_refusal(reason: str, max_late_ms: float) -> str | None:
    """What in a clock map's refusal the emulator's own lateness does not explain (None: all).

    The emulator counts time with ticks its loop runs; a reply read while a tick is overdue
    carries the tick before it, up to the loop's lateness stale (``max_late_ms``, the worst
    tick of the run). A map refuses only what such stale stamps (or a clock that gave up time
    it was starved of beyond ``MAX_CATCH_UP_TICKS`` ticks) can cause:

    - bounds that cross by X ms need a reply at least X ms stale;
    - round trips R ms outside a map whose uncertainty is U ms need stamps (R - U) / 2 stale
      (a stale burst moves the map as well as the round trip);
    - an implausible drift needs stale stamps at all, beyond the loop's wake-up delay (0.5 ms).

    The same 0.5 ms allows for the emulator's and the host's readings of one clock.
    """
    from experiments.emulators.thermocue.device import TICK_US
    from experiments.emulators.thermocue.emulator_core import MAX_CATCH_UP_TICKS
    if max_late_ms >= MAX_CATCH_UP_TICKS * TICK_US * 1e-3:
        return None                                   # the clock lost time: anything goes
    slack = 0.5
    missing = []
    for part in reason.split("; "):
        if m := re.match(r"a burst's round trips disagree by ([0-9.]+) ms", part):
            need = float(m[1])
        elif m := re.match(r"round trips up to ([0-9.]+) ms outside .*stated uncertainty "
                           r"([0-9.]+) ms", part):
            need = (float(m[1]) - float(m[2])) / 2
        elif part.startswith("drift "):
            need = slack
        else:
            missing.append(f"an unknown reason: {part!r}")
            continue
        if max_late_ms < need - slack or max_late_ms < slack:
            missing.append(f"{part!r} while the emulator's worst tick was {max_late_ms} ms late")
    return "; ".join(missing) or None


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


def xdotool_key(env: dict, key: str, title: str = PSYCHOPY_TITLE) -> None:
    """A real key press in PsychoPy's window (:func:`_xkeys.send_key`)."""
    send_key(env, key, title)


def gui_env(xvfb: dict) -> dict:
    env = {**os.environ, **xvfb}
    env["PYTHONPATH"] = str(REPO) + os.pathsep + env.get("PYTHONPATH", "")
    return env
