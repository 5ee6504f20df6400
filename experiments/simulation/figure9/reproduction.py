"""``thermocue reproduce figure9``: the paper's claims under every scenario, then the headline study.

1. A pool of simulated persons and many simulated 15 + 15 studies per (replay hypothesis x
   observer) scenario (:mod:`.scenarios`): the probability that a study shows each of the
   paper's claims (:mod:`analysis.claims`), and the expected proportions correct.
2. The headline scenario (the best match to the paper's evidence unless ``--replay`` /
   ``--observer`` say otherwise) run as the 30-participant study on the emulated display
   (:func:`experiments.simulation.figure9.study.run_figure9_study`), with its analysis; the
   sensitivity rows' studies (:func:`.scenarios.sensitivity`) run on the same cluster at the
   same time, then the receptor-depth fit's grid; the fitted-depth rows, which need the
   study's answers, start as soon as its sessions end, while this process analyses them.
3. ``figure9.png`` / ``.pdf``: the paper's method as printed (material-side replay, absolute
   observer; expected proportions) beside the headline's 30 emulated sessions; ``report.md``
   opening with the verdict, the claims table and the sensitivity table; the claims table last
   on the terminal.
"""
from __future__ import annotations

import json
import logging
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pandas as pd

__all__ = ["run_reproduction", "recompute_from", "claims_screen", "verdict_line",
           "sessions_claims_line", "PRINTED", "planner_note", "claims_held",
           "reproducing_scenarios", "DEFAULT_STUDIES"]

from .precision import FIRST_STUDIES, MAX_STUDIES, SENSITIVITY_MAX_STUDIES
from .report import planner_note, write_outputs as _write_outputs
from .verdict import PRINTED, claims_held, claims_screen, reproducing_scenarios, verdict_line

#: Simulated studies per scenario and per sensitivity row in the first round (``--studies``);
#: more are added to undecided ones up to ``--max-studies`` (:mod:`.precision`).
DEFAULT_STUDIES = FIRST_STUDIES

log = logging.getLogger("thermocue.study")


def run_reproduction(out_dir, *, seed: int = 0, workers=None, participants=None, replay=None,
                     observer=None, responder_options=None, n_studies: int = DEFAULT_STUDIES,
                     target_side=None, rate_limit=None, scheduler: str | None = None,
                     force_sd_N: float | None = None, max_studies: int | None = None) -> dict:
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
        Simulated studies per scenario and per sensitivity row in the first round.
    max_studies : int, optional
        Cap of the sequential studies of one scenario (default :data:`.precision.MAX_STUDIES`,
        at least ``n_studies``); a sensitivity row stops at
        :data:`.precision.SENSITIVITY_MAX_STUDIES` (or this cap if lower).
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
    out_dir = Path(out_dir)
    options, max_studies, lab, replay = _checked_options(
        out_dir, seed, workers, participants, replay, observer, responder_options, n_studies,
        target_side, force_sd_N, max_studies)
    seconds = {}
    t0 = time.perf_counter()
    run = _simulate(out_dir, seconds, t0, seed=seed, workers=workers, participants=participants,
                    replay=replay, observer=observer, options=options, n_studies=n_studies,
                    target_side=target_side, rate_limit=rate_limit, scheduler=scheduler,
                    force_sd_N=force_sd_N, max_studies=max_studies, lab=lab)
    try:
        return _finish(out_dir, run, seconds, t0, lab)
    finally:
        run["closed"].result()      # the cluster, closing while the report was written


def _checked_options(out_dir, seed, workers, participants, replay, observer, responder_options,
                     n_studies, target_side, force_sd_N, max_studies):
    """The options checked before any work (a UserInputError naming the option otherwise):
    ``(responder options, max_studies, lab, replay)`` with the defaults filled in."""
    import dataclasses as dc

    from experiments.errors import UserInputError
    from experiments.participant_model.cohort import paper_cohort
    from experiments.participant_model.observers import OBSERVERS
    from experiments.responders import get_responder
    from experiments.simulation.figure9.study import _positive_int
    from experiments.simulation.replay import REPLAY_HYPOTHESES, replay_hypothesis
    from experiments.simulation.studies import DEFAULT_LAB

    options = dict(responder_options or {})
    if participants is not None:
        _positive_int(participants, "--participants", len(paper_cohort(seed)))
    if workers is not None:
        _positive_int(workers, "--workers")
    _positive_int(n_studies, "--studies")
    if max_studies is None:
        max_studies = max(MAX_STUDIES, n_studies)
    if _positive_int(max_studies, "--max-studies") < n_studies:
        raise UserInputError(f"--max-studies: expected at least --studies ({n_studies}), got "
                             f"{max_studies}")
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
    return options, max_studies, lab, replay


