"""`thermocue reproduce {figure9,table2,figures} --out DIR`: the paper's results, recomputed.

* ``figures``: Figs. 3, 4a, 4b, 5, 6 as PNG + CSV, each with the paper's formulas as
  printed, corrected, and the exact solution side by side (:mod:`experiments.reproduction.model_figures`).
* ``table2``: Table 2 beside our models, with residuals (:mod:`experiments.reproduction.table2`); the
  markdown table is also printed.
* ``figure9``: the paper's claims under every (replay hypothesis x observer) scenario from
  many simulated 15 + 15 studies, then the 30-participant study on the emulated display for the
  headline scenario (:func:`experiments.simulation.figure9.reproduction.run_reproduction`): by default
  the scenario that best matches the paper's evidence; ``--replay`` and ``--observer`` choose
  it (``--target-side`` / ``--rate-limit`` override single fields); ``study.json`` and
  ``report.md`` say which. ``--participants N`` runs N of
  the 30 (taken from groups A and B in turn), ``--workers N`` sets the local dask cluster's worker processes (``--scheduler ADDRESS``: a
  running cluster instead), ``--force-sd-N`` the per-touch force spread,
  ``--responder-option KEY=VALUE`` passes options to every simulated participant.
"""
from __future__ import annotations

from pathlib import Path

from stimuli.paper import RATE_LIMITS, REPLAY_NAMES, TARGET_SIDES

TARGETS = ("figure9", "table2", "figures")


def register(sub) -> None:
    p = sub.add_parser("reproduce", help="recompute the paper's figures and tables",
                       description=__doc__.split("\n\n")[0])
    p.add_argument("target", choices=TARGETS, help="what to reproduce")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder (created if missing)")
    p.add_argument("--seed", type=int, default=0, help="figure9 only: cohort seed (default 0)")
    # the replay hypotheses are named after the side they replay (test_paper.py checks it)
    p.add_argument("--replay", choices=REPLAY_NAMES, default=None,
                   help="figure9 only: the headline's replay hypothesis, named by what the "
                        "display plays: 'printed' (Eq. 7 as printed, material side, half-space), "
                        "'halfspace' / 'slab' (exact material side of a half-space / the 3 mm "
                        "sample), 'skin' (exact skin side) or 'compensated'; default: the best "
                        "match to the paper's evidence")
    p.add_argument("--observer", choices=("absolute", "relative", "range_frequency",
                                          "display_learned"), default=None,
                   help="figure9 only: the headline's observer model (the simulated "
                        "participants' decision rule); default: the best match")
    p.add_argument("--studies", type=int, default=None, metavar="N",
                   help="figure9 only: simulated 15+15 studies per scenario and per sensitivity "
                        "row in the first round (default 200); undecided ones get more")
    p.add_argument("--max-studies", type=int, default=None, metavar="N",
                   help="figure9 only: cap of the studies added sequentially to a scenario "
                        "whose result is undecided at this precision (default 3200; a "
                        "sensitivity row stops at 800)")
    p.add_argument("--from", dest="from_dir", default=None, metavar="DIR",
                   help="figure9 only: recompute the claims, verdict and figure from the "
                        "per-study tables (studies.csv, sensitivity_studies.csv) of an earlier "
                        "run in DIR, without simulating")
    p.add_argument("--force-sd-N", type=float, default=None, metavar="N",
                   help="figure9 only: spread (sd, N) of the per-touch contact force about the "
                        "lab's 2.5 N (clipped to 2.05-3 N, past the display's 2 N trigger), in "
                        "the simulated studies and the emulated sessions alike (default 0.25: "
                        "an assumption, the paper says 'about 2 N'; 0: every touch at 2.5 N)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="figure9 only: run the simulated studies and the sessions on the dask "
                        "scheduler at ADDRESS (tcp://host:port) instead of a local cluster")
    p.add_argument("--target-side", choices=TARGET_SIDES, default=None,
                   help="figure9 only: what the display replays on simulated trials: 'material' "
                        "(the paper's Eq. 7), 'skin' or 'compensated' (through the finger-pad "
                        "resistance, the real contact); default: the protocol's (material)")
    p.add_argument("--rate-limit", choices=RATE_LIMITS, default=None,
                   help="figure9 only: profiles faster than the display's rate limit are refused "
                        "(the study stops before it starts) or slowed to it ('slew'; compensated "
                        "3#/4# need it); default: the replay hypothesis's")
    p.add_argument("--participants", type=int, default=None, metavar="N",
                   help="figure9 only: run N of the 30 participants, taken from groups A and B "
                        "in turn (P01, P16, P02, ...); default: all 30")
    p.add_argument("--workers", type=int, default=None, metavar="N",
                   help="figure9 only: worker processes of the local dask cluster running the "
                        "simulated studies and the sessions; default: the CPU count, at most 4")
    p.add_argument("--responder-option", action="append", default=[], metavar="KEY=VALUE",
                   help="figure9 only: option of every simulated participant (repeatable), "
                        "e.g. lapse_rate=0.1 or drop_noise_C=0.2")
    p.set_defaults(func=_run)


