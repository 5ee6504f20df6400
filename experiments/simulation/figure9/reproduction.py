"""``thermocue reproduce figure9``: the paper's claims under every scenario, then the headline study.

1. A pool of simulated persons and many simulated 15 + 15 studies per (replay hypothesis x
   observer) scenario (:mod:`.scenarios`): the probability that a study shows each of the
   paper's claims (:mod:`analysis.claims`), and the expected proportions correct.
2. The headline scenario (the best match to the paper's evidence unless ``--replay`` /
   ``--observer`` say otherwise) run as the 30-participant study on the emulated display
   (:func:`experiments.simulation.figure9.study.run_figure9_study`), with its analysis.
3. ``figure9.png`` / ``.pdf``: the paper's method as printed (material-side replay, absolute
   observer; expected proportions) beside the headline's 30 emulated sessions; ``report.md``
   opening with the verdict, the claims table and the sensitivity table; the claims table last
   on the terminal.
"""
from __future__ import annotations

import json
import logging
import time
from pathlib import Path

import pandas as pd

__all__ = ["run_reproduction", "claims_screen", "verdict_line", "sessions_claims_line", "PRINTED",
           "claims_held", "reproducing_scenarios"]

#: The paper's method as printed: Eq. 7's material side, judged as the project's original
#: absolute observer did.
PRINTED = ("printed", "absolute")
#: A claim is marked as reproduced (✓) in a scenario when at least this share of simulated
#: studies shows it.
MAJORITY = 0.5

log = logging.getLogger("thermocue.study")


def _mark(p: float) -> str:
    return f"{'✓' if p >= MAJORITY else '✗'}{p:4.2f}"


def claims_screen(result, headline=None) -> str:
    """The one-screen claims table: scenario rows, claim columns, ✓/✗ with the probability."""
    from analysis.claims import CLAIMS
    wide = result.wide()
    shorts = [c.short for c in CLAIMS if c.id in wide.columns] + ["all"]
    ids = [c.id for c in CLAIMS if c.id in wide.columns] + ["all"]
    head = f"{'replay':<12}{'observer':<16}" + "".join(f"{s:>10}" for s in shorts)
    lines = [head, "-" * len(head)]
    for (h, o), row in wide.iterrows():
        star = " <- headline" if headline == (h, o) else ""
        lines.append(f"{h:<12}{o:<16}" + "".join(f"{_mark(row[i]):>10}" for i in ids) + star)
    n = int(result.claims["n_studies"].iloc[0])
    lines.append(f"probability that a simulated 15+15 study shows the claim ({n} studies per "
                 f"scenario); ✓ when ≥ {MAJORITY:g}; 'all': every claim in the same study")
    return "\n".join(lines)


def claims_held(result, scenario) -> tuple[int, int]:
    """``(claims shown by at least MAJORITY of studies, claims)`` of one scenario."""
    from analysis.claims import CLAIMS
    wide = result.wide()
    ids = [c.id for c in CLAIMS if c.id in wide.columns]
    row = wide.loc[tuple(scenario)]
    return sum(bool(row[i] >= MAJORITY) for i in ids), len(ids)


def reproducing_scenarios(result) -> list:
    """Scenarios in which every claim is shown by at least MAJORITY of simulated studies."""
    return [k for k in result.wide().index if claims_held(result, k)[0] == claims_held(result, k)[1]]


