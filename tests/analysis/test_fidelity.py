"""Real vs simulated: mode contrasts, the equivalence test and the protocol's margin.

References nobody here wrote: statsmodels' GEE refitted in a different parameterisation (one
mean per cell; the bias-reduced sandwich is invariant to it), R's lme4::glmer (nAGQ = 11) for the
participant-scale contrast, statsmodels' ``ttost_paired`` and mpmath's t distribution for the
TOST.
"""
from __future__ import annotations

import json
import shutil
import subprocess
import warnings

import mpmath
import numpy as np
import pandas as pd
import pytest
from scipy import special

from analysis import LogError, analyze, fit_gee
from analysis.fidelity import (DEFAULT_EQUIVALENCE_MARGIN_PP, equivalence_margin,
                               mode_contrasts, tost)
from analysis.glmm import fit_glmm
from analysis.wording import df_text

from generator import generate, null_cells


@pytest.fixture(scope="module")
def trials():
    return generate(null_cells(), n_a=13, n_b=17, sigma=0.8, seed=11)


def _cell_means_gee(trials):
    """statsmodels GEE with one coefficient per cell (no intercept), bias-reduced covariance."""
    import statsmodels.api as sm

    d = trials.copy()
    d["cell"] = d["group"] + "_" + d["mode"] + "_" + d["roughness_id"].astype(str)
    x = pd.get_dummies(d["cell"]).astype(float)
    res = sm.GEE(d["correct"].astype(float), x, groups=d["participant"],
                 family=sm.families.Binomial(),
                 cov_struct=sm.cov_struct.Exchangeable()).fit(cov_type="bias_reduced")
    return list(x.columns), np.asarray(res.params), np.asarray(res.cov_params())


def _weights(names, groups, sign_real=1.0):
    """Contrast vector over the cell-mean coefficients: mean real - mean simulated."""
    w = np.zeros(len(names))
    for i, n in enumerate(names):
        g, m, _ = n.split("_")
        if g in groups:
            w[i] = (1 if m == "real" else -1) / (4 * len(groups))
    return w


def test_gee_mode_contrasts_equal_statsmodels_in_cell_means_coding(trials):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        gee = fit_gee(trials)
        names, beta, cov = _cell_means_gee(trials)
    table = mode_contrasts(gee, trials, margin_pp=10)
    m = trials["participant"].nunique()
    from scipy import stats
    for group, groups in (("A", ["A"]), ("B", ["B"]), ("both", ["A", "B"])):
        row = table[(table["role"] == "averaged") & (table["group"] == group)].iloc[0]
        w = _weights(names, groups)
        est, se = w @ beta, np.sqrt(w @ cov @ w)
        assert row["estimate"] == pytest.approx(est, abs=1e-6)
        assert row["se"] == pytest.approx(se, rel=1e-5)
        # a group's mode contrast rests on that group's participants: t(m_g - 1); both: the
        # Welch-Satterthwaite df of its two parts. In cell-means coding the sandwich is
        # block-diagonal by group, so each group's part is its block of statsmodels' own cov.
        sizes = trials.groupby("group")["participant"].nunique()
        if group == "both":
            part = {g: (lambda v: v @ cov @ v)(np.where([n.startswith(g) for n in names], w, 0))
                    for g in "AB"}
            df = (part["A"] + part["B"]) ** 2 / sum(part[g] ** 2 / (sizes[g] - 1) for g in "AB")
            assert 16 < df < 28 and row["test"] == f"Wald t({df:.1f})"
        else:
            df = sizes[group] - 1
            assert df == {"A": 12, "B": 16}[group] and row["test"] == f"Wald t({df})"
        assert row["p_value"] == pytest.approx(2 * stats.t.sf(abs(est / se), df), rel=1e-4)
        assert row["df"] == pytest.approx(df, rel=1e-6)
        q = stats.t.ppf(0.975, df)
        assert (row["ci_low"], row["ci_high"]) == pytest.approx((est - q * se, est + q * se),
                                                                rel=1e-5)
        tq = stats.t.ppf(0.95, df)
        assert row["tost_ci_low"] == pytest.approx(row["difference"] - tq * row["difference_se"],
                                                   rel=1e-9)
        # difference of mean proportions and its delta-method SE, from the cell means
        q = special.expit(beta)
        pw = np.where(w > 0, 1, np.where(w < 0, -1, 0)) / (4 * len(groups))
        grad = pw * q * (1 - q)
        assert row["difference"] == pytest.approx(pw @ q, abs=1e-6)
        assert row["difference_se"] == pytest.approx(np.sqrt(grad @ cov @ grad), rel=1e-5)
    # per-sample rows: Holm over the 8, against statsmodels' multipletests
    from statsmodels.stats.multitest import multipletests
    per = table[table["role"] == "per-sample"]
    assert len(per) == 8
    assert per.set_index("group")["df"].to_dict() == {"A": 12, "B": 16}
    np.testing.assert_allclose(per["p_holm"], multipletests(per["p_value"], method="holm")[1])


