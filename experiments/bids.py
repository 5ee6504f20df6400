"""BIDS-style export of the sessions: behavioural files a BIDS validator accepts.

A session's ``trials.csv`` becomes, in the dataset ``DATA/bids/`` (Brain Imaging Data Structure,
behavioural data: https://bids-specification.readthedocs.io, "Behavioral experiments")::

    DATA/bids/dataset_description.json
    DATA/bids/participants.tsv, participants.json
    DATA/bids/sub-<id>/ses-<n>/beh/sub-<id>_ses-<n>_task-<protocol>_beh.tsv
    DATA/bids/sub-<id>/ses-<n>/beh/sub-<id>_ses-<n>_task-<protocol>_beh.json
    DATA/bids/sub-<id>/ses-<n>/beh/sub-<id>_ses-<n>_task-<protocol>_events.tsv, _events.json

``<id>`` is the participant id, ``<n>`` the session's name and ``<protocol>`` the protocol's
name, each with every character other than a letter or a digit removed (BIDS labels are
alphanumeric: ``roughness_recognition`` -> ``roughnessrecognition``, ``S01`` -> ``S01``). The
``_beh.tsv`` holds the columns of ``trials.csv`` (missing values ``n/a``) but the participant's
own (:data:`PARTICIPANT_LEVEL_COLUMNS`: ``group``, ``sex``, ``skin_thickness_um``), which are in
``participants.tsv`` only; the JSON sidecar describes each column with its unit. The
``_events.tsv`` (BIDS allows it beside ``_beh.tsv`` in ``beh/``) holds when each trial, cue,
contact or playback, question and answer happened, in seconds from the session's start, on the
session log's one clock (:mod:`experiments.bids_events`).

``dataset_description.json`` ``Authors``: the ``authors`` argument (``export-bids --author``),
else the ``[protocol] authors`` of the sessions' protocols; with neither the dataset has no
``Authors`` and :func:`export_dataset` says so in ``notes``. :func:`export_session` is called by
the session when it finishes; :func:`export_dataset` rebuilds the whole dataset from the session
folders. Nothing hidden is left in the dataset: sessions finishing at once take turns on
``participants.tsv`` with a lock on the dataset folder itself.

Checked in the test suite by the reference BIDS validator (``bids-validator`` from npm, installed
by ``scripts/setup``).
"""
from __future__ import annotations

import csv
import fcntl
import io
import json
import os
import re
from contextlib import contextmanager
from pathlib import Path

from experiments.bids_events import EVENT_COLUMNS, EVENT_SIDECAR, event_rows
from sessionfiles.columns import DESCRIPTIONS
from sessionfiles.logbook import TRIAL_COLUMNS, atomic_write_text, ensure_dir
from sessionfiles.logformat import format_cell
from sessionfiles.session_reader import SessionFileError, SessionFolder, read_session_folder, \
    read_session_folders

__all__ = ["export_session", "export_dataset", "bids_label", "COLUMN_DESCRIPTIONS", "BIDS_VERSION",
           "PARTICIPANT_LEVEL_COLUMNS", "NO_AUTHORS_NOTE", "protocol_authors", "mark_complete"]

BIDS_VERSION = "1.9.0"

#: Each trials.csv column: (description, unit or None), from the one column table. Units as BIDS
#: asks (SI symbols).
COLUMN_DESCRIPTIONS = DESCRIPTIONS

_PARTICIPANT_COLUMNS = {
    "participant_id": ("Participant label (sub-<id>)", None),
    "age": ("Age from the participant record", "year"),
    "sex": ("Sex from the participant record", None),
    "handedness": ("Handedness from the participant record", None),
    "group": ("Skin-thickness group of the participant's sessions (A below the protocol's "
              "threshold, B above)", None),
    "skin_thickness_um": ("Fingertip skin thickness from the participant record", "um"),
}

#: Columns of ``trials.csv`` that describe the participant, not the trial: written to
#: ``participants.tsv`` only, never repeated on every row of a ``_beh.tsv``.
PARTICIPANT_LEVEL_COLUMNS = ("group", "sex", "skin_thickness_um")

#: What :func:`export_dataset` notes when the dataset has no authors (``{path}``: the file).
NO_AUTHORS_NOTE = ("{path}: Authors: none given (the BIDS validator warns NO_AUTHORS); add "
                   "`authors = [\"Name\", ...]` to the protocol's [protocol] table, or pass "
                   "--author NAME (once per author)")


def bids_label(text: str) -> str:
    """``text`` with everything but letters and digits removed (BIDS labels are alphanumeric).

    >>> bids_label("roughness_recognition"), bids_label("S01"), bids_label("P-07")
    ('roughnessrecognition', 'S01', 'P07')
    """
    label = re.sub(r"[^A-Za-z0-9]", "", str(text))
    if not label:
        raise ValueError(f"bids_label: expected some letters or digits, got {text!r}")
    return label


