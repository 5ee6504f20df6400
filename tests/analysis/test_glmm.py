"""Mixed logit by adaptive Gauss-Hermite ML, checked against R's lme4::glmer (Debian's r-cran-lme4).

The reference is run in a subprocess (``Rscript``) on the same trials written to a CSV;
scripts/setup installs it. Tolerances: estimates 1e-4 absolute, SEs 1e-3 relative (both
optimisers stop on their own criteria; lme4's Hessian is also a finite-difference one),
the log-likelihood 1e-4, the profile interval's ends 1e-3 (lme4 interpolates its profile
with a spline).
"""
from __future__ import annotations

import json
import shutil
import subprocess

import numpy as np
import pandas as pd
import pytest

from analysis import FORMULA, fit_gee, load_trials
from analysis.glmm import fit_glmm

from _study_writer import paper_like_cells

R_SCRIPT = r"""
suppressMessages(library(lme4))
args <- commandArgs(trailingOnly = TRUE)
d <- read.csv(args[1])
d$roughness_id <- factor(d$roughness_id); d$group <- factor(d$group); d$mode <- factor(d$mode)
form <- as.formula(paste(args[2], "+ (1 | participant)"))
f <- glmer(form, data = d, family = binomial, nAGQ = as.integer(args[3]),
           control = glmerControl(optimizer = "bobyqa", optCtrl = list(maxfun = 1e5)))
out <- list(beta = unname(fixef(f)), se = unname(sqrt(diag(as.matrix(vcov(f))))),
            names = names(fixef(f)), sigma = unname(getME(f, "theta")),
            loglik = as.numeric(logLik(f)))
if (args[4] == "profile") {
  ci <- confint(f, parm = "theta_", method = "profile", oldNames = FALSE)
  out$sigma_ci <- unname(as.vector(t(ci)))      # row by row: (low, high) per parameter
}
cat(jsonlite_free <- paste0("{", paste(sprintf('"%s": [%s]', names(out),
    sapply(out, function(v) paste(if (is.character(v)) sprintf('"%s"', v) else
        sprintf("%.12g", v), collapse = ","))), collapse = ", "), "}"))
"""

pytestmark = pytest.mark.skipif(shutil.which("Rscript") is None,
                                reason="Rscript missing: run ./scripts/setup (r-base-core r-cran-lme4)")


def _glmer(trials: pd.DataFrame, formula: str, tmp_path, n_agq: int, profile: bool) -> dict:
    csv = tmp_path / "trials.csv"
    trials[["participant", "group", "mode", "roughness_id", "correct"]].to_csv(csv, index=False)
    script = tmp_path / "glmer.R"
    script.write_text(R_SCRIPT)
    r_formula = formula.replace("C(roughness_id)", "roughness_id")
    done = subprocess.run(["Rscript", str(script), str(csv), r_formula, str(n_agq),
                           "profile" if profile else "none"],
                          capture_output=True, text=True, timeout=240, check=True)
    return json.loads(done.stdout)


@pytest.mark.slow
def test_saturated_model_agrees_with_lme4_glmer(study, tmp_path):
    data, _ = study(paper_like_cells(), sigma=0.8, seed=3, write_events=False)
    trials = load_trials(data).analysable
    fit = fit_glmm(trials, profile=False)
    assert fit.formula == FORMULA and fit.convergence["optimiser_success"]
    ref = _glmer(trials, FORMULA, tmp_path, 11, profile=False)
    fixed = fit.table.iloc[: len(ref["beta"])]
    np.testing.assert_allclose(fixed["log_odds"], ref["beta"], atol=1e-4)
    np.testing.assert_allclose(fixed["se"], ref["se"], rtol=1e-3)
    assert fit.theta[-1] == pytest.approx(ref["sigma"][0], abs=1e-4)
    assert fit.convergence["log_likelihood"] == pytest.approx(ref["loglik"][0], abs=1e-4)


