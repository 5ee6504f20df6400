"""``reproduce figure9``'s written outputs: tables, ``figure9.png`` and ``report.md``'s opening.

:func:`write_outputs` writes them from a :class:`.scenarios.ScenarioResult` and the sensitivity
table, whether they were just simulated (:func:`.reproduction.run_reproduction`) or read back
from the per-study tables (:func:`.reproduction.recompute_from`).
"""
from __future__ import annotations

from pathlib import Path

import pandas as pd

from .precision import MARK, MC_LEVEL, THRESHOLD
from .verdict import (PRINTED, READING_TEXT, bias_text, claim_statuses, claims_held,
                      claims_screen, reproducing_scenarios, scenario_statuses, verdict_line)

__all__ = ["write_outputs", "write_figure", "planner_note", "depth_paragraph", "depth_text"]

_LEVEL = f"{MC_LEVEL * 100:g} %"


def write_figure(out_dir, result, observed, headline, best, n_sessions) -> list:
    """``figure9.png`` / ``.pdf``: the printed Eq. 7 and the headline, as distributions (it
    needs neither the sensitivity table nor the depth fit: ``reproduce figure9`` draws it while
    the fit's studies run)."""
    from experiments.simulation.figure9.plot import claims_note, plot_figure9_distribution
    from experiments.simulation.replay import REPLAY_HYPOTHESES
    props = result.proportions
    n = result.n_studies()

    def rows(scenario):
        return props[(props.hypothesis == scenario[0]) & (props.observer == scenario[1])]
    held_d, total = claims_held(result, headline, "descriptive")
    held_i, _ = claims_held(result, headline, "inferential")
    status = scenario_statuses(result, "descriptive")[tuple(headline)]
    if headline != best["descriptive"]:
        named = "Scenario chosen by --replay/--observer"
    else:
        named = f"Best match (descriptive reading): {status}"
    return plot_figure9_distribution(
        rows(PRINTED), rows(headline), observed, Path(out_dir) / "figure9.png",
        left_title=(f"Figure 9 as the paper's method predicts it\n"
                    f"{REPLAY_HYPOTHESES[PRINTED[0]].label} replay\n{PRINTED[1]} observer\n"
                    f"{int(n.loc[PRINTED])} simulated 15+15 studies"),
        right_title=(f"{named}\n{REPLAY_HYPOTHESES[headline[0]].label} replay, {headline[1]} "
                     f"observer\nclaims shown ({_LEVEL} interval above {THRESHOLD:g}): "
                     f"{held_d}/{total} descriptive, {held_i}/{total} inferential\n"
                     f"{int(n.loc[tuple(headline)])} simulated studies"
                     + (f"; large black outlines: the one emulated study ({n_sessions} sessions)" if n_sessions else "")),
        left_note=claims_note(result.claims, PRINTED),
        right_note=claims_note(result.claims, headline))


def _md(df: pd.DataFrame, digits: int = 2) -> str:
    cols = list(df.columns)
    lines = ["| " + " | ".join(cols) + " |", "|" + "|".join("---" for _ in cols) + "|"]
    for row in df.itertuples(index=False):
        lines.append("| " + " | ".join(f"{v:.{digits}f}" if isinstance(v, float) else str(v)
                                       for v in row) + " |")
    return "\n".join(lines)


def _expected_table(result) -> pd.DataFrame:
    """Scenario rows; real and simulated 1#-4# (groups pooled) and A - B, real and simulated.

    Two group-bys over every study's rows (~365,000), not two per scenario and mode (0.76 s
    of the report written at the end): each mean adds the same rows in the same order."""
    p = result.proportions
    keys = ["hypothesis", "observer", "mode"]
    by_sample = p.groupby(keys + ["roughness_id"], sort=False)["expected"].mean().to_dict()
    by_group = p.groupby(keys + ["group"], sort=False)["expected"].mean().to_dict()
    rows = []
    for h, o in dict.fromkeys((h, o) for h, o, *_ in by_sample):
        row = {"replay": h, "observer": o}
        for mode, tag in (("real", "R"), ("simulated", "S")):
            for rid in sorted(r for hh, oo, mm, r in by_sample if (hh, oo, mm) == (h, o, mode)):
                row[f"{tag} {rid}#"] = float(by_sample[h, o, mode, rid])
            row[f"A-B {tag}"] = float(by_group.get((h, o, mode, "A"), float("nan"))
                                      - by_group.get((h, o, mode, "B"), float("nan")))
        rows.append(row)
    return pd.DataFrame(rows)


