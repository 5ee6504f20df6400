"""The paper's Figure 9 study end to end: the cohort's sessions on the emulated display, then the analysis.

§3.2 of the paper: thirty participants (:mod:`..cohort`), each run through
``roughness_recognition.toml`` with the emulated display on a virtual clock and the simulated
participant responding (:func:`run_participant`), then :func:`analysis.analyze` on their logs
(:func:`run_figure9_study`).

Progress ("participant n of N", elapsed, ETA) and the Figure 9 table are logged at INFO on the
``thermocue.study`` logger; ``thermocue`` shows them on stderr (``--quiet`` hides them).
"""
from __future__ import annotations

import io
import logging
import os
import time
from pathlib import Path

import numpy as np

from stimuli.paper import RATE_LIMITS, TARGET_SIDES

from experiments.participant_model.cohort import alternate_groups, paper_cohort, write_cohort

__all__ = ["run_figure9_study", "run_participant", "check_group_profiles", "MAX_DEFAULT_WORKERS"]

log = logging.getLogger("thermocue.study")


def _positive_int(value, option: str, high: int | None = None) -> int:
    """``value`` as an integer ≥ 1 (≤ ``high``), else a UserInputError naming ``option``."""
    from experiments.errors import UserInputError
    what = f"an integer from 1 to {high}" if high is not None else "an integer ≥ 1"
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1 \
            or (high is not None and value > high):
        raise UserInputError(f"{option}: expected {what}, got {value!r}")
    return int(value)


def run_participant(participant_path, data_dir, *, seed: int, protocol: str = "roughness_recognition",
                    responder_options: dict | None = None, durable: bool = True) -> dict:
    """Run one participant's session with the emulator (virtual clock) and the simulated responder.

    ``durable=False`` skips the fsyncs of this session's files (the session's ``durable``
    setting: same files, same order, same content).

    Returns
    -------
    dict
        ``participant``, ``session_dir``, ``seconds`` (wall time), ``trials``.
    """
    from experiments.responders import get_responder
    from experiments.session import create_session   # heavy: the session engine, display, stimuli
    from participants_schema import load_participant

    record = load_participant(participant_path)   # a bad file: ParticipantError naming file, field
    extra = record.get("x_simulation")
    options = {"seed": extra.get("seed", seed) if isinstance(extra, dict) else seed}
    options.update(responder_options or {})
    start = time.perf_counter()
    responder = get_responder("simulated", **options)
    # a study's 30 sessions tell nothing line by line (not even the group line written with the
    # folder); the study logs one line per participant instead
    session_log = logging.getLogger("thermocue.session")
    level = session_log.level
    session_log.setLevel(logging.WARNING)
    # one BLAS thread: a session's products are small (the skin's 32-cell step, the stimuli);
    # idle BLAS threads only spin, and cost as much CPU as a fifth of the session
    from threadpoolctl import threadpool_limits
    try:
        with threadpool_limits(1):
            session = create_session(protocol, participant_path, data_dir,
                                     f"emulator://?clock=virtual&seed={int(seed)}", seed=int(seed),
                                     responder_name="simulated", clock="virtual", out=io.StringIO(),
                                     durable=durable)
            status = session.run(responder)
    finally:
        session_log.setLevel(level)
    if status != 0:
        raise RuntimeError(f"{participant_path}: the session in {session.directory} ended with "
                           f"status {status}; see its events.jsonl")
    return {"participant": record["id"], "session_dir": str(session.directory),
            "seconds": time.perf_counter() - start, "n_trials": session.n_trials}


def _run_one(args):
    """One session (a task of the cluster); then the heap it freed goes back to the OS.

    On a worker, sessions run between batches of simulated studies, whose arrays come from the
    heap (:data:`..sweep.WORKER_MALLOC`): the session's long-lived objects pin it, and without
    the trim a worker grew by ~5 MiB a session (~70 MiB over the study).  The trim costs a few
    ms a session and changes no number.
    """
    from experiments.simulation.sweep import trim_heap
    path, data_dir, seed, protocol, options, durable = args
    try:
        return run_participant(path, data_dir, seed=seed, protocol=protocol,
                               responder_options=options, durable=durable)
    finally:
        trim_heap()


