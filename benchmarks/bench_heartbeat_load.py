"""Spurious watchdog trips of a busy host: a PsychoPy window drawing, CPU burners.  Not a test.

Run (an X server is needed; ``xvfb-run`` gives one):

    xvfb-run -a .venv/bin/python benchmarks/bench_heartbeat_load.py --loads 0,4,8 --trials 150

For each load L it starts L CPU burners (``python -c "while True: pass"``, each its own process)
and ``thermocue emulator --clock real`` on a pty (its own process, as a device is), opens the
display on the pty as a session does (the heartbeat helper process, the real clock), opens a
PsychoPy window and runs ``--trials`` short playback trials: upload once, then per trial ARM,
the emulator's scripted finger (press after 50 ms, 3 N), and ``run_trial`` whose telemetry
callback draws and flips the window on every frame (a responder's screen, 100 draws a second,
in the host's main thread). A trip is a trial the device ended by its watchdog (fault code
``WATCHDOG``; the emulator's log's ``watchdog`` records are counted too, also those between
trials). Every trip here is spurious: the host is alive throughout. It prints, per load, the
trials, the trial time, the trips, the trips per 1,000 trials, the other outcomes, the longest
gap between the host's own writes and the emulator's worst tick lateness (``max_late_ms``), and
the machine (CPU model, cores, load average at the end).
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import signal
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

BURNER = "while True:\n    pass\n"


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "?"


def _start_emulator(log: Path) -> tuple[subprocess.Popen, str]:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-m", "experiments", "emulator", "--clock", "real",
                             "--log", str(log)], env=env, stdout=subprocess.PIPE, text=True)
    path = proc.stdout.readline().strip()
    if not path.startswith("/"):
        proc.kill()
        raise SystemExit(f"emulator did not print a pty path: {path!r}")
    return proc, path


def _gil_holder(ms: float):
    """A call that holds the GIL for about ``ms`` of CPU (``sorted`` of a list: one C call that
    never releases it, as a text layout or texture upload of a window can), or None."""
    if ms <= 0:
        return None
    import random
    rng = random.Random(1)
    n = 20000
    while True:
        data = [rng.random() for _ in range(n)]
        t0 = time.process_time()
        sorted(data)
        took = (time.process_time() - t0) * 1e3
        if took >= ms or n > 5_000_000:
            break
        n = int(n * max(1.5, min(4.0, ms / max(took, 0.01))))
    return lambda: sorted(data)


def run_load(load: int, trials: int, tmp: Path, transport: str = "pty", gil_ms: float = 0.0,
             gil_every: int = 50) -> dict:
    import numpy as np
    from psychopy import visual

    from experiments.display import open_display

    burners = [subprocess.Popen([sys.executable, "-c", BURNER]) for _ in range(load)]
    log = tmp / f"emulator-{transport}-load{load}.jsonl"
    if transport == "pty":
        emu, path = _start_emulator(log)
    else:                                   # the emulator in this process, its own clock thread
        emu, path = None, f"emulator://?clock=real&log={log}"
    outcomes: Counter = Counter()
    trial_s = 0.0
    win = None
    try:
        time.sleep(1.0)                        # the burners at full speed
        win = visual.Window(size=(640, 480), units="pix", fullscr=False, allowGUI=False,
                            waitBlanking=False)
        grating = visual.GratingStim(win, tex="sin", mask="gauss", size=300, sf=0.02)
        text = visual.TextStim(win, text="Touch the sample", pos=(0, -180), height=24)

        hold = _gil_holder(gil_ms)
        frames = [0]

        def draw(frame):
            frames[0] += 1
            if hold is not None and frames[0] % gil_every == 0:
                hold()
            grating.phase += 0.01
            grating.draw()
            text.draw()
            win.flip()

        with open_display(path) as d:
            t = np.arange(0, 0.3001, 0.01)
            d.upload_profile(t, np.round(32.0 - 1.5 * np.sqrt(t / 0.3), 2))
            for i in range(trials):
                d.arm("playback", force_threshold_N=2.0, max_duration_s=5.0)
                d.sim_finger(press_after_s=0.05, force_N=3.0, hold_s=2.0)
                t0 = time.monotonic()
                rec = d.run_trial(timeout_s=10.0, on_telemetry=draw)
                trial_s += time.monotonic() - t0
                outcomes[rec.fault_code or rec.status] += 1
                if rec.status != "ok":
                    d.abort()
            max_gap_ms = d.max_tx_gap_s * 1e3
    finally:
        if win is not None:
            win.close()
        for b in burners:
            b.kill()
            b.wait()
        if emu is not None:
            emu.send_signal(signal.SIGTERM)
            emu.wait(timeout=10)
    records = [json.loads(line) for line in log.read_text().splitlines() if line.strip()]
    log_trips = sum(1 for r in records if r.get("event") == "watchdog")
    stop = next((r for r in reversed(records) if "max_late_ms" in r), {})
    trips = outcomes.get("WATCHDOG", 0)
    return dict(transport=transport, gil_hold_ms=gil_ms, gil_every_frames=gil_every if gil_ms else None,
                load=load, trials=trials, trial_time_s=round(trial_s, 1), watchdog_trips=trips,
                trips_per_1000_trials=round(1000.0 * trips / trials, 1),
                emulator_log_watchdog_records=log_trips, outcomes=dict(outcomes),
                host_max_tx_gap_ms=round(max_gap_ms, 1),
                emulator_max_late_ms=stop.get("max_late_ms"),
                loadavg_1min=round(os.getloadavg()[0], 2))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--loads", default="0,4,8", help="numbers of CPU burners, comma-separated")
    ap.add_argument("--trials", type=int, default=150, help="trials per load")
    ap.add_argument("--transport", choices=("pty", "inprocess"), default="pty",
                    help="pty: `thermocue emulator` in its own process (a device's place); "
                         "inprocess: emulator://?clock=real in this process")
    ap.add_argument("--gil-ms", type=float, default=0.0,
                    help="also hold the GIL this long (CPU ms, one C call) every --gil-every "
                         "telemetry frames in the drawing callback (default 0: never)")
    ap.add_argument("--gil-every", type=int, default=50, help="frames between GIL holds")
    ap.add_argument("--json", type=Path, help="also write the results here")
    a = ap.parse_args(argv)
    if not os.environ.get("DISPLAY"):
        print("bench_heartbeat_load: no DISPLAY (run it under xvfb-run -a)", file=sys.stderr)
        return 2
    print(f"machine: {_cpu_model()}, {os.cpu_count()} cores, {platform.platform()}, "
          f"Python {platform.python_version()}")
    results = []
    with tempfile.TemporaryDirectory(prefix="bench-heartbeat-") as tmp:
        for load in (int(x) for x in a.loads.split(",")):
            r = run_load(load, a.trials, Path(tmp), a.transport, a.gil_ms, a.gil_every)
            results.append(r)
            print(json.dumps(r), flush=True)
    if a.json:
        a.json.write_text(json.dumps(dict(machine=_cpu_model(), cores=os.cpu_count(),
                                          results=results), indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
