"""thermocue monitor while a session runs: page rate, latency, its cost, and the session's own
heartbeat and tracking with and without it; the time left before and after.  Not a test.

    nice -n 10 .venv/bin/python benchmarks/bench_monitor.py [--trials-sim 4] [--contact-s 3]

One run makes two real-clock sessions of the same short protocol (one recorded touch, then
replayed profiles; ``--contact-s`` of contact, a 3 s rewarm) against the in-process emulator
(``emulator://?clock=real&log=...``), the first with ``thermocue run --monitor`` and its page
open in Debian's headless Chromium, the second without. It reports:

- the page's redraws of the running trace per second and the gaps between them (the page logs
  ``[Date.now(), last frame's device time]`` per redraw: ``window.monitorStats.history``);
- telemetry to page: a thread here polls the trace file every 2 ms and notes when each frame's
  line reached the file; the page's redraw showing that frame, minus that. Also from the frame's
  device time (the emulator's real clock; offset = the smallest file-minus-device time seen),
  which includes the session's flush delay;
- the monitor process's resident memory (max) and CPU (share of one core over the session);
- per session: the longest host silence the emulator's watchdog saw while armed, playing or
  recording (``max_host_gap_ms`` of its log's stop record), watchdog trips, frames lost, and the
  replayed trials' tracking error (RMS and max, °C, trials.csv);
- the time left at each trial's start against the time the session really took from there, for
  the old estimate (the mean trial without its rewarm, times the trials left: the trial's start
  to the end of its answer, from the log) and for experiments.monitor.time_left.
"""
from __future__ import annotations

import argparse
import csv
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import psutil

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests" / "experiments"),
                str(ROOT / "tests" / "experiments" / "monitor")]
from _browser import chromium, wait_for  # noqa: E402  (the tests' browser)
from _session_helpers import P01, write_protocol  # noqa: E402
from experiments.monitor.time_left import TimeLeft, event_seconds  # noqa: E402


class TraceWatch(threading.Thread):
    """When each frame's line reached a trace file (epoch s, by device time), polled every 2 ms."""

    def __init__(self, traces: Path):
        super().__init__(daemon=True)
        self.traces, self.seen, self.stop = traces, {}, False
        self.start()

    def run(self):
        offsets: dict[Path, tuple[int, bytes]] = {}
        while not self.stop:
            for f in sorted(self.traces.glob("trial-*.csv")) if self.traces.is_dir() else ():
                pos, rest = offsets.get(f, (0, b""))
                try:
                    with open(f, "rb") as fh:
                        fh.seek(pos)
                        data = fh.read()
                except OSError:
                    continue
                now = time.time()
                head, sep, tail = (rest + data).rpartition(b"\n")
                offsets[f] = (pos + len(data), tail if sep else rest + data)
                for line in head.split(b"\n") if sep else ():
                    t = line.split(b",", 1)[0]
                    if t and t[:1].isdigit():
                        self.seen.setdefault(float(t), now)
            time.sleep(0.002)


def _sample(pid: int, out: dict, stop: threading.Event):
    try:
        p = psutil.Process(pid)
        t0, c0 = time.monotonic(), sum(p.cpu_times()[:2])
        while not stop.is_set():
            out["rss_max_MB"] = max(out.get("rss_max_MB", 0), p.memory_info().rss / 2**20)
            out["cpu_share"] = (sum(p.cpu_times()[:2]) - c0) / max(1e-9, time.monotonic() - t0)
            time.sleep(0.25)
    except psutil.Error:
        pass


def _percentile(values, q):
    values = sorted(values)
    return values[min(len(values) - 1, int(q * len(values)))] if values else None


