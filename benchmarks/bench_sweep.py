"""Simulated 15 + 15 studies on a dask.distributed LocalCluster: time per worker count.

    PYTHONPATH=. .venv/bin/python benchmarks/bench_sweep.py --studies 10000 --workers 1 2

One scenario (the exact 3 mm slab replay, absolute observer, the default lab), ``--studies``
studies in the sweep's fixed tasks of 100, for each worker count; prints wall time, the
cluster's start-up, studies per second and whether the claims table equals the first run's
(it must: the tasks and their seeds do not depend on the workers).
"""
from __future__ import annotations

import argparse
import os
import time


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--studies", type=int, default=10_000)
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ns = ap.parse_args()
    from experiments.simulation.figure9.scenarios import evaluate_scenarios
    from experiments.simulation.studies import build_pool
    from experiments.simulation.sweep import Sweep
    t = time.perf_counter()
    pool = build_pool(hypotheses=("slab",), seed=0)
    print(f"pool: {time.perf_counter() - t:.1f} s; cpus {os.cpu_count()}; load "
          f"{os.getloadavg()[0]:.1f}")
    first = None
    for w in ns.workers:
        t0 = time.perf_counter()
        with Sweep(workers=w) as sweep:
            t1 = time.perf_counter()
            res = evaluate_scenarios(pool, observers=["absolute"], n_studies=ns.studies, seed=0,
                                     sweep=sweep)
            t2 = time.perf_counter()
        same = "" if first is None else f", claims identical to the first run: {res.claims.equals(first)}"
        first = res.claims if first is None else first
        print(f"{w} worker(s): {ns.studies} studies in {t2 - t1:.1f} s ({ns.studies / (t2 - t1):.0f} "
              f"studies/s) after a {t1 - t0:.1f} s cluster start; load {os.getloadavg()[0]:.1f}{same}")


if __name__ == "__main__":
    main()
