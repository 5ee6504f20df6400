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
           "planner_note",
           "claims_held", "reproducing_scenarios", "DEFAULT_STUDIES"]

#: The paper's method as printed: Eq. 7's material side as printed (half-space), judged as the
#: project's original absolute observer did.
PRINTED = ("printed", "absolute")
#: A claim is marked as reproduced (✓) in a scenario when at least this share of simulated
#: studies shows it.
MAJORITY = 0.5
#: Simulated studies per scenario and per sensitivity row by default (``--studies``).
DEFAULT_STUDIES = 200

#: How each reading is named in lines and tables.
READING_TEXT = {"descriptive": "read descriptively (the direction the paper states, in a "
                               "study's point estimates)",
                "inferential": f"read inferentially (each direction with its one-sided test "
                               f"at 0.05)"}

log = logging.getLogger("thermocue.study")


def _mark(p: float) -> str:
    return f"{'✓' if p >= MAJORITY else '✗'}{p:4.2f}"


def _claim_ids(wide):
    from analysis.claims import CLAIMS
    return [c for c in CLAIMS if c.id in wide.columns]


def claims_screen(result, headline=None) -> str:
    """The claims table on one screen per reading: scenario rows, claim columns, ✓/✗ with P."""
    from experiments.simulation.replay import REPLAY_HYPOTHESES
    blocks = []
    for reading in ("descriptive", "inferential"):
        wide = result.wide(reading)
        claims = _claim_ids(wide)
        shorts = [c.short + ("*" if c.own else "") for c in claims] + ["all"]
        ids = [c.id for c in claims] + ["all"]
        head = f"{'replay':<12}{'observer':<16}" + "".join(f"{s:>10}" for s in shorts)
        lines = [f"{reading.upper()}: claims {READING_TEXT[reading]}", head, "-" * len(head)]
        for (h, o), row in wide.iterrows():
            star = " <- headline" if headline == (h, o) else ""
            lines.append(f"{h:<12}{o:<16}" + "".join(f"{_mark(row[i]):>10}" for i in ids) + star)
        blocks.append("\n".join(lines))
    n = int(result.claims["n_studies"].iloc[0])
    models = "; ".join(f"{h.name}: {h.profile_model}" for h in REPLAY_HYPOTHESES.values())
    blocks.append(f"probability that a simulated 15+15 study shows the claim ({n} studies per "
                  f"scenario); ✓ when ≥ {MAJORITY:g}; 'all': every claim in the same study; "
                  f"* the project's own criterion\nprofile models: {models}")
    return "\n\n".join(blocks)


def claims_held(result, scenario, reading: str = "descriptive") -> tuple[int, int]:
    """``(claims shown by at least MAJORITY of studies, claims)`` of one scenario."""
    wide = result.wide(reading)
    ids = [c.id for c in _claim_ids(wide)]
    row = wide.loc[tuple(scenario)]
    return sum(bool(row[i] >= MAJORITY) for i in ids), len(ids)


def reproducing_scenarios(result, reading: str = "descriptive") -> list:
    """Scenarios in which every claim is shown by at least MAJORITY of simulated studies."""
    out = []
    for k in result.wide(reading).index:
        held, total = claims_held(result, k, reading)
        if held == total:
            out.append(k)
    return out