def _progress(done: int, total: int, start: float, label: str) -> None:
    elapsed = time.perf_counter() - start
    eta = elapsed / done * (total - done) if done else float("nan")
    log.info("figure9: participant %d of %d done (%s); elapsed %5.1f s, ETA %5.1f s",
             done, total, label, elapsed, eta)


#: The sessions' dask priority, above the default 0 of the studies simulated beside them on a
#: shared cluster (``reproduce figure9``'s sensitivity rows and receptor-depth grid): the
#: analysis waits for the last session, the rows for nothing but the report.
SESSION_PRIORITY = 10

#: Largest default number of worker processes: each holds ~125 MiB (RSS) besides the main
#: process's ~390 MiB, so 4 keep the study under 1 GB however many cores the machine has.
MAX_DEFAULT_WORKERS = 4


def run_figure9_study(out_dir, seed: int = 0, workers: int | None = None, *,
                      protocol: str = "roughness_recognition", responder_options: dict | None = None,
                      analyze: bool = True, participants: int | None = None,
                      target_side: str | None = None, rate_limit: str | None = None,
                      replay: str | None = None, durable: bool = False, sweep=None,
                      after_sessions=None, analysis_figure9: bool = True) -> dict:
    """Run the paper's Figure 9 study end to end with simulated participants.

    Parameters
    ----------
    out_dir : path
        Gets ``participants/`` (the cohort's records), ``data/`` (session logs) and the
        analysis outputs (``figure9.png``, tables, ``report.md``).
    seed : int
        Seeds the cohort, the schedules, the emulator and the responders.
    workers : int, optional
        Worker processes of the ``dask.distributed`` LocalCluster running participants in
        parallel (1: in this process; at most one per participant; ignored with ``sweep``). Default: twice the CPU count (a session also waits for ``fsync``: every
        logged event is made durable before the next step), at most :data:`MAX_DEFAULT_WORKERS`
        so that the whole study stays under 1 GB on any machine. Measured on 2 cores
        (``benchmarks/bench_study.py``): 4 workers 53 s of sessions, 889 MiB summed RSS;
        2 workers 54 s, 641 MiB.
    protocol : str
        Protocol name or path.
    responder_options : dict, optional
        Options of :class:`experiments.responders.simulated.SimulatedResponder` for everyone
        (noise parameters...); checked before any session runs.
    analyze : bool
        Run :func:`analysis.analyze` on ``out_dir/data`` at the end.
    participants : int, optional
        Run only this many participants (1 to 30), taken from the two groups in turn
        (:func:`alternate_groups`: P01, P16, P02, P17, ...), so that any number ≥ 2 compares
        both groups; the cohort's ids and records are the same as in the whole study.
    target_side : {"material", "skin", "compensated"}, optional
        Override the protocol's ``[simulation] target_side`` (default: the protocol's, i.e.
        ``"material"``, the paper's Eq. 7, for ``roughness_recognition``); the protocol is then
        copied to ``out_dir/protocol.toml`` with that one line changed.
    rate_limit : {"refuse", "slew"}, optional
        Override the protocol's ``[simulation] rate_limit`` likewise. Profiles the display
        would refuse stop the study before any session runs.
    durable : bool
        fsync every file the sessions write (default False: a simulated study on the virtual
        clock is recomputed from its seed, so a power cut costs a rerun, not data; fsync was
        70 % of a session's wall time on the shared 2-core machine). The files, their order and
        content are the same either way; ``study.json`` records the setting.
    sweep : :class:`experiments.simulation.sweep.Sweep`, optional
        A running cluster to run the sessions on (``reproduce figure9`` passes its own).
    after_sessions : callable, optional
        Called with ``out_dir/data``, the per-participant results and the analysable trials
        (:func:`analysis.load.load_trials`'s, read once for it and the analysis; a copy of
        its own) once every session has ended, before the analysis (``reproduce figure9``
        starts the receptor-depth fit there, which needs only the sessions' answers).
    analysis_figure9 : bool
        Have the analysis draw ``figure9.png`` / ``.pdf`` (default); ``reproduce figure9``
        draws its own in their place (``analysis.analyze(..., figure9=False)``).
    replay : str, optional
        A replay hypothesis (:data:`stimuli.paper.REPLAY_NAMES`, :mod:`experiments.simulation.
        replay`): sets the side, the rate limit, the method and the replayed material.
        The variant is built from the protocol's data and recorded in ``out_dir/protocol.json``.
        A responder option ``observer=display_learned`` also adds a familiarisation block on
        the display.

    Returns
    -------
    dict
        ``out_dir``, ``sessions`` (per-participant results), ``seconds`` (wall time of the
        sessions), ``analysis`` (whatever :func:`analysis.analyze` returned), ``analysis_seconds``.

    Raises
    ------
    UserInputError
        ``out_dir`` is a file or holds earlier study data, ``participants`` or ``workers`` not
        an integer in range, an unknown or bad responder option, an unknown target side or
        rate limit, or profiles the display would refuse; all before any session runs.
    """
    out_dir = Path(out_dir)
    data_dir = out_dir / "data"
    records, n, workers = _checked_study_options(out_dir, seed, workers, participants,
                                                 responder_options)
    out_dir.mkdir(parents=True, exist_ok=True)      # a target-side protocol copy goes here
    from experiments.participant_model.observers import OBSERVERS
    observer = (responder_options or {}).get("observer", "absolute")
    on_display = observer in OBSERVERS and OBSERVERS[observer].familiarise_on_display
    protocol_name = str(protocol)
    protocol, used = _protocol_for_side(protocol, target_side, out_dir, rate_limit, replay,
                                        display_familiarisation=on_display)
    check_group_profiles(used)
    data_dir.mkdir(parents=True, exist_ok=True)
    paths = {p.stem: p for p in write_cohort(out_dir / "participants", seed=seed)}
    paths = [paths[r["id"]] for r in alternate_groups(records, n)]
    jobs = [(str(p), str(data_dir), int(seed), protocol, dict(responder_options or {}), bool(durable))
            for p in paths]
    start = time.perf_counter()
    results, workers = _run_sessions(jobs, workers, sweep)
    seconds = time.perf_counter() - start
    summary = {"out_dir": str(out_dir), "sessions": sorted(results, key=lambda r: r["participant"]),
               "seconds": seconds, "analysis": None, "analysis_seconds": 0.0}
    loaded, load_s = None, 0.0
    if after_sessions is not None or analyze:
        from analysis.load import load_trials
        t0 = time.perf_counter()
        loaded = load_trials(data_dir)      # read once, for both (~1 s of this process each)
        load_s = time.perf_counter() - t0
    if after_sessions is not None:
        after_sessions(data_dir, summary["sessions"], loaded.analysable)
    if analyze:
        _analyse(summary, data_dir, out_dir, used, loaded, load_s, analysis_figure9)
    from sessionfiles.logbook import atomic_write_json
    atomic_write_json(out_dir / "study.json", {
        "study": "figure9", "seed": int(seed), "workers": workers,
        "protocol": protocol_name if isinstance(protocol, str) else str(out_dir / "protocol.json"),
        "replay": replay, "observer": observer, "fsync": bool(durable),
        "responder_options": dict(responder_options or {}),
        "protocol_hash": used.hash,
        "target_side": used.simulation.target_side,
        "pad_roughness_um": used.simulation.pad_roughness_um,
        "pad_material": used.simulation.pad_material,
        "rate_limit": used.simulation.rate_limit,
        "sessions_s": seconds, "analysis_s": summary["analysis_seconds"],
        "participants": summary["sessions"]})
    return summary


