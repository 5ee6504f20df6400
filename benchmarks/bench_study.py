"""Wall time and peak memory of the whole simulated Figure 9 study (the README's main job).

Not a test.  Run:  .venv/bin/python benchmarks/bench_study.py [--out DIR] [-- extra figure9 options]
                   .venv/bin/python benchmarks/bench_study.py --session-rounds 3

``--session-rounds N`` instead times single emulated sessions in this process (P01 and P16 of
the seed-0 cohort, virtual clock), N interleaved rounds of: fsync on (what ``thermocue run``
does) and fsync off (what a simulated study does, ``durable=False``), and
prints the wall time per trial of each (median and best).

Starts ``thermocue reproduce figure9 --out DIR`` as a child process and samples, every 50 ms,
the resident memory (/proc/PID/smaps_rollup, Linux only) of that process and all its descendants
(the worker processes).  Reports the machine, the default number of workers there
(:func:`experiments.simulation.sweep.default_workers`; ``-- --workers N`` runs another), the
wall time, the study's own split (``study.json``: scenarios_s, sessions_s, analysis_s), the CPU time of the whole process tree
(user + system: on a shared machine a fairer figure than the wall time; at most 2 x wall on 2
cores), the peak of the *summed* RSS of the process tree (an
upper bound: pages the forked workers share are counted once per process) and the peak of the
summed PSS (shared pages divided among their users: the memory the study really holds).  The
target (under 1 GB, taken as 1e9 bytes) is judged on both, each said by name.
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


def _rss_pss_kib(pid: int) -> tuple[int, int]:
    """(Rss, Pss) of one process in KiB from /proc/PID/smaps_rollup (0, 0 if it is gone)."""
    rss = pss = 0
    try:
        with open(f"/proc/{pid}/smaps_rollup", encoding="utf-8") as fh:
            for line in fh:
                if line.startswith("Rss:"):
                    rss = int(line.split()[1])
                elif line.startswith("Pss:"):
                    pss = int(line.split()[1])
    except OSError:
        pass
    return rss, pss


def tree_memory_kib(root: int) -> tuple[int, int, int]:
    """(summed Rss, summed Pss in KiB, number of processes) of ``root`` and its descendants."""
    kids = _children_map()
    rss = pss = n = 0
    todo = [root]
    while todo:
        pid = todo.pop()
        r, p = _rss_pss_kib(pid)
        rss, pss, n = rss + r, pss + p, n + 1
        todo.extend(kids.get(pid, ()))
    return rss, pss, n


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
    ap.add_argument("--session-rounds", type=int, default=0, metavar="N",
                    help="time single emulated sessions instead (N interleaved rounds)")
    ap.add_argument("extra", nargs="*", help="more options for `thermocue reproduce figure9`")
    ns = ap.parse_args(argv)
    if ns.session_rounds:
        return session_speed(ns.session_rounds)
    exe = Path(sys.executable).with_name("thermocue")
    out = Path(ns.out) if ns.out else Path(tempfile.mkdtemp(prefix="bench-study-")) / "figure9"
    print(f"machine: {machine()}")
    from experiments.simulation.sweep import default_workers
    print(f"default workers on this machine: {default_workers()} (the workers line below: the "
          f"run's own, from study.json)")
    cmd = [str(exe), "reproduce", "figure9", "--out", str(out), *ns.extra]
    print("command:", " ".join(cmd))
    import resource
    cpu0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    peak, peak_pss, peak_n = 0, 0, 0
    while proc.poll() is None:
        rss, pss, n = tree_memory_kib(proc.pid)
        if rss > peak:
            peak, peak_n = rss, n
        peak_pss = max(peak_pss, pss)
        time.sleep(0.05)
    wall = time.perf_counter() - start
    cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (cpu1.ru_utime - cpu0.ru_utime) + (cpu1.ru_stime - cpu0.ru_stime)
    err = proc.stderr.read()
    if proc.returncode != 0:
        print(err, file=sys.stderr)
        return proc.returncode
    study = json.loads((out / "study.json").read_text(encoding="utf-8"))
    stages = study.get("reproduction_seconds", {})
    result = {"wall_s": round(wall, 1), "cpu_s": round(cpu, 1),
              "load_at_end": round(os.getloadavg()[0], 2), "scenarios_s": round(stages.get("scenarios_s", 0.0), 1),
              "sessions_s": round(study["sessions_s"], 1),
              "analysis_s": round(study["analysis_s"], 1), "workers": study["workers"],
              "participants": len(study["participants"]),
              "peak_tree_rss_MiB": round(peak / 1024, 1), "processes_at_peak": peak_n,
              "peak_tree_pss_MiB": round(peak_pss / 1024, 1)}
    for key, value in result.items():
        print(f"{key}: {value}")
    # the target names no measure: the summed RSS counts every page the processes share once
    # per process (an upper bound), the summed PSS divides shared pages among their users
    print("target: whole study under 1 GB (1e9 bytes) peak, summed RSS (upper bound):",
          "met" if peak * 1024 < 1e9 else "NOT met")
    print("target: whole study under 1 GB (1e9 bytes) peak, summed PSS:",
          "met" if peak_pss * 1024 < 1e9 else "NOT met")
    if not ns.out:
        shutil.rmtree(out.parent, ignore_errors=True)
    return 0


def session_speed(rounds: int) -> int:
    """Wall ms per trial of one emulated session, fsync on and off, interleaved rounds."""
    import statistics

    from experiments.participant_model.cohort import write_cohort
    from experiments.simulation.figure9.study import run_participant
    print(f"machine: {machine()}")
    tmp = Path(tempfile.mkdtemp(prefix="bench-session-"))
    try:
        paths = {p.stem: p for p in write_cohort(tmp / "participants", seed=0)}
        run_participant(paths["P02"], tmp / "warm", seed=0)          # imports, caches
        times = {True: [], False: []}
        for r in range(rounds):
            for durable in (True, False):
                for pid in ("P01", "P16"):
                    res = run_participant(paths[pid], tmp / f"r{r}-{durable}", seed=0, durable=durable)
                    times[durable].append(1000 * res["seconds"] / res["n_trials"])
        for durable, label in ((True, "fsync on "), (False, "fsync off")):
            v = times[durable]
            print(f"{label}: median {statistics.median(v):6.1f} ms/trial, best {min(v):6.1f} "
                  f"ms/trial ({len(v)} sessions)")
        print(f"load average at the end: {os.getloadavg()[0]:.2f}")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
