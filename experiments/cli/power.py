"""``thermocue power``: power to detect the group difference, by simulating cohorts.

The cohorts are simulated on a ``dask.distributed`` cluster (:class:`experiments.simulation.sweep.
Sweep`: a LocalCluster of ``--workers`` processes, or the scheduler at ``--scheduler``), in the
fixed, self-seeded tasks of :func:`analysis.power.cohort_task`: the same ``--seed`` gives the
same tables whatever the number of workers; progress with the time remaining on stderr.
"""
from __future__ import annotations

import json
import logging
import time
from pathlib import Path

from stimuli.paper import MODES

log = logging.getLogger("thermocue.analysis")


def register(sub) -> None:
    p = sub.add_parser(
        "power", help="power of the report's primary test (group A-B, real samples) vs cohort size",
        description="Simulate cohorts of each size from the participant-level model (random "
                    "intercepts, per-cell probabilities for a typical participant), run the "
                    "report's own test on each (GEE with its formula and fallbacks; A-B averaged "
                    "over samples), and write power.csv, power_summary.json (n per group for 80 "
                    "and 90 %% power), power.png and cells.csv to --out. The probabilities come "
                    "from --from-analysis DIR (the mixed model of `thermocue analyze`), --cells "
                    "FILE, else the simulated-participant model "
                    "(experiments.participant_model.prediction.predicted_cell_probabilities).")
    p.add_argument("--n-per-group", default=None, metavar="N,N,A:B,...",
                   help="participants per group, comma-separated; A:B for unequal groups "
                        "(default 5,10,15,20,30,40,60; with --from-analysis the analysed A:B "
                        "sizes are added)")
    p.add_argument("--simulations", type=int, default=400, metavar="N",
                   help="cohorts per size (default 400)")
    p.add_argument("--cells", metavar="FILE",
                   help="CSV with columns group, mode, roughness_id, p_correct (probability 0-1)")
    p.add_argument("--from-analysis", metavar="DIR",
                   help="output folder of `thermocue analyze`: the design (group sizes, "
                        "repetitions, missing rate) and nuisance parameters (participant SD, "
                        "group B's typical-participant cells) from it; needs --effect-pp "
                        "(observed power is not computed)")
    p.add_argument("--effect-pp", metavar="PP,PP,...",
                   help="stated A - B difference(s) of mean proportions correct in the tested "
                        "mode, percentage points (the smallest effect of interest; several give "
                        "a power curve per effect); required with --from-analysis")
    p.add_argument("--cells-scale", choices=("marginal", "conditional"),
                   help="marginal: the cells are population averages (observed proportions, the "
                        "participant model) and are converted to a typical participant's; "
                        "conditional: they already are (default: conditional with "
                        "--from-analysis, else marginal)")
    p.add_argument("--participant-sd", type=float, metavar="SD",
                   help="SD of participant random intercepts, log-odds (default: the mixed "
                        "model's with --from-analysis, else 0.5)")
    p.add_argument("--missing-rate", type=float, default=None, metavar="P",
                   help="probability that a scheduled trial gives no answer (default: the "
                        "analysis's missing share with --from-analysis, else 0)")
    p.add_argument("--mode", choices=MODES, default="real",
                   help="mode whose group difference is tested (default real: the primary test)")
    p.add_argument("--test", choices=("gee", "cluster-t"), default="gee",
                   help="gee: the report's primary test (default); cluster-t: Welch t on "
                        "per-participant proportions (fast approximation)")
    p.add_argument("--alpha", type=float, default=0.05, help="two-sided level (default 0.05)")
    p.add_argument("--repetitions", type=int, default=None,
                   help="trials per participant and cell (default: the analysis's with "
                        "--from-analysis, else 3)")
    p.add_argument("--workers", type=int, default=None, metavar="N",
                   help="worker processes of the local dask cluster that simulates the cohorts "
                        "(default: the CPU count, at most 4); the result does not depend on it")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="simulate the cohorts on the dask scheduler at ADDRESS (tcp://host:port) "
                        "instead of a local cluster (its workers need this package importable)")
    p.add_argument("--seed", type=int, default=20261122)
    p.add_argument("--out", required=True, metavar="DIR", help="output directory (created)")
    p.set_defaults(func=_run)


def _sizes(text: str):
    from experiments.errors import UserInputError
    sizes = []
    try:
        for v in text.split(","):
            v = v.strip()
            if not v:
                continue
            sizes.append(tuple(int(x) for x in v.split(":")) if ":" in v else int(v))
    except ValueError:
        sizes = []
    flat = [x for s in sizes for x in (s if isinstance(s, tuple) else (s,))]
    if not sizes or min(flat) < 2 or any(isinstance(s, tuple) and len(s) != 2 for s in sizes):
        raise UserInputError(f"--n-per-group: expected comma-separated integers >= 2 (or A:B "
                             f"pairs), got {text!r}")
    return sizes