def _checked_study_options(out_dir, seed, workers, participants, responder_options):
    """``(cohort records, participants to run, workers)`` after the checks made before any
    session runs (a UserInputError naming the option otherwise)."""
    from experiments.errors import UserInputError
    from experiments.responders import get_responder
    data_dir = out_dir / "data"
    if out_dir.exists() and not out_dir.is_dir():
        raise UserInputError(f"{out_dir}: --out: expected a folder, got an existing file")
    if data_dir.is_dir() and any(data_dir.iterdir()):
        raise UserInputError(f"{data_dir}: --out: expected a folder without earlier study data "
                             f"(the analysis would pool both runs), got a non-empty data/ folder")
    records = paper_cohort(seed)
    n = len(records) if participants is None else _positive_int(participants, "--participants",
                                                                 len(records))
    if workers is not None:
        workers = _positive_int(workers, "--workers")
    if "seed" in (responder_options or {}):
        # each simulated person has their own seed (from the cohort's); one seed for all would
        # give every participant the same noise draws
        raise UserInputError(f"--responder-option: seed: expected no seed (each participant's "
                             f"comes from the study's --seed), got {responder_options['seed']!r}")
    get_responder("simulated", **dict(responder_options or {}))   # bad options: fail now
    return records, n, workers


def _run_sessions(jobs, workers, sweep) -> tuple[list, int]:
    """Every job's session (:func:`_run_one`): here one after the other with one worker and no
    ``sweep``, else as tasks of a dask.distributed cluster (``sweep``'s, else a LocalCluster).

    Returns the per-participant results and the number of worker processes that ran them
    (``sweep``'s workers when given, not the ``workers`` asked for).
    """
    if workers is None:
        workers = min(2 * (os.cpu_count() or 1), MAX_DEFAULT_WORKERS)
    workers = min(workers, len(jobs))
    if workers == 1 and sweep is None:
        results, start = [], time.perf_counter()
        for job in jobs:
            results.append(_run_one(job))
            _progress(len(results), len(jobs), start, results[-1]["participant"])
        return results, workers
    from contextlib import nullcontext

    from experiments.simulation.sweep import Sweep
    with (nullcontext(sweep) if sweep is not None
          else Sweep(workers=workers, label="figure9 sessions")) as runner:
        results = runner.map(_run_one, [(job,) for job in jobs], what="participants",
                             priority=SESSION_PRIORITY)
        if sweep is not None:
            workers = runner.n_workers or workers
    return results, workers


