"""One emulated session counted in instructions (load-independent), under valgrind.  Not a test.

Run (each ~5 min on the shared 2-core machine):

    PYTHONHASHSEED=0 nice valgrind --tool=callgrind --callgrind-out-file=/dev/null \\
        --collect-atstart=no --toggle-collect=qsort_r \\
        .venv/bin/python benchmarks/bench_session_instructions.py [P01]

callgrind prints ``Collected : N``: the instructions of that one session only. The session (the
seed-0 cohort's participant, P01 by default, fsync off) runs after a warm-up session (P02:
imports, caches) inside a comparison callback of libc's ``qsort`` -- which nothing else here calls --
and ``--toggle-collect=qsort_r`` counts only while it runs. The script prints the
session's trials and its logs' fingerprint (``bench_emulated_session.fingerprint``), so two
commits can be compared for the same logs and their instruction counts.
"""
from __future__ import annotations

import ctypes
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_emulated_session as bench   # noqa: E402  (its path set-up: only this tree's code)


def in_qsort(fn) -> None:
    """Call ``fn`` once from inside libc's sort (sorting two ints with ``qsort``, whose work
    glibc does in the function callgrind names ``qsort_r``: called directly, ``qsort_r`` is
    not the one counted -- checked with a loop of N and 2N additions)."""
    libc = ctypes.CDLL(None)
    compare = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p)
    done = []

    def once(a, b):
        if not done:
            done.append(fn())
        return 0

    items = (ctypes.c_int * 2)(1, 2)
    libc.qsort(items, 2, ctypes.sizeof(ctypes.c_int), compare(once))
    if not done:
        raise RuntimeError("qsort did not call the comparison")


def main(argv=None) -> int:
    pid = (argv if argv is not None else sys.argv[1:] or ["P01"])[0]
    run_participant, write_cohort = bench._cohort()
    run_participant, _ = bench._runner(run_participant)
    tmp = Path(tempfile.mkdtemp(prefix="bench-instr-"))
    paths = {p.stem: p for p in write_cohort(tmp / "participants", seed=0)}
    run_participant(paths["P02"], tmp / "warm", seed=0, durable=False)
    res = {}
    in_qsort(lambda: res.update(run_participant(paths[pid], tmp / "m", seed=0, durable=False)))
    print(f"{pid}: {res['n_trials']} trials, logs fingerprint {bench.fingerprint(tmp / 'm', tmp)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
