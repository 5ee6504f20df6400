"""CPU time of emulated sessions (virtual clock), and their logs' fingerprint.  Not a test.

Run:  .venv/bin/python benchmarks/bench_emulated_session.py [--rounds 3] [--profile]

Runs P01 and P16 of the seed-0 simulated cohort (the default protocol, 24 trials each) on
``emulator://?clock=virtual`` with the simulated responder, ``--rounds`` times after one warm-up
session, and prints per session the CPU time of this process (user + system,
``time.process_time``: on a shared machine fairer than wall time) and the wall time, per trial,
median and best. fsync is off for every session (``run_participant(..., durable=False)``): the
figure is the cost of the emulated session, not of the disk (``--durable``: on for the measured
sessions, as in a real session). It also prints a SHA-256 over every
file the sessions wrote (trials, traces, events; timestamps and durations stripped), so two
commits can be compared for identical logs. ``--profile`` prints the top of a cProfile instead.
"""
from __future__ import annotations

import argparse
import hashlib
import os
import platform
import re
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
# only ROOT's code: an editable install's finder would supply the modules an older tree (a
# `git archive` of the "before" commit) lacks from the working copy, mixing two commits
sys.meta_path[:] = [f for f in sys.meta_path if "Editable" not in getattr(f, "__name__", type(f).__name__)]
sys.path_hooks[:] = [h for h in sys.path_hooks if "Editable" not in getattr(h, "__qualname__", "")]
sys.path_importer_cache.clear()
PARTICIPANTS = ("P01", "P16")
_VOLATILE = re.compile(rb'[0-9]{4}-[0-9]{2}-[0-9]{2}[T_ ][0-9:.h]+( \+0000)?Z?|"(seconds|wall_s|'
                       rb'elapsed_s|t_wall|duration_s_wall)": [0-9.e+-]+')


def _cohort():
    try:
        from experiments.participant_model.cohort import write_cohort
        from experiments.simulation.figure9.study import run_participant
    except ImportError:   # main 06e98b2 and before (the "before" of benchmarks/README's round 2)
        from experiments.cohort import run_participant, write_cohort
    return run_participant, write_cohort


def _runner(run_participant):
    """run_participant with ``durable`` when the commit has it (a89728d and before fsync always:
    their figures include the fsyncs' CPU, and their wall times the disk's)."""
    import inspect
    if "durable" in inspect.signature(run_participant).parameters:
        return run_participant, True
    return (lambda path, out, seed, durable: run_participant(path, out, seed=seed)), False


def fingerprint(folder: Path, tmp: Path) -> str:
    """SHA-256 over the sessions' files (relative names and contents; the temporary folder's
    name, the code's folder, timestamps, durations and the BIDS events' wall-clock onset and
    duration columns stripped)."""
    h = hashlib.sha256()
    for path in sorted(p for p in folder.rglob("*") if p.is_file()):
        h.update(path.relative_to(folder).as_posix().encode())
        data = path.read_bytes().replace(str(tmp).encode(), b"TMP").replace(str(ROOT).encode(), b"ROOT")
        if path.name.endswith("_events.tsv"):   # BIDS events: onset and duration are wall time
            data = b"\n".join(b"\t".join(row.split(b"\t")[2:]) for row in data.split(b"\n"))
        h.update(_VOLATILE.sub(b"X", data))
    return h.hexdigest()


def traces_digest(session_dir: Path) -> str:
    """SHA-256 over a session's telemetry traces (``traces/*.csv`` by name): the values of every
    row, numbers parsed (so a change of the number format alone does not change it)."""
    h = hashlib.sha256()
    for path in sorted((Path(session_dir) / "traces").glob("*.csv")):
        rows = path.read_text(encoding="utf-8").splitlines()[1:]          # not the header
        h.update(path.name.encode() + b"\0")
        for row in rows:
            h.update(repr([_value(c) for c in row.split(",")]).encode())
    return h.hexdigest()


def _value(cell: str):
    try:
        return float(cell)
    except ValueError:
        return cell


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--profile", action="store_true")
    ap.add_argument("--keep", metavar="DIR", help="copy round 0's sessions to DIR (to diff them)")
    ap.add_argument("--durable", action="store_true",
                    help="fsync as a real session does (the measured sessions only)")
    ns = ap.parse_args(argv)
    run_participant, write_cohort = _cohort()
    run_participant, has_switch = _runner(run_participant)
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}; code: {ROOT}")
    try:
        from experiments.emulators.thermocue import compiled_tick
        ticks = "compiled" if compiled_tick.enabled else (
            "Python (THERMOCUE_PYTHON_TICK=1)" if compiled_tick.AVAILABLE else "Python (not built)")
    except ImportError:            # before stop 19, and since the compiled tick was retired
        ticks = "Python"
    print(f"device ticks: {ticks}")
    print(f"load average at the start: {os.getloadavg()[0]:.2f}")
    tmp = Path(tempfile.mkdtemp(prefix="bench-emulated-"))
    try:
        paths = {p.stem: p for p in write_cohort(tmp / "participants", seed=0)}
        run_participant(paths["P02"], tmp / "warm", seed=0, durable=False)   # imports, caches
        if ns.profile:
            import cProfile
            import pstats
            prof = cProfile.Profile()
            prof.enable()
            run_participant(paths["P01"], tmp / "prof", seed=0, durable=False)
            prof.disable()
            pstats.Stats(prof).sort_stats("tottime").print_stats(25)
            return 0
        cpu, wall = [], []
        for r in range(ns.rounds):
            for pid in PARTICIPANTS:
                c0, w0 = time.process_time(), time.perf_counter()
                res = run_participant(paths[pid], tmp / "runs" / f"r{r}", seed=0, durable=ns.durable)
                n = res["n_trials"]
                cpu.append(1000 * (time.process_time() - c0) / n)
                wall.append(1000 * (time.perf_counter() - w0) / n)
        print(f"{len(cpu)} sessions ({', '.join(PARTICIPANTS)} x {ns.rounds}), {n} trials each, "
              f"fsync {'on' if ns.durable or not has_switch else 'off'}"
              f"{'' if has_switch else ' (this commit has no switch)'}")
        print(f"CPU : median {statistics.median(cpu):6.2f} ms/trial, best {min(cpu):6.2f}")
        print(f"wall: median {statistics.median(wall):6.2f} ms/trial, best {min(wall):6.2f}")
        print(f"logs fingerprint (round 0): {fingerprint(tmp / 'runs' / 'r0', tmp)}")
        if ns.keep:
            shutil.copytree(tmp / "runs" / "r0", ns.keep, dirs_exist_ok=True)
        print(f"load average at the end: {os.getloadavg()[0]:.2f}")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