def _simulate(out_dir, seconds, t0, *, seed, workers, participants, replay, observer, options,
              n_studies, target_side, rate_limit, scheduler, force_sd_N, max_studies, lab) -> dict:
    """Steps 1 and 2 of the module docstring on one cluster; stage times into ``seconds``.

    Returns ``result``, ``best``, ``headline``, ``sens`` (the sensitivity table, the fitted
    depth's rows included), ``study``, ``depth``, ``trials`` (the study's analysable trials),
    ``figure`` (a future of the figure's files, drawn by another thread after the analysis)
    and ``written`` (``studies.csv`` written).
    """
    from experiments.simulation.sweep import Sweep
    sens_cap = min(max_studies, max(SENSITIVITY_MAX_STUDIES, n_studies))
    # outputs final before the end are written by this thread while this process would wait
    writer = ThreadPoolExecutor(max_workers=1, thread_name_prefix="figure9-writer")
    sweep = Sweep(workers=workers, scheduler=scheduler, label="figure9").__enter__()
    try:
        run = _simulate_on(writer, sweep, out_dir, seconds, t0, seed=seed, workers=workers,
                           participants=participants, replay=replay, observer=observer,
                           options=options, n_studies=n_studies, target_side=target_side,
                           rate_limit=rate_limit, force_sd_N=force_sd_N,
                           max_studies=max_studies, lab=lab, sens_cap=sens_cap)
    except BaseException:
        sweep.__exit__(None, None, None)
        raise
    finally:
        writer.shutdown(cancel_futures=True)    # what it wrote was waited for (or failed)
    # nothing runs on the cluster any more: it closes (~1 s, waiting for its processes to
    # end) while this process writes the report
    closer = ThreadPoolExecutor(max_workers=1, thread_name_prefix="figure9-close")
    run["closed"] = closer.submit(sweep.__exit__, None, None, None)
    closer.shutdown(wait=False)
    return run


def _simulate_on(writer, sweep, out_dir, seconds, t0, *, seed, workers, participants, replay,
                 observer, options, n_studies, target_side, rate_limit, force_sd_N, max_studies,
                 lab, sens_cap) -> dict:
    """:func:`_simulate` with ``writer`` (a one-thread executor) writing ``studies.csv`` while
    the sessions run (this process only waits for them), waited for before returning (its
    failure is raised here); the same file as writing it at the end (it needs only the
    scenarios).  The depth fit starts as soon as the sessions end (:func:`_beside_the_study`),
    while this process analyses them."""
    from experiments.simulation.figure9.report import write_figure
    from experiments.simulation.figure9.scenarios import best_scenario, evaluate_scenarios
    from experiments.simulation.figure9.tasks import group_pool_task
    from experiments.simulation.replay import REPLAY_HYPOTHESES
    from experiments.simulation.studies import GROUPS, merge_pools

    # one person pool per group, built on the cluster's workers
    pool = merge_pools(sweep.map(group_pool_task, [(g, tuple(REPLAY_HYPOTHESES), seed)
                                                    for g in GROUPS], what="person pools"))
    seconds["pool_s"] = time.perf_counter() - t0
    result = evaluate_scenarios(pool, n_studies=n_studies, seed=seed, sweep=sweep,
                                variability=lab, max_studies=max_studies)
    seconds["claims_s"] = time.perf_counter() - t0 - seconds["pool_s"]
    best = {r: best_scenario(result, r) for r in ("descriptive", "inferential")}
    headline = (replay or best["descriptive"][0], observer or best["descriptive"][1])
    default_run = next(res for keys, res in result.runs
                       if (keys["hypothesis"], keys["observer"]) == headline)
    seconds["scenarios_s"] = time.perf_counter() - t0
    sweep.release_memory()      # the scenarios' studies, before the sessions
    written = {"studies": writer.submit(_write_studies, out_dir, result.runs)}
    t1 = time.perf_counter()
    # the figure is drawn by another thread once the analysis has written its own figure9.png,
    # while the depth fit's last studies run and this thread writes the report; waited for
    # at the end
    drawer = ThreadPoolExecutor(max_workers=1, thread_name_prefix="figure9-figure")

    def draw(study):
        analysis = study.get("analysis")
        return drawer.submit(write_figure, out_dir, result,
                             analysis.proportions if analysis is not None else None, headline,
                             best, len(study["sessions"]))
    try:
        sens, study, depth, figure = _beside_the_study(
            out_dir, seconds, t1, result, best, headline, default_run, pool, sweep, draw,
            seed=seed, workers=workers, participants=participants, options=options,
            n_studies=n_studies, target_side=target_side, rate_limit=rate_limit,
            force_sd_N=force_sd_N, lab=lab, sens_cap=sens_cap)
    finally:
        drawer.shutdown(wait=False)
    return {"result": result, "best": best, "headline": headline, "sens": sens, "study": study,
            "depth": depth["fit"], "trials": depth["trials"], "figure": figure,
            "written": {k: f.result() for k, f in written.items()}}


