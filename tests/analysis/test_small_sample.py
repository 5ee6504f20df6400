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


def _clustered_lm(seed=11):
    """Two groups of unequal clusters (9 and 4), unequal cluster sizes: design, response,
    cluster labels."""
    rng = np.random.default_rng(seed)
    rows = []
    for i in range(13):
        g = float(i >= 9)
        u = rng.normal(0, 0.7)
        for j in range(int(rng.integers(4, 12))):
            x1, sim = rng.normal(), float(j % 2)
            y = 0.3 + 0.5 * x1 + 0.4 * sim + 0.2 * g + u + rng.normal(0, 1 + g)
            rows.append((f"p{i:02d}", g, sim, x1, y))
    d = pd.DataFrame(rows, columns=["pid", "groupB", "sim", "x1", "y"])
    x = np.column_stack([np.ones(len(d)), d["groupB"], d["sim"], d["x1"], d["groupB"] * d["sim"]])
    return d, x


def _scores_and_information(x, resid, labels):
    """Per cluster: the score X_i' e_i and the information X_i' X_i (least squares)."""
    keys = sorted(set(labels))
    s = np.array([x[labels == k].T @ resid[labels == k] for k in keys])
    info = np.array([x[labels == k].T @ x[labels == k] for k in keys])
    return s, info


@pytest.mark.skipif(shutil.which("Rscript") is None, reason="Rscript missing: ./scripts/setup")
def test_cr2_sandwich_and_bell_mccaffrey_df_equal_r_clubsandwich(tmp_path):
    """The random-slope model's mode contrasts use the CR2 participant sandwich referred to t
    with the Bell-McCaffrey df, both computed in score space. Reference: R clubSandwich
    (``vcovCR(type = "CR2")``, ``linear_contrast(test = "Satterthwaite")``) on a clustered
    linear model, where the score-space and residual-space forms coincide."""
    from analysis.small_sample import bell_mccaffrey_df, leverage_adjustments

    d, x = _clustered_lm()
    d.to_csv(tmp_path / "d.csv", index=False)
    contrasts = np.array([[0, 0, 1, 0, 1],            # group B's sim effect (4 clusters)
                          [0, 0, 1, 0, 0],            # group A's (9 clusters)
                          [0, 0, 1, 0, 0.5],          # averaged over both groups
                          [0, 0, 0, 0, 1],            # the interaction
                          [1, 0, 0, 1, 0]], float)
    rows = ", ".join(",".join(map(repr, c.tolist())) for c in contrasts)
    code = f"""if (!requireNamespace("clubSandwich", quietly = TRUE)) quit(status = 3)
suppressMessages(library(clubSandwich))
d <- read.csv("{tmp_path / 'd.csv'}")
f <- lm(y ~ groupB * sim + x1, data = d)
V <- vcovCR(f, cluster = d$pid, type = "CR2")
L <- matrix(c({rows}), nrow = {len(contrasts)}, byrow = TRUE)
lc <- linear_contrast(f, vcov = V, contrasts = L, test = "Satterthwaite")
cat(sprintf("%.15g", c(as.vector(as.matrix(V)), lc$SE, lc$df)))"""
    done = subprocess.run(["Rscript", "-e", code], capture_output=True, text=True, timeout=120)
    assert done.returncode != 3, "R clubSandwich missing (./scripts/setup installs it)"
    assert done.returncode == 0, done.stderr
    ref = np.array(done.stdout.split(), float)
    r_cov, r_se, r_df = ref[:25].reshape(5, 5), ref[25:30], ref[30:]
    beta = np.linalg.lstsq(x, d["y"].to_numpy(), rcond=None)[0]
    s, info = _scores_and_information(x, d["y"].to_numpy() - x @ beta, d["pid"].to_numpy())
    adjusted = np.einsum("iab,ib->ia", leverage_adjustments(info), s)
    bread = np.linalg.inv(info.sum(axis=0))
    cov = bread @ adjusted.T @ adjusted @ bread
    np.testing.assert_allclose(cov, r_cov, rtol=1e-9, atol=1e-14)
    for c, se, df in zip(contrasts, r_se, r_df):
        assert np.sqrt(c @ cov @ c) == pytest.approx(se, rel=1e-9)
        assert bell_mccaffrey_df(info, c) == pytest.approx(df, rel=1e-6)
    assert r_df[0] < 3 and 6 < r_df[1] < 8      # one group: below m_g - 1 (unequal clusters)


def test_cr2_adjustment_equals_the_residual_space_cr2_of_a_logistic_glm():
    """Score space ``(I - F_i F^-1)^{-1/2} s_i`` against Bell and McCaffrey's residual form
    ``X~_i' (I - H~_ii)^{-1/2} e~_i`` on the whitened logistic GLM (X~ = W^{1/2} X, e~ =
    W^{-1/2} (y - mu)), written out here with the hat matrix; and the Mancl-DeRouen power
    (``(I - H_ii)^{-1}``) likewise."""
    import statsmodels.api as sm

    from analysis.small_sample import leverage_adjustments

    d, x = _clustered_lm(seed=3)
    y = (d["y"] > d["y"].median()).to_numpy(float)
    mu = sm.GLM(y, x, family=sm.families.Binomial()).fit(tol=1e-12).fittedvalues
    w = mu * (1 - mu)
    xt, et = x * np.sqrt(w)[:, None], (y - mu) / np.sqrt(w)
    hat = xt @ np.linalg.inv(xt.T @ xt) @ xt.T
    labels = d["pid"].to_numpy()
    keys = sorted(set(labels))
    s = np.array([x[labels == k].T @ (y - mu)[labels == k] for k in keys])
    info = np.array([xt[labels == k].T @ xt[labels == k] for k in keys])
    for power in (0.5, 1.0):
        mine = np.einsum("iab,ib->ia", leverage_adjustments(info, power), s)
        for k, key in enumerate(keys):
            rows = labels == key
            lam, u = np.linalg.eigh(np.eye(rows.sum()) - hat[np.ix_(rows, rows)])
            ref = xt[rows].T @ (u * lam ** -power) @ u.T @ et[rows]
            np.testing.assert_allclose(mine[k], ref, rtol=1e-8, atol=1e-12)


def test_bell_mccaffrey_df_of_one_group_of_equal_clusters_is_m_g_minus_1():
    # m_g clusters with the same information: the CR2 variance of their mean is an exact
    # chi-square with m_g - 1 df under the working model
    from analysis.small_sample import bell_mccaffrey_df

    info = np.array([np.diag([3.0, 0.0])] * 7 + [np.diag([0.0, 2.0])] * 5)
    assert bell_mccaffrey_df(info, [1.0, 0.0]) == pytest.approx(6.0, rel=1e-12)
    assert bell_mccaffrey_df(info, [0.0, 1.0]) == pytest.approx(4.0, rel=1e-12)
    both = bell_mccaffrey_df(info, [0.5, 0.5])       # Welch-like between 4 and 10
    assert 4.0 < both < 10.0