def verdict_line(result, best) -> str:
    """One line: are the paper's claims reproduced, and under which hypothesis.

    A scenario *reproduces* the paper when every claim is shown by at least :data:`MAJORITY`
    of its simulated studies.  When none does, the line says so first and then names the best
    match by :func:`.scenarios.best_scenario`'s rule, with the scenarios tied with it on that
    rule's first key and those within its Monte-Carlo interval.
    """
    from analysis.claims import CLAIMS
    from experiments.simulation.replay import REPLAY_HYPOTHESES
    from experiments.simulation.figure9.scenarios import tied_scenarios
    wide = result.wide()
    ids = [c.id for c in CLAIMS if c.id in wide.columns]
    row = wide.loc[best]
    failed = [f"{c.short} {row[c.id]:.2f}" for c in CLAIMS if c.id in ids and row[c.id] < MAJORITY]
    printed = wide.loc[[k for k in wide.index if k[0] == PRINTED[0]]]
    printed_all = printed[ids].ge(MAJORITY).all(axis=1).any()
    held, total = claims_held(result, best)
    full = held == total
    label = REPLAY_HYPOTHESES[best[0]].label
    # a runner-up whose probability of showing every claim lies inside the best's Monte-Carlo
    # interval is named: the choice between them is within simulation error
    allrows = result.claims[result.claims.claim == "all"].set_index(["hypothesis", "observer"])
    ties = tied_scenarios(result, best)
    close = []
    if best in allrows.index:
        lo, hi = allrows.loc[best, "mc_low"], allrows.loc[best, "mc_high"]
        close = [f"{h}/{o} {r.probability:.2f}" for (h, o), r in allrows.iterrows()
                 if (h, o) != best and (h, o) not in ties and lo <= r.probability <= hi]
    others = len(wide) - 1
    if ties:
        tie_text = ("tied with every other scenario" if len(ties) == others else
                    "tied with " + ", ".join(f"{h}/{o}" for h, o in ties))
        near = (f", {tie_text} at {row['all']:.2f}, chosen by the higher mean probability "
                f"of the single claims")
    else:
        near = ""
    if close:
        near += f", within Monte-Carlo error of {', '.join(close)}"
    tail = "" if full else f"; shown by fewer than half of simulated studies: {', '.join(failed)}"
    rest = (f"{'some observer reproduces them' if printed_all else 'no observer reproduces them'}")
    if full:
        return (f"The paper's Figure 9 / Table 2 claims are reproduced under the {label} replay "
                f"with the {best[1]} observer (best match: one 15+15 study shows them all with "
                f"probability {row['all']:.2f}{near}); under the printed Eq. 7 (material side) "
                f"{rest}.")
    reproducers = reproducing_scenarios(result)
    if reproducers:           # the best match by P(all) is not one of those showing every claim
        return (f"The paper's Figure 9 / Table 2 claims are partly reproduced ({held} of {total} "
                f"claims) under the {label} replay with the {best[1]} observer (best match: one "
                f"15+15 study shows them all with probability {row['all']:.2f}{near}){tail}; "
                f"every claim is shown by at least half of simulated studies under "
                f"{', '.join(f'{h}/{o}' for h, o in reproducers)}; under the printed Eq. 7 "
                f"(material side) {rest}.")
    return (f"No scenario reproduces the paper's Figure 9 / Table 2 claims (none has every "
            f"claim shown by at least half of its simulated 15+15 studies); best match by the "
            f"stated rule (highest probability that one study shows every claim): the {label} "
            f"replay with the {best[1]} observer, {held} of {total} claims, all in one study with "
            f"probability {row['all']:.2f}{near}{tail}; under the printed Eq. 7 (material side) "
            f"{rest}.")