def _reading_sentence(result, reading: str) -> str:
    """What one reading says: reproduced under which scenarios, else the best match and why not."""
    from experiments.simulation.figure9.scenarios import best_scenario, tied_scenarios
    from experiments.simulation.replay import REPLAY_HYPOTHESES
    wide = result.wide(reading)
    best = best_scenario(result, reading)
    row = wide.loc[best]
    held, total = claims_held(result, best, reading)
    label = REPLAY_HYPOTHESES[best[0]].label
    ties = tied_scenarios(result, best, reading)
    tie = f", tied at {row['all']:.2f} with {len(ties)} other scenario(s)" if ties else ""
    failed = [f"{c.short} {row[c.id]:.2f}" for c in _claim_ids(wide) if row[c.id] < MAJORITY]
    reproducers = reproducing_scenarios(result, reading)
    head = f"Read {reading}ly"
    if best in reproducers:
        others = [f"{h}/{o}" for h, o in reproducers if (h, o) != best]
        return (f"{head}, the claims are reproduced under the {label} replay with the {best[1]} "
                f"observer (every claim in at least half of simulated 15+15 studies; all in one "
                f"study with probability {row['all']:.2f}{tie})"
                + (f", and also under {', '.join(others)}" if others else ""))
    if reproducers:
        return (f"{head}, the claims are reproduced under "
                f"{', '.join(f'{h}/{o}' for h, o in reproducers)}; the best match by the "
                f"probability of all claims in one study is the {label} replay with the "
                f"{best[1]} observer ({held} of {total} claims, all in one study with "
                f"probability {row['all']:.2f}{tie})")
    return (f"{head}, no scenario reproduces the claims (none has every claim in at least half "
            f"of its simulated 15+15 studies); best match: the {label} replay with the {best[1]} "
            f"observer, {held} of {total} claims, all in one study with probability "
            f"{row['all']:.2f}{tie}; shown by fewer than half: {', '.join(failed)}")


def _printed_sentence(result) -> str:
    """How the printed Eq. 7 fares in both readings (its best observer in each)."""
    parts = []
    for reading in ("descriptive", "inferential"):
        wide = result.wide(reading)
        rows = [k for k in wide.index if k[0] == PRINTED[0]]
        if not rows:
            return ""
        best = max(rows, key=lambda k: (claims_held(result, k, reading)[0], wide.loc[k, "all"]))
        held, total = claims_held(result, best, reading)
        parts.append(f"{reading} {held} of {total} claims at best ({best[1]} observer)")
    return "under the printed Eq. 7 (material side): " + ", ".join(parts)


def verdict_line(result, best=None) -> str:
    """One line: are the paper's claims reproduced, in each reading, and under which hypothesis.

    A scenario *reproduces* the paper in a reading when every claim, read that way, is shown by
    at least :data:`MAJORITY` of its simulated studies.  The line states the descriptive reading
    (the paper's directions in a study's point estimates), then the inferential one (each with
    its one-sided test), then how the printed Eq. 7 fares in both.  ``best`` is accepted for
    compatibility and not used: each reading names its own best match.
    """
    printed = _printed_sentence(result)
    return ("Figure 9 / Table 2 claims. " + _reading_sentence(result, "descriptive") + ". "
            + _reading_sentence(result, "inferential") + "." + (f" {printed[0].upper()}"
                                                                  f"{printed[1:]}." if printed else ""))