def _tsv(header: list[str], rows: list[list]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, delimiter="\t", lineterminator="\n", quoting=csv.QUOTE_NONE,
                   escapechar="\\")
    w.writerow(header)
    for r in rows:
        w.writerow(["n/a" if v in (None, "") else re.sub(r"[\t\r\n]", " ", str(v)) for v in r])
    return buf.getvalue()


def _sidecar(columns, described: dict) -> dict:
    out = {}
    for c in columns:
        text, unit = described.get(c, (f"Column {c} of trials.csv", None))
        out[c] = {"Description": text, **({"Units": unit} if unit else {})}
    return out


def protocol_authors(meta: dict) -> list[str]:
    """The ``[protocol] authors`` of the protocol stored in ``session.json`` (``[]``: none)."""
    protocol = meta.get("protocol") if isinstance(meta.get("protocol"), dict) else {}
    head = protocol.get("protocol") if isinstance(protocol.get("protocol"), dict) else {}
    listed = head.get("authors")
    if not isinstance(listed, list):
        return []
    return [a.strip() for a in listed if isinstance(a, str) and a.strip()]


def _describe_dataset(root: Path, authors: list[str], override: bool = False, *,
                      durable: bool = True) -> None:
    """Write ``dataset_description.json`` (and ``README``) unless there; ``authors`` are added
    to one without ``Authors``, or replace them (``override``: given on the command line)."""
    path = root / "dataset_description.json"
    old = None
    if path.exists():
        try:
            old = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            old = None
    if not isinstance(old, dict):
        description = {
            "Name": "thermocue sessions: thermal-tactile roughness recognition",
            "BIDSVersion": BIDS_VERSION, "DatasetType": "raw",
            "GeneratedBy": [{"Name": "thermocue", "Description": "experiments.bids"}]}
        if authors:
            description["Authors"] = list(dict.fromkeys(authors))
        atomic_write_text(path, json.dumps(description, indent=2, ensure_ascii=False) + "\n",
                          durable=durable)
    elif authors and (not old.get("Authors") or (override and old["Authors"] != authors)):
        old["Authors"] = list(dict.fromkeys(authors))
        atomic_write_text(path, json.dumps(old, indent=2, ensure_ascii=False) + "\n",
                          durable=durable)
    readme = root / "README"
    if not readme.exists():
        atomic_write_text(readme, (
            "Behavioural data of thermocue sessions: thermal-tactile roughness recognition with\n"
            "real stainless-steel samples and a Peltier display replaying their temperature.\n\n"
            "Each sub-<id>/ses-<n>/beh/*_beh.tsv is a session's trials.csv, one row per trial\n"
            "attempt (status ok, fault or aborted), without the participant's own columns (in\n"
            "participants.tsv); its JSON sidecar describes every column and unit. Beside it,\n"
            "*_events.tsv says when each trial, cue, contact or playback, question and answer\n"
            "happened (onset and duration in seconds from the session's start, on the session\n"
            "log's clock). The session folders (DATA/<participant>/<session>/) hold the event\n"
            "logs and the contact traces. Written by thermocue (experiments/bids.py).\n"),
            durable=durable)