def run_reproduction(out_dir, *, seed: int = 0, workers=None, participants=None, replay=None,
                     observer=None, responder_options=None, n_studies: int = 400,
                     pool_size: int = 100, target_side=None, rate_limit=None) -> dict:
    """Run everything ``reproduce figure9`` promises (see the module docstring).

    Progress is logged at INFO on ``thermocue.study``; the verdict and the claims table are
    printed on stdout.

    Parameters
    ----------
    out_dir : path
    seed : int
        Seeds the cohort, the sessions and the simulated studies.
    workers, participants : int, optional
        As :func:`experiments.simulation.figure9.study.run_figure9_study`.
    replay, observer : str, optional
        The headline scenario; default: the best match to the paper's evidence
        (:func:`.scenarios.best_scenario`).
    responder_options : dict, optional
        For every simulated participant of the headline study.
    n_studies, pool_size : int
        Simulated studies per scenario, persons per group in the pool.
    target_side, rate_limit : str, optional
        Single-field overrides of the headline's protocol variant (after ``replay``); a
        ``target_side`` without ``replay`` names the replay hypothesis of the same name.

    Returns
    -------
    dict
        ``headline``, ``best``, ``scenarios`` (ScenarioResult), ``sensitivity``, ``study``
        (run_figure9_study's summary), ``seconds`` per stage.
    """
    from analysis.figures import plot_figure9_panels
    from experiments.simulation.figure9.study import run_figure9_study
    from experiments.errors import UserInputError
    from experiments.logbook import atomic_write_json, atomic_write_text
    from experiments.simulation.observers import OBSERVERS
    from experiments.simulation.replay import REPLAY_HYPOTHESES, replay_hypothesis
    from experiments.simulation.figure9.scenarios import best_scenario, evaluate_scenarios, sensitivity
    from experiments.simulation.studies import build_pool

    out_dir = Path(out_dir)
    options = dict(responder_options or {})
    from experiments.simulation.cohort import paper_cohort
    from experiments.simulation.figure9.study import _positive_int
    from experiments.responders import get_responder
    if participants is not None:
        _positive_int(participants, "--participants", len(paper_cohort(seed)))
    if workers is not None:
        _positive_int(workers, "--workers")
    _positive_int(n_studies, "--studies")
    _positive_int(pool_size, "--pool-size")
    if pool_size < 15:
        raise UserInputError(f"--pool-size: expected at least 15 (a study draws 15 per group), "
                             f"got {pool_size}")
    if "seed" in options:
        raise UserInputError(f"--responder-option: seed: expected no seed (each participant's "
                             f"comes from the study's --seed), got {options['seed']!r}")
    get_responder("simulated", **options)          # bad options: fail before any work
    if replay is None and target_side is not None:
        replay = {"material": "slab"}.get(target_side, target_side)
        replay = replay if replay in REPLAY_HYPOTHESES else None
    if replay is not None:
        replay_hypothesis(replay)
    if observer is not None and observer not in OBSERVERS:
        raise UserInputError(f"--observer: expected one of {', '.join(OBSERVERS)}, got {observer!r}")
    if "observer" in options:
        raise UserInputError(f"--responder-option: observer: expected --observer instead, got "
                             f"{options['observer']!r}")
    if out_dir.exists() and not out_dir.is_dir():
        raise UserInputError(f"{out_dir}: --out: expected a folder, got an existing file")
    data_dir = out_dir / "data"
    if data_dir.is_dir() and any(data_dir.iterdir()):
        raise UserInputError(f"{data_dir}: --out: expected a folder without earlier study data "
                             f"(the analysis would pool both runs), got a non-empty data/ folder")
    seconds = {}
    t0 = time.perf_counter()
    pool = build_pool(hypotheses=tuple(REPLAY_HYPOTHESES), pool_size=pool_size, seed=seed)
    result = evaluate_scenarios(pool, n_studies=n_studies, seed=seed)
    best = best_scenario(result)
    headline = (replay or best[0], observer or best[1])
    sens = sensitivity(pool, *headline, n_studies=n_studies, seed=seed)
    seconds["scenarios_s"] = time.perf_counter() - t0
    log.info("figure9: %d scenarios x %d simulated studies in %.1f s; headline: %s replay, "
             "%s observer", len(result.wide()), n_studies, seconds["scenarios_s"], *headline)
    t1 = time.perf_counter()
    study = run_figure9_study(out_dir, seed=seed, workers=workers,
                              participants=participants, replay=headline[0],
                              target_side=target_side, rate_limit=rate_limit,
                              responder_options={**options, "observer": headline[1]})
    seconds["study_s"] = time.perf_counter() - t1
    # tables
    result.claims.to_csv(out_dir / "claims.csv", index=False)
    result.proportions.to_csv(out_dir / "scenario_proportions.csv", index=False)
    sens.to_csv(out_dir / "sensitivity.csv", index=False)
    # figure
    analysis = study.get("analysis")
    files = []
    sessions_verdicts = None
    if analysis is not None:
        sessions_verdicts = _sessions_verdicts(analysis.log.analysable, headline)
        predicted = result.proportions[(result.proportions.hypothesis == PRINTED[0])
                                       & (result.proportions.observer == PRINTED[1])]
        held, total = claims_held(result, headline)
        if headline != best:
            named = "Scenario chosen by --replay/--observer"
        elif held == total:
            named = "Best match to the paper's claims: reproduces them"
        else:
            named = (f"Best match by the stated rule, not a reproduction\n({held} of {total} "
                     f"claims shown by at least half of simulated studies)")
        files = plot_figure9_panels(
            predicted, analysis.proportions, out_dir / "figure9.png",
            left_title=(f"Figure 9 as the paper's method predicts it\nprinted Eq. 7 (material "
                        f"side) replay, absolute observer\nexpected over {n_studies} simulated "
                        f"15+15 studies; bars: 95 % of single studies"),
            right_title=(f"{named}\n{headline[0]} replay, {headline[1]} observer\n"
                         f"{len(study['sessions'])} emulated sessions; 95 % bootstrap intervals"),
            left_note=_panel_note(result.wide().loc[PRINTED], "P(a 15+15 study shows it)"),
            right_note=_panel_note(sessions_verdicts, "this study shows it") if sessions_verdicts else "")
    # the headline study's own verdict on each claim
    sessions_line = ""
    if analysis is not None:
        sessions_line = sessions_claims_line(analysis.log.analysable, headline)
    # report opening
    report = out_dir / "report.md"
    screen = claims_screen(result, headline)
    verdict = verdict_line(result, best)
    opening = _report_opening(verdict, screen, result, sens, headline, best, n_studies,
                              sessions_line)
    body = report.read_text(encoding="utf-8") if report.is_file() else ""
    atomic_write_text(report, opening + body)
    seconds["total_s"] = time.perf_counter() - t0
    study_json = out_dir / "study.json"
    if study_json.is_file():
        record = json.loads(study_json.read_text(encoding="utf-8"))
        record.update({"headline": {"replay": headline[0], "observer": headline[1]},
                       "best_match": {"replay": best[0], "observer": best[1]},
                       "scenario_settings": result.settings, "verdict": verdict,
                       "reproduction_seconds": seconds})
        atomic_write_json(study_json, record)
    log.info("figure9: results in %s (%.1f s)", out_dir, seconds["total_s"])
    print(verdict)
    if sessions_line:
        print(sessions_line)
    print(screen)
    return {"headline": headline, "best": best, "scenarios": result, "sensitivity": sens,
            "study": study, "seconds": seconds, "files": files, "verdict": verdict}


