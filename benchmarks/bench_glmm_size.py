"""Type-I error of the mixed model's ``group[T.B]`` Wald test (t(m - 2)) over many null datasets.

The recovery benchmark (``bench_recovery.py``) measures it on 200 datasets, where its binomial
SE is 0.015; this measures the same test alone (no profile, no bootstrap: ~0.2 s a dataset) on
more datasets from the same generator, with seeds disjoint from the recovery benchmark's. Run:

    .venv/bin/python benchmarks/bench_glmm_size.py --datasets 1000
"""
from __future__ import annotations

import argparse
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests" / "analysis"))

from analysis.glmm import fit_glmm  # noqa: E402
from analysis.models import FORMULA  # noqa: E402
from generator import generate, null_cells  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--datasets", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=7_000_000)
    ns = ap.parse_args(argv)
    start, rejected, fitted = time.process_time(), 0, 0
    for i in range(ns.datasets):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fit = fit_glmm(generate(null_cells(), seed=ns.seed + i), profile=False)
        if fit.formula != FORMULA:
            continue
        fitted += 1
        p = fit.table.set_index("term").loc["group[T.B]", "p_value"]
        rejected += bool(p < 0.05)
    rate = rejected / fitted
    print(f"group[T.B] (t({fit.df:g}) Wald): {rejected}/{fitted} null datasets rejected at 0.05, "
          f"rate {rate:.3f} (binomial SE {np.sqrt(rate * (1 - rate) / fitted):.3f}); "
          f"{time.process_time() - start:.0f} s CPU, load {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