@contextmanager
def _dataset_lock(root: Path):
    """Hold an exclusive ``flock`` on the dataset folder itself (opened read-only).

    Sessions finishing at once (``reproduce --workers``) take turns on the files they
    read-merge-write (``participants.tsv``, ``dataset_description.json``), so that no participant
    is lost; no lock file is left in the dataset (an earlier version's ``.participants.lock`` is
    removed)."""
    fd = os.open(root, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
        try:
            os.unlink(root / ".participants.lock")
        except FileNotFoundError:
            pass
    finally:
        os.close(fd)


def _participants(root: Path, records: dict, *, durable: bool = True) -> None:
    """Write participants.tsv/json from ``records`` (label -> row), merged with the old file,
    under :func:`_dataset_lock`."""
    with _dataset_lock(root):
        _merge_participants(root, records, durable=durable)


def _merge_participants(root: Path, records: dict, *, durable: bool = True) -> None:
    path = root / "participants.tsv"
    rows = {}
    if path.exists():
        with open(path, newline="", encoding="utf-8") as fh:
            for r in csv.DictReader(fh, delimiter="\t"):
                rows[r["participant_id"]] = r
    rows.update(records)
    header = list(_PARTICIPANT_COLUMNS)
    atomic_write_text(path, _tsv(header, [[rows[k].get(c) for c in header] for k in sorted(rows)]),
                      durable=durable)
    sidecar = _sidecar(header[1:], _PARTICIPANT_COLUMNS)
    for column in ("sex", "handedness", "group"):
        levels = sorted({str(r.get(column)) for r in rows.values()} - {"None", "", "n/a"})
        if levels:
            sidecar[column]["Levels"] = {v: _LEVELS.get((column, v), v) for v in levels}
    atomic_write_text(root / "participants.json", json.dumps(sidecar, indent=2) + "\n",
                      durable=durable)


_LEVELS = {("group", "A"): "skin thinner than the protocol's threshold",
           ("group", "B"): "skin thicker than the protocol's threshold",
           ("handedness", "right"): "right-handed", ("handedness", "left"): "left-handed",
           ("handedness", "R"): "right-handed", ("handedness", "L"): "left-handed"}


def _trial_table(read: SessionFolder) -> tuple[list[str], list[list]]:
    """The session's trial table (``trials.csv``, or rebuilt from the log when the table is
    missing or older), every row checked against the table's domain and the session's id."""
    rows, source, lines = read.trial_rows()
    if not rows:
        raise SessionFileError(f"{read.path}: trials: expected trial rows (trials.csv, or finished "
                               f"trials in events.jsonl), got none")
    read.check_rows(rows, source, lines)
    for row, line in zip(rows, lines):
        for key, own in (("participant", read.participant), ("session", read.session)):
            value = row.get(key)
            if value not in (None, "") and str(value).strip() != own:
                raise SessionFileError(f"{read.path / source}: {key}: expected {own!r} (the "
                                       f"session's own) (line {line}), got {value!r}")
    if source == "trials.csv":
        header = list(rows[0])
        return header, [[r.get(c) for c in header] for r in rows]
    extra = sorted({k for r in rows for k in r} - set(TRIAL_COLUMNS))
    header = list(TRIAL_COLUMNS) + extra
    return header, [[format_cell(r.get(c), c) for c in header] for r in rows]


def _session_meta(read: SessionFolder) -> dict:
    """``session.json``, or, without one, what the log's ``session_started`` says."""
    if read.meta is not None:
        return read.meta
    started = next((e for e in read.events if e.get("event") == "session_started"), {})
    return {"group": started.get("group"), "protocol_name": started.get("protocol"),
            "participant": {"id": read.participant, "sex": started.get("sex"),
                            "skin_thickness": {"total_um": started.get("skin_thickness_um")}}}


def export_session(session_dir, root=None, read: SessionFolder | None = None,
                   authors: list[str] | None = None, override_authors: bool = False, *,
                   durable: bool = True) -> Path:
    """Write one session's behavioural TSV and sidecar into the BIDS dataset ``root``.

    Parameters
    ----------
    session_dir : path-like
        ``DATA/<participant>/<session>/`` with ``session.json`` and ``trials.csv`` (or, without
        them, ``events.jsonl``: the table rebuilt from it, the participant from its
        ``session_started``).
    root : path-like, optional
        The BIDS dataset (default ``DATA/bids``, two levels above ``session_dir``).
    read : SessionFolder, optional
        The folder as :func:`sessionfiles.session_reader.read_session_folder` read it.
    authors : list of str, optional
        ``dataset_description.json``'s ``Authors`` (default: the protocol's ``authors``),
        written when the file is new or has none (``override_authors``: also replacing others).
    durable : bool
        False: the same files without their fsyncs (the session's own setting: a simulated
        study's session, recomputed from its seed).

    Returns
    -------
    Path
        The ``_beh.tsv`` written.

    Raises
    ------
    SessionFileError
        What the session reader refuses, a session without trial rows, a row outside the trial
        table's domain or naming another participant or session.
    """
    session_dir = Path(session_dir)
    read = read_session_folder(session_dir) if read is None else read
    meta = _session_meta(read)
    root = Path(root) if root is not None else session_dir.parent.parent / "bids"
    participant = meta.get("participant") if isinstance(meta.get("participant"), dict) else {}
    sub = bids_label(read.participant)
    ses = bids_label(read.session)
    header, rows = _trial_table(read)
    protocol = meta.get("protocol") if isinstance(meta.get("protocol"), dict) else {}
    head = protocol.get("protocol") if isinstance(protocol.get("protocol"), dict) else {}
    names = [meta.get("protocol_name"), head.get("name")]
    names += [r[header.index("expName")] for r in rows[:1] if "expName" in header]
    name = next((n for n in names if isinstance(n, str) and re.search(r"[A-Za-z0-9]", n)), None)
    if name is None:
        raise SessionFileError(f"{session_dir / 'session.json'}: protocol_name: expected the "
                               f"protocol's name (session.json, or expName in the trials), got "
                               f"{meta.get('protocol_name')!r}")
    task = bids_label(name)
    keep = [i for i, c in enumerate(header) if c not in PARTICIPANT_LEVEL_COLUMNS]
    header, rows = [header[i] for i in keep], [[r[i] for i in keep] for r in rows]
    folder = ensure_dir(root / f"sub-{sub}" / f"ses-{ses}" / "beh", durable=durable)
    with _dataset_lock(root):
        _describe_dataset(root, list(dict.fromkeys(authors)) if authors else protocol_authors(meta),
                          override=bool(authors) and override_authors, durable=durable)
    stem = f"sub-{sub}_ses-{ses}_task-{task}"
    atomic_write_text(folder / f"{stem}_beh.tsv", _tsv(header, rows), durable=durable)
    described = {"TaskName": task,
                 "TaskDescription": head.get("title", "") if isinstance(head.get("title"), str) else ""}
    sidecar = {**described, **_sidecar(header, COLUMN_DESCRIPTIONS)}
    atomic_write_text(folder / f"{stem}_beh.json",
                      json.dumps(sidecar, indent=2, ensure_ascii=False) + "\n", durable=durable)
    events = event_rows(read.events)
    if events is not None:
        atomic_write_text(folder / f"{stem}_events.tsv", _tsv(list(EVENT_COLUMNS), events),
                          durable=durable)
        atomic_write_text(folder / f"{stem}_events.json",
                          json.dumps(EVENT_SIDECAR, indent=2, ensure_ascii=False) + "\n",
                          durable=durable)
    thickness = participant.get("skin_thickness")
    thickness = thickness.get("total_um") if isinstance(thickness, dict) else None
    _participants(root, {f"sub-{sub}": {
        "participant_id": f"sub-{sub}", "age": participant.get("age"), "sex": participant.get("sex"),
        "handedness": participant.get("handedness"), "group": meta.get("group"),
        "skin_thickness_um": thickness}}, durable=durable)
    return folder / f"{stem}_beh.tsv"


def export_dataset(data_dir, root=None, skipped: list | None = None,
                   notes: list | None = None, before=None,
                   authors: list[str] | None = None) -> list[Path]:
    """Export every session folder under ``data_dir`` (read by
    :func:`sessionfiles.session_reader.read_session_folders`: checked, duplicates once).

    Every folder is read and checked before anything is written.

    Parameters
    ----------
    data_dir, root : path-like
        The data folder and the BIDS dataset (default ``data_dir/bids``, never searched).
    skipped : list, optional
        Receives ``(folder, reason)`` for each session folder not exported: a copy of another
        folder's session (exported once), a folder without trial rows.
    notes : list, optional
        Receives what was worked around (one line each, naming the file).
    before : callable, optional
        Called once every folder is checked, before the first file is written (the command
        line's :meth:`sessionfiles.atomicfile.OutputFolder.begin`).
    authors : list of str, optional
        ``dataset_description.json``'s ``Authors`` (``export-bids --author``); default: the
        ``[protocol] authors`` of the sessions' protocols, in the order first met. With neither
        (and none in an existing ``dataset_description.json``), :data:`NO_AUTHORS_NOTE` is added
        to ``notes`` and the dataset is written without them.

    Raises
    ------
    SessionFileError
        What the reader refuses (naming the file and the field); nothing is written then.
    """
    data_dir = Path(data_dir)
    root = Path(root) if root is not None else data_dir / "bids"
    skipped = [] if skipped is None else skipped
    notes = [] if notes is None else notes
    found = read_session_folders(data_dir, exclude=[root])
    skipped.extend(found.skipped)
    ready = []
    for read in found.folders:
        notes.extend(read.notes)
        if not read.trial_rows()[0]:
            skipped.append((read.path, "no trial rows (no trials.csv, no finished trial in "
                                       "events.jsonl)"))
            continue
        _trial_table(read)                # refuse before anything is written
        ready.append(read)
    if ready and before is not None:
        before()
    given = bool(authors)
    if not authors:
        found = [a for read in ready for a in protocol_authors(read.meta or {})]
        authors = list(dict.fromkeys(found))
    written = [export_session(read.path, root, read=read, authors=authors, override_authors=given)
               for read in ready]
    if written and not _has_authors(root):
        notes.append(NO_AUTHORS_NOTE.format(path=root / "dataset_description.json"))
    return written


def _has_authors(root: Path) -> bool:
    try:
        described = json.loads((root / "dataset_description.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    return isinstance(described, dict) and bool(described.get("Authors"))


def mark_complete(folder) -> Path:
    """Mark a rebuilt dataset complete (an :class:`sessionfiles.atomicfile.OutputFolder`):
    ``COMPLETE`` written last, and listed in ``.bidsignore`` (it is not a BIDS file)."""
    ignore = Path(folder.path) / ".bidsignore"
    listed = ignore.read_text(encoding="utf-8").split() if ignore.is_file() else []
    if "COMPLETE" not in listed:
        atomic_write_text(ignore, "".join(f"{line}\n" for line in listed + ["COMPLETE"]))
    return folder.finish()
