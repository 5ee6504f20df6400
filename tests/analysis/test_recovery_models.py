"""Recovery of the models' intervals and the tests' size: a small honest version of
benchmarks/bench_recovery.py (which runs 200 datasets per scenario; figures in docs/analysis.md).

30 datasets from tests/analysis/generator.py (independent of the code under test: random
intercepts SD 0.8, groups of 13 and 17, 3 % of trials lost, neighbour-biased confusions), no group
effect. Bands: coverage within 3.5 binomial SEs of 0.95 for the pooled intervals of each
family (intervals within a dataset are correlated, so this is lenient, not strict); the primary
test rejects at most 5 of 30 times (P(>= 6) = 0.016 at a true size of 0.05). The participant SD's
profile interval is measured in the benchmark only (it costs ~2 s a dataset); here its Wald
interval on log SD is used instead so the test stays well under a minute of CPU.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))

DATASETS = 30


@pytest.mark.slow
def test_intervals_cover_and_the_primary_test_holds_its_size():
    from bench_recovery import run
    coverage, rejections, info = run(DATASETS, "null", 0.8, 20261125, n_boot=200,
                                     progress=False, profile=False)
    assert info["fallbacks"] == {"gee": 0, "glmm": 0} and info["glmm_failed"] == 0
    cov = coverage.set_index("interval")
    for family in ("glmm fixed effects (Wald)", "gee contrast per-sample: log odds ratio",
                   "gee contrast per-sample: proportion difference",
                   "glmm contrast per-sample: log odds ratio", "cell: participant bootstrap",
                   "chance t interval (cell)"):
        row = cov.loc[family]
        se = np.sqrt(0.95 * 0.05 / row["n_intervals"])
        assert abs(row["coverage"] - 0.95) <= 3.5 * se, (family, row.to_dict())
    rej = rejections.set_index("test")["rejections"]
    assert rej["primary (GEE averaged A-B, real)"] <= 5, rejections
    # Holm keeps the familywise rate of the 8 per-sample tests near 0.05; unadjusted it is
    # about 0.3 (the reviewer's 0.30-0.34), so Holm must reject no more often than unadjusted
    assert rej["any per-sample, Holm"] <= min(6, rej["any per-sample, unadjusted"])


SLOPE_DATASETS = 8


@pytest.mark.slow
def test_random_slope_models_profile_intervals_cover():
    # The random-slope model's SDs and correlation (profile likelihood, F(1, m - 2) cut-off)
    # over 8 datasets with a true random mode slope (SD 0.8, independent of the intercept: true
    # correlation 0); ~1.5 s CPU a dataset. The benchmark's slope scenario measures 200. Band:
    # at least 20 of the 24 intervals cover (P(<= 19) = 0.006 at a true coverage of 0.95), and
    # the intervals say something: finite SD upper ends, and the correlation's interval not the
    # whole [-1, 1] in most datasets (an interval that always covers would pass otherwise).
    import warnings

    from analysis.glmm_slope import fit_glmm_slope
    from generator import generate, null_cells
    covered, whole_corr = 0, 0
    for seed in range(SLOPE_DATASETS):
        trials = generate(null_cells(), sigma=0.8, slope_sd=0.8, seed=31_000 + seed)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fit = fit_glmm_slope(trials)
        t = fit.table.set_index("term")
        for term, truth in (("sd_intercept", 0.8), ("sd_mode_slope", 0.8),
                            ("corr_intercept_slope", 0.0)):
            low, high = t.loc[term, ["ci_low", "ci_high"]].to_numpy(float)
            assert low <= t.loc[term, "log_odds"] <= high, (term, low, high)
            covered += bool(low <= truth <= high)
        assert np.isfinite(t.loc["sd_intercept", "ci_high"])
        assert np.isfinite(t.loc["sd_mode_slope", "ci_high"])
        whole_corr += bool(t.loc["corr_intercept_slope", "ci_low"] == -1
                           and t.loc["corr_intercept_slope", "ci_high"] == 1)
    assert covered >= 20, covered
    assert whole_corr <= SLOPE_DATASETS // 2, whole_corr