def session(tmp: Path, args, monitor: bool) -> dict:
    proto = write_protocol(tmp, contact_s=args.contact_s, rewarm_s=3.0, real_samples=(1,),
                           sim_samples=tuple(range(1, args.trials_sim + 1)) if args.trials_sim <= 4
                           else (1, 2, 3, 4), sim_reps=max(1, args.trials_sim // 4))
    data, log = tmp / "data", tmp / "emulator.log"
    cmd = [sys.executable, "-m", "experiments", "run", str(proto), "--participant", str(P01),
           "--display", f"emulator://?clock=real&log={log}", "--responder", "simulated",
           "--data", str(data), "--seed", "1", "--quiet"] + (["--monitor"] if monitor else [])
    run = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    lines: list[str] = []
    threading.Thread(target=lambda: lines.extend(run.stderr), daemon=True).start()
    out: dict = {"monitor": monitor}
    if monitor:
        url = wait_for(lambda: next((m[1] for m in (re.search(r"view of .*: (http://\S+)", x)
                                                      for x in lines) if m), None), what="the URL")
        mon = next(c for c in psutil.Process(run.pid).children()
                   if c.cmdline()[1:4] == ["-m", "experiments", "monitor"])
        stop = threading.Event()
        threading.Thread(target=_sample, args=(mon.pid, out, stop), daemon=True).start()
        watch = TraceWatch(data / "P01" / "S01" / "traces")
        with chromium() as d:
            d.get(url)
            run.wait(timeout=600)
            history = d.execute_script("return window.monitorStats.history")
        stop.set()
        watch.stop = True
        out.update(_page_figures(history, watch.seen))
    else:
        run.wait(timeout=600)
    folder = data / "P01" / "S01"
    with open(folder / "trials.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    sim = [r for r in rows if r["mode"] == "simulated" and r["status"] == "ok"]
    records = [json.loads(x) for x in log.read_text().splitlines() if x.strip()]
    stop_rec = next((r for r in reversed(records) if r.get("event") == "stop"), {})
    out.update(exit=run.returncode, trials=len(rows),
               statuses=sorted({r["status"] for r in rows}),
               max_host_gap_ms=stop_rec.get("max_host_gap_ms"),
               watchdog_trips=sum(1 for r in records if r.get("event") == "watchdog"),
               frames_lost=sum(int(r["frames_lost"] or 0) for r in rows),
               tracking_rms_C_mean=round(statistics.mean(float(r["tracking_rms_C"]) for r in sim), 4),
               tracking_max_C_max=max(float(r["tracking_max_C"]) for r in sim))
    out["time_left"] = _time_left_errors(folder)
    return out


def _page_figures(history, seen) -> dict:
    gaps = [b[0] - a[0] for a, b in zip(history, history[1:]) if b[1] is not None
            and a[1] is not None and 0 < b[1] - a[1] < 1.0]          # within one trial's stream
    lat = [h[0] / 1e3 - seen[h[1]] for h in history if h[1] in seen]
    offset = min(s - t for t, s in seen.items()) if seen else 0.0
    lat_dev = [h[0] / 1e3 - (h[1] + offset) for h in history if h[1] is not None]
    ms = lambda v: None if v is None else round(v * 1e3, 1)  # noqa: E731
    return {"redraws": len(history),
            "redraw_gap_ms_median": round(statistics.median(gaps), 1) if gaps else None,
            "redraw_gap_ms_p95": _percentile(gaps, 0.95), "redraws_per_s": round(1e3 / statistics.median(gaps), 1) if gaps else None,
            "file_to_page_ms_median": ms(statistics.median(lat)) if lat else None,
            "file_to_page_ms_p95": ms(_percentile(lat, 0.95)), "file_to_page_ms_max": ms(max(lat, default=None)),
            "frame_to_page_ms_median": ms(statistics.median(lat_dev)) if lat_dev else None,
            "frame_to_page_ms_p95": ms(_percentile(lat_dev, 0.95)),
            "frame_to_page_ms_max": ms(max(lat_dev, default=None))}


def _time_left_errors(folder: Path) -> dict:
    events = [json.loads(x) for x in (folder / "events.jsonl").read_text().splitlines() if x.strip()]
    meta = json.loads((folder / "session.json").read_text())
    modes = {s["trial_index"]: s["mode"] for s in meta["schedule"]}
    end = event_seconds(next(e for e in events if e["event"] == "session_finished"))
    n = len(modes)
    new = TimeLeft(modes, rewarm_s=meta["protocol"]["contact"]["rewarm_s"])
    old_durations, starts, rows = [], {}, []
    for e in events:
        new.feed(e)
        if e["event"] == "trial_started":
            at = event_seconds(e)
            starts[(e["trial_index"], e["attempt"])] = at
            if old_durations:
                old = (n - e["trial_index"] + 1) * statistics.mean(old_durations)
                rows.append((e["trial_index"], end - at, old, new.seconds_left(at)))
        elif e["event"] == "state" and e.get("to") == "write" and (e.get("trial_index"), e.get("attempt")) in starts:
            old_durations.append(event_seconds(e) - starts[(e["trial_index"], e["attempt"])])
    return {"per_trial": [dict(trial=t, actual_s=round(a, 1), old_s=round(o, 1), new_s=round(w, 1))
                          for t, a, o, w in rows],
            "old_mean_abs_error_s": round(statistics.mean(abs(o - a) for _, a, o, _ in rows), 1),
            "new_mean_abs_error_s": round(statistics.mean(abs(w - a) for _, a, _, w in rows), 1)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--trials-sim", type=int, default=4)
    ap.add_argument("--contact-s", type=float, default=3.0)
    args = ap.parse_args(argv)
    results = []
    for monitor in (True, False):
        with tempfile.TemporaryDirectory() as tmp:
            results.append(session(Path(tmp), args, monitor))
    print(json.dumps({"results": results, "loadavg": os.getloadavg(), "cpus": os.cpu_count()},
                     indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