def _beside_the_study(out_dir, seconds, t1, result, best, headline, default_run, pool, sweep,
                      draw, *, seed, workers, participants, options, n_studies, target_side,
                      rate_limit, force_sd_N, lab, sens_cap) -> tuple:
    """The sensitivity rows beside the emulated study (:func:`_beside`); the depth fit started
    once its sessions end (:func:`_depth_after_sessions`, on another thread, its studies on the
    workers) while this process analyses them; ``draw(study summary)`` (a future of the
    figure's files) called once the analysis has ended.  ``(sensitivity rows, study summary,
    the depth fit's result, the figure's future)``; stage times into ``seconds``."""
    from experiments.simulation.figure9.study import run_figure9_study
    depth_thread = ThreadPoolExecutor(max_workers=1, thread_name_prefix="figure9-depth")
    fitted = []                 # the depth fit's future, once the sessions have ended
    figure = []                 # the figure's future, once the analysis has ended

    def sessions_then_analysis(rows):
        def start_depth_fit(data_dir, sessions, trials):
            fitted.append(depth_thread.submit(
                _depth_after_sessions, trials, rows, out_dir, pool, headline, n_studies,
                seed, sweep, lab, sens_cap))
        study = run_figure9_study(out_dir, seed=seed, workers=workers,
                                  participants=participants, replay=headline[0],
                                  target_side=target_side, rate_limit=rate_limit,
                                  responder_options={**options, "observer": headline[1],
                                                     **({} if force_sd_N is None else
                                                        {"force_sd_N": lab.force_sd_N})},
                                  sweep=sweep, after_sessions=start_depth_fit,
                                  analysis_figure9=False)    # drawn by draw(study) instead
        figure.append(draw(study))
        return study
    try:
        (sens, _), study, seconds["study_s"] = _beside(
            lambda: _sensitivity_rows(pool, headline, n_studies, seed, sweep, lab,
                                      default_run, sens_cap, participants),
            sessions_then_analysis)
        seconds["sensitivity_and_study_s"] = time.perf_counter() - t1
        seconds["studies_simulated"] = int(result.n_studies().sum()) + sum(
            len(res["proportions"]) for _, res in sens.attrs["runs"] if res is not default_run)
        log.info("figure9: %d scenarios (%d-%d simulated studies each) in %.1f s, and %d "
                 "sensitivity rows beside the emulated study (%.1f s together) on %d "
                 "workers; headline: %s replay, %s observer", len(result.wide()),
                 result.n_studies().min(), result.n_studies().max(),
                 seconds["scenarios_s"], len(sens), seconds["sensitivity_and_study_s"],
                 sweep.n_workers, *headline)
        t2 = time.perf_counter()
        depth = fitted[0].result()
    except BaseException:
        depth_thread.shutdown(wait=False, cancel_futures=True)   # the closing cluster ends it
        raise
    depth_thread.shutdown()
    seconds["depth_fit_s"] = time.perf_counter() - t2    # waited for after the analysis
    return depth["sens"], study, depth, figure[0]


