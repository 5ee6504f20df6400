"""Named tests (primary, omnibus, Holm, interaction, chance), mean-proportion contrasts and the
psychophysics measures, each against a reference computed another way."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from analysis import fit_gee, group_contrasts, load_trials
from analysis.inference import chance_tests, holm, interaction_test, omnibus_group_test
from analysis.psychophysics import agreement_table, hu_values, information_transfer, ordinal_table

from generator import effect_cells, generate, null_cells


def test_holm_matches_statsmodels_multipletests():
    from statsmodels.stats.multitest import multipletests
    p = np.random.default_rng(20261124).uniform(0, 0.2, size=8)
    np.testing.assert_allclose(holm(p), multipletests(p, method="holm")[1], rtol=1e-12)
    with_nan = np.append(p, np.nan)
    out = holm(with_nan)
    assert np.isnan(out[-1])
    np.testing.assert_allclose(out[:-1], multipletests(p, method="holm")[1], rtol=1e-12)


def test_omnibus_wald_equals_statsmodels_wald_test():
    trials = generate(effect_cells(), seed=11)
    gee = fit_gee(trials)
    omni = omnibus_group_test(gee, trials)
    assert omni["df"] == 8
    # the same hypothesis through statsmodels: all group and group:* terms zero
    # (A - B at every mode x sample is a full-rank recoding of these 8 coefficients)
    names = gee.table["term"].tolist()
    rows = [i for i, n in enumerate(names) if n.startswith("group[T.B]")]
    lmat = np.zeros((len(rows), len(names)))
    lmat[np.arange(len(rows)), rows] = 1
    ref = gee.result.wald_test(lmat, scalar=True)
    assert omni["chi2"] == pytest.approx(float(ref.statistic), rel=1e-8)
    # small-sample F with each group's own covariance (Nel-van der Merwe), recomputed here from
    # statsmodels' GEE in cell-means coding, whose sandwich is block-diagonal by group: S_g is
    # the A - B contrasts' covariance over group g's block alone
    import statsmodels.api as sm
    d = trials.assign(cell=trials["group"] + "_" + trials["mode"] + "_"
                      + trials["roughness_id"].astype(str))
    x = pd.get_dummies(d["cell"]).astype(float)
    cm = sm.GEE(d["correct"].astype(float), x, groups=d["participant"],
                family=sm.families.Binomial(),
                cov_struct=sm.cov_struct.Exchangeable()).fit(cov_type="bias_reduced")
    cols = list(x.columns)
    lmat = np.zeros((8, len(cols)))
    for k, (mode, r) in enumerate((m, r) for m in ("real", "simulated") for r in range(1, 5)):
        lmat[k, cols.index(f"A_{mode}_{r}")] = 1
        lmat[k, cols.index(f"B_{mode}_{r}")] = -1
    cov, dvec = np.asarray(cm.cov_params()), lmat @ np.asarray(cm.params)
    s_g = {g: (lmat * [c.startswith(g) for c in cols]) @ cov
           @ (lmat * [c.startswith(g) for c in cols]).T for g in "AB"}
    s = s_g["A"] + s_g["B"]
    assert float(dvec @ np.linalg.solve(s, dvec)) == pytest.approx(omni["chi2"], rel=1e-5)
    sizes = trials.groupby("group")["participant"].nunique()
    nu = (np.trace(s @ s) + np.trace(s) ** 2) / sum(
        (np.trace(s_g[g] @ s_g[g]) + np.trace(s_g[g]) ** 2) / (sizes[g] - 1) for g in "AB")
    assert omni["df_denominator"] == pytest.approx(nu - 8 + 1, rel=1e-5)
    f = omni["chi2"] * (nu - 8 + 1) / (8 * nu)
    assert omni["f"] == pytest.approx(f, rel=1e-5)
    assert omni["p_value"] == pytest.approx(stats.f.sf(f, 8, nu - 7), rel=1e-5)
    assert omni["p_value"] > float(ref.pvalue)        # the correction only makes it stricter


def test_averaged_contrast_is_a_difference_of_mean_proportions():
    # saturated GEE on balanced data: per-sample probabilities are the observed proportions;
    # the averaged row must be their mean (expit of the mean log odds, the old value, is not)
    trials = generate(effect_cells(), n_a=15, n_b=15, missing=0.0, seed=12)
    gee = fit_gee(trials)
    c = group_contrasts(gee, trials)
    for mode in ("real", "simulated"):
        sel = c[c["mode"] == mode].set_index("roughness_id")
        observed = trials[trials["mode"] == mode].groupby(["group", "roughness_id"])["correct"].mean()
        assert sel.loc[0, "p_correct_A"] == pytest.approx(observed["A"].mean(), abs=1e-6)
        assert sel.loc[0, "p_correct_B"] == pytest.approx(observed["B"].mean(), abs=1e-6)
        assert sel.loc[0, "difference_A_minus_B"] == pytest.approx(
            observed["A"].mean() - observed["B"].mean(), abs=1e-6)
        assert "mean over 1#-4#" in sel.loc[0, "compares"]
        assert all(f"sample {r}#" in sel.loc[r, "compares"] for r in range(1, 5))


def test_interaction_is_the_difference_of_the_two_averaged_contrasts():
    trials = generate(effect_cells(), n_a=25, n_b=25, sigma=0.3, seed=13)
    gee = fit_gee(trials)
    c = group_contrasts(gee, trials).set_index(["mode", "roughness_id"])
    it = interaction_test(gee, trials)
    real, sim = c.loc[("real", 0)], c.loc[("simulated", 0)]
    assert it["log_odds"] == pytest.approx(real["log_odds_ratio_A_vs_B"]
                                           - sim["log_odds_ratio_A_vs_B"], abs=1e-10)
    assert it["difference_of_differences"] == pytest.approx(
        real["difference_A_minus_B"] - sim["difference_A_minus_B"], abs=1e-10)
    assert it["ci_low"] < it["log_odds"] < it["ci_high"]


def test_chance_tests_are_one_sample_t_tests_on_participant_proportions():
    trials = generate(null_cells(), seed=14)
    table = chance_tests(trials)
    assert set(table["family"]) == {"cell", "group x mode"}
    assert (table["family"] == "cell").sum() == 16 and (table["family"] == "group x mode").sum() == 4
    row = table[(table["family"] == "cell") & (table["group"] == "B") & (table["mode"] == "real")
                & (table["roughness_id"] == 3)].iloc[0]
    sel = trials[(trials["group"] == "B") & (trials["mode"] == "real") & (trials["roughness_id"] == 3)]
    props = sel.groupby("participant")["correct"].mean()
    ref = stats.ttest_1samp(props, 0.25)
    assert row["p_value"] == pytest.approx(ref.pvalue, rel=1e-10)
    assert row["mean_participant_proportion"] == pytest.approx(props.mean())
    cells = table[table["family"] == "cell"]
    np.testing.assert_allclose(cells["p_holm"], holm(cells["p_value"]), rtol=1e-12)


def test_information_transfer_equals_entropy_identity_and_kappa_matches_statsmodels():
    from statsmodels.stats.inter_rater import cohens_kappa
    n = np.array([[20, 5, 3, 2], [6, 15, 6, 3], [2, 7, 14, 7], [1, 3, 6, 20]], float)
    h = lambda v: stats.entropy(v.ravel() / v.sum(), base=2)
    it = information_transfer(n)
    assert it["it_bits"] == pytest.approx(h(n.sum(axis=1)) + h(n.sum(axis=0)) - h(n), rel=1e-12)
    assert it["it_bits_corrected"] == pytest.approx(it["it_bits"] - 9 / (2 * n.sum() * np.log(2)))
    independent = np.full((4, 4), 10.0)
    assert information_transfer(independent)["it_bits_corrected"] == 0.0
    rows = [(s, r) for s in range(4) for r in range(4) for _ in range(int(n[s, r]))]
    trials = pd.DataFrame({"group": "A", "mode": "real", "participant": "p",
                           "roughness_id": [s + 1 for s, _ in rows],
                           "response_id": [r + 1 for _, r in rows]})
    table = agreement_table(trials)
    assert table["kappa"].iloc[0] == pytest.approx(cohens_kappa(n).kappa, rel=1e-12)
    hu, chance = hu_values(n)
    assert hu[0] == pytest.approx(20 ** 2 / (30 * 29))
    assert chance[0] == pytest.approx(30 * 29 / n.sum() ** 2)


def test_ordinal_slope_is_positive_when_answers_follow_the_order():
    trials = generate(effect_cells(), seed=15)
    table = ordinal_table(trials)
    assert (table["spearman_pooled"] > 0.3).all() and (table["po_ci_low"] > 0).all()
    shuffled = trials.assign(response_id=np.random.default_rng(1).permutation(trials["response_id"]))
    assert (ordinal_table(shuffled)["spearman_pooled"].abs() < 0.2).all()


def test_the_ordinal_slope_is_statsmodels_own_logit_fit_to_the_last_bit():
    # the ordinal table's logit link skips scipy's generic argument handling: statsmodels'
    # OrderedModel with its own distr="logit" (scipy's stats.logistic) is the reference
    import warnings

    from statsmodels.miscmodels.ordinal_model import OrderedModel

    from analysis.psychophysics import _po_slope, _standard_logistic
    x = np.array([-np.inf, -800.0, -40.0, -1e-3, -0.0, 0.0, 5e-324, 2.5, 40.0, 800.0, np.inf,
                  np.nan])
    fast = _standard_logistic()
    for name in ("cdf", "pdf"):
        mine, scipys = getattr(fast, name), getattr(stats.logistic, name)
        assert np.array_equal(mine(x), scipys(x), equal_nan=True), name
        assert mine(2.5) == scipys(2.5)
        assert mine(x, loc=1.0) == pytest.approx(scipys(x, loc=1.0), nan_ok=True)   # scipy's own
    trials = generate(effect_cells(), seed=15)
    for _, sel in trials.groupby(["group", "mode"]):
        y = pd.Series(pd.Categorical(sel["response_id"].astype(int), categories=[1, 2, 3, 4],
                                     ordered=True))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = OrderedModel(y.cat.remove_unused_categories(),
                               sel[["roughness_id"]].astype(float).reset_index(drop=True),
                               distr="logit").fit(
                method="bfgs", disp=False, cov_type="cluster",
                cov_kwds={"groups": pd.factorize(sel["participant"])[0]})
        low, high = res.conf_int(alpha=0.05).loc["roughness_id"]
        assert _po_slope(sel) == (res.params["roughness_id"], res.bse["roughness_id"], low, high)


def test_summary_names_only_holm_adjusted_results():
    from analysis.summary import tests_summary
    def table(p_holm):
        rows = [{"role": "per-sample", "model": "gee", "p_value": 0.02, "p_holm": p_holm,
                 "compares": "group A - group B, real sample 2#: log odds ratio", "basis": "model"}]
        rows += [{"role": "per-sample", "model": "gee", "p_value": 0.5, "p_holm": 1.0,
                  "compares": f"group A - group B, real sample {r}#: log odds ratio",
                  "basis": "model"} for r in (1, 3, 4)]
        return pd.DataFrame(rows)
    text = " ".join(tests_summary(pd.DataFrame(), table(0.08)))
    # non-significance is not absence: the old "no single sample shows a group difference
    # (all adjusted p >= 0.05)" read a failed test as no difference
    assert "no single sample shows a group difference" not in text and "2#" not in text
    assert ("no single sample's group difference is significant at 0.05 (smallest adjusted "
            "p 0.080); this does not show that the samples do not differ") in text
    text = " ".join(tests_summary(pd.DataFrame(), table(0.03)))
    assert "remains for: group A - group B, real sample 2# (adjusted p = 0.030)" in text
    # the omnibus test rejects, no sample survives Holm: the groups differ somewhere
    rejected = pd.concat([pd.DataFrame([{"role": "omnibus", "model": "gee", "p_value": 0.005,
                                         "statistic": 3.1, "df": 8, "basis": "model",
                                         "test": "Wald F(8, 22)", "compares": "no A - B"}]),
                          table(0.08)])
    text = " ".join(tests_summary(pd.DataFrame(), rejected))
    assert "no single sample" not in text and "all adjusted p >= 0.05" not in text
    assert ("The omnibus test rejects (p = 0.005): the groups differ on at least one sample in "
            "one mode, but after Holm's adjustment for the 4 per-sample comparisons none of them "
            "on its own is significant at 0.05 (smallest adjusted p 0.080): the data do not say "
            "which.") in text
    tiny = rejected.assign(p_value=rejected["p_value"].where(rejected["role"] != "omnibus", 2e-5))
    text = " ".join(tests_summary(pd.DataFrame(), tiny))
    assert "rejects (p < 0.001)" in text and "p = 0.000" not in text
    # the omnibus test comes first: when it does not reject, no sample is named
    gated = pd.concat([pd.DataFrame([{"role": "omnibus", "model": "gee", "p_value": 0.2,
                                      "statistic": 1.3, "df": 8, "basis": "model",
                                      "test": "Wald F: F(8, 22) from Wald chi2 = 11",
                                      "compares": "no A - B difference"}]), table(0.03)])
    text = " ".join(tests_summary(pd.DataFrame(), gated))
    assert "omnibus test does not reject (p = 0.200)" in text and "remains for" not in text


def test_cli_bayes_is_opt_in_and_the_mixed_model_can_be_skipped(study, tmp_path):
    from experiments.cli import main
    data, _ = study(n_per_group=5, sigma=0.5, seed=63, write_events=False)
    assert main(["analyze", str(data), "--out", str(tmp_path / "a"), "--bootstrap", "50",
                 "--bayes-vb"]) == 0
    report = (tmp_path / "a" / "report.md").read_text()
    assert (tmp_path / "a" / "bayes.csv").exists() and "comparison only" in report
    assert "## Mixed logit" in report and "(1 + mode | participant)" in report
    assert main(["analyze", str(data), "--out", str(tmp_path / "b"), "--bootstrap", "50",
                 "--no-mixed"]) == 0
    report = (tmp_path / "b" / "report.md").read_text()
    assert not (tmp_path / "b" / "bayes.csv").exists() and "## Mixed logit" not in report


def test_holm_is_statsmodels_multipletests_with_nan_kept():
    from statsmodels.stats.multitest import multipletests

    from analysis.inference import holm
    p = np.array([0.01, np.nan, 0.04, 0.03, 0.5, 0.03, np.nan, 0.2])
    out = holm(p)
    ok = np.isfinite(p)
    np.testing.assert_array_equal(out[ok], multipletests(p[ok], method="holm")[1])
    assert np.isnan(out[~ok]).all()
    assert np.isnan(holm([np.nan, np.nan])).all()
