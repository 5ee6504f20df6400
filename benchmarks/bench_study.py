"""Wall time and peak memory of the whole simulated Figure 9 study (the README's main job).

Not a test.  Run:  .venv/bin/python benchmarks/bench_study.py [--out DIR] [-- extra figure9 options]

Starts ``thermocue reproduce figure9 --out DIR`` as a child process and samples, every 50 ms,
the resident memory (VmRSS from /proc, Linux only) of that process and all its descendants
(the worker processes).  Reports the machine, the wall time, the study's own split
(``study.json``: sessions_s, analysis_s) and the peak of the *summed* RSS of the process tree,
an upper bound on the memory the study needs (shared library pages are counted once per
process).  Target (the developers' brief): under 1 GB.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def _children_map():
    kids = {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat", encoding="utf-8") as fh:
                ppid = int(fh.read().rsplit(")", 1)[1].split()[1])
        except (OSError, ValueError, IndexError):
            continue
        kids.setdefault(ppid, []).append(int(entry))
    return kids


def _rss_kib(pid: int) -> int:
    try:
        with open(f"/proc/{pid}/status", encoding="utf-8") as fh:
            for line in fh:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1])
    except OSError:
        pass
    return 0


def tree_rss_kib(root: int) -> tuple[int, int]:
    """(summed RSS in KiB, number of processes) of ``root`` and its descendants."""
    kids = _children_map()
    total, n, todo = 0, 0, [root]
    while todo:
        pid = todo.pop()
        total += _rss_kib(pid)
        n += 1
        todo.extend(kids.get(pid, ()))
    return total, n


def machine() -> str:
    cpu = platform.processor() or ""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            cpu = next(line.split(":", 1)[1].strip() for line in fh if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    return (f"{cpu} x{os.cpu_count()}, {platform.platform()}, Python {platform.python_version()}, "
            f"load {os.getloadavg()[0]:.2f} at start")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=None, help="study folder (default: a temporary one, removed)")
    ap.add_argument("extra", nargs="*", help="more options for `thermocue reproduce figure9`")
    ns = ap.parse_args(argv)
    exe = Path(sys.executable).with_name("thermocue")
    out = Path(ns.out) if ns.out else Path(tempfile.mkdtemp(prefix="bench-study-")) / "figure9"
    print(f"machine: {machine()}")
    cmd = [str(exe), "reproduce", "figure9", "--out", str(out), *ns.extra]
    print("command:", " ".join(cmd))
    start = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    peak, peak_n = 0, 0
    while proc.poll() is None:
        rss, n = tree_rss_kib(proc.pid)
        if rss > peak:
            peak, peak_n = rss, n
        time.sleep(0.05)
    wall = time.perf_counter() - start
    err = proc.stderr.read()
    if proc.returncode != 0:
        print(err, file=sys.stderr)
        return proc.returncode
    study = json.loads((out / "study.json").read_text(encoding="utf-8"))
    result = {"wall_s": round(wall, 1), "sessions_s": round(study["sessions_s"], 1),
              "analysis_s": round(study["analysis_s"], 1), "workers": study["workers"],
              "participants": len(study["participants"]),
              "peak_tree_rss_MiB": round(peak / 1024, 1), "processes_at_peak": peak_n}
    for key, value in result.items():
        print(f"{key}: {value}")
    print("target: whole study under 1 GB peak:", "met" if peak * 1024 < 1e9 else "NOT met")
    if not ns.out:
        shutil.rmtree(out.parent, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
