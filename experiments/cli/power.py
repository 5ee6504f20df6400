"""``thermocue power``: power to detect the group difference, by simulating cohorts."""
from __future__ import annotations

import sys
import time


def register(sub) -> None:
    p = sub.add_parser(
        "power", help="power to detect the group A-B difference vs participants per group",
        description="Simulate cohorts of each size with participant random intercepts and the "
                    "per-cell probabilities of a correct answer, test the group difference, and "
                    "write power.csv, power.png and cells.csv to --out. The probabilities come "
                    "from --cells FILE, else from the simulated-participant model "
                    "(experiments.participant_model.predicted_cell_probabilities).")
    p.add_argument("--n-per-group", default="5,10,15,20,30", metavar="N,N,...",
                   help="participants per group, comma-separated (default 5,10,15,20,30)")
    p.add_argument("--simulations", type=int, default=2000, metavar="N",
                   help="cohorts per size (default 2000)")
    p.add_argument("--cells", metavar="FILE",
                   help="CSV with columns group, mode, roughness_id, p_correct (probability 0-1)")
    p.add_argument("--participant-sd", type=float, default=0.5, metavar="SD",
                   help="SD of participant random intercepts, log-odds (default 0.5)")
    p.add_argument("--mode", choices=("real", "simulated"), default="real",
                   help="mode whose group difference is tested (default real)")
    p.add_argument("--test", choices=("cluster-t", "gee"), default="cluster-t",
                   help="cluster-t: Welch t on per-participant proportions (fast); gee: the "
                        "report's GEE Wald test (slow)")
    p.add_argument("--alpha", type=float, default=0.05, help="two-sided level (default 0.05)")
    p.add_argument("--repetitions", type=int, default=3, help="trials per participant and cell (default 3)")
    p.add_argument("--seed", type=int, default=20261122)
    p.add_argument("--out", required=True, metavar="DIR", help="output directory (created)")
    p.set_defaults(func=_run)


def _sizes(text: str):
    from experiments.errors import UserInputError
    try:
        sizes = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        sizes = []
    if not sizes or min(sizes) < 2:
        raise UserInputError(f"--n-per-group: expected comma-separated integers >= 2, got {text!r}")
    return sizes


def _model_cells(progress):
    """Per-cell probabilities from the simulated-participant model, or None if unavailable."""
    try:
        from experiments.participant_model import predicted_cell_probabilities
    except ImportError:
        return None
    progress("predicting per-cell probabilities from the simulated-participant model")
    return predicted_cell_probabilities()


def _run(ns) -> int:
    from pathlib import Path

    from analysis.power import plot_power, power_curve, read_cells
    from experiments.errors import UserInputError

    from experiments.cli.paths import check_writable_dir
    check_writable_dir(ns.out, "--out")      # before any computation
    sizes = _sizes(ns.n_per_group)
    if ns.simulations < 1:
        raise UserInputError(f"--simulations: expected an integer >= 1, got {ns.simulations!r}")
    if ns.participant_sd < 0:
        raise UserInputError(f"--participant-sd: expected a number >= 0, got {ns.participant_sd!r}")
    if not 0 < ns.alpha < 1:
        raise UserInputError(f"--alpha: expected a number between 0 and 1, got {ns.alpha!r}")
    start = time.monotonic()

    def progress(message: str) -> None:
        print(f"[{time.monotonic() - start:6.1f} s] {message}", file=sys.stderr, flush=True)

    if ns.cells:
        if not Path(ns.cells).is_file():
            raise UserInputError(f"--cells: expected an existing CSV file, got {ns.cells!r}")
        cells, source = read_cells(ns.cells), ns.cells
    else:
        cells, source = _model_cells(progress), "experiments.participant_model"
        if cells is None:
            raise UserInputError("--cells: expected a CSV of per-cell probabilities (group, mode, "
                                 "roughness_id, p_correct), got none, and the simulated-participant "
                                 "model is not available")
    result = power_curve(cells, sizes, simulations=ns.simulations, repetitions=ns.repetitions,
                         participant_sd=ns.participant_sd, mode=ns.mode, alpha=ns.alpha,
                         test=ns.test, seed=ns.seed, progress=progress)
    out = Path(ns.out)
    out.mkdir(parents=True, exist_ok=True)
    result.table.to_csv(out / "power.csv", index=False, float_format="%.6g")
    result.cells.to_csv(out / "cells.csv", index=False, float_format="%.6g")
    plot_power(result, out / "power.png")
    progress(f"cells from {source}; wrote {out / 'power.csv'}, {out / 'power.png'}")
    print(result.table.to_string(index=False))
    return 0