def _model_cells(progress):
    """Per-cell probabilities from the simulated-participant model, or None if unavailable."""
    try:
        from experiments.participant_model.prediction import predicted_cell_probabilities
    except ImportError:
        return None
    progress("predicting per-cell probabilities from the simulated-participant model")
    return predicted_cell_probabilities()


def _run(ns) -> int:
    from experiments.errors import UserInputError

    from experiments.cli.paths import check_writable_dir
    check_writable_dir(ns.out, "--out")      # before any computation
    from analysis.power_design import OBSERVED_POWER_WHY
    if ns.from_analysis and ns.effect_pp is None:
        raise UserInputError(f"--effect-pp: expected the smallest A - B difference of interest "
                             f"in percentage points with --from-analysis, got none: "
                             f"{OBSERVED_POWER_WHY}")
    effects = _effects(ns.effect_pp) if ns.effect_pp is not None else None
    if effects is not None and not ns.from_analysis:
        raise UserInputError("--effect-pp: expected --from-analysis DIR with it (the cells it "
                             "shifts), got none")
    sizes = _sizes(ns.n_per_group or "5,10,15,20,30,40,60")
    if ns.simulations < 1:
        raise UserInputError(f"--simulations: expected an integer >= 1, got {ns.simulations!r}")
    if ns.participant_sd is not None and ns.participant_sd < 0:
        raise UserInputError(f"--participant-sd: expected a number >= 0, got {ns.participant_sd!r}")
    if not 0 < ns.alpha < 1:
        raise UserInputError(f"--alpha: expected a number between 0 and 1, got {ns.alpha!r}")
    if ns.missing_rate is not None and not 0 <= ns.missing_rate < 1:
        raise UserInputError(f"--missing-rate: expected a number in [0, 1), got {ns.missing_rate!r}")
    if ns.workers is not None and ns.workers < 1:
        raise UserInputError(f"--workers: expected an integer >= 1, got {ns.workers!r}")
    if ns.from_analysis and not Path(ns.from_analysis).is_dir():     # before the cluster starts
        raise UserInputError(f"--from-analysis: expected an output folder of thermocue "
                             f"analyze, got {ns.from_analysis!r}")
    if not ns.from_analysis and ns.cells and not Path(ns.cells).is_file():
        raise UserInputError(f"--cells: expected an existing CSV file, got {ns.cells!r}")
    from experiments.simulation.sweep import Sweep
    # the cohorts go to a dask.distributed cluster (a LocalCluster unless --scheduler)
    with Sweep(workers=ns.workers, scheduler=ns.scheduler, label="power") as sweep:
        return _compute(ns, effects, sizes, sweep.map)


def _compute(ns, effects, sizes, map_tasks) -> int:
    from analysis.power import power_curve, read_cells
    from experiments.errors import UserInputError
    start = time.monotonic()

    def progress(message: str) -> None:      # power_curve's steps, with the time so far
        log.info("[%6.1f s] %s", time.monotonic() - start, message)

    sd, scale = ns.participant_sd, ns.cells_scale
    reps, missing_rate = ns.repetitions, ns.missing_rate
    if ns.from_analysis:
        if not Path(ns.from_analysis).is_dir():
            raise UserInputError(f"--from-analysis: expected an output folder of thermocue "
                                 f"analyze, got {ns.from_analysis!r}")
        from analysis.power_design import design_from_analysis, power_by_effect, sd_scenarios
        design = design_from_analysis(ns.from_analysis)
        scenarios = sd_scenarios(design, sd)
        reps = design["repetitions"] if reps is None else reps
        missing_rate = design["missing_rate"] if missing_rate is None else missing_rate
        if ns.n_per_group is None:
            observed = (design["n_group_A"], design["n_group_B"])
            sizes = sorted(set(sizes) | {observed if observed[0] != observed[1] else observed[0]},
                           key=lambda s: sum(s) / 2 if isinstance(s, tuple) else s)
        results = []
        for basis, sd in scenarios:
            progress(f"participant SD {sd:.3f} ({basis})")
            results.append((basis, power_by_effect(
                design["cells"], effects, sizes, participant_sd=sd, mode=ns.mode,
                simulations=ns.simulations, repetitions=reps, alpha=ns.alpha, test=ns.test,
                missing_rate=missing_rate, seed=ns.seed, progress=progress,
                map_tasks=map_tasks)))
        source = (f"{ns.from_analysis}: design (n {design['n_group_A']}:{design['n_group_B']}, "
                  f"{reps} repetitions, missing {missing_rate:.3f}) and participant SD "
                  + ", ".join(f"{sd:.3f} ({basis})" for basis, sd in scenarios)
                  + " from the analysis; group B's cells from its mixed model; group A's set "
                    "by the stated effect(s)")
        return _write(ns, results, source, sizes, progress)
    elif ns.cells:
        if not Path(ns.cells).is_file():
            raise UserInputError(f"--cells: expected an existing CSV file, got {ns.cells!r}")
        cells, source = read_cells(ns.cells), ns.cells
    else:
        cells, source = _model_cells(progress), "experiments.participant_model.prediction"
        if cells is None:
            raise UserInputError("--cells: expected a CSV of per-cell probabilities (group, mode, "
                                 "roughness_id, p_correct), got none, and the simulated-participant "
                                 "model is not available")
    basis = "stated (--participant-sd)" if sd is not None else "default"
    sd = 0.5 if sd is None else sd
    scale = scale or "marginal"
    result = power_curve(cells, sizes, simulations=ns.simulations,
                         repetitions=3 if reps is None else reps,
                         participant_sd=sd, mode=ns.mode, alpha=ns.alpha, test=ns.test,
                         cells_scale=scale, missing_rate=missing_rate or 0.0, seed=ns.seed,
                         progress=progress, map_tasks=map_tasks)
    return _write(ns, [(basis, result)], source, sizes, progress)


