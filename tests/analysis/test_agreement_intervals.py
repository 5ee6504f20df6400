"""The per-participant intervals of IT, kappa and Hu against R's ``boot`` package.

``analysis.agreement_participants.studentized_interval`` is the bootstrap-t interval; R's
``boot::boot.ci(type = "stud")`` (Davison-Hinkley, Debian's r-cran-boot) computes the same
interval from its own resamples. With 20,000 resamples each, both are within Monte Carlo error
of the ideal bootstrap-t interval: the ends must agree to a few per cent of the width.
"""
from __future__ import annotations

import shutil
import subprocess

import numpy as np
import pytest
from scipy import stats

from analysis.agreement_participants import agreement_comparison, studentized_interval

pytestmark = pytest.mark.skipif(shutil.which("Rscript") is None,
                                reason="Rscript missing: run ./scripts/setup (r-base-core "
                                       "r-cran-boot)")

# Skewed, bounded values like per-participant information transfer (bits).
A = np.array([0.05, 0.11, 0.12, 0.20, 0.22, 0.31, 0.35, 0.41, 0.52, 0.66, 0.90, 1.35, 1.70])
B = np.array([0.02, 0.08, 0.15, 0.16, 0.27, 0.29, 0.44, 0.95])

R_SCRIPT = r"""
suppressMessages(library(boot))
a <- c(%(a)s); b <- c(%(b)s)
set.seed(1)
one <- boot(a, function(x, i) c(mean(x[i]), var(x[i]) / length(i)), R = 20000)
print(sprintf("%%.6f %%.6f", boot.ci(one, conf = 0.95, type = "stud")$student[4],
              boot.ci(one, conf = 0.95, type = "stud")$student[5]))
d <- c(a, b); s <- c(rep(1, length(a)), rep(2, length(b)))
two <- boot(d, function(x, i) {
  xa <- x[i][s[i] == 1]; xb <- x[i][s[i] == 2]
  c(mean(xa) - mean(xb), var(xa) / length(xa) + var(xb) / length(xb))
}, R = 20000, strata = s)
ci <- boot.ci(two, conf = 0.95, type = "stud")$student
print(sprintf("%%.6f %%.6f", ci[4], ci[5]))
"""


def _r_intervals():
    script = R_SCRIPT % {"a": ", ".join(map(str, A)), "b": ", ".join(map(str, B))}
    done = subprocess.run(["Rscript", "-e", script], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    lines = [ln.split('"')[1] for ln in done.stdout.splitlines() if '"' in ln]
    return [tuple(map(float, ln.split())) for ln in lines]


@pytest.mark.slow
def test_studentized_interval_matches_r_boot():
    (r1_low, r1_high), (r2_low, r2_high) = _r_intervals()
    low, high = studentized_interval(A, resamples=20000)
    width = r1_high - r1_low
    assert abs(low - r1_low) < 0.04 * width and abs(high - r1_high) < 0.04 * width
    low, high = studentized_interval(A, B, resamples=20000)
    width = r2_high - r2_low
    assert abs(low - r2_low) < 0.04 * width and abs(high - r2_high) < 0.04 * width
    # skewed data: the bootstrap-t interval is not the symmetric t interval
    t_half = stats.t.ppf(0.975, len(A) - 1) * A.std(ddof=1) / np.sqrt(len(A))
    assert abs((r1_high - A.mean()) - t_half) > 0.04 * width


def test_difference_row_is_the_union_with_welch_and_tests_by_welch():
    import pandas as pd
    per = pd.DataFrame({"participant": [f"a{i}" for i in range(len(A))]
                        + [f"b{i}" for i in range(len(B))],
                        "group": ["A"] * len(A) + ["B"] * len(B), "mode": "real",
                        "it_bits_corrected": np.r_[A, B], "kappa": np.r_[A, B] / 2,
                        "mean_hu": np.r_[A, B] / 3})
    comp = agreement_comparison(per)
    row = comp[(comp["measure"] == "it_bits_corrected") & (comp["group"] == "A - B")].iloc[0]
    welch = stats.ttest_ind(A, B, equal_var=False)
    ci = welch.confidence_interval(0.95)
    low, high = studentized_interval(A, B)
    assert row["p_value"] == pytest.approx(welch.pvalue, rel=1e-10)
    assert row["df"] == pytest.approx(welch.df, rel=1e-10)
    assert row["ci_low"] == pytest.approx(min(ci.low, low), rel=1e-12)
    assert row["ci_high"] == pytest.approx(max(ci.high, high), rel=1e-12)
    assert "union of Welch" in row["interval"]
