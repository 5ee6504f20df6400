"""The report's plain-language summary: a few sentences a reader without statistics can follow."""
from __future__ import annotations

import numpy as np
import pandas as pd

from .load import TrialLog
from .models import ModelFit
from .wording import p_text, signed

__all__ = ["plain_summary"]


def _pct(p: float) -> str:
    return f"{100 * p:.0f} %"


def plain_summary(log: TrialLog, proportions: pd.DataFrame, confusion: pd.DataFrame,
                  gee: ModelFit, bayes: ModelFit, contrasts: pd.DataFrame,
                  glmm: ModelFit | None = None, tests: pd.DataFrame | None = None,
                  fidelity: str | None = None, choice=None) -> str:
    """A few sentences a reader without statistics can follow.

    Parameters
    ----------
    log, proportions, confusion, gee, bayes, contrasts, glmm, tests
        As computed by :func:`analyze`. Only Holm-adjusted per-sample results are
        named as significant.
    fidelity : str, optional
        The real-vs-simulated paragraph (:func:`analysis.fidelity.fidelity_paragraph`), placed
        right after the counts.
    choice : analysis.mixed_choice.MixedChoice, optional
        Which mixed model's SDs to quote (the random-slope model when its LR test rejects).

    Returns
    -------
    str
        Markdown paragraphs.
    """
    a = log.analysable
    people = a.drop_duplicates("participant")["group"].value_counts()
    excluded = int((~log.trials["included"]).sum())
    out = [f"{a['participant'].nunique()} participants (group A: {int(people.get('A', 0))}, "
           f"group B: {int(people.get('B', 0))}) gave {len(a)} analysable answers; {excluded} "
           f"logged trials were left out (familiarisation, faults, aborted or superseded attempts)."]
    if fidelity:
        out.append(fidelity)
    out += _mode_lines(a, contrasts)
    out += _gap_line(a)
    out += _pooled_lines(a, proportions)
    out += _confusion_line(confusion)
    out += tests_summary(contrasts, tests)
    out += _spread_lines(glmm, choice)
    notes = gee.notes + (glmm.notes if glmm is not None else []) + bayes.notes
    if notes:
        out.append("Model notes:\n" + "\n".join(f"- {n}" for n in notes))
    return "\n\n".join(out)


def _mode_lines(a: pd.DataFrame, contrasts: pd.DataFrame) -> list[str]:
    """Per mode: each group's share correct and the GEE's A vs B odds ratio."""
    out: list[str] = []
    for mode in ("real", "simulated"):
        sel = a[a["mode"] == mode]
        if sel.empty:
            continue
        rates = sel.groupby("group")["correct"].mean()
        text = ", ".join(f"group {g} {_pct(r)}" for g, r in rates.items())
        line = f"With {mode} samples the answers were correct in {text} of trials (chance: 25 %)."
        row = contrasts[(contrasts["model"] == "gee") & (contrasts["mode"] == mode)
                        & (contrasts["roughness_id"] == 0)]
        if not row.empty and not np.isfinite(row.iloc[0]["ci_low"]):
            line += (f" Group A vs B averaged over the four samples: not tested "
                     f"({str(row.iloc[0]['basis']).removeprefix('not estimable: ')}).")
        elif not row.empty:
            r = row.iloc[0]
            verdict = odds_verdict(r["ci_low"], r["ci_high"])
            line += (f" Averaged over the four samples, the GEE puts group A's odds of a correct "
                     f"answer at {r['odds_ratio_A_vs_B']:.2f} times group B's (95 % CI "
                     f"{np.exp(r['ci_low']):.2f}-{np.exp(r['ci_high']):.2f}, "
                     f"{p_text(r['p_value'])}): {verdict}.")
        out.append(line)
    return out


def _gap_line(a: pd.DataFrame) -> list[str]:
    """Group A minus B per mode, against the paper's Figure 9."""
    out: list[str] = []
    gap = {}
    for mode in ("real", "simulated"):
        rates = a[a["mode"] == mode].groupby("group")["correct"].mean()
        if {"A", "B"} <= set(rates.index):
            gap[mode] = 100 * (rates["A"] - rates["B"])
    if len(gap) == 2:
        out.append(f"The paper (Figure 9, §3.2) reports group A above group B with real samples "
                   f"and a smaller difference with simulated ones; here group A minus group B is "
                   f"{gap['real']:+.1f} percentage points with real samples and "
                   f"{gap['simulated']:+.1f} with simulated ones.")
    return out