def _depth_after_sessions(trials, rows, out_dir, pool, headline, n_studies, seed, sweep, lab,
                          max_studies) -> dict:
    """Once the sessions have ended (while this process analyses them): the receptor depth
    fitted to their analysable ``trials`` (read once for this and the analysis,
    :func:`analysis.load.load_trials`) by :func:`.fitted_depth.fitted_depth_row`, its studies on
    ``sweep``'s workers, once the sensitivity rows and the fit's grid (``rows``, a future of
    :func:`_sensitivity_rows`) are done; ``sensitivity_studies.csv`` written.

    Returns ``trials``, ``fit`` (:func:`.fitted_depth.fitted_depth_row`'s) and ``sens`` (the
    sensitivity table with the fitted depth's rows).  The same tasks and seeds as after the
    analysis, so the same numbers and files.
    """
    from analysis.exports import write_csv        # whole or not at all
    from experiments.simulation.figure9.fitted_depth import fitted_depth_row, with_depth_row
    from experiments.simulation.figure9.precision import study_table
    sens, grid = rows.result()
    fit = fitted_depth_row(trials, pool, headline, n_studies, seed, sweep, lab, max_studies,
                           grid)
    sens = with_depth_row(sens, fit)
    write_csv(study_table(sens.attrs["runs"]), Path(out_dir) / "sensitivity_studies.csv")
    return {"trials": trials, "fit": fit, "sens": sens}


def _write_studies(out_dir, runs) -> None:
    """``studies.csv``: the scenarios' per-study table (:func:`.precision.study_table`)."""
    from analysis.exports import write_csv        # whole or not at all
    from experiments.simulation.figure9.precision import study_table
    Path(out_dir).mkdir(parents=True, exist_ok=True)
    write_csv(study_table(runs), Path(out_dir) / "studies.csv")


def _sensitivity_rows(pool, headline, n_studies, seed, sweep, lab, default_run, max_studies,
                      participants):
    """The sensitivity rows, then the depth fit's grid (None without both groups): the
    background of :func:`_beside`; ``(rows, grid)``."""
    from experiments.simulation.figure9.fitted_depth import depth_grid
    from experiments.simulation.figure9.scenarios import sensitivity
    sens = sensitivity(pool, *headline, n_studies=n_studies, seed=seed, sweep=sweep,
                       variability=lab, default_run=default_run, max_studies=max_studies)
    # the depth fit's grid needs no answers: built once the rows are done, beside the sessions
    # and while this process analyses them (a fit needs both groups)
    grid = (depth_grid(seed, headline, sweep)
            if participants is None or participants >= 2 else None)
    return sens, grid


def _finish(out_dir, run, seconds, t0, lab) -> dict:
    """Step 3 of the module docstring: the per-study tables, the figure and report, the
    study record; the verdict and the claims table printed.  ``run_reproduction``'s result."""
    from sessionfiles.logbook import atomic_write_json
    result, sens, study, headline, best = (run["result"], run["sens"], run["study"],
                                           run["headline"], run["best"])
    analysis = study.get("analysis")
    observed = analysis.proportions if analysis is not None else None
    sessions_line = ""
    if analysis is not None:
        sessions_line = sessions_claims_line(run["trials"], headline)
    depth_record = None if run["depth"] is None else run["depth"]["record"]
    outputs = _write_outputs(out_dir, result, sens, headline, best, observed,
                             len(study["sessions"]), sessions_line, lab.to_dict(), depth_record,
                             body=True, figure=())      # () : drawn by run["figure"]'s thread
    verdict, screen = outputs["verdict"], outputs["screen"]
    files = run["figure"].result()
    seconds["total_s"] = time.perf_counter() - t0
    study_json = out_dir / "study.json"
    if study_json.is_file():
        record = json.loads(study_json.read_text(encoding="utf-8"))
        record.update({"headline": {"replay": headline[0], "observer": headline[1]},
                       "best_match": {r: {"replay": b[0], "observer": b[1]}
                                      for r, b in best.items()},
                       "scenario_settings": {**result.settings, "lab": lab.to_dict()},
                       "verdict": verdict, "reproduction_seconds": seconds,
                       "receptor_depth_fit": depth_record})
        atomic_write_json(study_json, record)
    log.info("figure9: results in %s (%.1f s)", out_dir, seconds["total_s"])
    print(verdict)
    if sessions_line:
        print(sessions_line)
    print(screen)
    return {"headline": headline, "best": best, "scenarios": result, "sensitivity": sens,
            "study": study, "seconds": seconds, "files": files, "verdict": verdict}


