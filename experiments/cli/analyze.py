"""``thermocue analyze DATA_DIR --out DIR``: Figure 9, every table and report.md from the logs."""
from __future__ import annotations

import logging
import time
from pathlib import Path
import warnings

log = logging.getLogger("thermocue.analysis")


def register(sub) -> None:
    p = sub.add_parser(
        "analyze", help="analyse the sessions under DATA_DIR: figure9.png, CSV tables, report.md",
        description="Load and validate every session under DATA_DIR (DATA/<participant>/<session>/), "
                    "compute proportions correct with Wilson and participant-bootstrap intervals, "
                    "confusion matrices, a GEE (the primary test), a maximum-likelihood mixed logit "
                    "(participant random intercepts), the named tests (omnibus, Holm, interaction, "
                    "chance), missing data and psychophysics tables, and write figure9.png, the "
                    "full-precision CSV tables, codebook.json, settings.json and report.md to --out.")
    p.add_argument("data_dir", metavar="DATA_DIR", help="data directory holding the session folders")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory (created)")
    p.add_argument("--bootstrap", type=int, default=2000, metavar="N",
                   help="participant-bootstrap resamples (default 2000)")
    p.add_argument("--seed", type=int, default=20261122, help="seed of the bootstrap (default 20261122)")
    p.add_argument("--sessions", choices=("first", "latest", "all"), default="first",
                   help="which sessions of a participant are analysed: the first complete one "
                        "(default), the latest complete one, or all (incomplete ones included); "
                        "the report lists every session and why")
    p.add_argument("--equivalence-margin-pp", type=float, default=None, metavar="PP",
                   help="margin of the real-vs-simulated equivalence test, percentage points of "
                        "proportion correct (default: the protocol's [analysis] "
                        "equivalence_margin_pp, else 10)")
    p.add_argument("--condition", default=None, metavar="BACKEND/CONTACT",
                   help="analyse only the sessions of this display backend and contact model "
                        "(e.g. tcs2/resting, serial/press); needed when DATA_DIR holds more than "
                        "one: trials of different displays or contact models are never pooled")
    p.add_argument("--no-mixed", action="store_true",
                   help="skip the maximum-likelihood mixed logit (faster)")
    p.add_argument("--bayes-vb", action="store_true",
                   help="also fit the mean-field variational Bayes mixed logit (comparison only: "
                        "its intervals are too narrow)")
    p.add_argument("--no-bayes", action="store_true",
                   help="accepted for old scripts; variational Bayes is off unless --bayes-vb")
    p.set_defaults(func=_run)


def _run(ns) -> int:
    from experiments.errors import UserInputError

    from experiments.cli.paths import check_writable_dir
    check_writable_dir(ns.out, "--out")      # before any computation
    if ns.bootstrap < 0:
        raise UserInputError(f"--bootstrap: expected an integer >= 0, got {ns.bootstrap!r}")
    start = time.monotonic()
    # the sessions are read by a forked child while this process imports SciPy, statsmodels
    # and the analysis (~1 s of the command on 2 cores; the same tables, analysis.load_ahead)
    from analysis import load_ahead
    pending = load_ahead.start(ns.data_dir, sessions=ns.sessions, condition=ns.condition)
    from analysis import LogWarning, analyze

    def progress(message: str) -> None:      # analysis.analyze's steps, with the time so far
        log.info("[%6.1f s] %s", time.monotonic() - start, message)

    from sessionfiles.atomicfile import OutputFolder
    folder = OutputFolder(ns.out, "thermocue analyze")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LogWarning)     # listed in the report and below
        progress(f"loading sessions under {ns.data_dir}")
        loaded = pending.result()
        result = analyze(ns.data_dir, ns.out, loaded=loaded, n_boot=ns.bootstrap, seed=ns.seed,
                         bayes=ns.bayes_vb and not ns.no_bayes, mixed=not ns.no_mixed,
                         progress=progress, sessions=ns.sessions,
                         equivalence_margin_pp=ns.equivalence_margin_pp,
                         condition=ns.condition,
                         before_write=folder.begin)     # COMPLETE removed, written last
    written = {Path(p) for p in result.files.values()}
    written |= {p.with_suffix(".pdf") for p in written if p.suffix == ".png"
                and p.with_suffix(".pdf").is_file()}            # figure9's vector copy
    folder.finish(written)
    for message in result.log.warnings:
        log.warning("warning: %s", message)
    progress(f"done: {result.files['report']}")
    print(result.files["report"])
    return 0