def _analyse(summary, data_dir, out_dir, used, loaded=None, load_s=0.0, figure9=True) -> None:
    """:func:`analysis.analyze` of the sessions (``loaded``: already read, in ``load_s``) into
    ``summary`` (``analysis``, ``analysis_seconds``, the reading included); the Figure 9 table
    logged.  In this process, figures and profile intervals included: given the cluster's
    workers (``analyze(..., executor=client)``) the analysis took ~4 s less of this process but
    the workers' imports for it (~190 MiB each) took the whole study over 1 GB (summed RSS
    963-996 MiB, ``benchmarks/bench_study.py``)."""
    from analysis import analyze as run_analysis
    t0 = time.perf_counter()
    summary["analysis"] = run_analysis(data_dir, out_dir, loaded=loaded, figure9=figure9)
    summary["analysis_seconds"] = load_s + time.perf_counter() - t0
    _note_simulation(out_dir / "report.md", used)
    if log.isEnabledFor(logging.INFO):
        table = _figure9_text(getattr(summary["analysis"], "proportions", None))
        log.info("figure9: target side %r, finger-pad %g µm %s, rate limit %r",
                 used.simulation.target_side, used.simulation.pad_roughness_um,
                 used.simulation.pad_material, used.simulation.rate_limit)
        for line in table.splitlines():
            log.info("%s", line)
        log.info("figure9: sessions %.1f s, analysis %.1f s; results in %s", summary["seconds"],
                 summary["analysis_seconds"], out_dir)