def _claims_md(result, reading: str) -> str:
    """The claims table of one reading, each row naming its profile model."""
    from analysis.claims import CLAIMS
    from experiments.simulation.replay import REPLAY_HYPOTHESES
    wide = result.wide(reading)
    low, high = result.bounds(reading)
    claims = [c for c in CLAIMS if c.id in wide.columns]
    n = result.n_studies()
    rows = []
    whole, paper = (scenario_statuses(result, reading, paper_only=v) for v in (False, True))
    for k in wide.index:
        st = claim_statuses(result, k, reading)
        row = {"replay": k[0], "profile model": REPLAY_HYPOTHESES[k[0]].profile_model,
               "observer": k[1], "studies": str(int(n.loc[k]))}
        for c in claims:
            s, p, lo, hi = st[c.id]
            row[c.short + ("*" if c.own else "")] = f"{MARK[s]} {p:.2f} [{lo:.2f}, {hi:.2f}]"
        for key, name in (("all", "all"), ("all_paper", "paper")):
            row[name] = f"{wide.loc[k, key]:.2f} [{low.loc[k, key]:.2f}, {high.loc[k, key]:.2f}]"
        row["result"] = whole[k]
        row["paper only"] = paper[k]
        rows.append(row)
    return _md(pd.DataFrame(rows))


def planner_note(settings: dict) -> str:
    """The report's sentences on the scene planner's decisions in the simulated studies: every
    receptor temperature of the person pool (real contacts and replayed profiles) went through
    it; per path, the models chosen, how often, method, tolerance and largest error bound; and
    the models of the 'T2 rise' claim's replayed Table 2 temperatures, per replay."""
    dec = settings.get("planner_decisions") or {}
    parts = []
    for path, what in (("real", "real contacts"), ("display", "replayed profiles felt on the pad")):
        models = "; ".join(f"{m}, method {e['method']}, error bound at most {e['max_bound_K']:.2g} "
                           f"K ({e['count']} evaluations)" for m, e in dec.get(path, {}).items())
        parts.append(f"{what}: {models or 'none recorded'}")
    t2 = settings.get("table2_replay_models") or {}
    t2_text = "; ".join(
        f"{h}: " + ", ".join(f"{e['model']} (method {e['method']}, tolerance "
                             f"{'none' if e['tolerance_K'] is None else format(e['tolerance_K'], 'g')}"
                             f"{'' if e['tolerance_K'] is None else ' K'}, error bound at most "
                             f"{e['max_bound_K']:.2g} K)" for e in models)
        for h, models in t2.items())
    t2_sentence = (f" The 'T2 rise' claim's replayed Table 2 temperatures (20 s, 35 °C skin on "
                   f"24 °C steel), per replay: {t2_text}." if t2_text else "")
    return (f"Every receptor temperature of the simulated persons went through the scene planner "
            f"at a tolerance of {settings.get('model_tolerance_C', float('nan')):g} K (a quarter "
            f"of the smallest difference at the receptors between the stimuli to tell apart, real "
            f"and replayed, not the perceptual floor); models chosen: " + "; ".join(parts) + "."
            + t2_sentence)




def depth_text(record: dict) -> str:
    """The report's paragraph on the receptor depth fitted to the emulated study."""
    profile = record["profile"]
    top = max(profile.values())
    shares = sorted(float(d) for d in profile)
    lo, hi = record["interval_share_of_L"]
    return (f"Receptor depth fitted to the emulated study's real-block answers (profile "
            f"likelihood over depth shares {shares[0]:g}-{shares[-1]:g} of L and noise floors, "
            f"absolute observer, answers treated as independent): "
            f"{record['estimate_share_of_L']:.2f} of L, 95 % likelihood-ratio interval "
            f"{lo:.2f}-{hi:.2f} ("
            + ("identifiable on this grid" if record["identifiable"] else
               "not identifiable: the interval is the whole grid, the profile is flat")
            + f"), noise {record['noise_C']:g} K; log-likelihood relative to the maximum: "
            + ", ".join(f"{d}: {v - top:+.1f}" for d, v in profile.items())
            + ". The paper's own proportions cannot be used the same way: its Figure 9 is "
              "printed as a chart without numbers, and the text gives none.")


def depth_paragraph(sens: pd.DataFrame, depth_record: dict | None) -> str:
    """The verdict paragraph's statement on the receptor depth: the two named hypotheses side by
    side (from the sensitivity rows) and whether the emulated study identifies it."""
    sel = sens[sens["choice"] == "receptor depth (hypothesis)"]
    if sel.empty:
        return ""
    parts = []
    for row in sel.itertuples():
        r = row._asdict()
        parts.append(f"{r['setting']}: A>B R {r['a_above_b_real']:.2f} "
                     f"[{r['a_above_b_real_low']:.2f}, {r['a_above_b_real_high']:.2f}], headline "
                     f"{r['status']} (descriptive), {r['status_inf']} (inferential)")
    fit = ""
    if depth_record is not None:
        lo, hi = depth_record["interval_share_of_L"]
        fit = (f" The emulated study's real-block answers give a depth of "
               f"{depth_record['estimate_share_of_L']:.2f} L with a 95 % likelihood interval "
               f"{lo:.2f}-{hi:.2f} L" + (", the whole grid" if not depth_record["identifiable"]
                                         else ""))
    return ("**The receptor depth is not identifiable from this design, and the verdict is "
            "conditional on it.** The scenarios assume that the cold receptors' depth scales "
            "with skin thickness (0.35-0.45 L); under the other named hypothesis, one fixed "
            "absolute depth for everyone, the groups differ less. Side by side: "
            + "; ".join(parts) + "." + fit + (". " if fit else " ")
            + "Neither the paper nor 30 participants' answers decide between them.")