R_CONTRAST = r"""
suppressMessages(library(lme4))
args <- commandArgs(trailingOnly = TRUE)
d <- read.csv(args[1])
d$cell <- factor(paste(d$group, d$mode, d$roughness_id, sep = "_"))
f <- glmer(correct ~ 0 + cell + (1 | participant), data = d, family = binomial, nAGQ = 11,
           control = glmerControl(optimizer = "bobyqa", optCtrl = list(maxfun = 1e5)))
nm <- levels(d$cell)
w <- ifelse(grepl("_real_", nm), 1, -1) / 8
b <- fixef(f); V <- as.matrix(vcov(f))
cat(sprintf("%.12g %.12g", sum(w * b), sqrt(drop(t(w) %*% V %*% w))))
"""


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("Rscript") is None, reason="Rscript missing: ./scripts/setup")
def test_glmm_mode_contrast_equals_lme4(trials, tmp_path):
    csv = tmp_path / "t.csv"
    trials[["participant", "group", "mode", "roughness_id", "correct"]].to_csv(csv, index=False)
    script = tmp_path / "c.R"
    script.write_text(R_CONTRAST)
    out = subprocess.run(["Rscript", str(script), str(csv)], capture_output=True, text=True,
                         timeout=240, check=True).stdout.split()
    ref_est, ref_se = float(out[0]), float(out[1])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        glmm = fit_glmm(trials, profile=False)
    row = mode_contrasts(glmm, trials, margin_pp=10)
    row = row[(row["role"] == "averaged") & (row["group"] == "both")].iloc[0]
    assert row["estimate"] == pytest.approx(ref_est, abs=2e-4)
    assert row["se"] == pytest.approx(ref_se, rel=2e-3)
    assert row["scale"] == "typical participant (u = 0)"


def _t_sf_mpmath(x, df):
    """P(T > x) for Student's t, by mpmath's regularised incomplete beta."""
    x, df = mpmath.mpf(x), mpmath.mpf(df)
    tail = mpmath.betainc(df / 2, mpmath.mpf(1) / 2, 0, df / (df + x * x), regularized=True) / 2
    return float(tail if x >= 0 else 1 - tail)


@pytest.mark.parametrize("est,se,margin,df", [(0.02, 0.03, 0.10, 28), (-0.07, 0.02, 0.10, 28),
                                               (0.09, 0.05, 0.10, 10), (0.0, 0.2, 0.1, 5)])
def test_tost_equals_the_two_one_sided_t_tests_by_mpmath(est, se, margin, df):
    r = tost(est, se, margin, df)
    assert r["p_lower"] == pytest.approx(_t_sf_mpmath((est + margin) / se, df), rel=1e-9)
    assert r["p_upper"] == pytest.approx(_t_sf_mpmath((margin - est) / se, df), rel=1e-9)
    assert r["p_value"] == max(r["p_lower"], r["p_upper"])
    # duality: equivalence at alpha iff the 1 - 2 alpha interval lies inside the margin
    assert r["equivalent"] == (-margin < r["ci_low"] and r["ci_high"] < margin)


def test_tost_equals_statsmodels_ttost_paired():
    from statsmodels.stats.weightstats import ttost_paired

    rng = np.random.default_rng(4)
    a, b = rng.normal(0.6, 0.1, 30), rng.normal(0.58, 0.1, 30)
    d = a - b
    ref_p = ttost_paired(a, b, -0.05, 0.05)[0]
    mine = tost(d.mean(), d.std(ddof=1) / np.sqrt(len(d)), 0.05, len(d) - 1)
    assert mine["p_value"] == pytest.approx(ref_p, rel=1e-10)