def _note_simulation(report, protocol) -> None:
    """Append which target side and finger–pad contact the simulated trials used to ``report``."""
    if not report.is_file():
        return
    sim = protocol.simulation
    side = {"material": f"the material side of the interface, T_M(L+), method {sim.method!r}, "
                        f"{sim.replayed_material} steel",
            "skin": "the skin side of the interface, T_S(L-)",
            "compensated": "the pad temperature that reproduces the real contact through the "
                           "finger-pad resistance"}[sim.target_side]
    text = (f"\n## Simulated trials (Figure 9 study)\n\n"
            f"- target side: `{sim.target_side}` ({side})\n"
            f"- finger-pad contact: {sim.pad_material}, R_a {sim.pad_roughness_um:g} µm "
            f"(Eq. 5, {sim.pad_resistance():.4g} m² K/W for the default skin conductivity); "
            f"the simulated participants feel the pad through it\n"
            f"- profiles faster than the display's {protocol.display.max_rate_C_per_s:g} °C/s: "
            f"`{sim.rate_limit}`\n"
            f"- replays computed for {sim.skin_temperature_C:g} °C skin (the protocol's "
            f"[simulation] skin_temperature_C; the paper's simulations used 36 °C: a sensitivity "
            f"row)\n"
            + _replay_bounds(protocol) +
            f"- protocol: `{protocol.path if protocol.path is not None else 'protocol.json'}` "
            f"(sha256 {protocol.hash[:12]})\n")
    text += _felt_at_receptors(protocol)
    with open(report, "a", encoding="utf-8") as fh:
        fh.write(text)


def _replay_bounds(protocol) -> str:
    """One line: each group's uploaded profiles' ``error_bound_C`` (the model's bound plus what
    the rate limit changed), naming the profiles the slew changed and by how much."""
    from experiments.session.setup import simulated_target_profile
    cells, slewed = [], []
    for group in sorted(protocol.simulation.group_skin_thickness_um):
        for sample in protocol.samples:
            prof = simulated_target_profile(protocol, {}, group, None, sample.id,
                                            sample.roughness_um)
            cells.append(f"{group} {sample.label} {prof.error_bound:.3g}")
            change = prof.parameters["rate_limited_max_change_C"]
            if change > 0:
                slewed.append(f"{group} {sample.label} by {change:.2f} K")
    return (f"- error_bound_C of the uploaded profiles (model bound + rate-limit change), K: "
            + ", ".join(cells) + "; slewed: " + (", ".join(slewed) or "none") + "\n")


