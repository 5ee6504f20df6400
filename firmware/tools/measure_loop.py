"""Measure the firmware's tick period and jitter under QEMU (an emulated figure, not the board's).

Runs one playback trial on ``qemu-firmware://`` and reads the device time stamp of every
telemetry frame: the firmware stamps a frame with its clock at the moment the 10 ms tick runs,
so the differences are the tick period as executed, including the main loop's lateness. The sim
image's clock is TIM2 (1 µs) less the stalls of QEMU's thread (gaps over 0.5 ms, when the host
machine holds the emulator off); their total is printed too. Usage (from the repository root)::

    python firmware/tools/measure_loop.py [--seconds 5]
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", ".."))

from experiments.display import open_display  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=5.0, help="trial length, s")
    args = ap.parse_args()
    d = open_display("qemu-firmware://")
    try:
        t = np.arange(0.0, args.seconds, 0.001)
        d.upload_profile(t, 32.0 + 2.0 * np.sin(2 * np.pi * 0.5 * t))
        d.arm("playback", 2.0, args.seconds + 2.0)
        d.sim_finger(press_after_s=0.1, hold_s=args.seconds + 1.0)
        tel = []
        paused0 = d.sim_fault("")["paused_s"]
        wall0 = time.monotonic()
        rec = d.run_trial(timeout_s=args.seconds + 30.0, on_telemetry=tel.append)
        wall = time.monotonic() - wall0
        paused = d.sim_fault("")["paused_s"] - paused0
    finally:
        d.close()
    times = np.array([f.device_time_s for f in tel])
    dt_ms = np.diff(times) * 1e3
    print(f"trial: {rec.status}, {len(tel)} frames, lost {rec.frames_lost}, "
          f"tracking max {rec.tracking_max_C:.3f} °C")
    print(f"tick period (emulated, QEMU): mean {dt_ms.mean():.4f} ms, sd {dt_ms.std():.4f} ms, "
          f"min {dt_ms.min():.3f} ms, max {dt_ms.max():.3f} ms, "
          f"p99 |dev| {np.percentile(np.abs(dt_ms - 10.0), 99):.3f} ms")
    print(f"QEMU stalls (the simulated world paused): {paused:.3f} s during the trial's "
          f"{wall:.3f} s of wall time")
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    return 0


if __name__ == "__main__":
    sys.exit(main())
