"""Size of the real-vs-simulated equivalence test (TOST) at its margin.

Not a test. Datasets come from ``tests/analysis/generator.py`` (independent of the code under
test): random intercepts (SD ``--sigma``), 13 vs 17 participants, 3 repetitions, 3 % of trials
lost. The simulated cells are the real ones shifted by one constant on the log-odds scale,
chosen (by root-finding over 80-node Gauss-Hermite population averages, with the random mode
slope's SD when ``--slope-sd`` > 0) so that the *true* population-averaged real - simulated
difference of mean proportions, both groups weighted equally, is exactly +margin (``--side
upper``) or -margin (``lower``): the boundary of the equivalence null hypothesis, where the
TOST's rejection rate is its size. Each dataset is analysed with ``fit_gee`` and
``analysis.fidelity.mode_contrasts`` (what ``thermocue analyze`` calls). Prints the share of
datasets in which equivalence was declared, with its binomial SE, and the coverage of the
averaged real - simulated intervals (log odds and proportions, 95 %).

    .venv/bin/python benchmarks/bench_tost_size.py --datasets 600 --side upper
"""
from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from scipy import optimize
from scipy.special import expit, logit

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests" / "analysis"))

from analysis import fit_gee  # noqa: E402
from analysis.fidelity import mode_contrasts  # noqa: E402
from generator import generate  # noqa: E402

BASE = (0.30, 0.45, 0.55, 0.70)


def cells_at(shift: float) -> dict:
    """Real cells BASE (both groups, group A 0.05 higher), simulated shifted by ``-shift``."""
    out = {}
    for g, plus in (("A", 0.05), ("B", 0.0)):
        for r, p in enumerate(BASE, start=1):
            q = p + plus
            out[(g, "real", r)] = q
            out[(g, "simulated", r)] = float(expit(logit(q) - shift))
    return out


def marginal_difference(cells: dict, sigma: float, slope_sd: float) -> tuple[float, float]:
    """True population-averaged (difference of mean proportions, log odds ratio of the
    marginal cells), real - simulated, both groups equally weighted."""
    z, w = np.polynomial.hermite_e.hermegauss(80)
    w = w / w.sum()
    sd = {"real": sigma, "simulated": np.hypot(sigma, slope_sd)}
    marg = {k: float(w @ expit(logit(p) + sd[k[1]] * z)) for k, p in cells.items()}
    real = [marg[k] for k in marg if k[1] == "real"]
    sim = [marg[k] for k in marg if k[1] == "simulated"]
    lor = np.mean(logit(np.array(real))) - np.mean(logit(np.array(sim)))
    return float(np.mean(real) - np.mean(sim)), float(lor)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--datasets", type=int, default=600)
    ap.add_argument("--margin-pp", type=float, default=10.0)
    ap.add_argument("--side", choices=("upper", "lower"), default="upper")
    ap.add_argument("--sigma", type=float, default=0.8)
    ap.add_argument("--slope-sd", type=float, default=0.0)
    ap.add_argument("--seed", type=int, default=50_000_000)
    ap.add_argument("--out", type=Path, default=None, help="write the result as JSON here")
    ns = ap.parse_args(argv)
    target = ns.margin_pp / 100 * (1 if ns.side == "upper" else -1)
    shift = optimize.brentq(lambda c: marginal_difference(cells_at(c), ns.sigma,
                                                          ns.slope_sd)[0] - target, -3, 3,
                            xtol=1e-12)
    cells = cells_at(shift)
    true_diff, true_lor = marginal_difference(cells, ns.sigma, ns.slope_sd)
    declared = cover_d = cover_l = done = 0
    start = time.process_time()
    for i in range(ns.datasets):
        trials = generate(cells, sigma=ns.sigma, seed=ns.seed + i, slope_sd=ns.slope_sd)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            gee = fit_gee(trials)
        f = mode_contrasts(gee, trials, margin_pp=ns.margin_pp)
        row = f[(f["role"] == "averaged") & (f["group"] == "both")]
        if row.empty:
            continue
        r = row.iloc[0]
        done += 1
        declared += bool(r["equivalent"])
        cover_d += bool(r["difference_ci_low"] <= true_diff <= r["difference_ci_high"])
        cover_l += bool(r["ci_low"] <= true_lor <= r["ci_high"])
    cpu = time.process_time() - start
    size = declared / done
    out = {"datasets": done, "side": ns.side, "margin_pp": ns.margin_pp, "sigma": ns.sigma,
           "slope_sd": ns.slope_sd, "seed": ns.seed, "true_difference": true_diff,
           "true_log_odds_ratio": true_lor, "logit_shift": shift,
           "equivalence_declared": size, "binomial_se": float(np.sqrt(size * (1 - size) / done)),
           "coverage_difference": cover_d / done, "coverage_log_odds": cover_l / done,
           "cpu_s": round(cpu, 1)}
    print(json.dumps(out, indent=2))
    if ns.out:
        ns.out.write_text(json.dumps(out, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