def _felt_at_receptors(protocol, at_s: float = 5.0) -> str:
    """What the model's receptors feel after ``at_s`` of contact, real against replayed.

    For the group's profile skin (no noise, the protocol's temperatures): the receptor
    temperature touching each real sample (:func:`stimuli.planner.planned_temperature`), and
    touching the pad while it plays that sample's target profile through the finger-pad
    resistance (:func:`stimuli.display_planner.planned_skin_response`), both through the scene
    planner at the simulated participant's tolerance
    (:data:`experiments.participant_model.person.MODEL_TOLERANCE_C`). Markdown lines; they say
    why simulated samples are named as they are, and which model the planner chose for each
    (method, tolerance, error bound).
    """
    from experiments.participant_model.person import MODEL_TOLERANCE_C
    from stimuli import Skin, contact_resistance, material, target_profile
    from stimuli.display_planner import planned_skin_response
    from stimuli.planner import plan_summary, planned_temperature
    sim = protocol.simulation
    steel = material(protocol.material.name, protocol.material.thickness_m)
    tol = MODEL_TOLERANCE_C
    lines = [f"\nReceptor temperature after {at_s:g} s of contact (model, no noise; the group's "
             f"profile skin, {sim.skin_temperature_C:g} °C skin, {sim.material_temperature_C:g} °C "
             f"samples): real sample / display playing its `{sim.target_side}` profile\n"]
    spans = {}
    decisions = {}          # (felt as, model summary) -> [group sample, ...]
    grid = np.arange(int(round(at_s * sim.rate_Hz)) + 1) / sim.rate_Hz
    for group in sorted(sim.group_skin_thickness_um):
        L = sim.skin_thickness_for(group) * 1e-6
        skin = Skin(L, dermis=sim.dermis_fraction * L)
        r_pad = sim.pad_resistance(skin)
        cells = []
        for sample in protocol.samples:
            R = contact_resistance(sample.roughness_m, skin, steel)
            T_real, p_real = planned_temperature("receptor", skin, steel, R, sim.skin_temperature_C,
                                                 sim.material_temperature_C, grid, tolerance=tol)
            real = float(T_real[-1])
            played = steel if sim.replayed_material == "sample" else material(protocol.material.name)
            prof = target_profile(material=played, roughness=sample.roughness_m, skin=skin,
                                  skin_temperature=sim.skin_temperature_C,
                                  material_temperature=sim.material_temperature_C,
                                  duration=at_s, rate=sim.rate_Hz, resolution=sim.resolution_C,
                                  side=sim.target_side, pad_resistance=r_pad, cache=False,
                                  method=sim.method, resistance=R)
            T_felt, p_felt = planned_skin_response(skin, prof.times, prof.temperature,
                                                   sim.skin_temperature_C, depth=skin.dermis,
                                                   resistance=r_pad, tolerance=tol)
            felt = float(T_felt[-1])
            cells.append(f"{sample.label} {real:.2f} / {felt:.2f} °C")
            spans.setdefault(group, []).append((real, felt))
            for what, p in (("real sample", p_real), ("display", p_felt)):
                d = plan_summary(p)
                key = (what, d["model"], d["method"])
                decisions.setdefault(key, []).append((f"{group} {sample.label}", d["bound_K"]))
        lines.append(f"- group {group} ({L * 1e6:g} µm): " + ", ".join(cells) + "\n")
    lines.append(f"\nModels of these receptor temperatures (scene planner, tolerance {tol:g} K, "
                 f"the simulated participant's):\n")
    for (what, model, method), where in decisions.items():
        lines.append(f"- {what}: {model} (method {method}; error bound at most "
                     f"{max(b for _, b in where):.2g} K) for {len(where)} contacts "
                     f"({', '.join(w for w, _ in where)})\n")
    real_rise = np.mean([v[-1][0] - v[0][0] for v in spans.values()])
    felt_rise = np.mean([v[-1][1] - v[0][1] for v in spans.values()])
    if real_rise > 0 and felt_rise < real_rise / 4:
        lines.append(f"\nThe real samples leave the receptors {real_rise:.2f} K warmer on the "
                     f"roughest than on the smoothest; the replayed ones {felt_rise:+.2f} K, so the "
                     f"display's rough samples feel like the smooth real ones and are named so: "
                     f"the profile leaves out the contact resistance that made the real ones "
                     f"feel warmer (see README; `--target-side compensated --rate-limit slew` "
                     f"replays it).\n")
    return "".join(lines)


