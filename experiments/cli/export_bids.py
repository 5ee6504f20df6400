"""`thermocue export-bids DATA_DIR`: (re)write the BIDS behavioural dataset of every session."""
from __future__ import annotations

import sys
from pathlib import Path


def register(sub) -> None:
    p = sub.add_parser(
        "export-bids", help="write DATA_DIR/bids (BIDS behavioural files) from every session",
        description="Write sub-<id>/ses-<n>/beh/sub-<id>_ses-<n>_task-<protocol>_beh.tsv and its "
                    "JSON sidecar for every session folder under DATA_DIR, with "
                    "dataset_description.json and participants.tsv (a finished session does this "
                    "itself; this rebuilds the dataset). Every folder is read and checked first "
                    "(regular UTF-8 files, session.json against the log, every value in its "
                    "domain): a refusal names the file and the field, exit 2, nothing written. "
                    "Folders not exported (a copy of another folder's session, no trial rows) "
                    "are named on stderr with the reason; COMPLETE is written last. "
                    "dataset_description.json's Authors: every --author, else the [protocol] "
                    "authors of the sessions' protocols; with neither, the dataset is written "
                    "without them and one warning line says how to add them.")
    p.add_argument("data_dir", metavar="DATA_DIR", help="data directory holding the session folders")
    p.add_argument("--out", default=None, metavar="DIR", help="the BIDS dataset (default DATA_DIR/bids)")
    p.add_argument("--author", action="append", default=[], metavar="NAME",
                   help="an author of the dataset (repeat for each, in order; default: the "
                        "protocol's [protocol] authors)")
    p.set_defaults(func=_run)


def _run(ns) -> int:
    from sessionfiles.atomicfile import OutputFolder
    from experiments.bids import export_dataset, mark_complete
    from experiments.cli.paths import check_writable_dir
    from experiments.errors import UserInputError

    if not Path(ns.data_dir).is_dir():
        raise UserInputError(f"{ns.data_dir}: DATA_DIR: expected an existing folder, got none")
    out = check_writable_dir(ns.out or Path(ns.data_dir) / "bids", "--out")
    folder = OutputFolder(out, "thermocue export-bids")
    skipped: list = []
    notes: list = []
    authors = [a.strip() for a in ns.author]
    if any(not a for a in authors):
        raise UserInputError(f"--author: expected a name, got {ns.author!r}")
    written = export_dataset(ns.data_dir, out, skipped=skipped, notes=notes, before=folder.begin,
                             authors=list(dict.fromkeys(authors)))
    for text in notes:
        print(f"thermocue export-bids: warning: {text}", file=sys.stderr)
    for path, reason in skipped:
        print(f"thermocue export-bids: not exported: {path}: {reason}", file=sys.stderr)
    if not written:
        raise UserInputError(f"{ns.data_dir}: DATA_DIR: expected session folders with trial rows "
                             f"(session.json, trials.csv or events.jsonl), got none"
                             + (f" ({len(skipped)} not exported, named above)" if skipped else ""))
    mark_complete(folder)
    people = len({p.parent.parent.parent.name for p in written})
    print(f"{len(written)} session(s) of {people} participant(s) -> {out}"
          + (f"; {len(skipped)} folder(s) not exported (named above)" if skipped else ""))
    return 0
