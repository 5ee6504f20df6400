"""Spurious watchdog trips of the C firmware under QEMU on a loaded host.  Not a test.

Run:

    nice -n 10 .venv/bin/python benchmarks/bench_qemu_watchdog.py --trials 100 --burners 8

It starts ``--burners`` CPU burners (``python -c "while True: pass"``, each its own process at
this process's own nice value -- so they compete with QEMU and the host as equals -- tied to
this one so that none outlives it), opens ``qemu-firmware://`` (the sim image under
``qemu-system-arm``, its heartbeat helper process, the backend's 20 ms heartbeat) and runs
``--trials`` short playback trials: a 0.3 s profile uploaded once, then per trial ARM, the sim
bench's finger (press 0.05 s after READY, 2 N, hold 0.6 s) and ``run_trial``. A trip is a trial
that ended with fault ``WATCHDOG`` or any WATCHDOG event seen; every trip is spurious (the host
is alive throughout). It prints the trials, the trips, the other outcomes, the longest host
silence the firmware saw while armed or playing (``host_gap_max_s``, device time: the margin
against its 90 ms watchdog), the time its clock paused for QEMU's stalls, whether QEMU's event
loop got nice −10, the wall time, the load averages before and after (the burners included) and
the machine. ``--plain-qemu`` leaves QEMU's event loop at the default priority (the code before
the fix), for comparison.
"""
from __future__ import annotations

import argparse
import json
import os
import signal
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

BURNER = "while True:\n    pass\n"


def run(trials: int, burners: int, plain_qemu: bool = False) -> dict:
    from experiments.display import open_display
    from experiments.display.children import popen_tied
    from experiments.display.thermocue import qemu_firmware
    if plain_qemu:
        qemu_firmware.raise_io_thread = lambda pid: False
    procs = [popen_tied([sys.executable, "-c", BURNER]) for _ in range(burners)]
    load_before = os.getloadavg()
    outcomes: Counter = Counter()
    trips = events_wd = 0
    trip_after: Counter = Counter()
    t0 = time.monotonic()
    try:
        time.sleep(2.0 if burners else 0.0)          # the burners get going
        with open_display("qemu-firmware://") as d:
            t = np.arange(0.0, 0.3, 0.01)
            d.upload_profile(t, 32.0 + 5.0 * t)
            for _ in range(trials):
                d.arm("playback", force_threshold_N=1.0, max_duration_s=5.0)
                d.sim_finger(press_after_s=0.05, force_N=2.0, hold_s=0.6)
                seen = []
                rec = d.run_trial(timeout_s=30.0, on_event=seen.append)
                wd = any(e.kind == "WATCHDOG" for e in seen)
                if wd:                                # the event before it: None = ARMED
                    kinds = [e.kind for e in seen]
                    i = kinds.index("WATCHDOG")
                    trip_after[kinds[i - 1] if i else None] += 1
                events_wd += wd
                trips += rec.fault_code == "WATCHDOG" or wd
                outcomes[rec.status if rec.status == "ok" else str(rec.fault_code)] += 1
                if d.status().state == "FAULT":
                    d.clear_fault()
                d.abort()
            sim = d.sim_fault("")
            io_raised = d.io_raised
    finally:
        for p in procs:
            p.send_signal(signal.SIGKILL)
            p.wait()
    return dict(trials=trials, burners=burners, trips=trips, watchdog_events=events_wd,
                outcomes=dict(outcomes),
                trips_after_event={str(k): v for k, v in trip_after.items()},
                host_gap_max_s=sim.get("host_gap_max_s"),
                paused_s=sim.get("paused_s"), qemu_event_loop_nice_minus_10=io_raised,
                nice=os.nice(0), wall_s=round(time.monotonic() - t0, 1),
                load_before=[round(x, 1) for x in load_before],
                load_after=[round(x, 1) for x in os.getloadavg()],
                cores=os.cpu_count())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=100)
    ap.add_argument("--burners", type=int, default=8, help="CPU burners meanwhile (this nice)")
    ap.add_argument("--plain-qemu", action="store_true",
                    help="QEMU's event loop at the default priority (before the fix)")
    ap.add_argument("--json", type=Path, help="also write the result here")
    ns = ap.parse_args(argv)
    res = run(ns.trials, ns.burners, ns.plain_qemu)
    print(json.dumps(res, indent=1))
    if ns.json:
        ns.json.write_text(json.dumps(res, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
