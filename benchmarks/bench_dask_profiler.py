"""CPU of an emulated session on a dask worker with dask's worker profiler on and off.  Not a test.

Run:  .venv/bin/python benchmarks/bench_dask_profiler.py [--rounds 4] [--sessions 3]

dask's statistical profiler (``distributed.worker.profile.enabled``, on by default) takes the
running task's stack every 10 ms on the worker's event loop, for a dashboard; ``Sweep``'s
LocalCluster (``reproduce figure9``, ``power``) turns it off. This measures what that saves: a
LocalCluster of one worker process, profiler on, then off, ``--rounds`` times alternated; on each,
one warm-up session (imports, caches) and ``--sessions`` emulated sessions of P01 of the seed-0
cohort (virtual clock, fsync off), each timed inside the task by ``time.process_time`` (the
worker process's CPU, its event loop included: where the profiler runs). It prints each session's
CPU, the medians, and whether the sessions' logs are the same either way (their fingerprint, as
``bench_emulated_session.py`` computes it, of one session per setting).
"""
from __future__ import annotations

import argparse
import os
import platform
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))


def session_cpu(path: str, out: str) -> float:
    """One emulated session (a task): its CPU seconds in this worker process."""
    from experiments.simulation.figure9.study import run_participant
    c0 = time.process_time()
    run_participant(Path(path), Path(out), seed=0, durable=False)
    return time.process_time() - c0


def one_cluster(profile: bool, participant: Path, tmp: Path, sessions: int) -> tuple:
    import dask
    from distributed import Client, LocalCluster
    with dask.config.set({"distributed.worker.profile.enabled": profile}):
        with LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                          dashboard_address=":0") as cluster, Client(cluster) as client:
            client.submit(session_cpu, str(participant), str(tmp / "warm"), pure=False).result()
            outs = [tmp / f"{'on' if profile else 'off'}-{time.monotonic_ns()}-{k}"
                    for k in range(sessions)]
            cpu = [client.submit(session_cpu, str(participant), str(o), pure=False).result()
                   for o in outs]
    return cpu, outs[0]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=4)
    ap.add_argument("--sessions", type=int, default=3)
    ns = ap.parse_args(argv)
    from bench_emulated_session import fingerprint
    from experiments.participant_model.cohort import write_cohort
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}; load average at the start: "
          f"{os.getloadavg()[0]:.2f}")
    tmp = Path(tempfile.mkdtemp(prefix="bench-dask-profiler-"))
    try:
        participant = {p.stem: p for p in write_cohort(tmp / "participants", seed=0)}["P01"]
        cpu = {True: [], False: []}
        prints = {}
        for r in range(ns.rounds):
            for profile in (True, False):
                got, folder = one_cluster(profile, participant, tmp, ns.sessions)
                cpu[profile] += got
                prints.setdefault(profile, fingerprint(folder, folder))
                print(f"round {r + 1} profiler {'on ' if profile else 'off'}: "
                      + ", ".join(f"{c:.3f}" for c in got) + " s CPU per session", flush=True)
        on, off = statistics.median(cpu[True]), statistics.median(cpu[False])
        print(f"median CPU per session: profiler on {on:.3f} s, off {off:.3f} s "
              f"({100 * (on - off) / on:+.1f} % of on)")
        print(f"logs the same: {prints[True] == prints[False]}")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
