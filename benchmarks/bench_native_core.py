"""The emulator's two cores compared: the Python twin and the firmware's C core.  Not a test.

Run:  nice .venv/bin/python benchmarks/bench_native_core.py [--ticks 3000] [--sessions 1]

Prints, for ``emulator://?core=py`` and ``?core=c``:

- the CPU time of one 10 ms device tick (``time.process_time``), idle and during a playback
  trial with the scripted finger on the pad (the figure of the emulator's own loop);
- the CPU and wall time of one whole emulated session on the virtual clock (participant P01 of
  the seed-0 simulated cohort, the default protocol, 24 trials, fsync off): the figure a
  reproduction pays per session;
- the time to build the C core's library from nothing (``firmware/build --native``), the set-up
  cost on a fresh machine (cc comes with scripts/setup).
"""
from __future__ import annotations

import argparse
import io
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def _device(core: str):
    from experiments.emulators.thermocue.emulator_core import EmulatorCore
    return EmulatorCore(seed=0, core=core).device


def tick_cost(core: str, n: int) -> tuple[float, float]:
    """µs of CPU per tick: idle, and in a playback trial (finger pressing, 10 s profile)."""
    import numpy as np

    from experiments.display.thermocue import messages as m
    from experiments.display.thermocue.framing import encode_frame
    from experiments.display.thermocue.messages import Cmd

    dev = _device(core)
    for _ in range(10):
        dev.step()
    c0 = time.process_time()
    for _ in range(n):
        dev.step()
    idle = (time.process_time() - c0) / n * 1e6
    # a trial: HELLO, a 10 s profile at 10 ms, ARM, a finger that presses at once
    seq = iter(range(1, 256))
    vals = (np.full(1000, 32.0) * 100).astype("<i2").tobytes()

    def cmd(t, payload=b""):
        dev.receive(encode_frame(next(seq), t, payload))
        dev.take_output()
    cmd(Cmd.HELLO, bytes([m.PROTOCOL_VERSION]))
    cmd(Cmd.UPLOAD_BEGIN, m.UPLOAD_BEGIN.pack(1000, 10_000))
    for off in range(0, 1000, 500):
        cmd(Cmd.UPLOAD_CHUNK, m.UPLOAD_CHUNK_HEAD.pack(off, 500) + vals[2 * off:2 * off + 1000])
    import zlib
    cmd(Cmd.UPLOAD_COMMIT, m.COMMIT.pack(zlib.crc32(vals)))
    cmd(Cmd.ARM, m.ARM.pack(0, 200, 12_000))
    cmd(Cmd.SIM_FINGER, m.encode_json(dict(press_after_s=0.2, force_N=2.0, hold_s=30.0)))
    hb = encode_frame(0, Cmd.HEARTBEAT, b"\x00")
    for _ in range(100):                       # ready and contact
        dev.receive(hb)
        dev.step()
        dev.take_output()
    assert int(dev.state) == 2, f"{core}: no trial running (state {dev.state!r})"
    k = min(n, 800)
    c0 = time.process_time()
    for _ in range(k):
        dev.receive(hb)
        dev.step()
        dev.take_output()
    trial = (time.process_time() - c0) / k * 1e6
    return idle, trial


def session_time(core: str) -> tuple[float, float, int]:
    """(CPU s, wall s, trials) of one emulated session on the virtual clock."""
    from threadpoolctl import threadpool_limits

    from experiments.participant_model.cohort import write_cohort
    from experiments.responders import get_responder
    from experiments.session import create_session
    tmp = Path(tempfile.mkdtemp(prefix="bench-native-"))
    paths = {p.stem: p for p in write_cohort(tmp / "participants", seed=0)}
    c0, w0 = time.process_time(), time.perf_counter()
    with threadpool_limits(1):
        session = create_session("roughness_recognition", paths["P01"], tmp / "data",
                                 f"emulator://?clock=virtual&seed=0&core={core}", seed=0,
                                 responder_name="simulated", clock="virtual", out=io.StringIO(),
                                 durable=False)
        status = session.run(get_responder("simulated", seed=0))
    if status != 0:
        raise RuntimeError(f"core={core}: the session ended with status {status}")
    return time.process_time() - c0, time.perf_counter() - w0, session.n_trials


def build_time() -> float:
    out = Path(tempfile.mkdtemp(prefix="bench-native-build-")) / "core.so"
    w0 = time.perf_counter()
    subprocess.run(["sh", str(ROOT / "firmware" / "build"), "--native", str(out)], check=True)
    return time.perf_counter() - w0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ticks", type=int, default=3000)
    ap.add_argument("--sessions", type=int, default=1)
    ns = ap.parse_args(argv)
    print(f"load average at the start: {os.getloadavg()[0]:.2f}")
    print(f"build of the C core from nothing: {build_time():.2f} s wall")
    for core in ("py", "c"):
        idle, trial = tick_cost(core, ns.ticks)
        print(f"core={core}: tick CPU idle {idle:7.1f} µs, in a trial {trial:7.1f} µs")
    _device("c")                               # imports and the library, outside the figures
    session_time("py")
    for core in ("py", "c"):
        runs = [session_time(core) for _ in range(ns.sessions)]
        cpu = statistics.median(r[0] for r in runs)
        wall = statistics.median(r[1] for r in runs)
        print(f"core={core}: one session ({runs[0][2]} trials) CPU {cpu:6.2f} s, wall {wall:6.2f} s")
    print(f"load average at the end: {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