def run_reproduction(out_dir, *, seed: int = 0, workers=None, participants=None, replay=None,
                     observer=None, responder_options=None, n_studies: int = DEFAULT_STUDIES,
                     target_side=None, rate_limit=None, scheduler: str | None = None,
                     force_sd_N: float | None = None) -> dict:
    """Run everything ``reproduce figure9`` promises (see the module docstring).

    Progress is logged at INFO on ``thermocue.study``; the verdict and the claims table are
    printed on stdout.

    Parameters
    ----------
    out_dir : path
    seed : int
        Seeds the cohort, the sessions and the simulated studies.
    workers : int, optional
        Worker processes of the ``dask.distributed`` LocalCluster that runs the simulated
        studies and the sessions (default :func:`..sweep.default_workers`).
    participants : int, optional
        As :func:`experiments.simulation.figure9.study.run_figure9_study`.
    replay, observer : str, optional
        The headline scenario; default: the best match to the paper's evidence read
        descriptively (:func:`.scenarios.best_scenario`).
    responder_options : dict, optional
        For every simulated participant of the headline study.
    n_studies : int
        Simulated studies per scenario and per sensitivity row.
    target_side, rate_limit : str, optional
        Single-field overrides of the headline's protocol variant (after ``replay``); a
        ``target_side`` without ``replay`` names the replay hypothesis that plays that side of
        the 3 mm sample.
    scheduler : str, optional
        Address of a dask scheduler to run on instead of a LocalCluster.
    force_sd_N : float, optional
        Per-touch contact force spread of the simulated studies (default
        :data:`..studies.DEFAULT_LAB`'s 0.25 N).

    Returns
    -------
    dict
        ``headline``, ``best`` (per reading), ``scenarios`` (ScenarioResult), ``sensitivity``,
        ``study`` (run_figure9_study's summary), ``seconds`` per stage, ``verdict``.
    """
    import dataclasses as dc

    from experiments.errors import UserInputError
    from sessionfiles.logbook import atomic_write_json, atomic_write_text
    from experiments.responders import get_responder
    from experiments.participant_model.cohort import paper_cohort
    from experiments.simulation.figure9.scenarios import (best_scenario, evaluate_scenarios,
                                                          sensitivity)
    from experiments.simulation.figure9.study import _positive_int, run_figure9_study
    from experiments.participant_model.observers import OBSERVERS
    from experiments.simulation.replay import REPLAY_HYPOTHESES, replay_hypothesis
    from experiments.simulation.studies import DEFAULT_LAB, GROUPS, merge_pools
    from experiments.simulation.sweep import Sweep

    out_dir = Path(out_dir)
    options = dict(responder_options or {})
    if participants is not None:
        _positive_int(participants, "--participants", len(paper_cohort(seed)))
    if workers is not None:
        _positive_int(workers, "--workers")
    _positive_int(n_studies, "--studies")
    lab = DEFAULT_LAB
    if force_sd_N is not None:
        if isinstance(force_sd_N, bool) or not isinstance(force_sd_N, (int, float)) \
                or not 0 <= force_sd_N <= 1.0:
            raise UserInputError(f"--force-sd-N: expected a spread from 0 to 1 N, got {force_sd_N!r}")
        lab = dc.replace(lab, force_sd_N=float(force_sd_N))
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
    with Sweep(workers=workers, scheduler=scheduler, label="figure9") as sweep:
        # one person pool per group, built on the cluster's workers
        pool = merge_pools(sweep.map(_group_pool, [(g, tuple(REPLAY_HYPOTHESES), seed)
                                                   for g in GROUPS], what="person pools"))
        seconds["pool_s"] = time.perf_counter() - t0
        result = evaluate_scenarios(pool, n_studies=n_studies, seed=seed, sweep=sweep,
                                    variability=lab)
        best = {r: best_scenario(result, r) for r in ("descriptive", "inferential")}
        headline = (replay or best["descriptive"][0], observer or best["descriptive"][1])
        sens = sensitivity(pool, *headline, n_studies=n_studies, seed=seed, sweep=sweep,
                           variability=lab)
        seconds["scenarios_s"] = time.perf_counter() - t0
        log.info("figure9: %d scenarios x %d simulated studies and %d sensitivity rows in "
                 "%.1f s on %d workers; headline: %s replay, %s observer", len(result.wide()),
                 n_studies, len(sens), seconds["scenarios_s"], sweep.n_workers, *headline)
        t1 = time.perf_counter()
        study = run_figure9_study(out_dir, seed=seed, workers=workers,
                                  participants=participants, replay=headline[0],
                                  target_side=target_side, rate_limit=rate_limit,
                                  responder_options={**options, "observer": headline[1]},
                                  sweep=sweep)
        seconds["study_s"] = time.perf_counter() - t1
        t2 = time.perf_counter()
        depth = _fitted_depth_row(study, pool, headline, n_studies, seed, sweep, lab)
        if depth is not None:
            sens = pd.concat([sens, depth["row"]], ignore_index=True)
        seconds["depth_fit_s"] = time.perf_counter() - t2
    # tables
    from analysis.exports import write_csv        # whole or not at all
    write_csv(result.claims, out_dir / "claims.csv")
    write_csv(result.proportions, out_dir / "scenario_proportions.csv")
    write_csv(sens, out_dir / "sensitivity.csv")
    # figure
    analysis = study.get("analysis")
    files = []
    if analysis is not None:
        files = _figure(out_dir, result, analysis, headline, best, n_studies, len(study["sessions"]))
    sessions_line = ""
    if analysis is not None:
        sessions_line = sessions_claims_line(analysis.log.analysable, headline)
    report = out_dir / "report.md"
    screen = claims_screen(result, headline)
    verdict = verdict_line(result)
    opening = _report_opening(verdict, screen, result, sens, headline, best, n_studies,
                              sessions_line, lab, depth)
    body = report.read_text(encoding="utf-8") if report.is_file() else ""
    atomic_write_text(report, opening + body)
    seconds["total_s"] = time.perf_counter() - t0
    study_json = out_dir / "study.json"
    if study_json.is_file():
        record = json.loads(study_json.read_text(encoding="utf-8"))
        record.update({"headline": {"replay": headline[0], "observer": headline[1]},
                       "best_match": {r: {"replay": b[0], "observer": b[1]}
                                      for r, b in best.items()},
                       "scenario_settings": {**result.settings, "lab": lab.to_dict()},
                       "verdict": verdict, "reproduction_seconds": seconds,
                       "receptor_depth_fit": None if depth is None else depth["record"]})
        atomic_write_json(study_json, record)
    log.info("figure9: results in %s (%.1f s)", out_dir, seconds["total_s"])
    print(verdict)
    if sessions_line:
        print(sessions_line)
    print(screen)
    return {"headline": headline, "best": best, "scenarios": result, "sensitivity": sens,
            "study": study, "seconds": seconds, "files": files, "verdict": verdict}