def _sensitivity_md(sens: pd.DataFrame) -> str:
    """Sensitivity rows: each claim's probability, † where its interval does not overlap the
    default row's, ? where it is undecided at this precision; the headline's result per row."""
    from analysis.claims import CLAIMS
    from .precision import claim_status
    ids = [c.id for c in CLAIMS if c.id in sens.columns] + ["all"]
    rows = []
    for _, r in sens.iterrows():
        differs = set(str(r.get("differs", "") or "").split())
        row = {"choice": r["choice"], "setting": r["setting"], "studies": str(int(r["n_studies"]))}
        for suffix, tag in (("", ""), ("_inf", " inf")):
            for cid in ids:
                c = cid + suffix
                if c not in sens.columns:
                    continue
                s = claim_status(r[c + "_low"], r[c + "_high"]) if cid != "all" else "shown"
                mark = "†" if c in differs else ("?" if s == "undecided" else "")
                short = next((x.short + ("*" if x.own else "") for x in CLAIMS if x.id == cid),
                             "all")
                row[short + tag] = f"{r[c]:.2f}{mark}"
        row["result"] = f"{r['status']} / {r['status_inf']}"
        row["paper only"] = f"{r['paper_status']} / {r['paper_status_inf']}"
        for g in ("A", "B"):
            row[f"p_real_{g}"] = f"{r[f'p_real_{g}']:.2f}"
            row[f"p_sim_{g}"] = f"{r[f'p_sim_{g}']:.2f}"
        note = r.get("note", "")
        row["note"] = note if isinstance(note, str) else ""
        rows.append(row)
    return _md(pd.DataFrame(rows))