def _pooled_lines(a: pd.DataFrame, proportions: pd.DataFrame) -> list[str]:
    """Proportion correct per sample, and the cells below chance."""
    out: list[str] = []
    if not proportions.empty:
        by_r = a.groupby("roughness_id")["correct"].mean()
        out.append("Pooled over groups and modes, the proportion correct was "
                   + ", ".join(f"{_pct(v)} for {r}#" for r, v in by_r.items()) + ".")
    below = proportions[proportions["boot_high"] < 0.25]
    if not below.empty:
        out.append("Below chance (whole bootstrap interval under 0.25): " + ", ".join(
            f"group {r.group} {r.mode} {r.roughness_id}# ({_pct(r.proportion_correct)})"
            for r in below.itertuples()) + "; these samples are systematically named as another "
            "one (see the confusion matrices).")
    return out


def _confusion_line(confusion: pd.DataFrame) -> list[str]:
    """The sample most often confused with the others, per mode."""
    out: list[str] = []
    if not confusion.empty:
        worst_by_mode = []
        for mode in ("real", "simulated"):
            conf = confusion[confusion["mode"] == mode]
            if conf.empty:
                continue
            diag = conf[conf["stimulus_roughness_id"] == conf["response_id"]]
            worst = diag.groupby("stimulus_roughness_id")["n_trials"].sum() / \
                conf.groupby("stimulus_roughness_id")["n_trials"].sum()
            worst_by_mode.append(f"with {mode} samples {int(worst.idxmin())}# "
                                 f"(named correctly in {_pct(worst.min())} of its trials)")
        out.append("The sample most often confused with the others was, "
                   + "; ".join(worst_by_mode) + ".")
    return out


def _spread_lines(glmm, choice) -> list[str]:
    """The participants' spread from the mixed model the choice quotes."""
    out: list[str] = []
    spread = choice.spread if choice is not None else glmm
    if spread is not None and spread.kind == "glmm-slope" and spread.formula is not None:
        t = spread.table.set_index("term")
        s0, s1 = t.loc["sd_intercept"], t.loc["sd_mode_slope"]
        out.append(f"The participants differ in how much better they do with real than with "
                   f"simulated samples (LR test of a random mode slope: p = {choice.lrt_p:.3f}), so "
                   f"the spread comes from the random-slope mixed logit: participant SD "
                   f"{s0['log_odds']:.2f} with real samples (95 % profile interval "
                   f"{s0['ci_low']:.2f}-{s0['ci_high']:.2f}) and SD {s1['log_odds']:.2f} of the "
                   f"simulated-minus-real effect ({s1['ci_low']:.2f}-{s1['ci_high']:.2f}) on the "
                   f"log-odds scale.")
    elif glmm is not None and glmm.formula is not None:
        t = glmm.table.set_index("term")
        sd, icc = t.loc["participant_sd"], t.loc["icc_latent"]
        out.append(f"The mixed logit (maximum likelihood, participant random intercepts) puts the "
                   f"spread between participants at SD {sd['log_odds']:.2f} on the log-odds scale "
                   f"(95 % profile interval {sd['ci_low']:.2f}-{sd['ci_high']:.2f}; latent-scale "
                   f"ICC {icc['log_odds']:.2f}, {icc['ci_low']:.2f}-{icc['ci_high']:.2f}).")
    return out


def odds_verdict(ci_low: float, ci_high: float) -> str:
    """What a log odds ratio's 95 % interval says, in words that match the numbers.

    An interval that excludes 0 shows a difference; one that includes 0 shows neither a
    difference nor its absence (the old wording, "the interval excludes no difference", read
    as the second).
    """
    if ci_low > 0 or ci_high < 0:
        return "the 95 % interval excludes equal odds: the data show a difference"
    return ("the 95 % interval includes equal odds: these data neither show a difference nor "
            "rule one out")