def test_tost_without_a_standard_error_shows_nothing():
    assert tost(0.0, 0.0, 0.1, 28)["equivalent"] is False


def test_default_margin_equals_the_protocols():
    from experiments.protocol import DEFAULT_EQUIVALENCE_MARGIN_PP as protocol_default

    assert DEFAULT_EQUIVALENCE_MARGIN_PP == protocol_default


def _set_margin(data, value):
    for path in sorted(data.glob("*/*/session.json")):
        meta = json.loads(path.read_text())
        meta.setdefault("protocol", {})["analysis"] = {"equivalence_margin_pp": value}
        path.write_text(json.dumps(meta))


def test_margin_from_the_protocol_and_its_validation(study, tmp_path):
    data, _ = study(n_per_group=3)
    folders = sorted(p.parent for p in data.glob("*/*/session.json"))
    assert equivalence_margin(folders) == (10.0, "default (the protocol sets none)")
    _set_margin(data, 7.5)
    assert equivalence_margin(folders)[0] == 7.5
    assert equivalence_margin(folders, 12)[0] == 12          # the command line wins
    _set_margin(data, 75)
    with pytest.raises(LogError, match=r"session.json: protocol.analysis.equivalence_margin_pp"):
        equivalence_margin(folders)
    _set_margin(data, 5)
    last = folders[-1] / "session.json"
    meta = json.loads(last.read_text())
    meta["protocol"]["analysis"]["equivalence_margin_pp"] = 6
    last.write_text(json.dumps(meta))
    with pytest.raises(LogError, match="expected the same margin"):
        equivalence_margin(folders)


def test_cli_rejects_a_bad_margin_in_one_line(study, tmp_path):
    import os
    import sys

    data, _ = study(n_per_group=3)
    _set_margin(data, "ten")
    done = subprocess.run([sys.executable, "-m", "experiments", "analyze", str(data), "--out",
                           str(tmp_path / "out"), "--bootstrap", "0", "--no-mixed"],
                          capture_output=True, text=True, timeout=300,
                          env={**os.environ, "PYTHONPATH": os.getcwd()})
    assert done.returncode == 2
    assert "Traceback" not in done.stderr
    assert "protocol.analysis.equivalence_margin_pp" in done.stderr
    assert not (tmp_path / "out" / "report.md").exists()


# ----------------------------------------------------------- IT, kappa, Hu per participant
def test_per_participant_agreement_against_independent_formulas(trials):
    from scipy import stats
    from scipy.stats import entropy
    from statsmodels.stats.inter_rater import cohens_kappa
    from statsmodels.stats.weightstats import ttest_ind

    from analysis.agreement_participants import agreement_comparison, participant_agreement

    per = participant_agreement(trials)
    one = per.iloc[3]
    sel = trials[(trials["participant"] == one["participant"]) & (trials["mode"] == one["mode"])]
    table = pd.crosstab(sel["roughness_id"], sel["response_id"]).reindex(
        index=[1, 2, 3, 4], columns=[1, 2, 3, 4], fill_value=0).to_numpy(float)
    n = table.sum()
    joint = table[table > 0] / n
    it = entropy(table.sum(1) / n, base=2) + entropy(table.sum(0) / n, base=2) \
        - entropy(joint, base=2)
    r, c = (table.sum(1) > 0).sum(), (table.sum(0) > 0).sum()
    assert one["it_bits_corrected"] == pytest.approx(
        max(0.0, it - (r - 1) * (c - 1) / (2 * n * np.log(2))), abs=1e-12)
    assert one["kappa"] == pytest.approx(cohens_kappa(table, return_results=False), abs=1e-12)
    comp = agreement_comparison(per)
    row = comp[(comp["measure"] == "kappa") & (comp["mode"] == "real")
               & (comp["group"] == "A - B")].iloc[0]
    real = per[per["mode"] == "real"]
    a = real.loc[real["group"] == "A", "kappa"].dropna()
    b = real.loc[real["group"] == "B", "kappa"].dropna()
    t, p, df = ttest_ind(a, b, usevar="unequal")
    assert (row["statistic"], row["p_value"], row["df"]) == pytest.approx((t, p, df), rel=1e-9)
    assert row["test"] == f"Welch t({df:.1f})"
    # the interval contains Welch's (the percentile bootstrap covered 0.89-0.92 with unequal
    # groups; the studentized one is checked against R's boot in test_agreement_intervals.py)
    half = stats.t.ppf(0.975, df) * np.sqrt(a.var() / len(a) + b.var() / len(b))
    assert row["ci_low"] <= a.mean() - b.mean() - half + 1e-12
    assert row["ci_high"] >= a.mean() - b.mean() + half - 1e-12
    assert row["interval"].startswith(f"union of Welch t({df:.1f}) and the studentized")
    means = comp[(comp["measure"] == "kappa") & (comp["mode"] == "real")].set_index("group")
    assert means.loc["A", "estimate"] == pytest.approx(a.mean())