def _report_opening(verdict, result, sens, headline, best, sessions_line="", lab=None,
                    depth_record=None) -> str:
    from analysis.claims import CLAIMS
    from experiments.simulation.replay import REPLAY_HYPOTHESES
    from experiments.simulation.studies import __doc__ as studies_doc
    claim_lines = "\n".join(
        f"- **{c.short}** ({c.id}): {c.text}. {c.quote}. Statistic: {c.statistic}. "
        f"Descriptive: {c.descriptive}. Inferential: {c.inferential}."
        + (f" *The project's own criterion*: {c.own}." if c.own else "") for c in CLAIMS)
    hyp_lines = "\n".join(f"- **{h.name}**: {h.label}; plays {h.profile_model}. {h.reason}."
                          for h in REPLAY_HYPOTHESES.values())
    note = studies_doc.split("Where this differs from emulated sessions")[1].split("Everything else")[0]
    note = "\n".join(line for line in note.splitlines() if not set(line.strip()) <= {"-"})
    repro = {r: reproducing_scenarios(result, r) for r in ("descriptive", "inferential")}
    undecided = [k for r in repro for k, s in scenario_statuses(result, r).items() if s == "undecided"]
    title = ("Figure 9, reproduced" if repro["descriptive"] or repro["inferential"] else
             "Figure 9, undecided at this precision" if undecided else
             "Figure 9, not reproduced by any scenario")
    lab_text = ", ".join(f"{k} {v}" for k, v in (lab or {}).items())
    n = result.n_studies()
    sections = []
    for reading in ("descriptive", "inferential"):
        sections.append(
            f"### Claims {READING_TEXT[reading]}\n\n"
            f"Best match: {best[reading][0]} replay, {best[reading][1]} observer; reproducing "
            f"(every claim ✓): {', '.join(f'{h}/{o}' for h, o in repro[reading]) or 'none'}."
            f"\n\n{_claims_md(result, reading)}\n")
    bias = bias_text(result, headline)
    depth = depth_paragraph(sens, depth_record)
    return (f"# {title}\n\n**{verdict}**\n\n"
            + (f"{sessions_line}\n\n" if sessions_line else "")
            + (f"{depth}\n\n" if depth else "")
            + (f"Response bias of the headline scenario: {bias}.\n\n" if bias else "") +
            f"## The paper's claims under each scenario\n\n"
            f"Probability that one simulated 15 + 15 study shows the claim, with its {_LEVEL} "
            f"Wilson score interval over the simulated studies (Bonferroni-corrected 95 % over "
            f"at most five sequential looks). Studies are added per scenario, from "
            f"{result.settings.get('n_studies', int(n.min()))} and doubling, until every "
            f"scenario's result is decided or it has "
            f"{result.settings.get('max_studies', int(n.max()))} (here {int(n.min())}-"
            f"{int(n.max())}); ✓ / ✗ when the interval lies above / below {THRESHOLD:g}, ? "
            f"undecided at this precision. The observer models are applied to simulated "
            f"percepts, with a fresh cohort per study; lab: {lab_text}. * marks a criterion "
            f"that is the project's own reading; 'paper' is every claim without * in one "
            f"study. Headline scenario (its sessions below): {headline[0]} replay, "
            f"{headline[1]} observer (the best match read descriptively unless chosen by "
            f"option). The best match of a reading has the highest probability of showing "
            f"every claim in one study (ties to the higher mean probability of the single "
            f"claims). Every study's statistics and outcomes: `studies.csv` "
            f"(`thermocue reproduce figure9 --from DIR` recomputes this report's tables, verdict "
            f"and figure from it).\n\n"
            + "\n".join(sections) +
            f"\nExpected proportion correct per scenario (mean over the simulated studies, groups "
            f"A and B; every cell's median and 50 / 95 % single-study ranges in "
            f"`scenario_proportions.csv`):\n\n{_md(_expected_table(result))}\n\n"
            f"Claims:\n\n{claim_lines}\n\nReplay hypotheses:\n\n{hyp_lines}\n\n"
            f"Where the simulated studies are not exactly the emulated sessions:\n{note}\n"
            f"{planner_note(result.settings)}\n\n"
            f"## Sensitivity of the headline scenario\n\n"
            f"The headline scenario with one choice changed at a time, studies added by the "
            f"same rule (the cap per row in `studies`); rows that change nothing are the claims "
            f"table's headline studies themselves. Claim columns: probability read "
            f"descriptively, then inferentially (` inf`); † where the row's {_LEVEL} interval "
            f"does not overlap the default's (only then does a row differ from the default), ? "
            f"where it contains {THRESHOLD:g}; result: the headline's result under the row "
            f"(descriptive / inferential), on every claim and on the paper's own; p_*: expected "
            f"proportion correct, mean over samples. A pad sensor lag makes the display drive "
            f"its face ahead of the target (T + tau dT/dt); where that would be faster than the "
            f"display's {result.settings.get('max_rate_C_per_s', 10.0):g} °C/s rate limit the "
            f"face is slewed to it, as the display would. Intervals per row: "
            f"`sensitivity.csv`; every study: `sensitivity_studies.csv`.\n\n"
            f"{_sensitivity_md(sens)}\n\n"
            + (f"{depth_text(depth_record)}\n\n" if depth_record else "") +
            f"The figure: `figure9.png` (and `figure9.pdf`): per cell the median of the "
            f"simulated studies' proportion correct with the middle 50 % and 95 % of them; left, "
            f"the paper's method as printed (printed Eq. 7 replay, absolute observer); right, "
            f"the headline scenario with its one emulated study on top; a third panel lists the "
            f"paper's Figure 9 claims (the paper prints Figure 9 as a chart without numbers, "
            f"so no values are digitised).\n\n---\n\n")


def write_outputs(out_dir, result, sens, headline, best, observed, n_sessions: int,
                  sessions_line: str = "", lab: dict | None = None, depth_record=None,
                  body: bool = True, figure: list | None = None) -> dict:
    """claims.csv, scenario_proportions.csv, sensitivity.csv, figure9.png/.pdf and report.md.

    ``body``: keep what ``report.md`` already holds (the analysis of the sessions) after the
    new opening.  ``figure``: the figure's files, already written by :func:`write_figure` with
    the same arguments (default: drawn here).  Returns ``files``, ``verdict``, ``screen``.
    """
    from analysis.exports import write_csv        # whole or not at all
    from sessionfiles.logbook import atomic_write_text
    out_dir = Path(out_dir)
    write_csv(result.claims, out_dir / "claims.csv")
    write_csv(result.proportions, out_dir / "scenario_proportions.csv")
    write_csv(sens, out_dir / "sensitivity.csv")
    files = (figure if figure is not None
             else write_figure(out_dir, result, observed, headline, best, n_sessions))
    verdict = verdict_line(result)
    screen = claims_screen(result, headline)
    report = out_dir / "report.md"
    opening = _report_opening(verdict, result, sens, headline, best, sessions_line, lab,
                              depth_record)
    rest = report.read_text(encoding="utf-8") if body and report.is_file() else ""
    atomic_write_text(report, opening + rest)
    return {"files": files, "verdict": verdict, "screen": screen}