def _group_pool(group, hypotheses, seed):
    """The person pool of one group (a sweep task)."""
    from experiments.simulation.studies import build_pool
    return build_pool(hypotheses=hypotheses, seed=seed, groups=(group,))


def _fitted_depth_row(study, pool, headline, n_studies, seed, sweep, lab):
    """Fit the receptor depth to the emulated study's real block; the headline at that depth.

    Returns None without a study with both groups; else ``row`` (a sensitivity row),
    ``record`` (estimate, interval, noise, the profile) and ``text`` (a report paragraph).
    """
    from experiments.simulation.depth_fit import DEPTH_SHARES, confusion_from_trials, fit_depth
    from experiments.simulation.figure9.scenarios import sensitivity
    from experiments.simulation.studies import build_pool
    analysis = study.get("analysis")
    trials = None if analysis is None else analysis.log.analysable
    if trials is None or trials.empty or trials["group"].nunique() < 2:
        return None
    counts = confusion_from_trials(trials, "real")
    fit = fit_depth(counts, n_studies=20, seed=seed)
    # the estimate and the ends of its interval: the claims' probabilities across the depths
    # the study's answers allow (their best noise each)
    settings = {}
    for what, share in (("fitted", fit.estimate), ("interval low end", fit.interval[0]),
                        ("interval high end", fit.interval[1])):
        if any(abs(share - v[2]) < 1e-9 for v in settings.values()):
            continue
        frac = 1.0 - share
        noise = float(fit.grid.loc[fit.grid.depth_share == share].sort_values("loglik")
                      ["noise_C"].iloc[-1])
        depth_pool = build_pool(hypotheses=(headline[0],), dermis_fraction=(frac, frac),
                                seed=pool.settings["seed"], params=pool.params)
        label = (f"depth share {share:.2f} of L, noise {noise:g} ({what}; 95 % LR "
                 f"{fit.interval[0]:.2f}-{fit.interval[1]:.2f})")
        settings[label] = ({"pool": depth_pool, "noise": noise}, what, share)
    row = sensitivity(pool, *headline, n_studies=n_studies, seed=seed, sweep=sweep,
                      variability=lab,
                      choices={"receptor depth (fitted)": {k: v[0] for k, v in settings.items()}})
    profile = ", ".join(f"{d:.2f}: {v - fit.profile.max():+.1f}" for d, v in fit.profile.items())
    text = (f"Receptor depth fitted to the emulated study's real-block answers (profile "
            f"likelihood over depth shares {DEPTH_SHARES[0]:g}-{DEPTH_SHARES[-1]:g} of L and noise "
            f"floors, absolute observer, answers treated as independent): {fit.estimate:.2f} of "
            f"L, 95 % likelihood-ratio interval {fit.interval[0]:.2f}-{fit.interval[1]:.2f} "
            f"({'identifiable' if fit.identifiable() else 'not identifiable: the profile is flat'}"
            f" on this grid), noise {fit.noise_C:g} K; log-likelihood relative to the maximum: "
            f"{profile}. The paper's own proportions cannot be used the same way: its Figure 9 "
            f"is printed as a chart without numbers, and the text gives none.")
    record = {"estimate_share_of_L": fit.estimate, "interval_share_of_L": list(fit.interval),
              "noise_C": fit.noise_C, "identifiable": fit.identifiable(),
              "profile": {f"{d:.2f}": float(v) for d, v in fit.profile.items()}}
    return {"row": row, "record": record, "text": text}