def test_markdown_cells_escape_the_bar_of_a_random_effects_formula():
    from analysis.report_markdown import _md_table
    line = _md_table(pd.DataFrame({"note": ["(1 + mode | participant)"]})).splitlines()[-1]
    assert line == "| (1 + mode \\| participant) |"


# ----------------------------------------------------------- which mixed model for mode
def _fit(kind, formula, lrt_p=None, notes=()):
    from analysis.models import ModelFit
    rows = [] if lrt_p is None else [{"term": "lrt_slope", "p_value": lrt_p}]
    return ModelFit(kind=kind, formula=formula, requested="correct ~ group * mode * C(roughness_id)",
                    table=pd.DataFrame(rows, columns=["term", "p_value"]), notes=list(notes))


def test_mixed_choice_prefers_the_slope_model_and_says_why():
    from analysis.mixed_choice import choose_mixed
    full = "correct ~ group * mode * C(roughness_id)"
    glmm = _fit("glmm", full)
    c = choose_mixed(glmm, _fit("glmm-slope", full, lrt_p=0.01))
    assert c.contrasts.kind == "glmm-slope" and c.spread.kind == "glmm-slope"
    assert "rejects (p = 0.010)" in c.reason
    c = choose_mixed(glmm, _fit("glmm-slope", full, lrt_p=0.4))
    assert c.contrasts.kind == "glmm-slope" and c.spread is glmm
    # the slope model's fallback is never silent: the intercept model, with the reason
    simpler = "correct ~ group * mode + C(roughness_id)"
    c = choose_mixed(glmm, _fit("glmm-slope", simpler, notes=["GLMM slope: did not converge"]))
    assert c.contrasts is glmm and "fell back" in c.reason and simpler in c.reason
    c = choose_mixed(glmm, _fit("glmm-slope", None, notes=["GLMM slope: no formula could be fitted"]))
    assert c.contrasts is glmm and "no formula could be fitted" in c.reason


