"""Degrees of freedom for unequal groups (analysis.small_sample), checked against computations
that share no code with it: R's Welch t-test, and statsmodels' GEE fitted on one group alone."""
from __future__ import annotations

import shutil
import subprocess
import warnings

import numpy as np
import pandas as pd
import pytest

from analysis.models import fit_gee, model_data
from analysis.small_sample import group_covariances, welch_df
from generator import generate, null_cells


@pytest.mark.skipif(shutil.which("Rscript") is None, reason="Rscript missing: ./scripts/setup")
def test_welch_df_equals_r_t_test():
    rng = np.random.default_rng(4)
    x, y = rng.normal(0, 1, 20), rng.normal(0, 3, 8)
    code = (f"x <- c({','.join(map(repr, x.tolist()))}); y <- c({','.join(map(repr, y.tolist()))});"
            f" cat(sprintf('%.12g', t.test(x, y)$parameter))")
    r_df = float(subprocess.run(["Rscript", "-e", code], capture_output=True, text=True,
                                check=True, timeout=120).stdout)
    parts = {"A": (np.array([[x.var(ddof=1) / len(x)]]), len(x)),
             "B": (np.array([[y.var(ddof=1) / len(y)]]), len(y))}
    assert welch_df(parts, [1.0]) == pytest.approx(r_df, rel=1e-9)
    assert 7 < r_df < 10                  # the small, noisy group dominates: not 26


def test_group_parts_sum_to_the_sandwich_and_equal_one_group_fits():
    import statsmodels.api as sm

    trials = generate(null_cells(), n_a=20, n_b=8, seed=5)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = fit_gee(trials)
    data = model_data(trials)
    parts = group_covariances(fit.result, dict(zip(data["participant"], data["group"])))
    assert {g: m for g, (_, m) in parts.items()} == {"A": 20, "B": 8}
    np.testing.assert_allclose(parts["A"][0] + parts["B"][0], fit.cov, atol=1e-12)
    # independence working correlation, cell-means coding: the bread and the meat are
    # block-diagonal by group, so group A's part is exactly a GEE fitted on group A alone
    d = data.assign(cell=data["group"] + "_" + data["mode"] + "_" + data["roughness_id"].astype(str))
    x = pd.get_dummies(d["cell"]).astype(float)
    pooled = sm.GEE(d["correct"].astype(float), x, groups=d["participant"],
                    family=sm.families.Binomial(),
                    cov_struct=sm.cov_struct.Independence()).fit(cov_type="bias_reduced")
    split = group_covariances(pooled, dict(zip(d["participant"], d["group"])))
    for g in "AB":
        mine = d["group"] == g
        cols = [c for c in x.columns if c.startswith(g)]
        alone = sm.GEE(d.loc[mine, "correct"].astype(float), x.loc[mine, cols],
                       groups=d.loc[mine, "participant"], family=sm.families.Binomial(),
                       cov_struct=sm.cov_struct.Independence()).fit(cov_type="bias_reduced")
        idx = [list(x.columns).index(c) for c in cols]
        np.testing.assert_allclose(split[g][0][np.ix_(idx, idx)], alone.cov_params(),
                                   rtol=1e-6, atol=1e-12)