@pytest.mark.slow
def test_profile_interval_of_participant_sd_agrees_with_lme4(study, tmp_path):
    data, _ = study(paper_like_cells(), n_per_group=10, sigma=1.0, seed=5, write_events=False)
    trials = load_trials(data).analysable
    formula = "correct ~ group * mode + C(roughness_id)"
    fit = fit_glmm(trials, formula, sd_cutoff="chi2")       # lme4's profile uses chi2(1)
    ref = _glmer(trials, formula, tmp_path, 11, profile=True)
    sd = fit.table.set_index("term").loc["participant_sd"]
    assert sd["log_odds"] == pytest.approx(ref["sigma"][0], abs=1e-4)
    assert sd["ci_low"] == pytest.approx(ref["sigma_ci"][0], abs=1e-3)
    assert sd["ci_high"] == pytest.approx(ref["sigma_ci"][1], abs=1e-3)
    np.testing.assert_allclose(fit.table["se"].iloc[:len(ref["se"])], ref["se"], rtol=1e-3)


def test_laplace_agrees_with_lme4_default(study, tmp_path):
    data, _ = study(paper_like_cells(), n_per_group=8, sigma=0.6, seed=7, write_events=False)
    trials = load_trials(data).analysable
    formula = "correct ~ group + mode + C(roughness_id)"
    fit = fit_glmm(trials, formula, n_agq=1, profile=False)
    ref = _glmer(trials, formula, tmp_path, 1, profile=False)
    np.testing.assert_allclose(fit.table["log_odds"].iloc[:6], ref["beta"], atol=1e-4)
    np.testing.assert_allclose(fit.table["se"].iloc[:6], ref["se"], rtol=1e-3)


def test_convergence_details_and_latent_icc(study):
    data, _ = study(n_per_group=8, sigma=1.0, seed=8, write_events=False)
    fit = fit_glmm(load_trials(data).analysable, profile=False)
    conv = fit.convergence
    assert conv["optimiser_success"] and conv["iterations"] > 0 and conv["max_abs_gradient"] < 1e-2
    assert conv["hessian_positive_definite"]
    sigma = conv["participant_sd"]
    assert conv["icc_latent"] == pytest.approx(sigma ** 2 / (sigma ** 2 + np.pi ** 2 / 3))


def test_glmm_without_participant_differences_puts_sd_near_zero_and_gee_agrees(study):
    # sigma = 0: the conditional and marginal models coincide, so the GLMM's fixed effects
    # must match the GEE's (population-averaged) ones closely
    data, _ = study(n_per_group=15, sigma=0.0, seed=9, write_events=False)
    trials = load_trials(data).analysable
    fit = fit_glmm(trials)
    sd = fit.table.set_index("term").loc["participant_sd"]
    assert sd["log_odds"] < 0.4 and sd["ci_low"] == 0.0
    gee = fit_gee(trials)
    np.testing.assert_allclose(fit.params, gee.params, atol=0.1)


