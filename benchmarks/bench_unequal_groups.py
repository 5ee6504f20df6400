"""Size and coverage of the GEE's group comparisons with unequal groups (Welch-Satterthwaite df,
Nel-van der Merwe omnibus test), against the old t(m - 2) and F(q, m - q).

Not a test. Datasets from ``tests/analysis/generator.py`` (independent of the code under test):
no group effect anywhere (``null_cells``), random intercepts SD 0.8, 3 repetitions, 3 % of
trials lost. Per dataset only what the rows need: one ``fit_gee``, the omnibus test, the
primary (A - B, real, averaged) row, the GEE interaction, the both-groups real - simulated row
(``mode_contrasts``). Truths (population-averaged) by 80-node Gauss-Hermite over the random
effects. Scenarios:

    balanced   15 + 15
    20+8       20 + 8
    24+6       24 + 6
    slope      20 + 8 with a random mode slope (SD 0.8)
    halfmiss   15 + 15, half the participants lose a random half of their trials

    nice -n 10 .venv/bin/python benchmarks/bench_unequal_groups.py --scenario 20+8 --datasets 300

``--mixed`` adds the random-slope mixed model's rows (:func:`mixed_rows`), ``--mixed-only`` fits
that model alone, ``--rows`` keeps every dataset's rows for ``benchmarks/mixed_se_rules.py``.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from scipy import stats
from scipy.special import expit, logit

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests" / "analysis"))

from analysis import fit_gee  # noqa: E402
from analysis.glmm_slope import (_person_groups, _sandwich_sum, fit_glmm_slope,  # noqa: E402
                                 score_parts, slope_data)
from analysis.models import FORMULA, model_data  # noqa: E402
from analysis.fidelity import _rows, mode_contrasts  # noqa: E402
from analysis.small_sample import welch_df  # noqa: E402
from analysis.inference import averaged_contrast, interaction_test, omnibus_group_test  # noqa: E402
from generator import generate, null_cells  # noqa: E402

SCENARIOS = {"balanced": (15, 15, 0.0, False), "20+8": (20, 8, 0.0, False),
             "24+6": (24, 6, 0.0, False), "slope": (20, 8, 0.8, False),
             "halfmiss": (15, 15, 0.0, True)}
SIGMA = 0.8


def truth(cells: dict, slope_sd: float) -> dict:
    """Population-averaged real - simulated (both groups equally weighted): log odds ratio of
    the mean marginal log odds, difference of mean marginal proportions."""
    z, w = np.polynomial.hermite_e.hermegauss(80)
    w = w / w.sum()
    sd = {"real": SIGMA, "simulated": np.hypot(SIGMA, slope_sd)}
    marg = {k: float(w @ expit(logit(p) + sd[k[1]] * z)) for k, p in cells.items()}
    lo = {m: np.mean([logit(v) for k, v in marg.items() if k[1] == m]) for m in sd}
    pr = {m: np.mean([v for k, v in marg.items() if k[1] == m]) for m in sd}
    cond = {m: np.mean([logit(p) for k, p in cells.items() if k[1] == m]) for m in sd}
    return {"log_odds": lo["real"] - lo["simulated"], "difference": pr["real"] - pr["simulated"],
            "conditional": cond["real"] - cond["simulated"]}


def mixed_rows(trials, target_conditional: float) -> dict:
    """The random-slope mixed model's real - simulated rows (group A, B, both; log odds for a
    typical participant, whose truth is the generator's conditional cells) and its interaction
    (true value 0), as reported (SE the CR2 participant sandwich, Bell-McCaffrey df of
    ``analysis.small_sample.row_df``); "old" the same rows under the rule before: SE the larger
    of the model-based SE and the Mancl-DeRouen (MD) sandwich, df Welch-Satterthwaite of the MD
    sandwich's group parts where it was the larger, else t(m - 2). Each row also keeps its
    error and every candidate variance (model-based, CR0 = no leverage adjustment, MD, CR2),
    for ``benchmarks/mixed_se_rules.py``."""
    fit = fit_glmm_slope(trials, profile=False)
    if fit.formula is None:
        return {}
    fid = mode_contrasts(fit, trials, margin_pp=10)
    inter = interaction_test(fit, trials)
    m_all = trials["participant"].nunique()
    out = {"mixed_full_formula": fit.formula == FORMULA and fit.cov_robust is not None}
    if not out["mixed_full_formula"]:
        return out
    data_t = model_data(trials)
    _, _, data, z = slope_data(fit.formula, data_t)
    s, a_i = score_parts(fit.theta, data, z)
    people = _person_groups(data_t)
    parts = {name: _sandwich_sum(s, a_i, people, name)[1] for name in ("MD", "CR2")}
    parts["CR0"] = {g: (np.linalg.inv(a_i.sum(0)) @ s[people == g].T @ s[people == g]
                        @ np.linalg.inv(a_i.sum(0)), int((people == g).sum())) for g in ("A", "B")}
    samples = sorted(trials["roughness_id"].unique())
    rows = {g: (fid[(fid["role"] == "averaged") & (fid["group"] == g)].iloc[0],
                (_rows(fit, ["A", "B"] if g == "both" else [g], "real", samples).mean(axis=0)
                 - _rows(fit, ["A", "B"] if g == "both" else [g], "simulated", samples)
                 .mean(axis=0)), target_conditional) for g in ("A", "B", "both")}
    x = {(g, mo): _rows(fit, [g], mo, samples) for g in ("A", "B") for mo in ("real", "simulated")}
    sign = {("A", "real"): 1, ("B", "real"): -1, ("A", "simulated"): -1, ("B", "simulated"): 1}
    inter_row = {"estimate": inter["log_odds"], "ci_low": inter["ci_low"],
                 "ci_high": inter["ci_high"], "df": inter["df"], "se": inter["se"]}
    rows["interaction"] = (inter_row, sum(sg * x[k].mean(axis=0) for k, sg in sign.items()), 0.0)
    for g, (r, lvec, truth_g) in rows.items():
        err = float(r["estimate"] - truth_g)
        var = {"model": float(lvec @ fit.cov @ lvec)}
        var.update({k: float(sum(lvec @ w @ lvec for w, _ in p.values()))
                    for k, p in parts.items()})
        old_var = max(var["model"], var["MD"])
        old_df = welch_df(parts["MD"], lvec) if var["MD"] > var["model"] else m_all - 2
        old_half = stats.t.ppf(0.975, old_df) * np.sqrt(old_var)
        out[f"mixed_{g}_cover"] = bool(r["ci_low"] <= truth_g <= r["ci_high"])
        out[f"mixed_{g}_old_cover"] = bool(abs(err) <= old_half)
        out[f"mixed_{g}_width_ratio_new_to_old"] = float((r["ci_high"] - r["ci_low"])
                                                         / (2 * old_half))
        out[f"mixed_{g}_df"] = float(r["df"])
        out[f"mixed_{g}_old_df"] = float(old_df)
        out[f"mixed_{g}_error"] = err
        for k, v in var.items():
            out[f"mixed_{g}_var_{k}"] = v
        for k in ("MD", "CR2", "CR0"):
            out[f"mixed_{g}_welch_df_{k}"] = float(welch_df(parts[k], lvec))
    out["mixed_interaction_reject"] = not out.pop("mixed_interaction_cover")
    out["mixed_interaction_old_reject"] = not out.pop("mixed_interaction_old_cover")
    return out


def one(seed: int, n_a: int, n_b: int, slope_sd: float, halfmiss: bool, target: dict,
        mixed: bool = False, gee: bool = True) -> dict:
    trials = generate(null_cells(), n_a=n_a, n_b=n_b, sigma=SIGMA, seed=seed, slope_sd=slope_sd)
    if halfmiss:
        rng = np.random.default_rng(seed + 10**6)
        people = trials["participant"].unique()
        hit = set(rng.choice(people, len(people) // 2, replace=False))
        drop = trials["participant"].isin(hit) & (rng.random(len(trials)) < 0.5)
        trials = trials[~drop].reset_index(drop=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if not gee:
            return mixed_rows(trials, target["conditional"])
        fit = fit_gee(trials)
        m = trials["participant"].nunique()
        omni = omnibus_group_test(fit, trials)
        prim = averaged_contrast(fit, "real")
        inter = interaction_test(fit, trials)
        fid = mode_contrasts(fit, trials, margin_pp=10)
        extra = mixed_rows(trials, target["conditional"]) if mixed else {}
    both = fid[(fid["role"] == "averaged") & (fid["group"] == "both")].iloc[0]
    old_f = omni["chi2"] * (m - 8) / (8 * (m - 1))
    t_old = stats.t.ppf(0.975, m - 2)
    return {
        "omnibus_tested": bool(np.isfinite(omni["p_value"])),
        "omnibus_reject": bool(omni["p_value"] < 0.05),
        "omnibus_old_reject": bool(stats.f.sf(old_f, 8, m - 8) < 0.05),
        "primary_reject": bool(prim["p_value"] < 0.05),
        "primary_old_reject": bool(2 * stats.t.sf(abs(prim["log_odds_ratio"] / prim["se"]), m - 2)
                                   < 0.05),
        "primary_df": float(prim["df"]),
        "interaction_reject": bool(inter["p_value"] < 0.05),
        "both_cover": bool(both["ci_low"] <= target["log_odds"] <= both["ci_high"]),
        "both_cover_difference": bool(both["difference_ci_low"] <= target["difference"]
                                      <= both["difference_ci_high"]),
        "both_old_cover": bool(abs(both["estimate"] - target["log_odds"]) <= t_old * both["se"]),
        "both_df": float(both["df"]),
        **extra,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", choices=sorted(SCENARIOS), required=True)
    ap.add_argument("--datasets", type=int, default=300)
    ap.add_argument("--seed", type=int, default=36000000)
    ap.add_argument("--out", type=Path, default=None, help="JSON file for the tallies")
    ap.add_argument("--mixed", action="store_true",
                    help="also the random-slope mixed model's rows (about 1.5 s more a dataset)")
    ap.add_argument("--mixed-only", action="store_true",
                    help="the mixed model's rows alone (no GEE: about 0.5 s CPU a dataset)")
    ap.add_argument("--rows", type=Path, default=None,
                    help="JSON file for every dataset's row (with --mixed: each mixed row's "
                         "error, model-based and sandwich variances, Welch df)")
    ns = ap.parse_args()
    n_a, n_b, slope_sd, halfmiss = SCENARIOS[ns.scenario]
    target = truth(null_cells(), slope_sd)
    start, cpu = time.time(), time.process_time()
    rows = []
    for i in range(ns.datasets):
        rows.append(one(ns.seed + i, n_a, n_b, slope_sd, halfmiss, target,
                        ns.mixed or ns.mixed_only, not ns.mixed_only))
        if ns.out and (i + 1) % 25 == 0:        # a partial tally survives a stopped run
            ns.out.write_text(json.dumps(tally(rows, ns, start, cpu), indent=1))
        if ns.rows and (i + 1) % 25 == 0:
            ns.rows.write_text(json.dumps(rows))
    text = json.dumps(tally(rows, ns, start, cpu), indent=1)
    print(text)
    if ns.out:
        ns.out.write_text(text)
    if ns.rows:
        ns.rows.write_text(json.dumps(rows))


def tally(rows: list, ns, start: float, cpu: float) -> dict:
    """Rejection rates and coverages with binomial SEs over the datasets run so far."""
    n_a, n_b, slope_sd, _ = SCENARIOS[ns.scenario]
    n = len(rows)
    out = {"scenario": ns.scenario, "datasets": n, "n_a": n_a, "n_b": n_b, "slope_sd": slope_sd,
           "seed": ns.seed, "cpu_s": round(time.process_time() - cpu, 1),
           "wall_s": round(time.time() - start, 1)}
    for key in dict.fromkeys(k for r in rows for k in r):
        if key.endswith("_error") or "_var_" in key:
            continue                            # raw parts: in --rows only
        values = np.array([r[key] for r in rows if key in r], float)
        if "_df" in key or key.endswith("_ratio_new_to_old"):
            out[key + "_median"] = float(np.median(values))
            continue
        p = float(values.mean())
        out[key] = [round(p, 4), round(float(np.sqrt(p * (1 - p) / len(values))), 4)]
        if len(values) < n:
            out[key].append(len(values))
    tested = [r for r in rows if r.get("omnibus_tested")]
    if tested:
        out["omnibus_reject_when_tested"] = round(
            float(np.mean([r["omnibus_reject"] for r in tested])), 4)
    return out


if __name__ == "__main__":
    main()
