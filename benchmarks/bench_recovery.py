"""Recovery suite: coverage of every 95 % interval the report prints, and the tests' type-I error.

Not a test (a smaller version runs in tests/analysis/test_recovery_models.py). Run:

    .venv/bin/python benchmarks/bench_recovery.py --datasets 200 --scenario null --out DIR
    .venv/bin/python benchmarks/bench_recovery.py --datasets 200 --scenario effect --out DIR

Datasets come from ``tests/analysis/generator.py`` (independent of the code under test and of the
simulated participant): a random-intercept logistic model with known typical-participant cell
probabilities, SD ``--sigma`` (default 0.8), groups of 13 and 17, 3 repetitions, 3 % of trials
lost at random, wrong answers biased to neighbouring samples. ``null``: no group effect
anywhere; ``effect``: group A 0.15 above B with real samples only; ``slope``: the null cells
plus a participant effect of simulated vs real samples, SD ``SLOPE_SD``, independent of the
intercept (the random-slope model's intervals are then measured too; ``--slope-model`` measures
them in the other scenarios, where the true slope SD is 0 and the correlation undefined).

Each dataset is analysed with the functions ``thermocue analyze`` calls (cell_proportions,
fit_gee, group_contrasts, fit_glmm, the named tests, chance_tests). For each interval family the
share of intervals covering the truth is printed with its binomial SE (intervals within a
dataset are correlated, so the SE is a lower bound); for each test the rejection rate at 0.05.
Truths: population-averaged quantities (GEE, cells, chance) by 80-node Gauss-Hermite over the
random intercept; typical-participant ones (GLMM) from the cells directly.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import patsy
from scipy.special import expit, logit

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests" / "analysis"))

from analysis import cell_proportions, fit_gee, group_contrasts  # noqa: E402
from analysis.glmm import fit_glmm  # noqa: E402
from analysis.glmm_slope import fit_glmm_slope  # noqa: E402
from analysis.inference import chance_tests, interaction_test  # noqa: E402
from analysis.models import FORMULA  # noqa: E402
from analysis.fidelity import mode_contrasts  # noqa: E402
from analysis.mixed_choice import choose_mixed  # noqa: E402
from analysis.report import tests_table  # noqa: E402
from generator import effect_cells, generate, null_cells  # noqa: E402

MODES = ("real", "simulated")
#: The "slope" scenario's SD of the participants' simulated-vs-real effect (independent of the
#: intercept: true correlation 0).
SLOPE_SD = 0.8


def truths(cells: dict, sigma: float, slope_sd: float = 0.0) -> dict:
    z, w = np.polynomial.hermite_e.hermegauss(80)
    w = w / w.sum()
    sd = {"real": sigma, "simulated": np.hypot(sigma, slope_sd)}      # u and u + u_sim
    marg = {k: float(w @ expit(logit(p) + sd[k[1]] * z)) for k, p in cells.items()}
    out = {"marg": marg, "cond": dict(cells)}
    for scale, table in (("gee", marg), ("glmm", cells)):
        for m in MODES:
            for r in range(1, 5):
                a, b = table[("A", m, r)], table[("B", m, r)]
                out[(scale, m, r)] = (logit(a) - logit(b), a - b)
            lor = np.mean([out[(scale, m, r)][0] for r in range(1, 5)])
            diff = np.mean([table[("A", m, r)] for r in range(1, 5)]) - \
                np.mean([table[("B", m, r)] for r in range(1, 5)])
            out[(scale, m, 0)] = (lor, diff)
        out[(scale, "interaction")] = tuple(out[(scale, "real", 0)][i] - out[(scale, "simulated", 0)][i]
                                            for i in (0, 1))
        # real - simulated, averaged over the samples, per group and both groups equally
        for who, groups in (("A", ["A"]), ("B", ["B"]), ("both", ["A", "B"])):
            real = [table[(g, "real", r)] for g in groups for r in range(1, 5)]
            sim = [table[(g, "simulated", r)] for g in groups for r in range(1, 5)]
            out[(scale, "mode", who)] = (float(np.mean(logit(np.array(real)))
                                               - np.mean(logit(np.array(sim)))),
                                         float(np.mean(real) - np.mean(sim)))
    return out


class Tally:
    def __init__(self):
        self.hits, self.total, self.missing = {}, {}, {}

    def add(self, family, low, high, truth):
        if not (np.isfinite(low) and np.isfinite(high)):
            self.missing[family] = self.missing.get(family, 0) + 1
            return
        self.hits[family] = self.hits.get(family, 0) + int(low <= truth <= high)
        self.total[family] = self.total.get(family, 0) + 1

    def table(self):
        rows = []
        for f in self.total:
            c = self.hits[f] / self.total[f]
            rows.append({"interval": f, "coverage": c, "n_intervals": self.total[f],
                         "binomial_se": np.sqrt(c * (1 - c) / self.total[f]),
                         "not_estimable": self.missing.get(f, 0)})
        return pd.DataFrame(rows)


#: The tests whose rejection rate at 0.05 is counted (the slope model's only with --slope-model).
TESTS = ("primary (GEE averaged A-B, real)", "omnibus (GEE, 8 df)", "any per-sample, unadjusted",
         "any per-sample, Holm", "interaction (GEE)", "interaction (mixed model as reported)",
         "interaction (GLMM, intercept only)", "GLMM group[T.B] (real 1#)",
         "slope model: LR test of the random slope")


def _quiet(fit, *args, **kwargs):
    """``fit(*args, **kwargs)`` with its warnings silenced."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fit(*args, **kwargs)