def _protocol_for_side(protocol, target_side, out_dir, rate_limit=None, replay=None,
                       display_familiarisation: bool = False):
    """``(protocol to run, parsed Protocol)``; with overrides, a variant built from its data.

    ``replay`` names a replay hypothesis (:data:`experiments.simulation.replay.REPLAY_HYPOTHESES`,
    which sets ``target_side`` and ``rate_limit``); ``target_side`` / ``rate_limit`` override
    single fields.  A variant is parsed from a modified copy of the protocol's data
    (:func:`experiments.protocol.parse_protocol`, never by editing TOML text) and its content is
    written to ``out_dir/protocol.json`` for the record; the sessions get the parsed protocol
    (each session.json holds it whole).
    """
    from experiments.errors import UserInputError
    from sessionfiles.logbook import atomic_write_json
    from experiments.protocol import load_protocol, parse_protocol
    from experiments.simulation.replay import (_add_display_familiarisation, _with_simulation,
                                               replay_hypothesis)
    base = load_protocol(protocol)
    sim = base.simulation
    if sim is None:
        raise UserInputError(f"{protocol}: simulation: expected a [simulation] table for the "
                             f"Figure 9 study, got nothing")
    changes = {}
    if replay is not None:
        hyp = replay_hypothesis(replay)
        changes = {"target_side": hyp.target_side, "rate_limit": hyp.rate_limit,
                   "method": hyp.method, "replayed_material": hyp.replayed_material}
    for key, value, choices, option in (("target_side", target_side, TARGET_SIDES, "--target-side"),
                                        ("rate_limit", rate_limit, RATE_LIMITS, "--rate-limit")):
        if value is None:
            continue
        if value not in choices:
            raise UserInputError(f"{option}: expected one of {', '.join(choices)}, got {value!r}")
        changes[key] = value
    changes = {k: v for k, v in changes.items() if v != getattr(sim, k)}
    if not changes and not display_familiarisation:
        return str(protocol), base
    data = _with_simulation(base.data, **changes)
    if display_familiarisation:
        data = _add_display_familiarisation(data)
    where = base.path.name if base.path is not None else base.name
    variant = parse_protocol(data, source=f"{where} (variant: " + ", ".join(
        [f"{k} = {v!r}" for k, v in changes.items()] +
        (["familiarised on the display"] if display_familiarisation else [])) + ")")
    atomic_write_json(Path(out_dir) / "protocol.json", variant.data)
    return variant, variant


def check_group_profiles(protocol) -> None:
    """Refuse, before any session runs, a study protocol whose group profiles the display refuses.

    Computes each sample's profile for each group's profile thickness (as the session will, for a
    participant without calibration) and applies the display's checks
    (:func:`experiments.display.safety.check_profile`). The session checks one participant's
    schedule the same way when it is made (:func:`experiments.session.check_schedule_profiles`).

    Raises
    ------
    UserInputError
        Naming the protocol file, the sample and the fields to change.
    """
    from experiments.errors import SafetyLimitError, UserInputError
    from experiments.display.safety import check_profile
    from experiments.session import simulated_target_profile
    sim = protocol.simulation
    limits = protocol.display.safety_limits()
    groups = sorted(sim.group_skin_thickness_um) or [None]
    where = protocol.path.name if protocol.path is not None else protocol.name
    for group in groups:
        thickness = sim.group_skin_thickness_um.get(group, 1000.0) if group else 1000.0
        for sample in protocol.samples:
            prof = simulated_target_profile(protocol, {}, group, thickness, sample.id, sample.roughness_um)
            try:
                check_profile(prof.times, prof.temperature, limits)
            except SafetyLimitError as exc:
                hint = (" (or --rate-limit slew)" if sim.rate_limit == "refuse" else "")
                raise UserInputError(
                    f"{where}: simulation.target_side: expected profiles the display accepts; "
                    f"{sim.target_side!r} for sample {sample.label} (group {group}) gives "
                    f"{str(exc).removeprefix('display: ')}; set [simulation] rate_limit = "
                    f"\"slew\"{hint} or raise display.max_rate_C_per_s") from None


def _figure9_text(proportions) -> str:
    """Figure 9's numbers as a small text table (proportion correct per group x mode x sample)."""
    if proportions is None or not hasattr(proportions, "pivot_table"):
        return ""
    try:
        table = proportions.pivot_table(index=["group", "mode"], columns="roughness_id",
                                        values="proportion_correct")
    except (KeyError, ValueError):
        return ""
    lines = ["figure9: proportion correct   " + "  ".join(f"{c}#".rjust(5) for c in table.columns)]
    for (group, mode), row in table.iterrows():
        lines.append(f"figure9:   group {group} {mode:<10}  " + "  ".join(f"{v:5.2f}" for v in row))
    return "\n".join(lines) + "\n"
