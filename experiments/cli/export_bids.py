"""`thermocue export-bids DATA_DIR`: (re)write the BIDS behavioural dataset of every session."""
from __future__ import annotations

from pathlib import Path


def register(sub) -> None:
    p = sub.add_parser(
        "export-bids", help="write DATA_DIR/bids (BIDS behavioural files) from every session",
        description="Write sub-<id>/ses-<n>/beh/sub-<id>_ses-<n>_task-<protocol>_beh.tsv and its "
                    "JSON sidecar for every session folder under DATA_DIR, with "
                    "dataset_description.json and participants.tsv (a finished session does this "
                    "itself; this rebuilds the dataset).")
    p.add_argument("data_dir", metavar="DATA_DIR", help="data directory holding the session folders")
    p.add_argument("--out", default=None, metavar="DIR", help="the BIDS dataset (default DATA_DIR/bids)")
    p.set_defaults(func=_run)


def _run(ns) -> int:
    from experiments.bids import export_dataset
    from experiments.cli.paths import check_writable_dir
    from experiments.errors import UserInputError

    if not Path(ns.data_dir).is_dir():
        raise UserInputError(f"{ns.data_dir}: DATA_DIR: expected an existing folder, got none")
    out = check_writable_dir(ns.out or Path(ns.data_dir) / "bids", "--out")
    written = export_dataset(ns.data_dir, out)
    if not written:
        raise UserInputError(f"{ns.data_dir}: DATA_DIR: expected session folders (session.json "
                             f"and trials.csv), got none")
    print(f"{len(written)} session(s) -> {out}")
    return 0
