"""Words that say what the numbers say. Each assertion fails on a sentence the report printed
before: "p = 0.000", "90 % CI -0.0 to +12.7", "a difference the data support (the interval
excludes no difference)", "none differs at 0.05 after adjustment"."""
from __future__ import annotations

import numpy as np
import pytest
import pandas as pd

from analysis.fidelity import FIDELITY_COLUMNS, fidelity_paragraph
from analysis.summary import odds_verdict
from analysis.wording import p_text, signed


def test_p_below_0001_and_values_rounding_to_zero():
    assert p_text(0.0) == "p < 0.001" and p_text(0.00099) == "p < 0.001"
    assert p_text(0.001) == "p = 0.001" and p_text(0.0426) == "p = 0.043"
    assert p_text(np.nan) == "p not computed"
    assert signed(-0.0004 * 100) == "0.0" and signed(-0.04) == "0.0" and signed(0.0) == "0.0"
    assert signed(-0.05) == "-0.1" and signed(12.7) == "+12.7" and signed(-1.234, 2) == "-1.23"


def test_an_interval_that_excludes_zero_is_not_worded_as_no_difference():
    shown = odds_verdict(0.10, 0.90)
    assert "excludes no difference" not in shown and "show a difference" in shown
    open_ = odds_verdict(-0.2, 0.9)
    assert "neither show a difference nor rule one out" in open_


def _fidelity_table():
    row = dict.fromkeys(FIDELITY_COLUMNS, np.nan)
    both = {**row, "role": "averaged", "model": "gee", "group": "both", "roughness_id": 0,
            "estimate": 0.30, "difference": 0.0635, "difference_ci_low": -0.0004,
            "difference_ci_high": 0.127, "p_value": 0.00002, "test": "Wald t(28)",
            "tost_p_value": 0.0000003, "tost_ci_low": -0.0004, "tost_ci_high": 0.127,
            "equivalent": False}
    per = [{**row, "role": "per-sample", "model": "gee", "group": g, "roughness_id": r,
            "difference": 0.01, "p_value": 0.5, "p_holm": 1.0, "test": "Wald t(12)"}
           for g in "AB" for r in (1, 2, 3, 4)]
    return pd.DataFrame([both, *per], columns=FIDELITY_COLUMNS)


def test_fidelity_paragraph_prints_p_below_0001_and_no_negative_zero():
    text = fidelity_paragraph(_fidelity_table(), 10, "default")
    assert "p = 0.000" not in text and "-0.0 " not in text and "-0.0)" not in text
    assert "Wald t(28) p < 0.001" in text
    assert "90 % CI 0.0 to +12.7" in text and "95 % CI 0.0 to +12.7" in text
    # the per-sample family: not significant is not "none differs"
    assert "none differs" not in text
    assert "no sample's difference is significant at 0.05 after adjustment (which does not " \
           "show that they are equal)" in text


def test_every_coefficient_table_names_its_reference_distribution_and_df():
    """The GEE and mixed-model tables headed their statistic 'z' while their p-values came from
    t(m - 2); the covariates table printed normal-reference p-values unlabelled; ordinal's
    t_p_value named no df."""
    import statsmodels.api as sm
    from scipy import stats

    from analysis.glmm import fit_glmm
    from analysis.models import fit_gee
    from analysis.psychophysics import covariate_table, ordinal_table
    from generator import generate, null_cells

    trials = generate(null_cells(), n_a=6, n_b=8, seed=3)
    trials["trial_index"] = trials.groupby("participant").cumcount() + 1
    trials["session"] = "S1"
    m = trials["participant"].nunique()
    for fit in (fit_gee(trials), fit_glmm(trials, profile=False)):
        table = fit.table
        assert "z" not in table.columns, fit.kind
        fixed = table[table["se"].notna() & table["statistic"].notna()]
        assert (fixed["test"] == f"Wald t({m - 2})").all(), fit.kind
        expected = 2 * stats.t.sf(np.abs(fixed["log_odds"] / fixed["se"]), m - 2)
        assert np.allclose(fixed["p_value"], expected, rtol=1e-9), fit.kind
    cov = covariate_table(trials)
    position = cov[cov["term"] == "position_10"].iloc[0]
    assert position["test"] == f"Wald t({m - 2})"
    data = trials.assign(position_10=trials["trial_index"] / 10.0,
                         correct=trials["correct"].astype(int))
    ref = sm.GEE.from_formula("correct ~ group * mode + C(roughness_id) + position_10",
                              "participant", data, family=sm.families.Binomial(),
                              cov_struct=sm.cov_struct.Exchangeable()).fit(cov_type="bias_reduced")
    ratio = ref.params["position_10"] / ref.bse["position_10"]
    assert position["p_value"] == pytest.approx(2 * stats.t.sf(abs(ratio), m - 2), rel=1e-6)
    assert position["p_value"] != pytest.approx(float(ref.pvalues["position_10"]), rel=1e-3)
    ordinal = ordinal_table(trials)
    assert (ordinal["t_df"] == ordinal["n_participants"] - 1).all()