def _figure(out_dir, result, analysis, headline, best, n_studies, n_sessions) -> list:
    """``figure9.png`` / ``.pdf``: the printed Eq. 7 and the headline, as distributions."""
    from experiments.simulation.figure9.plot import claims_note, plot_figure9_distribution
    from experiments.simulation.replay import REPLAY_HYPOTHESES
    props = result.proportions

    def rows(scenario):
        return props[(props.hypothesis == scenario[0]) & (props.observer == scenario[1])]
    held_d, total = claims_held(result, headline, "descriptive")
    held_i, _ = claims_held(result, headline, "inferential")
    if headline != best["descriptive"]:
        named = "Scenario chosen by --replay/--observer"
    elif held_d == total:
        named = "Best match (descriptive reading): reproduces the claims"
    else:
        named = "Best match by the stated rule, not a reproduction"
    return plot_figure9_distribution(
        rows(PRINTED), rows(headline), analysis.proportions, out_dir / "figure9.png",
        left_title=(f"Figure 9 as the paper's method predicts it\n{REPLAY_HYPOTHESES[PRINTED[0]].label}"
                    f" replay\n{PRINTED[1]} observer\n{n_studies} simulated 15+15 studies"),
        right_title=(f"{named}\n{REPLAY_HYPOTHESES[headline[0]].label} replay, {headline[1]} "
                     f"observer\nclaims shown by ≥ half of studies: {held_d}/{total} "
                     f"descriptive, {held_i}/{total} inferential\n{n_studies} simulated "
                     f"studies; ×: the one emulated study ({n_sessions} sessions)"),
        left_note=claims_note(result.claims, PRINTED),
        right_note=claims_note(result.claims, headline))


def _sessions_verdicts(trials: pd.DataFrame, headline):
    """Both readings of the emulated study itself (None without both groups)."""
    from analysis.claims import answers_from_trials, counts_from_trials, evaluate_readings
    from experiments.simulation.figure9.scenarios import table2_replay_temperatures
    if trials is None or trials.empty or trials["group"].nunique() < 2:
        return None
    props, groups = counts_from_trials(trials)
    return evaluate_readings(props, groups, 1, table2_replay_temperatures(headline[0]),
                             answered=answers_from_trials(trials))


def sessions_claims_line(trials: pd.DataFrame, headline) -> str:
    """Which claims the emulated study itself shows, in both readings (descriptive/inferential)."""
    from analysis.claims import CLAIMS, counts_from_trials
    both = _sessions_verdicts(trials, headline)
    if both is None:
        return ""
    _, groups = counts_from_trials(trials)
    d, i = both["descriptive"], both["inferential"]

    def mark(v, cid):
        return "✓" if v[cid][1][0] else "✗"
    cells = [f"{c.short} {mark(d, c.id)}{mark(i, c.id)} ({d[c.id][0][0]:+.2f})"
             for c in CLAIMS if c.id in d]
    return (f"The {groups.size}-participant emulated study ({headline[0]} replay, {headline[1]} "
            f"observer) shows (descriptive, inferential): " + ", ".join(cells) +
            " (statistic in brackets).")


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


def _claims_md(result, reading: str) -> str:
    """The claims table of one reading, each row naming its profile model."""
    from experiments.simulation.replay import REPLAY_HYPOTHESES
    wide = result.wide(reading).reset_index()
    claims = _claim_ids(result.wide(reading))
    ids = [c.id for c in claims] + ["all"]
    shown = pd.DataFrame({"replay": wide["hypothesis"],
                          "profile model": [REPLAY_HYPOTHESES[h].profile_model
                                            for h in wide["hypothesis"]],
                          "observer": wide["observer"]})
    for c, i in zip([c.short + ("*" if c.own else "") for c in claims] + ["all"], ids):
        shown[c] = [f"{'✓' if p >= MAJORITY else '✗'} {p:.2f}" for p in wide[i]]
    return _md(shown)


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