def test_participant_sandwich_equals_leave_one_participant_out_refits():
    """The Mancl-DeRouen sandwich of the slope model is the one-step delete-one-participant
    jackknife: sum_i (beta_(-i) - beta)(beta_(-i) - beta)'. Reference: each participant left
    out in turn and the fixed effects refitted by scipy (random-effect parameters held at the
    estimate), 30 real refits. The rows report the CR2 sandwich, which halves the power of the
    same leverage factor: between the unadjusted and the MD sandwich."""
    from scipy import optimize

    from analysis.glmm import GLMMData
    from analysis.glmm_slope import (fit_glmm_slope, participant_sandwich, slope_data,
                                     slope_deviance)
    from analysis.models import FORMULA, model_data

    trials = generate(null_cells(), n_a=13, n_b=17, sigma=0.8, seed=7, slope_sd=0.8)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = fit_glmm_slope(trials, profile=False)
    assert fit.formula == FORMULA and fit.cov_robust is not None
    _, _, data, z = slope_data(FORMULA, model_data(trials))
    sandwich = participant_sandwich(fit.theta, data, z, adjustment="MD")
    np.testing.assert_allclose(participant_sandwich(fit.theta, data, z), fit.cov_robust,
                               rtol=1e-6, atol=1e-12)
    beta, lam = fit.theta[:-3], fit.theta[-3:]
    shifts = []
    for i in range(data.m):
        keep = data.person != i
        person = np.searchsorted(np.unique(data.person[keep]), data.person[keep])
        d = GLMMData(data.x[keep], data.k[keep], data.n[keep], person, data.m - 1)

        def fun(b, d=d, zk=z[keep]):
            dev, g = slope_deviance(np.append(b, lam), d, zk, 5, grad=True)
            return dev, g[:-3]
        res = optimize.minimize(fun, beta, jac=True, method="L-BFGS-B",
                                options={"ftol": 1e-14, "gtol": 1e-9, "maxiter": 500})
        shifts.append(res.x - beta)
    shifts = np.array(shifts)
    jackknife = shifts.T @ shifts
    sizes = trials.groupby("group")["participant"].nunique()
    assert fit.cov_by_group is not None            # the sandwich split by group sums to it
    np.testing.assert_allclose(sum(w for w, _ in fit.cov_by_group.values()), fit.cov_robust,
                               rtol=1e-10, atol=1e-14)
    assert {g: m for g, (_, m) in fit.cov_by_group.items()} == sizes.to_dict()
    # the contrasts the report prints: real - simulated per group and both, the interaction
    table = mode_contrasts(fit, trials, margin_pp=10)
    for row in table[table["role"] == "averaged"].itertuples():
        groups = ["A", "B"] if row.group == "both" else [row.group]
        grid = pd.DataFrame([(g, m, r, 0, "x") for g in groups for m in ("real", "simulated")
                             for r in (1, 2, 3, 4)],
                            columns=["group", "mode", "roughness_id", "correct", "participant"])
        import patsy
        x = np.asarray(patsy.build_design_matrices([fit.design_info], grid)[0])
        sign = np.where(grid["mode"] == "real", 1.0, -1.0) / (4 * len(groups))
        lvec = sign @ x
        assert row.estimate == pytest.approx(lvec @ beta, abs=1e-9)
        jk = np.sqrt(lvec @ jackknife @ lvec)
        sw = np.sqrt(lvec @ sandwich @ lvec)
        assert sw == pytest.approx(jk, rel=0.05)          # one-step vs full refits
        assert row.se == pytest.approx(np.sqrt(lvec @ fit.cov_robust @ lvec), rel=1e-9)
        # CR2's (1 - h)^(-1/2) lies between no adjustment and MD's (1 - h)^(-1): the reported
        # SE is below MD's, by about (1 - 1/m_g)^(1/2) on a group's row
        m_g = sizes[row.group] if row.group != "both" else min(sizes)
        assert sw * (1 - 1 / m_g) ** 0.5 * 0.97 < row.se < sw
        assert "CR2 participant sandwich, Bell-McCaffrey df" in row.interval
        # the df (Bell-McCaffrey, checked against R clubSandwich in test_small_sample.py): a
        # group's row rests on that group's participants alone, about m_g - 1 (a little less
        # with unequal information); both groups' row near the Welch-Satterthwaite df of the
        # refits' shifts summed within each group
        people = np.array(sorted(trials["participant"].unique()))
        parts = {g: float(np.sum((shifts[np.char.startswith(people, g)] @ lvec) ** 2))
                 for g in ("A", "B")}
        if row.group != "both":
            assert sizes[row.group] - 2 < row.df <= sizes[row.group] - 1 + 1e-9
            assert row.test == f"Wald t({df_text(row.df)})"
        else:
            welch = sum(parts.values()) ** 2 / sum(v ** 2 / (sizes[g] - 1)
                                                   for g, v in parts.items())
            assert row.df == pytest.approx(welch, rel=0.15)
    # the A - B group comparisons use the model-based covariance alone: t(m - 2), never the
    # sandwich's df
    from analysis.models import group_contrasts
    assert set(group_contrasts(fit, trials)["df"]) == {data.m - 2}


def test_a_formula_without_group_by_mode_keeps_t_m_minus_2_on_every_row(trials):
    # the additive fallback has one mode effect for both groups (all participants): no
    # per-group df then
    from analysis.models import FORMULA
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        gee = fit_gee(trials, "correct ~ group + mode + C(roughness_id)")
    assert gee.formula != FORMULA
    table = mode_contrasts(gee, trials, margin_pp=10)
    m = trials["participant"].nunique()
    assert set(table["df"]) == {m - 2} and set(table["test"]) == {f"Wald t({m - 2})"}


def test_intercept_only_mixed_rows_refer_to_t_m_minus_2(trials):
    # no sandwich: the model-based SE rests on every participant's likelihood; t(m_g - 1) made
    # its group rows wider than needed (the 8-person group's row covered 150/150 at 20 + 8)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        glmm = fit_glmm(trials, profile=False)
    table = mode_contrasts(glmm, trials, margin_pp=10)
    m = trials["participant"].nunique()
    assert glmm.cov_robust is None and set(table["df"]) == {m - 2}
    assert set(table["test"]) == {f"Wald t({m - 2})"}