class Recovery:
    """One scenario's tallies over datasets: each dataset analysed as ``thermocue analyze`` does
    (:meth:`dataset`), its intervals held against the truth and its tests' rejections counted."""

    def __init__(self, cells, sigma, slope_sd, n_boot, profile, slope_model, slope_profile):
        self.cells, self.sigma, self.slope_sd, self.n_boot = cells, sigma, slope_sd, n_boot
        self.profile, self.slope_model, self.slope_profile = profile, slope_model, slope_profile
        self.truth = truths(cells, sigma, slope_sd)
        # with a true random slope the intercept-only mixed model is misspecified: its intervals
        # have no true value to cover and are not tallied (the GEE's and the cells' still do)
        self.intercept_model_ok = slope_sd == 0
        self.grid = pd.DataFrame([(g, m, r, 0, "x") for (g, m, r) in cells],
                                 columns=["group", "mode", "roughness_id", "correct", "participant"])
        self.cond_logit = logit(np.array([cells[k] for k in cells]))
        self.marg_logit = logit(np.array([self.truth["marg"][k] for k in cells]))
        self.tally = Tally()
        self.rejections = {k: 0 for k in TESTS}
        self.fallbacks = {"gee": 0, "glmm": 0}
        self.used = {"slope model": 0, "intercept model": 0}
        self.glmm_fail = 0

    def _fixed_effects(self, family, fit, beta_truth):
        """Tally the Wald intervals of ``fit``'s coefficients of the full formula against the
        coefficients that reproduce ``beta_truth`` (cell log odds) on the cell grid."""
        x = np.asarray(patsy.build_design_matrices([fit.design_info], self.grid)[0])
        beta_true = np.linalg.lstsq(x, beta_truth, rcond=None)[0]
        fixed = fit.table.iloc[: len(beta_true)]
        for row, b in zip(fixed.itertuples(), beta_true):
            self.tally.add(family, row.ci_low, row.ci_high, b)
        return fixed

    def gee(self, trials):
        """The GEE fit; its coefficient table against the population-averaged truth."""
        gee = _quiet(fit_gee, trials)
        self.fallbacks["gee"] += gee.formula != FORMULA
        if gee.formula == FORMULA:
            self._fixed_effects("gee coefficients (Wald)", gee, self.marg_logit)
        return gee

    def cells_and_contrasts(self, trials, props, gee, glmm):
        """The cells' intervals (``props``) and the A - B contrasts (GEE, and the GLMM's when
        it fits the truth); returns the contrasts."""
        for row in props.itertuples():
            t = self.truth["marg"][(row.group, row.mode, row.roughness_id)]
            self.tally.add("cell: participant bootstrap", row.boot_low, row.boot_high, t)
            self.tally.add("cell: Wilson (trials independent)", row.wilson_low, row.wilson_high, t)
        contrasts = group_contrasts(gee, trials)
        if glmm.formula is not None and self.intercept_model_ok:
            gc = group_contrasts(glmm, trials)
            gc["model"] = "glmm"
            contrasts = pd.concat([contrasts, gc], ignore_index=True)
        for row in contrasts.itertuples():
            scale = "gee" if row.model == "gee" else "glmm"
            lor, diff = self.truth[(scale, row.mode, row.roughness_id)]
            which = "averaged" if row.roughness_id == 0 else "per-sample"
            self.tally.add(f"{scale} contrast {which}: log odds ratio", row.ci_low, row.ci_high, lor)
            self.tally.add(f"{scale} contrast {which}: proportion difference", row.difference_low,
                           row.difference_high, diff)
        return contrasts

    def mode_contrasts(self, trials, gee, choice, reported_ok):
        """Real - simulated, averaged, by GEE and by the mixed model the report uses."""
        for fit in (gee, choice.contrasts):
            if fit is None or (fit.kind != "gee" and not reported_ok):
                continue
            scale = "gee" if fit.kind == "gee" else "glmm"
            label = "gee" if fit.kind == "gee" else "mixed (as reported)"
            fid = mode_contrasts(fit, trials, margin_pp=10)
            for row in fid[fid["role"] == "averaged"].itertuples():
                lor, diff = self.truth[(scale, "mode", row.group)]
                self.tally.add(f"{label} real - simulated averaged: log odds", row.ci_low,
                               row.ci_high, lor)
                self.tally.add(f"{label} real - simulated averaged: proportions",
                               row.difference_ci_low, row.difference_ci_high, diff)
                # the same by row: group A (t(12)), group B (t(16)), both groups (t(28))
                self.tally.add(f"{label} real - simulated, group {row.group}: log odds", row.ci_low,
                               row.ci_high, lor)
                self.tally.add(f"{label} real - simulated, group {row.group}: proportions",
                               row.difference_ci_low, row.difference_ci_high, diff)
        if choice.contrasts is not None:
            self.used["slope model" if choice.contrasts.kind == "glmm-slope"
                      else "intercept model"] += 1

    def interactions(self, tests, reported_ok):
        """The interaction rows of the tests table against the truth."""
        for row in tests.itertuples():
            if row.role == "interaction" and row.model != "gee" and reported_ok:
                lor, dd = self.truth[("glmm", "interaction")]
                self.tally.add("mixed interaction as reported: log odds", row.ci_low, row.ci_high,
                               lor)
                self.tally.add("mixed interaction as reported: proportions", row.difference_ci_low,
                               row.difference_ci_high, dd)
            if row.role == "interaction" and row.model == "gee":
                lor, dd = self.truth[(row.model, "interaction")]
                self.tally.add(f"{row.model} interaction: log odds", row.ci_low, row.ci_high, lor)
                self.tally.add(f"{row.model} interaction: proportions", row.difference_ci_low,
                               row.difference_ci_high, dd)

    def count_rejections(self, tests, glmm, trials):
        """The tests table's rejections at 0.05, and the GLMM's own interaction test's."""
        rej = self.rejections
        p = {role: sel["p_value"].to_numpy(float) for role, sel in tests.groupby("role")}
        rej["primary (GEE averaged A-B, real)"] += bool(p.get("primary", [1])[0] < 0.05)
        rej["omnibus (GEE, 8 df)"] += bool(p.get("omnibus", [1])[0] < 0.05)
        per = tests[tests["role"] == "per-sample"]
        rej["any per-sample, unadjusted"] += bool((per["p_value"] < 0.05).any())
        rej["any per-sample, Holm"] += bool((per["p_holm"] < 0.05).any())
        inter = tests[tests["role"] == "interaction"].set_index("model")["p_value"]
        rej["interaction (GEE)"] += bool(inter.get("gee", 1) < 0.05)
        rej["interaction (mixed model as reported)"] += bool(
            inter.drop("gee", errors="ignore").min() < 0.05) if len(inter) > 1 else False
        it = interaction_test(glmm, trials) if glmm.formula else None
        rej["interaction (GLMM, intercept only)"] += bool(it is not None and it["p_value"] < 0.05)

    def glmm_intervals(self, glmm):
        """The GLMM's fixed effects, group test, participant SD and ICC against the truth."""
        if glmm.formula == FORMULA and self.intercept_model_ok:
            fixed = self._fixed_effects("glmm fixed effects (Wald)", glmm, self.cond_logit)
            g = fixed.set_index("term").loc["group[T.B]"]
            self.rejections["GLMM group[T.B] (real 1#)"] += bool(g["p_value"] < 0.05)
        sigma = self.sigma
        if glmm.formula is not None and self.intercept_model_ok:
            t = glmm.table.set_index("term")
            how = "profile" if self.profile else "Wald on log SD"
            self.tally.add(f"glmm participant SD ({how})", t.loc["participant_sd", "ci_low"],
                           t.loc["participant_sd", "ci_high"], sigma)
            self.tally.add(f"glmm ICC latent ({how})", t.loc["icc_latent", "ci_low"],
                           t.loc["icc_latent", "ci_high"], sigma ** 2 / (sigma ** 2 + np.pi ** 2 / 3))
        elif glmm.formula is None:
            self.glmm_fail += 1

    def slope_intervals(self, sl):
        """The random-slope model's fixed effects, SDs, correlation and LR test."""
        if sl.formula is None:
            self.glmm_fail += 1
            return
        t = sl.table.set_index("term")
        if sl.formula == FORMULA:
            self._fixed_effects("slope model fixed effects (Wald)", sl, self.cond_logit)
        for term, truth_v in (("sd_intercept", self.sigma), ("sd_mode_slope", self.slope_sd),
                              ("corr_intercept_slope", 0.0 if self.slope_sd > 0 else None)):
            if truth_v is not None and self.slope_profile:
                self.tally.add(f"slope model {term} (profile)", t.loc[term, "ci_low"],
                               t.loc[term, "ci_high"], truth_v)
        if "lrt_slope" in t.index:
            self.rejections["slope model: LR test of the random slope"] += \
                bool(t.loc["lrt_slope", "p_value"] < 0.05)

    def chance(self, trials):
        """The chance tests' t intervals against the population-averaged truth."""
        marg = self.truth["marg"]
        for row in chance_tests(trials).itertuples():
            if row.family == "cell":
                t = marg[(row.group, row.mode, row.roughness_id)]
            else:
                t = np.mean([marg[(row.group, row.mode, r)] for r in range(1, 5)])
            self.tally.add(f"chance t interval ({row.family})", row.t_low, row.t_high, t)

    def dataset(self, trials, i, gee_only):
        """Analyse one dataset (``i``: its bootstrap seed) and tally it."""
        gee = self.gee(trials)
        if gee_only:
            return
        props = _quiet(cell_proportions, trials, n_boot=self.n_boot, seed=i)
        glmm = _quiet(fit_glmm, trials, profile=self.profile)
        self.fallbacks["glmm"] += glmm.formula != FORMULA
        contrasts = self.cells_and_contrasts(trials, props, gee, glmm)
        sl = None
        if self.slope_model and glmm.formula is not None:
            sl = _quiet(fit_glmm_slope, trials, glmm.formula, intercept_fit=glmm,
                        profile=self.slope_profile)
        # the mixed model the report uses for mode contrasts (analysis.mixed_choice)
        choice = choose_mixed(glmm if glmm.formula else None, sl)
        reported_ok = choice.contrasts is not None and (
            choice.contrasts.kind == "glmm-slope" or self.intercept_model_ok)
        tests = tests_table(gee, choice.contrasts, contrasts[contrasts["model"] == "gee"], trials)
        self.mode_contrasts(trials, gee, choice, reported_ok)
        self.interactions(tests, reported_ok)
        self.count_rejections(tests, glmm, trials)
        self.glmm_intervals(glmm)
        if sl is not None:
            self.slope_intervals(sl)
        self.chance(trials)

    def rejection_table(self, n):
        """Each test's rejections and rate over ``n`` datasets, with its binomial SE."""
        rejections = dict(self.rejections)
        if not self.slope_model:
            del rejections["slope model: LR test of the random slope"]
        return pd.DataFrame([{"test": k, "rejections": v, "datasets": n, "rate": v / n,
                              "binomial_se": np.sqrt(max(v / n * (1 - v / n), 1e-12) / n)}
                             for k, v in rejections.items()])