def _report_opening(verdict, screen, result, sens, headline, best, n_studies,
                    sessions_line="", lab=None, depth=None) -> str:
    from analysis.claims import CLAIMS
    from experiments.simulation.replay import REPLAY_HYPOTHESES
    from experiments.simulation.studies import __doc__ as studies_doc
    claim_lines = "\n".join(
        f"- **{c.short}** ({c.id}): {c.text}. {c.quote}. Statistic: {c.statistic}. "
        f"Descriptive: {c.descriptive}. Inferential: {c.inferential}."
        + (f" *The project's own criterion*: {c.own}." if c.own else "") for c in CLAIMS)
    hyp_lines = "\n".join(f"- **{h.name}**: {h.label}; plays {h.profile_model}. {h.reason}."
                          for h in REPLAY_HYPOTHESES.values())
    ids = [c.id for c in CLAIMS if c.id in sens.columns] + ["all"]
    sens_cols = ["choice", "setting"] + [i for i in ids if i in sens.columns] + \
        [i + "_inf" for i in ids if i + "_inf" in sens.columns] + \
        ["p_real_A", "p_real_B", "p_sim_A", "p_sim_B"]
    note = studies_doc.split("Where this differs from emulated sessions")[1].split("Everything else")[0]
    note = "\n".join(line for line in note.splitlines() if not set(line.strip()) <= {"-"})
    repro = {r: reproducing_scenarios(result, r) for r in ("descriptive", "inferential")}
    title = ("Figure 9, reproduced" if repro["descriptive"] or repro["inferential"]
             else "Figure 9, not reproduced by any scenario")
    lab_text = ", ".join(f"{k} {v}" for k, v in (lab.to_dict().items() if lab else []))
    sections = []
    for reading in ("descriptive", "inferential"):
        sections.append(
            f"### Claims {READING_TEXT[reading]}\n\n"
            f"Best match: {best[reading][0]} replay, {best[reading][1]} observer; reproducing "
            f"(every claim ✓): {', '.join(f'{h}/{o}' for h, o in repro[reading]) or 'none'}."
            f"\n\n{_claims_md(result, reading)}\n")
    return (f"# {title}\n\n**{verdict}**\n\n"
            + (f"{sessions_line}\n\n" if sessions_line else "") +
            f"## The paper's claims under each scenario\n\n"
            f"Probability that one simulated 15 + 15 study shows the claim ({n_studies} studies "
            f"per scenario, the observer models applied to simulated percepts, a fresh cohort "
            f"per study; lab: {lab_text}; 95 % Monte-Carlo intervals in `claims.csv`); ✓ when "
            f"at least {MAJORITY:g}; * marks a criterion that is the project's own reading. "
            f"Headline scenario (its sessions below): {headline[0]} replay, {headline[1]} "
            f"observer (the best match read descriptively unless chosen by option). The best "
            f"match of a reading has the highest probability of showing every claim in one "
            f"study (ties to the higher mean probability of the single claims).\n\n"
            + "\n".join(sections) +
            f"\nExpected proportion correct per scenario (mean over the simulated studies, groups "
            f"A and B; every cell's median and 50 / 95 % single-study ranges in "
            f"`scenario_proportions.csv`):\n\n{_md(_expected_table(result))}\n\n"
            f"Claims:\n\n{claim_lines}\n\nReplay hypotheses:\n\n{hyp_lines}\n\n"
            f"Where the simulated studies are not exactly the emulated sessions:\n{note}\n"
            f"{planner_note(result.settings)}\n\n"
            f"## Sensitivity of the headline scenario\n\n"
            f"The headline scenario with one choice changed at a time ({n_studies} studies "
            f"each): the claims' probabilities read descriptively (claim columns) and "
            f"inferentially (`_inf`); p_*: expected proportion correct, mean over samples.\n\n"
            f"{_md(sens[sens_cols])}\n\n"
            + (f"{depth['text']}\n\n" if depth else "") +
            f"The figure: `figure9.png` (and `figure9.pdf`): per cell the median of the "
            f"simulated studies' proportion correct with the middle 50 % and 95 % of them; left, "
            f"the paper's method as printed (printed Eq. 7 replay, absolute observer); right, "
            f"the headline scenario with its one emulated study on top (×).\n\n---\n\n")
