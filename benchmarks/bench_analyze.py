"""Wall and CPU time of ``thermocue analyze`` on one study folder (the <= 10 s goal at 30
participants).

Not a test. Runs ``python -m experiments analyze DATA_DIR --out TMP --quiet`` as a fresh process
``--runs`` times (imports included, as a user runs it) and prints, per run and as the median,
the wall time and the CPU time of the child (user + system, from ``getrusage``), with the load
average before and after. ``--profile FILE`` also runs it once under cProfile and writes the 25
functions with the largest cumulative time to FILE.

    .venv/bin/python benchmarks/bench_analyze.py DATA_DIR [--runs 3] [--profile prof.txt]

``--cluster``: instead, ``analysis.analyze`` in this process beside a running 2-worker dask
LocalCluster, as inside ``reproduce figure9`` (whose threads rule out the fork): per run the
wall and this process's CPU time, given the cluster's client as ``executor`` (and without it,
``--no-executor``: the figures and profile intervals then run here), with the workers' summed
RSS before and after.

A 30-participant study folder: ``thermocue reproduce figure9 --out DIR`` (or
``./scripts/reproduce``) writes one to ``DIR/data``.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _child_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run_once(data: Path, out: Path, extra=()) -> tuple[float, float]:
    """One ``analyze`` in a fresh interpreter: (wall s, CPU s)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    shutil.rmtree(out, ignore_errors=True)
    cpu0, t0 = _child_cpu(), time.perf_counter()
    done = subprocess.run([sys.executable, *extra, "-m", "experiments", "analyze", str(data),
                           "--out", str(out), "--quiet"], env=env, capture_output=True,
                          text=True, cwd=ROOT)
    wall, cpu = time.perf_counter() - t0, _child_cpu() - cpu0
    if done.returncode != 0:
        raise SystemExit(f"analyze failed ({done.returncode}): {done.stderr.strip()[-500:]}")
    return wall, cpu


def _worker_rss() -> float:
    import psutil                          # a dependency of dask.distributed
    return psutil.Process().memory_info().rss / 2**20        # now, MiB


def on_cluster(data: Path, out: Path, runs: int, executor: bool) -> list[dict]:
    """``analyze`` beside a running 2-worker LocalCluster (see the module's docstring)."""
    import logging

    from distributed import Client, LocalCluster

    from analysis import analyze
    rows = []
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
                      silence_logs=logging.ERROR) as cluster, Client(cluster) as client:
        before = sum(client.run(_worker_rss).values())
        for i in range(runs):
            shutil.rmtree(out, ignore_errors=True)
            load = os.getloadavg()[0]
            t0, c0 = time.perf_counter(), time.process_time()
            analyze(data, out, **({"executor": client} if executor else {}))
            rows.append({"run": i + 1, "wall_s": round(time.perf_counter() - t0, 2),
                         "cpu_s": round(time.process_time() - c0, 2), "executor": executor,
                         "workers_rss_MiB": [round(before), round(sum(
                             client.run(_worker_rss).values()))],
                         "load_average_1min_before": round(load, 2),
                         "load_average_1min_after": round(os.getloadavg()[0], 2)})
            print(json.dumps(rows[-1]), flush=True)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data", type=Path, help="study folder (DATA/<participant>/<session>/)")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--profile", type=Path, help="also profile one run; top 25 to this file")
    ap.add_argument("--cluster", action="store_true",
                    help="analyze here beside a 2-worker LocalCluster (reproduce's setting)")
    ap.add_argument("--no-executor", action="store_true",
                    help="with --cluster: do not give analyze the cluster's client")
    ns = ap.parse_args(argv)
    ns.data = ns.data.resolve()          # analyze runs with the repository as its folder
    if not ns.data.is_dir():
        print(f"{ns.data}: not a folder", file=sys.stderr)
        return 2
    # participant folders: those holding a session folder with a session.json
    participants = len({p.parent.parent for p in ns.data.glob("*/*/session.json")})
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        if ns.cluster:
            rows = on_cluster(ns.data, Path(tmp) / "out", ns.runs, not ns.no_executor)
        for i in range(0 if ns.cluster else ns.runs):
            before = os.getloadavg()
            wall, cpu = run_once(ns.data, Path(tmp) / "out")
            rows.append({"run": i + 1, "wall_s": round(wall, 2), "cpu_s": round(cpu, 2),
                         "load_average_1min_before": round(before[0], 2),
                         "load_average_1min_after": round(os.getloadavg()[0], 2)})
            print(json.dumps(rows[-1]), flush=True)
        if ns.profile:
            stats = Path(tmp) / "analyze.prof"
            run_once(ns.data, Path(tmp) / "out", extra=("-m", "cProfile", "-o", str(stats)))
            import io
            import pstats
            buf = io.StringIO()
            pstats.Stats(str(stats), stream=buf).sort_stats("cumulative").print_stats(25)
            ns.profile.write_text(buf.getvalue())
    summary = {"participants": participants, "runs": ns.runs,
               "median_wall_s": statistics.median(r["wall_s"] for r in rows),
               "median_cpu_s": statistics.median(r["cpu_s"] for r in rows),
               "machine": f"{platform.machine()}, {os.cpu_count()} cores, "
                          f"Python {platform.python_version()}"}
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
