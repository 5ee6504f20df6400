"""Coverage of the per-participant IT, kappa and Hu intervals (``agreement_comparison``).

Not a test. Datasets from ``tests/analysis/generator.py`` with no group effect
(``null_cells``: both groups draw participants from one distribution, so the true A - B
difference of every per-participant measure is exactly 0), random intercepts SD 0.8, 3
repetitions, 3 % of trials lost. The true group mean of each measure (per mode) is that of
``--truth-size`` simulated participants. Prints, per measure, the coverage of the group-mean
t intervals and of the A - B Welch intervals, with binomial SEs.

    nice -n 10 .venv/bin/python benchmarks/bench_agreement_coverage.py --n-a 20 --n-b 8 --datasets 400
"""
from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests" / "analysis"))

from analysis.agreement_participants import (MEASURES, agreement_comparison,  # noqa: E402
                                             participant_agreement)
from generator import generate, null_cells  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n-a", type=int, default=13)
    ap.add_argument("--n-b", type=int, default=17)
    ap.add_argument("--datasets", type=int, default=400)
    ap.add_argument("--truth-size", type=int, default=6000)
    ap.add_argument("--seed", type=int, default=36100000)
    ns = ap.parse_args()
    start, cpu = time.time(), time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        big = participant_agreement(generate(null_cells(), n_a=ns.truth_size, n_b=0,
                                             seed=ns.seed - 1))
        truth = big.groupby("mode")[list(MEASURES)].mean()
        hits: dict = {}
        for i in range(ns.datasets):
            per = participant_agreement(generate(null_cells(), n_a=ns.n_a, n_b=ns.n_b,
                                                 seed=ns.seed + i))
            comp = agreement_comparison(per)
            for r in comp.itertuples():
                target = 0.0 if r.group == "A - B" else truth.loc[r.mode, r.measure]
                key = f"{r.measure} {'A - B' if r.group == 'A - B' else 'group mean'}"
                hits.setdefault(key, []).append(bool(r.ci_low <= target <= r.ci_high))
    out = {"n_a": ns.n_a, "n_b": ns.n_b, "datasets": ns.datasets, "seed": ns.seed,
           "cpu_s": round(time.process_time() - cpu, 1), "wall_s": round(time.time() - start, 1)}
    for key, h in sorted(hits.items()):
        p = float(np.mean(h))
        out[key] = {"coverage": round(p, 4), "se": round(float(np.sqrt(p * (1 - p) / len(h))), 4),
                    "intervals": len(h)}
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