@pytest.mark.slow
def test_random_mode_slope_agrees_with_lme4_laplace(tmp_path):
    # (1 + mode | participant): lme4 fits vector random effects by the Laplace approximation
    # only, so the comparison is at n_agq = 1. lme4's penalised IRLS stops by default at a
    # relative change of 1e-7 in the penalised deviance (glmerControl(tolPwrss)), before the
    # conditional modes are exact: its reported log-likelihood is then 0.0012 below the
    # Laplace formula evaluated at its own modes (measured in R with getME). With
    # tolPwrss = 1e-12 lme4's log-likelihood equals that formula to 1e-7 and agrees with ours
    # to 5e-8, its estimates with ours to 1e-6.
    from analysis.glmm_slope import fit_glmm_slope
    from generator import effect_cells, generate
    trials = generate(effect_cells(), n_a=20, n_b=20, sigma=0.5, slope_sd=1.0, seed=0)
    formula = "correct ~ group * mode + C(roughness_id)"
    fit = fit_glmm_slope(trials, formula, n_agq=1, sd_cutoff="chi2")   # lme4's cut-off
    script = tmp_path / "slope.R"
    script.write_text(R_SCRIPT.replace("(1 | participant)", "(1 + mode | participant)")
                      .replace("maxfun = 1e5))", "maxfun = 1e5), tolPwrss = 1e-12)"))
    csv = tmp_path / "trials.csv"
    trials[["participant", "group", "mode", "roughness_id", "correct"]].to_csv(csv, index=False)
    done = subprocess.run(["Rscript", str(script), str(csv), formula.replace("C(roughness_id)",
                           "roughness_id"), "1", "profile"], capture_output=True, text=True,
                          timeout=240, check=True)
    ref = json.loads(done.stdout)
    np.testing.assert_allclose(fit.params, ref["beta"], atol=1e-4)
    np.testing.assert_allclose(fit.table["se"].iloc[:len(ref["se"])], ref["se"], rtol=1e-3)
    np.testing.assert_allclose(fit.theta[-3:], ref["sigma"], atol=1e-4)   # lme4's theta
    assert fit.convergence["log_likelihood"] == pytest.approx(ref["loglik"][0], abs=1e-4)
    # profile intervals: lme4's confint(method = "profile") rows are sd_(Intercept), cor,
    # sd_mode; it interpolates a spline through its profile points (on the correlation a
    # coarser grid): ends within 1e-3 (SDs) and 3e-3 (correlation). Measured: 2e-4 and 1.9e-3.
    t = fit.table.set_index("term")
    lme4 = np.reshape(ref["sigma_ci"], (3, 2))
    np.testing.assert_allclose(t.loc["sd_intercept", ["ci_low", "ci_high"]].to_numpy(float),
                               lme4[0], atol=1e-3)
    np.testing.assert_allclose(t.loc["sd_mode_slope", ["ci_low", "ci_high"]].to_numpy(float),
                               lme4[2], atol=1e-3)
    np.testing.assert_allclose(t.loc["corr_intercept_slope", ["ci_low", "ci_high"]]
                               .to_numpy(float), lme4[1], atol=3e-3)
    sd = fit.table.set_index("term")["log_odds"]
    assert sd["sd_mode_slope"] > 0.5 and abs(sd["corr_intercept_slope"]) < 1


def test_row_logsumexp_is_scipys_to_the_bit():
    """The quadrature's own logsumexp (SciPy's arithmetic without its array-API overhead) gives
    SciPy's bits: on quadrature-like rows, with tied maxima, an all-equal row, a -inf term, and
    rows whose result is not finite (handed to SciPy)."""
    from scipy import special

    from analysis.glmm import logsumexp_rows
    rng = np.random.default_rng(3)
    a = rng.normal(-40.0, 15.0, (200, 25))
    a[0, 3] = a[0, 7] = a[0].max() + 1.0          # two tied maxima
    a[1] = -3.25                                  # every term tied
    a[2, 5] = -np.inf                             # one term adds nothing
    a[3] = -np.inf                                # log of zero
    a[4, 0] = np.inf
    a[5, 1] = np.nan
    got = logsumexp_rows(a)
    want = special.logsumexp(a, axis=1, keepdims=True)
    assert got.shape == (200, 1)
    np.testing.assert_array_equal(got, want)      # bit for bit, NaN and inf included
    assert np.count_nonzero(got[6:] != want[6:]) == 0 and np.all(np.isfinite(got[6:]))


@pytest.mark.slow
def test_slope_profiles_computed_in_a_worker_are_the_same_numbers():
    """``analyze`` has the random-slope model's profile intervals computed in its forked
    worker (``fit_glmm_slope(submit=...)``, then ``complete_profiles``): the table must be the
    one the fit computes in place, to the bit, and nothing is left pending."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor
    from analysis.glmm_slope import fit_glmm_slope
    from analysis.glmm_slope_profile import complete_profiles
    from generator import effect_cells, generate
    trials = generate(effect_cells(), n_a=8, n_b=8, sigma=0.5, slope_sd=1.0, seed=3)
    formula = "correct ~ group * mode + C(roughness_id)"
    here = fit_glmm_slope(trials, formula)
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("fork")) as pool:
        there = fit_glmm_slope(trials, formula, submit=pool.submit)
        assert there.pending is not None
        assert there.table.set_index("term").loc["sd_mode_slope", ["ci_low", "ci_high"]] \
            .isna().all()
        assert complete_profiles(there) is there and there.pending is None
    assert here.pending is None
    pd.testing.assert_frame_equal(there.table, here.table, check_exact=True)
    assert np.isfinite(here.table.set_index("term").loc["sd_mode_slope", "ci_high"])
