"""Which SE for the random-slope model's mode contrasts: model-based or the participant sandwich.

Not a test. The diagnosis behind ``analysis.models.contrast_se``: on datasets from
``tests/analysis/generator.py`` (null cells, random intercepts SD 0.8, 13 vs 17 participants;
``--slope-sd`` the true random mode slope, 0.8 or 0), fits the random-slope model as
``thermocue analyze`` does and, for the real - simulated rows (group A, B, both) and the
interaction, records the coverage of the 95 % Wald interval with two SEs: as reported (the CR2
participant sandwich, ``fit.cov_robust``, with its Bell-McCaffrey df) and the model-based one
(``fit.cov``, t(m - 2)), and, for comparison, each with t(m - 2) on every row. (Until
2026-11-28 the report took the larger of the model-based SE and the Mancl-DeRouen sandwich;
the tables in benchmarks/README.md before that date measured that rule.)

    .venv/bin/python benchmarks/bench_contrast_se.py --datasets 200 --slope-sd 0.8
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests" / "analysis"))
sys.path.insert(0, str(ROOT / "benchmarks"))

from analysis.fidelity import mode_contrasts  # noqa: E402
from analysis.glmm import fit_glmm  # noqa: E402
from analysis.glmm_slope import fit_glmm_slope  # noqa: E402
from analysis.inference import interaction_test  # noqa: E402
from analysis.models import FORMULA, reference_quantile  # noqa: E402
from bench_recovery import truths  # noqa: E402
from generator import generate, null_cells  # noqa: E402


def rows_of(fit, trials, truth):
    """(group, estimate, se, difference, difference_se, truth_lor, truth_diff, df) rows."""
    out = []
    f = mode_contrasts(fit, trials, margin_pp=10)
    for r in f[f["role"] == "averaged"].itertuples():
        lor, diff = truth[("glmm", "mode", r.group)]
        out.append((r.group, r.estimate, r.se, r.difference, r.difference_se, lor, diff, r.df))
    it = interaction_test(fit, trials)
    q = reference_quantile(0.95, it["df"])          # the interaction's own df (Bell-McCaffrey)
    lor, diff = truth[("glmm", "interaction")]
    out.append(("interaction", it["log_odds"], it["se"], it["difference_of_differences"],
                (it["dd_high"] - it["dd_low"]) / (2 * q), lor, diff, it["df"]))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--datasets", type=int, default=200)
    ap.add_argument("--slope-sd", type=float, default=0.8)
    ap.add_argument("--seed", type=int, default=20261124)
    ns = ap.parse_args(argv)
    cells = null_cells()
    truth = truths(cells, 0.8, ns.slope_sd)
    records = []
    start = time.process_time()
    for i in range(ns.datasets):
        trials = generate(cells, sigma=0.8, seed=ns.seed + i, slope_sd=ns.slope_sd)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            glmm = fit_glmm(trials, profile=False)
            fit = fit_glmm_slope(trials, glmm.formula, intercept_fit=glmm, profile=False)
        if fit.formula != FORMULA or fit.cov_robust is None:
            continue
        variants = {"reported (CR2, Bell-McCaffrey df)": fit,
                    "model-based": dataclasses.replace(fit, cov_robust=None, cluster_info=None,
                                                       cov_by_group=None)}
        for name, f in variants.items():
            for row in rows_of(f, trials, truth):
                records.append((i, name, *row))
    cpu = time.process_time() - start
    d = pd.DataFrame(records, columns=["dataset", "se_from", "row", "estimate", "se",
                                       "difference", "difference_se", "truth_lor",
                                       "truth_difference", "df"])
    m = 30
    out = []
    for (se_from, row), s in d.groupby(["se_from", "row"], sort=False):
        for ref, df in (("as reported", s["df"].to_numpy(float)),
                        ("t(m - 2) everywhere", np.full(len(s), m - 2.0))):
            q = stats.t.ppf(0.975, df)
            lor = np.mean(np.abs(s["estimate"] - s["truth_lor"]) <= q * s["se"])
            dif = np.mean(np.abs(s["difference"] - s["truth_difference"])
                          <= q * s["difference_se"])
            out.append({"se_from": se_from, "row": row, "reference": ref, "n": len(s),
                        "coverage_log_odds": round(lor, 3), "coverage_proportions": round(dif, 3),
                        "binomial_se": round(float(np.sqrt(0.95 * 0.05 / len(s))), 3)})
    pd.set_option("display.width", 200)
    print(f"slope SD {ns.slope_sd}, {d['dataset'].nunique()} of {ns.datasets} datasets with the "
          f"full slope model, {cpu:.0f} s CPU")
    print(pd.DataFrame(out).to_string(index=False))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