def grid_text(sizes) -> str:
    """The sizes power was computed at: ``[15, (13, 17)]`` -> ``15 per group, 13 + 17``."""
    return ", ".join(f"{s[0]} + {s[1]}" if isinstance(s, tuple) and s[0] != s[1]
                     else f"{s[0] if isinstance(s, tuple) else s} per group" for s in sizes)


def not_reached(sizes) -> str:
    """What the grid searched, when a power target was not reached on it.

    ``[15, 30, 60]`` -> ``not reached up to 60 per group (grid searched: 15, 30, 60)``;
    with unequal groups (``13:17``) the sizes searched are named as A + B, never as one
    "up to" size that neither group had.
    """
    grid = ", ".join(f"{s[0]} + {s[1]}" if isinstance(s, tuple) else str(s) for s in sizes)
    if any(isinstance(s, tuple) and s[0] != s[1] for s in sizes):
        return f"not reached on the grid searched ({grid} participants, group A + group B)"
    largest = max(s[0] if isinstance(s, tuple) else s for s in sizes)
    return f"not reached up to {largest} per group (grid searched: {grid})"


def _effects(text: str) -> list[float]:
    from experiments.errors import UserInputError
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        values = []
    if not values or any(not -100 < v < 100 for v in values):
        raise UserInputError(f"--effect-pp: expected comma-separated percentage points between "
                             f"-100 and 100, got {text!r}")
    return values


def _write(ns, results, source, sizes, progress) -> int:
    """Write power.csv (one block per participant SD, ``sd_basis`` saying which), cells.csv,
    power_summary.json, codebook.json and power.png (the first SD's curve); print each SD's
    table and the n for 80 % and 90 % power, each "conditional on SD = x"."""
    import pandas as pd

    from analysis.power_plot import plot_power
    from analysis.exports import codebook, write_csv
    from sessionfiles.atomicfile import OutputFolder, output_file

    table = pd.concat([r.table.assign(sd_basis=basis) for basis, r in results], ignore_index=True)
    folder = OutputFolder(ns.out, "thermocue power")
    out = folder.begin()                # every file whole (temporary + rename), COMPLETE last
    write_csv(table, out / "power.csv")
    write_csv(results[0][1].cells, out / "cells.csv")
    grid = [list(s) if isinstance(s, tuple) else s for s in sizes]
    by_sd = [{**r.settings, "sd_basis": basis} for basis, r in results]
    with output_file(out / "power_summary.json") as fh:
        fh.write(json.dumps({**by_sd[0], "cells_source": source, "n_per_group_grid": grid,
                             "by_participant_sd": by_sd}, indent=2))
    with output_file(out / "codebook.json") as fh:
        fh.write(json.dumps(codebook({"power": out / "power.csv", "cells": out / "cells.csv"}),
                            indent=2, ensure_ascii=False))
    plot_power(results[0][1], out / "power.png")
    folder.finish()
    progress(f"cells from {source}; wrote {out / 'power.csv'}, {out / 'power.png'}")
    print(f"Grid searched: {grid_text(sizes)} ({ns.simulations} simulated cohorts per size)")
    for basis, result in results:
        sd = result.settings["participant_sd"]
        print(f"Conditional on participant SD = {sd:.3f} ({basis}):")
        print(result.table.drop(columns=["test", "mode", "cells_scale"]).to_string(index=False))
        by_effect = result.settings.get("n_for_80_by_effect")
        for target, key in ((80, "n_for_80"), (90, "n_for_90")):
            found = (result.settings[f"{key}_by_effect"] if by_effect is not None
                     else {None: result.settings[key]})
            for effect, n in found.items():
                where = f" at A - B {float(effect):+g} points" if effect is not None else ""
                print(f"n per group for {target} % power{where}, conditional on SD = {sd:.3f}: "
                      + (f"{n:.0f} (interpolated on the grid; Monte Carlo error in power.csv)"
                         if n is not None else not_reached(sizes)))
    if len(results) > 1:
        print("The pilot's participant SD is an estimate: power at the ends of its 95 % profile "
              "interval shows how far the answer moves with it (Monte Carlo intervals in "
              "power.csv do not include this).")
    if results[0][1].settings.get("n_for_80_by_effect") is not None:
        print("Observed (post-hoc) power is not shown: computed at the effect the study found it "
              "is a function of the study's p-value and says nothing beyond it.")
    return 0