def _sessions_verdicts(trials: pd.DataFrame, headline):
    """``evaluate_claims`` of the emulated study itself (None without both groups)."""
    from analysis.claims import answers_from_trials, counts_from_trials, evaluate_claims
    from experiments.simulation.figure9.scenarios import table2_replay_temperatures
    if trials is None or trials.empty or trials["group"].nunique() < 2:
        return None
    props, groups = counts_from_trials(trials)
    return evaluate_claims(props, groups, 1, table2_replay_temperatures(headline[0]),
                           answered=answers_from_trials(trials))


def _panel_note(values, what: str) -> str:
    """Claims box of a figure panel: probabilities (a Series) or one study's verdicts (a dict)."""
    from analysis.claims import CLAIMS
    lines = [what + ":"]
    for c in CLAIMS:
        if isinstance(values, dict):
            if c.id in values:
                lines.append(f"{'✓' if values[c.id][1][0] else '✗'} {c.text}")
        elif c.id in values.index:
            p = float(values[c.id])
            lines.append(f"{'✓' if p >= MAJORITY else '✗'} {p:4.2f} {c.text}")
    return "\n".join(lines)


def sessions_claims_line(trials: pd.DataFrame, headline) -> str:
    """Which claims the emulated study itself shows (one study: ✓ or ✗ with its statistic)."""
    from analysis.claims import CLAIMS, counts_from_trials
    verdicts = _sessions_verdicts(trials, headline)
    if verdicts is None:
        return ""
    _, groups = counts_from_trials(trials)
    cells = [f"{c.short} {'✓' if verdicts[c.id][1][0] else '✗'} ({verdicts[c.id][0][0]:+.2f})"
             for c in CLAIMS if c.id in verdicts]
    return (f"The {groups.size}-participant emulated study ({headline[0]} replay, {headline[1]} "
            f"observer) shows: " + ", ".join(cells) + " (statistic in brackets).")


def _md(df: pd.DataFrame, digits: int = 2) -> str:
    cols = list(df.columns)
    lines = ["| " + " | ".join(cols) + " |", "|" + "|".join("---" for _ in cols) + "|"]
    for row in df.itertuples(index=False):
        lines.append("| " + " | ".join(f"{v:.{digits}f}" if isinstance(v, float) else str(v)
                                       for v in row) + " |")
    return "\n".join(lines)