def tests_summary(contrasts: pd.DataFrame, tests: pd.DataFrame | None) -> list[str]:
    """Primary test, omnibus, Holm-adjusted per-sample results, interaction: in words."""
    out = []
    if tests is None or tests.empty:
        return out
    withheld = (tests[tests["test"].astype(str).str.startswith("not tested")]
                if "test" in tests else tests.iloc[:0])
    if not withheld.empty:
        for reason, rows in withheld.groupby("test", sort=False):
            roles = ", ".join(dict.fromkeys(rows["role"]))
            out.append(f"Not tested ({roles}; {len(rows)} row(s) of tests.csv): "
                       f"{str(reason).removeprefix('not tested: ')}. Their estimates, where "
                       f"there are any, are in tests.csv without intervals or p-values.")
        tests = tests.drop(withheld.index)
    by_role = {role: sel for role, sel in tests.groupby("role")}
    if "primary" in by_role:
        r = by_role["primary"].iloc[0]
        out.append(f"Primary test (the paper's claim: group A vs B with real samples, averaged "
                   f"over the four samples; GEE, {r.test}): log odds ratio "
                   f"{signed(r.estimate, 2)} (95 % CI {signed(r.ci_low, 2)} to "
                   f"{signed(r.ci_high, 2)}), {p_text(r.p_value)}; difference of mean "
                   f"proportions {signed(100 * r.difference)} percentage points "
                   f"({signed(100 * r.difference_ci_low)} to "
                   f"{signed(100 * r.difference_ci_high)}).")
    if "omnibus" in by_role:
        r = by_role["omnibus"].iloc[0]
        out.append(f"Omnibus test of any group difference on any sample ({r.test}; "
                   f"F = {r.statistic:.2f}): {p_text(r.p_value)}.")
    per = by_role.get("per-sample")
    if per is not None and not per.empty:
        missing = per[per["p_value"].isna()]
        if not missing.empty:
            out.append("No group comparison is possible for " + ", ".join(missing["compares"].map(
                lambda c: c.split(",")[1].strip() if "," in c else c))
                + " (a group answered it all right or all wrong).")
        sig = per[per["p_holm"] < 0.05]
        n_tests = int(per["p_value"].notna().sum())
        omnibus = by_role.get("omnibus")
        gate = None if omnibus is None else float(omnibus["p_value"].iloc[0])
        smallest = p_text(per["p_holm"].min()).removeprefix("p = ").removeprefix("p ")
        if gate is not None and not gate < 0.05:
            out.append(f"The omnibus test does not reject ({p_text(gate)}), so no single sample "
                       f"is claimed to differ between the groups (Holm-adjusted per-sample "
                       f"p-values are in tests.csv; the smallest is {smallest}); this is not "
                       f"evidence that the groups are alike.")
        elif sig.empty and gate is not None:
            out.append(f"The omnibus test rejects ({p_text(gate)}): the groups differ on at "
                       f"least one sample in one mode, but after Holm's adjustment for the "
                       f"{n_tests} per-sample comparisons none of them on its own is significant "
                       f"at 0.05 (smallest adjusted p {smallest}): the data do not say which.")
        elif sig.empty:
            out.append(f"After Holm's adjustment for the {n_tests} per-sample comparisons, no "
                       f"single sample's group difference is significant at 0.05 (smallest "
                       f"adjusted p {smallest}); this does not show that the samples do not "
                       f"differ.")
        else:
            out.append(f"After Holm's adjustment for the {n_tests} per-sample comparisons, the "
                       f"group difference remains for: " + "; ".join(
                           f"{r.compares.split(':')[0]} (adjusted {p_text(r.p_holm)})"
                           for r in sig.itertuples()) + ".")
        if (per["basis"].astype(str).str.startswith("per-sample")).any():
            out.append("Per-sample group comparisons come from a GEE of each sample's trials "
                       "alone (the full model could not be fitted; see the model notes).")
    inter = by_role.get("interaction")
    if inter is not None and not inter.empty:
        r = inter[inter["model"] == "gee"].iloc[0] if (inter["model"] == "gee").any() \
            else inter.iloc[0]
        if np.isfinite(r.estimate):
            out.append(f"Group x mode interaction (is the A-B gap different with real and simulated "
                       f"samples?): difference of the two A-B log odds ratios "
                       f"{signed(r.estimate, 2)} (95 % CI {signed(r.ci_low, 2)} to "
                       f"{signed(r.ci_high, 2)}), {r.test} {p_text(r.p_value)}; as proportions, "
                       f"{signed(100 * r.difference)} percentage points "
                       f"({signed(100 * r.difference_ci_low)} to "
                       f"{signed(100 * r.difference_ci_high)}).")
    return out