def _out_dir(path: str, create: bool = True) -> Path:
    from experiments.errors import UserInputError
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise UserInputError(f"{path}: --out: expected a folder, got an existing file")
    if create:
        out.mkdir(parents=True, exist_ok=True)
    return out


#: Options that only the figure9 study takes (argparse dest, option).
_FIGURE9_ONLY = (("replay", "--replay"), ("observer", "--observer"), ("studies", "--studies"),
                 ("max_studies", "--max-studies"), ("from_dir", "--from"),
                 ("force_sd_N", "--force-sd-N"), ("scheduler", "--scheduler"),
                 ("target_side", "--target-side"), ("rate_limit", "--rate-limit"),
                 ("participants", "--participants"), ("workers", "--workers"),
                 ("responder_option", "--responder-option"))


def _run(ns) -> int:
    from experiments.errors import UserInputError
    if ns.target != "figure9":
        for dest, option in _FIGURE9_ONLY:
            if getattr(ns, dest) not in (None, []):
                raise UserInputError(f"{option}: expected only with `reproduce figure9`, got it "
                                     f"with `reproduce {ns.target}`")
    # figure9 makes its folder itself, once every option has been checked
    out = _out_dir(ns.out, create=ns.target != "figure9")
    from sessionfiles.atomicfile import OutputFolder
    folder = OutputFolder(out, f"thermocue reproduce {ns.target}")   # COMPLETE written last
    if ns.target == "figures":
        from experiments.reproduction.model_figures import write_figures
        folder.begin()
        written = write_figures(out)
        folder.finish(written)
        for path in written:
            print(path)
        return 0
    if ns.target == "table2":
        from experiments.reproduction.table2 import write_table2
        folder.begin()
        csv_path, md_path, md = write_table2(out)
        folder.finish([csv_path, md_path])
        print(md)
        print(csv_path)
        print(md_path)
        return 0
    # figure9: the simulated cohort (experiments/participant_model/cohort.py, figure9.py)
    from experiments.cli.run import responder_options
    from experiments.simulation.figure9.reproduction import recompute_from, run_reproduction
    if ns.from_dir is not None:
        for dest, option in _FIGURE9_ONLY:
            if dest != "from_dir" and getattr(ns, dest) not in (None, []):
                raise UserInputError(f"{option}: expected nothing with --from (it simulates "
                                     f"nothing), got {getattr(ns, dest)!r}")
        if Path(ns.from_dir).resolve() == out.resolve():
            raise UserInputError(f"{ns.out}: --out: expected a folder other than --from's")
        out.mkdir(parents=True, exist_ok=True)
        folder.begin()
        recompute_from(ns.from_dir, out)
        folder.finish()
        return 0
    if out.is_dir():          # an earlier run's COMPLETE goes first (the study makes the folder)
        folder.begin()
    run_reproduction(out, seed=ns.seed, target_side=ns.target_side, rate_limit=ns.rate_limit,
                     participants=ns.participants, workers=ns.workers, replay=ns.replay,
                     observer=ns.observer, scheduler=ns.scheduler, force_sd_N=ns.force_sd_N,
                     **({} if ns.studies is None else {"n_studies": ns.studies}),
                     **({} if ns.max_studies is None else {"max_studies": ns.max_studies}),
                     responder_options=responder_options(ns.responder_option))
    folder.finish()
    return 0