def _beside(background, foreground):
    """``(background(), foreground(future of background()), seconds of foreground)``, the
    two run at the same time.

    The sensitivity rows and the emulated study need only the headline: the rows' studies run
    on the cluster's workers beside the sessions, and while this process analyses the sessions
    (when the workers would otherwise wait); the foreground gets the rows' future (the depth
    fit, started once the sessions end, waits for it).  Their tasks and seeds are the same
    either way, so are the results.  A failure of the foreground does not wait for the
    background.
    """
    start = time.perf_counter()
    bg = ThreadPoolExecutor(max_workers=1, thread_name_prefix="figure9-sensitivity")
    try:
        pending = bg.submit(background)
        front = foreground(pending)
    except BaseException:
        bg.shutdown(wait=False, cancel_futures=True)    # the closing cluster ends the rows
        raise
    seconds = time.perf_counter() - start
    try:
        return pending.result(), front, seconds
    finally:
        bg.shutdown()


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


def recompute_from(src_dir, out_dir) -> dict:
    """``reproduce figure9 --from SRC --out OUT``: claims, verdict and figure from the per-study
    tables of an earlier run, without simulating.

    Reads ``SRC/studies.csv`` and ``SRC/sensitivity_studies.csv`` (:func:`.precision.study_table`),
    the headline and the lab from ``SRC/study.json`` and the emulated study's proportions from
    ``SRC/proportions.csv`` (both optional); writes ``claims.csv``,
    ``scenario_proportions.csv``, ``sensitivity.csv``, ``figure9.png`` / ``.pdf`` and the
    report's opening as ``report.md`` in ``OUT``, and prints the verdict and the claims table.

    Raises
    ------
    UserInputError
        A missing or malformed table, naming the file (and the column).
    """
    from experiments.errors import UserInputError
    from experiments.simulation.figure9.precision import runs_from_table
    from experiments.simulation.figure9.scenarios import (SENSITIVITY_CHOICES, mark_differences,
                                                          sensitivity_row, best_scenario,
                                                          result_from_runs)
    src, out_dir = Path(src_dir), Path(out_dir)
    tables = {}
    for name in ("studies.csv", "sensitivity_studies.csv"):
        path = src / name
        if not path.is_file():
            raise UserInputError(f"{path}: --from: expected the per-study table of a "
                                 f"`reproduce figure9` run, got no such file")
        try:
            tables[name] = pd.read_csv(path)
        except (OSError, ValueError) as exc:
            raise UserInputError(f"{path}: --from: expected a CSV table, got {exc}") from None
    try:
        runs = runs_from_table(tables["studies.csv"], ("hypothesis", "observer"),
                               str(src / "studies.csv"))
        sens_runs = runs_from_table(tables["sensitivity_studies.csv"], ("choice", "setting"),
                                    str(src / "sensitivity_studies.csv"))
    except ValueError as exc:
        raise UserInputError(str(exc)) from None
    record = {}
    if (src / "study.json").is_file():
        record = json.loads((src / "study.json").read_text(encoding="utf-8"))
    settings = dict(record.get("scenario_settings") or {})
    roughness = tuple(settings.get("roughness_um") or (1.6, 12.5, 50.0, 100.0))
    result = result_from_runs(runs, roughness, settings)
    notes = {}                    # how a row's lab was made realisable (not in the studies)
    if (src / "sensitivity.csv").is_file():
        old = pd.read_csv(src / "sensitivity.csv").fillna({"note": ""})
        if "note" in old:
            notes = {(r.choice, r.setting): r.note for r in old.itertuples()}
    sens = mark_differences(pd.DataFrame([
        dict(sensitivity_row(k["choice"], k["setting"], res),
             note=notes.get((k["choice"], k["setting"]), "")) for k, res in sens_runs]),
        SENSITIVITY_CHOICES)
    best = {r: best_scenario(result, r) for r in ("descriptive", "inferential")}
    named = record.get("headline") or {}
    headline = (named.get("replay", best["descriptive"][0]),
                named.get("observer", best["descriptive"][1]))
    observed = None
    if (src / "proportions.csv").is_file():
        observed = pd.read_csv(src / "proportions.csv")
    out_dir.mkdir(parents=True, exist_ok=True)
    outputs = _write_outputs(out_dir, result, sens, headline, best, observed,
                             len(record.get("participants") or []) if observed is not None else 0,
                             lab=settings.get("lab"), depth_record=record.get("receptor_depth_fit"),
                             body=False)
    print(outputs["verdict"])
    print(outputs["screen"])
    return {"headline": headline, "best": best, "scenarios": result, "sensitivity": sens,
            **outputs}