def _expected_table(result) -> pd.DataFrame:
    """Scenario rows; real and simulated 1#-4# (groups pooled) and A - B, real and simulated."""
    p = result.proportions
    rows = []
    for (h, o), sel in p.groupby(["hypothesis", "observer"], sort=False):
        row = {"replay": h, "observer": o}
        for mode, tag in (("real", "R"), ("simulated", "S")):
            m = sel[sel["mode"] == mode]
            for rid, v in m.groupby("roughness_id")["expected"].mean().items():
                row[f"{tag} {rid}#"] = float(v)
            by_group = m.groupby("group")["expected"].mean()
            row[f"A-B {tag}"] = float(by_group.get("A", float("nan")) - by_group.get("B", float("nan")))
        rows.append(row)
    return pd.DataFrame(rows)


def _report_opening(verdict, screen, result, sens, headline, best, n_studies,
                    sessions_line="") -> str:
    from analysis.claims import CLAIMS
    from experiments.simulation.replay import REPLAY_HYPOTHESES
    from experiments.simulation.studies import __doc__ as studies_doc
    wide = result.wide().reset_index()
    ids = [c.id for c in CLAIMS if c.id in wide.columns] + ["all"]
    shown = wide[["hypothesis", "observer"] + ids].copy()
    for i in ids:
        shown[i] = [f"{'✓' if p >= MAJORITY else '✗'} {p:.2f}" for p in shown[i]]
    shown.columns = ["replay", "observer"] + [c.short for c in CLAIMS if c.id in ids] + ["all"]
    claim_lines = "\n".join(f"- **{c.short}** ({c.id}): {c.text}. {c.quote}. Statistic: "
                            f"{c.statistic}; shown when {c.criterion}." for c in CLAIMS)
    hyp_lines = "\n".join(f"- **{h.name}**: {h.label}. {h.reason}." for h in REPLAY_HYPOTHESES.values())
    sens_cols = ["choice", "setting"] + [c for c in ids if c in sens.columns] + \
        ["p_real_A", "p_real_B", "p_sim_A", "p_sim_B"]
    note = studies_doc.split("Where this differs from emulated sessions")[1].split("Everything else")[0]
    note = "\n".join(line for line in note.splitlines() if not set(line.strip()) <= {"-"})
    title = ("Figure 9, reproduced" if reproducing_scenarios(result)
             else "Figure 9, not reproduced by any scenario")
    return (f"# {title}\n\n**{verdict}**\n\n"
            + (f"{sessions_line}\n\n" if sessions_line else "") +
            f"## The paper's claims under each scenario\n\n"
            f"Probability that one simulated 15 + 15 study shows the claim ({n_studies} studies "
            f"per scenario, the observer models applied to simulated percepts; 95 % Monte-Carlo "
            f"intervals in `claims.csv`); ✓ when at least {MAJORITY:g}. Headline scenario (its "
            f"30 sessions below): {headline[0]} replay, {headline[1]} observer; best match by "
            f"the stated rule (highest probability of showing every claim in one study; "
            f"ties to the higher mean probability of the single claims): {best[0]} replay, "
            f"{best[1]} observer. A scenario reproduces the paper when every claim is ✓; "
            f"reproducing: "
            f"{', '.join(f'{h}/{o}' for h, o in reproducing_scenarios(result)) or 'none'}."
            f"\n\n{_md(shown)}\n\n"
            f"Expected proportion correct per scenario (mean over the simulated studies, groups "
            f"A and B; all cells with their 95 % single-study ranges in "
            f"`scenario_proportions.csv`):\n\n{_md(_expected_table(result))}\n\n"
            f"Claims:\n\n{claim_lines}\n\nReplay hypotheses:\n\n{hyp_lines}\n\n"
            f"Where the simulated studies are not exactly the emulated sessions:\n{note}\n"
            f"## Sensitivity of the headline scenario\n\n"
            f"The headline scenario with one choice changed at a time (same pool seed, "
            f"{n_studies} studies each); p_*: expected proportion correct, mean over samples.\n\n"
            f"{_md(sens[sens_cols])}\n\n"
            f"The figure: `figure9.png` (and `figure9.pdf`): left, the paper's method as printed "
            f"(material-side replay, absolute observer), expected proportions; right, the "
            f"headline scenario's emulated sessions.\n\n---\n\n")