def run(n, scenario, sigma, seed0, n_boot, progress=True, profile=True, slope_model=False,
        slope_sd=None, gee_only=False, slope_profile=True):
    """The coverage table, the rejection table and the run's facts of ``n`` datasets."""
    cells = effect_cells() if scenario == "effect" else null_cells()
    if slope_sd is None:
        slope_sd = SLOPE_SD if scenario == "slope" else 0.0
    rec = Recovery(cells, sigma, slope_sd, n_boot, profile, slope_model, slope_profile)
    start = time.process_time()
    for i in range(n):
        rec.dataset(generate(cells, sigma=sigma, seed=seed0 + i, slope_sd=slope_sd), i, gee_only)
        if progress and (i + 1) % 10 == 0:
            print(f"  {i + 1}/{n} datasets, {time.process_time() - start:.0f} s CPU",
                  file=sys.stderr, flush=True)
    cpu = time.process_time() - start
    return rec.tally.table(), rec.rejection_table(n), {
        "fallbacks": rec.fallbacks, "glmm_failed": rec.glmm_fail,
        "mixed_model_for_mode_contrasts": rec.used, "cpu_s": cpu, "datasets": n,
        "scenario": scenario, "sigma": sigma, "slope_sd": slope_sd, "slope_model": slope_model,
        "seed0": seed0, "n_boot": n_boot, "load_average": os.getloadavg()}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--datasets", type=int, default=200)
    ap.add_argument("--scenario", choices=("null", "effect", "slope"), default="null",
                    help="slope: null cells plus a random mode slope of SD %g" % SLOPE_SD)
    ap.add_argument("--slope-model", action="store_true",
                    help="also fit the random-slope model and measure its intervals (slow)")
    ap.add_argument("--sigma", type=float, default=0.8)
    ap.add_argument("--seed", type=int, default=20261124)
    ap.add_argument("--bootstrap", type=int, default=1000)
    ap.add_argument("--gee-only", action="store_true",
                    help="only the GEE coefficient table's intervals (fast)")
    ap.add_argument("--no-slope-profile", action="store_true",
                    help="skip the slope model's profile intervals of the SDs (their coverage "
                         "is then not measured; about half its CPU)")
    ap.add_argument("--out", type=Path)
    ns = ap.parse_args(argv)
    cov, rej, info = run(ns.datasets, ns.scenario, ns.sigma, ns.seed, ns.bootstrap,
                         slope_model=ns.slope_model or ns.scenario == "slope",
                         gee_only=ns.gee_only, slope_profile=not ns.no_slope_profile)
    pd.set_option("display.width", 200)
    print(f"scenario {ns.scenario}, {ns.datasets} datasets, sigma {ns.sigma}: "
          f"{info['cpu_s']:.0f} s CPU; fallbacks {info['fallbacks']}")
    print(cov.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    if not ns.gee_only:
        print(rej.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    if ns.out:
        ns.out.mkdir(parents=True, exist_ok=True)
        if ns.gee_only:
            cov.to_csv(ns.out / f"coverage_gee_{ns.scenario}.csv", index=False)
            return
        cov.to_csv(ns.out / f"coverage_{ns.scenario}.csv", index=False)
        rej.to_csv(ns.out / f"rejections_{ns.scenario}.csv", index=False)
        (ns.out / f"info_{ns.scenario}.json").write_text(json.dumps(info, indent=2))


if __name__ == "__main__":
    main()