def test_a_group_of_one_participant_gets_no_test_and_no_interval():
    """A group's mode contrast rests on its own participants; with one there is no
    between-participant variation to refer it to (its sandwich is one cluster's score, which
    sums to 0): its rows, and the both-groups row that averages it in, carry no p-value,
    interval or equivalence, and say why. Before: df None, "Wald z (normal)", p < 1e-5."""
    from analysis.models import FORMULA

    full = generate(null_cells(), n_a=13, n_b=17, reps=12, sigma=0.3, seed=11)
    trials = full[(full["group"] == "A") | (full["participant"] == "B00")]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        gee = fit_gee(trials)
    assert gee.formula == FORMULA          # group x mode estimated, B from one participant
    table = mode_contrasts(gee, trials, margin_pp=10)
    withheld = table[table["group"].isin(["B", "both"])]
    assert len(withheld) == 6
    for row in withheld.itertuples():
        assert np.isnan(row.p_value) and np.isnan(row.df) and np.isnan(row.ci_low)
        assert np.isnan(row.difference_ci_low) and not row.equivalent
        assert "group B has 1 participant" in row.test
        assert np.isfinite(row.estimate)   # the estimate itself is still reported
    kept = table[table["group"] == "A"]
    assert set(kept["df"]) == {12.0} and kept["p_value"].notna().all()
    assert kept.loc[kept["role"] == "per-sample", "p_holm"].notna().all()
    from analysis.fidelity import fidelity_paragraph
    text = fidelity_paragraph(table, 10, "the protocol")
    assert "group B has 1 participant" in text and "nan" not in text


def test_a_group_of_one_participant_gets_no_group_comparison_test():
    """The same 13 + 1 study: the comparisons of the groups (primary, omnibus, per-sample,
    interaction) took group B's variance from one participant and printed p-values (the
    interaction p = 0.70 with a variance from group A alone). They now keep their estimates
    and say why there is no test; the summary says it in one sentence, never 'nan'."""
    from analysis import group_contrasts
    from analysis.report import GROUP_COMPARISON_ROLES, tests_table
    from analysis.summary import tests_summary

    full = generate(null_cells(), n_a=13, n_b=17, reps=12, sigma=0.3, seed=11)
    trials = full[(full["group"] == "A") | (full["participant"] == "B00")]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        gee = fit_gee(trials)
        contrasts = group_contrasts(gee, trials)
        table = tests_table(gee, None, contrasts, trials)
    # contrasts.csv says the same as the tests table: estimates, no SE, interval or p-value
    assert contrasts["p_value"].isna().all() and contrasts["ci_low"].isna().all()
    assert contrasts["log_odds_ratio_A_vs_B"].notna().any()
    assert contrasts["basis"].str.contains("group B has 1 participant").all()
    compared = table[table["role"].isin(GROUP_COMPARISON_ROLES)]
    assert set(compared["role"]) == {"primary", "omnibus", "per-sample", "interaction"}
    assert compared["test"].str.startswith("not tested: group B has 1 participant").all()
    assert compared["p_value"].isna().all() and compared["ci_low"].isna().all()
    assert compared.loc[compared["role"] == "primary", "estimate"].notna().all()
    text = " ".join(tests_summary(contrasts, table))
    assert "Not tested (primary, omnibus, per-sample, interaction;" in text \
        and "group B has 1 participant" in text
    assert "nan" not in text

    # two participants in B: the one-df comparisons are tested, with the Welch-Satterthwaite df
    # of their variance, which rests almost wholly on group B (t(13) before: far too sure); an
    # 8-df omnibus test from B's rank-1 covariance is not
    trials2 = full[(full["group"] == "A") | full["participant"].isin(["B00", "B01"])]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        gee2 = fit_gee(trials2)
        table2 = tests_table(gee2, None, group_contrasts(gee2, trials2), trials2)
    omnibus = table2["role"] == "omnibus"
    assert table2.loc[omnibus, "test"].str.startswith(
        "not tested: too few participants in the smaller group for a 8-df test").all()
    assert not table2.loc[~omnibus, "test"].str.startswith("not tested").any()
    primary = table2[table2["role"] == "primary"].iloc[0]
    assert np.isfinite(primary["p_value"]) and 1 <= primary["df"] < 2
