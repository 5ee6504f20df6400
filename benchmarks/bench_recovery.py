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


def run(n, scenario, sigma, seed0, n_boot, progress=True, profile=True, slope_model=False,
        slope_sd=None, gee_only=False, slope_profile=True):
    cells = effect_cells() if scenario == "effect" else null_cells()
    if slope_sd is None:
        slope_sd = SLOPE_SD if scenario == "slope" else 0.0
    truth = truths(cells, sigma, slope_sd)
    # with a true random slope the intercept-only mixed model is misspecified: its intervals
    # have no true value to cover and are not tallied (the GEE's and the cells' still do)
    intercept_model_ok = slope_sd == 0
    grid = pd.DataFrame([(g, m, r, 0, "x") for (g, m, r) in cells],
                        columns=["group", "mode", "roughness_id", "correct", "participant"])
    cond_logit = logit(np.array([cells[k] for k in cells]))
    marg_logit = logit(np.array([truth["marg"][k] for k in cells]))
    tally = Tally()
    rejections = {k: 0 for k in ("primary (GEE averaged A-B, real)", "omnibus (GEE, 8 df)",
                                 "any per-sample, unadjusted", "any per-sample, Holm",
                                 "interaction (GEE)", "interaction (mixed model as reported)",
                                 "interaction (GLMM, intercept only)",
                                 "GLMM group[T.B] (real 1#)",
                                 "slope model: LR test of the random slope")}
    fallbacks = {"gee": 0, "glmm": 0}
    used = {"slope model": 0, "intercept model": 0}
    glmm_fail = 0
    start = time.process_time()
    for i in range(n):
        trials = generate(cells, sigma=sigma, seed=seed0 + i, slope_sd=slope_sd)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            gee = fit_gee(trials)
        fallbacks["gee"] += gee.formula != FORMULA
        if gee.formula == FORMULA:      # the GEE table's coefficients: population-averaged truth
            x = np.asarray(patsy.build_design_matrices([gee.design_info], grid)[0])
            beta_true = np.linalg.lstsq(x, marg_logit, rcond=None)[0]
            for row, b in zip(gee.table.iloc[: len(beta_true)].itertuples(), beta_true):
                tally.add("gee coefficients (Wald)", row.ci_low, row.ci_high, b)
        if gee_only:
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            props = cell_proportions(trials, n_boot=n_boot, seed=i)
            glmm = fit_glmm(trials, profile=profile)
        fallbacks["glmm"] += glmm.formula != FORMULA
        for row in props.itertuples():
            t = truth["marg"][(row.group, row.mode, row.roughness_id)]
            tally.add("cell: participant bootstrap", row.boot_low, row.boot_high, t)
            tally.add("cell: Wilson (trials independent)", row.wilson_low, row.wilson_high, t)
        contrasts = group_contrasts(gee, trials)
        if glmm.formula is not None and intercept_model_ok:
            gc = group_contrasts(glmm, trials)
            gc["model"] = "glmm"
            contrasts = pd.concat([contrasts, gc], ignore_index=True)
        for row in contrasts.itertuples():
            scale = "gee" if row.model == "gee" else "glmm"
            lor, diff = truth[(scale, row.mode, row.roughness_id)]
            which = "averaged" if row.roughness_id == 0 else "per-sample"
            tally.add(f"{scale} contrast {which}: log odds ratio", row.ci_low, row.ci_high, lor)
            tally.add(f"{scale} contrast {which}: proportion difference", row.difference_low,
                      row.difference_high, diff)
        sl = None
        if slope_model and glmm.formula is not None:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                sl = fit_glmm_slope(trials, glmm.formula, intercept_fit=glmm,
                                    profile=slope_profile)
        # the mixed model the report uses for mode contrasts (analysis.mixed_choice)
        choice = choose_mixed(glmm if glmm.formula else None, sl)
        reported_ok = choice.contrasts is not None and (
            choice.contrasts.kind == "glmm-slope" or intercept_model_ok)
        tests = tests_table(gee, choice.contrasts, contrasts[contrasts["model"] == "gee"],
                            trials)
        for fit in (gee, choice.contrasts):
            if fit is None or (fit.kind != "gee" and not reported_ok):
                continue
            scale = "gee" if fit.kind == "gee" else "glmm"
            label = "gee" if fit.kind == "gee" else "mixed (as reported)"
            fid = mode_contrasts(fit, trials, margin_pp=10)
            for row in fid[fid["role"] == "averaged"].itertuples():
                lor, diff = truth[(scale, "mode", row.group)]
                tally.add(f"{label} real - simulated averaged: log odds", row.ci_low,
                          row.ci_high, lor)
                tally.add(f"{label} real - simulated averaged: proportions",
                          row.difference_ci_low, row.difference_ci_high, diff)
                # the same by row: group A (t(12)), group B (t(16)), both groups (t(28))
                tally.add(f"{label} real - simulated, group {row.group}: log odds", row.ci_low,
                          row.ci_high, lor)
                tally.add(f"{label} real - simulated, group {row.group}: proportions",
                          row.difference_ci_low, row.difference_ci_high, diff)
        if choice.contrasts is not None:
            used["slope model" if choice.contrasts.kind == "glmm-slope" else "intercept model"] += 1
        for row in tests.itertuples():
            if row.role == "interaction" and row.model != "gee" and reported_ok:
                lor, dd = truth[("glmm", "interaction")]
                tally.add("mixed interaction as reported: log odds", row.ci_low, row.ci_high, lor)
                tally.add("mixed interaction as reported: proportions", row.difference_ci_low,
                          row.difference_ci_high, dd)
            if row.role == "interaction" and row.model == "gee":
                lor, dd = truth[(row.model, "interaction")]
                tally.add(f"{row.model} interaction: log odds", row.ci_low, row.ci_high, lor)
                tally.add(f"{row.model} interaction: proportions", row.difference_ci_low,
                          row.difference_ci_high, dd)
        roles = tests.groupby("role")
        p = {role: sel["p_value"].to_numpy(float) for role, sel in roles}
        rejections["primary (GEE averaged A-B, real)"] += bool(p.get("primary", [1])[0] < 0.05)
        rejections["omnibus (GEE, 8 df)"] += bool(p.get("omnibus", [1])[0] < 0.05)
        per = tests[tests["role"] == "per-sample"]
        rejections["any per-sample, unadjusted"] += bool((per["p_value"] < 0.05).any())
        rejections["any per-sample, Holm"] += bool((per["p_holm"] < 0.05).any())
        inter = tests[tests["role"] == "interaction"].set_index("model")["p_value"]
        rejections["interaction (GEE)"] += bool(inter.get("gee", 1) < 0.05)
        rejections["interaction (mixed model as reported)"] += bool(
            inter.drop("gee", errors="ignore").min() < 0.05) if len(inter) > 1 else False
        it = interaction_test(glmm, trials) if glmm.formula else None
        rejections["interaction (GLMM, intercept only)"] += bool(
            it is not None and it["p_value"] < 0.05)
        if glmm.formula == FORMULA and intercept_model_ok:
            x = np.asarray(patsy.build_design_matrices([glmm.design_info], grid)[0])
            beta_true = np.linalg.lstsq(x, cond_logit, rcond=None)[0]
            fixed = glmm.table.iloc[: len(beta_true)]
            for row, b in zip(fixed.itertuples(), beta_true):
                tally.add("glmm fixed effects (Wald)", row.ci_low, row.ci_high, b)
            g = fixed.set_index("term").loc["group[T.B]"]
            rejections["GLMM group[T.B] (real 1#)"] += bool(g["p_value"] < 0.05)
        if glmm.formula is not None and intercept_model_ok:
            t = glmm.table.set_index("term")
            how = "profile" if profile else "Wald on log SD"
            tally.add(f"glmm participant SD ({how})", t.loc["participant_sd", "ci_low"],
                      t.loc["participant_sd", "ci_high"], sigma)
            tally.add(f"glmm ICC latent ({how})", t.loc["icc_latent", "ci_low"],
                      t.loc["icc_latent", "ci_high"], sigma ** 2 / (sigma ** 2 + np.pi ** 2 / 3))
        elif glmm.formula is None:
            glmm_fail += 1
        if sl is not None:
            if sl.formula is None:
                glmm_fail += 1
            else:
                t = sl.table.set_index("term")
                if sl.formula == FORMULA:
                    x = np.asarray(patsy.build_design_matrices([sl.design_info], grid)[0])
                    beta_true = np.linalg.lstsq(x, cond_logit, rcond=None)[0]
                    for row, b in zip(sl.table.iloc[: len(beta_true)].itertuples(), beta_true):
                        tally.add("slope model fixed effects (Wald)", row.ci_low, row.ci_high, b)
                for term, truth_v in (("sd_intercept", sigma), ("sd_mode_slope", slope_sd),
                                      ("corr_intercept_slope", 0.0 if slope_sd > 0 else None)):
                    if truth_v is not None and slope_profile:
                        tally.add(f"slope model {term} (profile)", t.loc[term, "ci_low"],
                                  t.loc[term, "ci_high"], truth_v)
                if "lrt_slope" in t.index:
                    rejections["slope model: LR test of the random slope"] += \
                        bool(t.loc["lrt_slope", "p_value"] < 0.05)
        chance = chance_tests(trials)
        for row in chance.itertuples():
            if row.family == "cell":
                t = truth["marg"][(row.group, row.mode, row.roughness_id)]
            else:
                t = np.mean([truth["marg"][(row.group, row.mode, r)] for r in range(1, 5)])
            tally.add(f"chance t interval ({row.family})", row.t_low, row.t_high, t)
        if progress and (i + 1) % 10 == 0:
            print(f"  {i + 1}/{n} datasets, {time.process_time() - start:.0f} s CPU",
                  file=sys.stderr, flush=True)
    cpu = time.process_time() - start
    if not slope_model:
        del rejections["slope model: LR test of the random slope"]
    rej = pd.DataFrame([{"test": k, "rejections": v, "datasets": n, "rate": v / n,
                         "binomial_se": np.sqrt(max(v / n * (1 - v / n), 1e-12) / n)}
                        for k, v in rejections.items()])
    return tally.table(), rej, {"fallbacks": fallbacks, "glmm_failed": glmm_fail,
                                "mixed_model_for_mode_contrasts": used,
                                "cpu_s": cpu, "datasets": n, "scenario": scenario,
                                "sigma": sigma, "slope_sd": slope_sd, "slope_model": slope_model,
                                "seed0": seed0, "n_boot": n_boot,
                                "load_average": os.getloadavg()}


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
