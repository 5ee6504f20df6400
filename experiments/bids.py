"""BIDS-style export of the sessions: behavioural files a BIDS validator accepts.

A session's ``trials.csv`` becomes, in the dataset ``DATA/bids/`` (Brain Imaging Data Structure,
behavioural data: https://bids-specification.readthedocs.io, "Behavioral experiments")::

    DATA/bids/dataset_description.json
    DATA/bids/participants.tsv, participants.json
    DATA/bids/sub-<id>/ses-<n>/beh/sub-<id>_ses-<n>_task-<protocol>_beh.tsv
    DATA/bids/sub-<id>/ses-<n>/beh/sub-<id>_ses-<n>_task-<protocol>_beh.json

``<id>`` is the participant id, ``<n>`` the session's name and ``<protocol>`` the protocol's
name, each with every character other than a letter or a digit removed (BIDS labels are
alphanumeric: ``roughness_recognition`` -> ``roughnessrecognition``, ``S01`` -> ``S01``). The
TSV holds every column of ``trials.csv`` (missing values ``n/a``); the JSON sidecar describes
each column with its unit. :func:`export_session` is called by the session when it finishes;
:func:`export_dataset` rebuilds the whole dataset from the session folders.

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
from pathlib import Path

from experiments.logbook import TRIAL_COLUMNS, atomic_write_text, ensure_dir

__all__ = ["export_session", "export_dataset", "bids_label", "COLUMN_DESCRIPTIONS", "BIDS_VERSION"]

BIDS_VERSION = "1.9.0"

#: Each trials.csv column: (description, unit or None). Units as BIDS asks (SI symbols).
COLUMN_DESCRIPTIONS = {
    "participant": ("Participant id (the participant record's id)", None),
    "session": ("Session name (its folder)", None),
    "group": ("Skin-thickness group (A below the protocol's threshold, B above)", None),
    "sex": ("Sex from the participant record", None),
    "skin_thickness_um": ("Fingertip skin thickness from the participant record", "um"),
    "date": ("PsychoPy's column: date and local time the session first started (data.getDateStr format)", None),
    "expName": ("PsychoPy's column: the experiment's name (the protocol's name)", None),
    "expStart": ("PsychoPy's column: local time the session first started, with its UTC offset (%Y-%m-%d %Hh%M.%S.%f %z)", None),
    "protocol_version": ("Protocol version", None),
    "protocol_hash": ("SHA-256 of the protocol's canonical JSON", None),
    "thermocue_version": ("thermocue version that ran the session", None),
    "psychopyVersion": ("PsychoPy's column: PsychoPy version of the participant's window (n/a: no PsychoPy window ran)", None),
    "frameRate": ("PsychoPy's column: the window's frame rate as PsychoPy measured it (win.getActualFrameRate; n/a: no window; empty: not measurable)", "Hz"),
    "thisN": ("PsychoPy's column: the trial's 0-based position in the session (trial_index - 1)", None),
    "thisRepN": ("PsychoPy's column: the 0-based repetition of the sample within its block (repetition - 1)", None),
    "block": ("Block name from the protocol", None),
    "trial_index": ("Trial number in the session's schedule, from 1", None),
    "attempt": ("Attempt number of this trial (a faulted or aborted attempt is run again)", None),
    "repetition": ("Repetition of the sample within its block, from 1", None),
    "mode": ("real: a physical sample; simulated: the Peltier display replaying its profile", None),
    "roughness_id": ("The sample presented (1..4 for 1#..4#)", None),
    "roughness_um": ("Roughness Ra of the sample presented", "um"),
    "target_side": ("Which interface temperature the simulated profile replays", None),
    "profile_skin_thickness_um": ("Skin thickness the simulated profile was computed for", "um"),
    "profile_resistance_m2K_W": ("Finger-sample contact resistance of the simulated profile", "m^2*K/W"),
    "profile_resistance_source": ("Where that resistance came from: calibration or eq5", None),
    "pad_resistance_m2K_W": ("Finger-pad contact resistance of the display", "m^2*K/W"),
    "rate_limited_max_change_C": ("Largest change made to keep the profile within the display's rate limit", "degC"),
    "cue_played": ("1 if the sound cue was played, 0 if no audio was available", None),
    "response_id": ("The sample the participant named (1..4); n/a where no answer was asked", None),
    "correct": ("1 if response_id equals roughness_id, else 0", None),
    "rt_s": ("Response time from the first frame showing the question to the key press; n/a for spoken answers", "s"),
    "response_source": ("What produced the answer (keyboard backend, console, simulated model)", None),
    "answer_mode": ("keyed: the participant pressed the answer; spoken: the participant said it and the experimenter keyed it", None),
    "answer_keyed_after_cue_s": ("Spoken answers: time from the question's sound cue to the experimenter's key (not a response time)", "s"),
    "started_at_utc": ("UTC time the trial started (ISO 8601)", None),
    "finished_at_utc": ("UTC time the trial was written (ISO 8601)", None),
    "contact_onset_s": ("Display clock at the moment of contact (a time stamp, not a duration)", "s"),
    "contact_duration_s": ("Time from contact to the end of the recording", "s"),
    "status": ("ok, fault (display fault; run again) or aborted (no contact or interrupted; run again)", None),
    "fault_code": ("Display or host fault code of a faulted attempt", None),
    "abort_reason": ("Why an aborted attempt stopped", None),
    "skin_temperature_C": ("Fingertip temperature just before touching (radiation thermometer)", "degC"),
    "skin_temperature_in_range": ("1 if skin_temperature_C was within the protocol's range, else 0", None),
    "tracking_rms_C": ("RMS of display contact temperature minus target during playback", "degC"),
    "tracking_max_C": ("Largest absolute tracking error during playback", "degC"),
    "frames": ("Telemetry frames received during the trial", None),
    "frames_lost": ("Telemetry frames missing from the device's numbering", None),
    "trace_file": ("The trial's telemetry trace, relative to the session folder", None),
    "contact_force_N": ("Mean summed force of the display's four sensors over the contact", "N"),
}

_PARTICIPANT_COLUMNS = {
    "participant_id": ("Participant label (sub-<id>)", None),
    "age": ("Age from the participant record", "year"),
    "sex": ("Sex from the participant record", None),
    "handedness": ("Handedness from the participant record", None),
    "group": ("Skin-thickness group of the participant's sessions", None),
    "skin_thickness_um": ("Fingertip skin thickness", "um"),
}


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
        w.writerow(["n/a" if v in (None, "") else str(v).replace("\t", " ") for v in r])
    return buf.getvalue()


def _sidecar(columns, described: dict) -> dict:
    out = {}
    for c in columns:
        text, unit = described.get(c, (f"Column {c} of trials.csv", None))
        out[c] = {"Description": text, **({"Units": unit} if unit else {})}
    return out


def _describe_dataset(root: Path) -> None:
    path = root / "dataset_description.json"
    if not path.exists():
        atomic_write_text(path, json.dumps({
            "Name": "thermocue sessions: thermal-tactile roughness recognition",
            "BIDSVersion": BIDS_VERSION, "DatasetType": "raw",
            "GeneratedBy": [{"Name": "thermocue", "Description": "experiments.bids"}],
        }, indent=2) + "\n")
    readme = root / "README"
    if not readme.exists():
        atomic_write_text(readme, (
            "Behavioural data of thermocue sessions: thermal-tactile roughness recognition with\n"
            "real stainless-steel samples and a Peltier display replaying their temperature.\n\n"
            "Each sub-<id>/ses-<n>/beh/*_beh.tsv is a session's trials.csv, one row per trial\n"
            "attempt (status ok, fault or aborted); its JSON sidecar describes every column and\n"
            "unit. The session folders (DATA/<participant>/<session>/) hold the event logs and\n"
            "the contact traces. Written by thermocue (experiments/bids.py).\n"))


def _participants(root: Path, records: dict) -> None:
    """Write participants.tsv/json from ``records`` (label -> row), merged with the old file.

    Sessions finishing at once (``reproduce --workers``) take turns: an exclusive lock on
    ``.participants.lock`` around the read-merge-write, so that no participant is lost."""
    fd = os.open(root / ".participants.lock", os.O_RDWR | os.O_CREAT, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        _merge_participants(root, records)
    finally:
        os.close(fd)


def _merge_participants(root: Path, records: dict) -> None:
    path = root / "participants.tsv"
    rows = {}
    if path.exists():
        with open(path, newline="", encoding="utf-8") as fh:
            for r in csv.DictReader(fh, delimiter="\t"):
                rows[r["participant_id"]] = r
    rows.update(records)
    header = list(_PARTICIPANT_COLUMNS)
    atomic_write_text(path, _tsv(header, [[rows[k].get(c) for c in header] for k in sorted(rows)]))
    atomic_write_text(root / "participants.json",
                      json.dumps(_sidecar(header[1:], _PARTICIPANT_COLUMNS), indent=2) + "\n")


def export_session(session_dir, root=None) -> Path:
    """Write one session's behavioural TSV and sidecar into the BIDS dataset ``root``.

    Parameters
    ----------
    session_dir : path-like
        ``DATA/<participant>/<session>/`` with ``session.json`` and ``trials.csv``.
    root : path-like, optional
        The BIDS dataset (default ``DATA/bids``, two levels above ``session_dir``).

    Returns
    -------
    Path
        The ``_beh.tsv`` written.
    """
    session_dir = Path(session_dir)
    meta = json.loads((session_dir / "session.json").read_text(encoding="utf-8"))
    root = Path(root) if root is not None else session_dir.parent.parent / "bids"
    participant = meta.get("participant") or {}
    sub = bids_label(meta.get("participant_id") or participant.get("id"))
    ses = bids_label(meta.get("session") or session_dir.name)
    task = bids_label(meta.get("protocol_name") or (meta.get("protocol") or {}).get("protocol", {}).get("name"))
    with open(session_dir / "trials.csv", newline="", encoding="utf-8") as fh:
        reader = csv.DictReader(fh)
        header = list(reader.fieldnames or TRIAL_COLUMNS)
        rows = [[r.get(c) for c in header] for r in reader]
    folder = ensure_dir(root / f"sub-{sub}" / f"ses-{ses}" / "beh")
    _describe_dataset(root)
    stem = f"sub-{sub}_ses-{ses}_task-{task}_beh"
    atomic_write_text(folder / f"{stem}.tsv", _tsv(header, rows))
    sidecar = {"TaskName": task,
               "TaskDescription": (meta.get("protocol") or {}).get("protocol", {}).get("title", ""),
               **_sidecar(header, COLUMN_DESCRIPTIONS)}
    atomic_write_text(folder / f"{stem}.json", json.dumps(sidecar, indent=2, ensure_ascii=False) + "\n")
    thickness = (participant.get("skin_thickness") or {}).get("total_um")
    _participants(root, {f"sub-{sub}": {
        "participant_id": f"sub-{sub}", "age": participant.get("age"), "sex": participant.get("sex"),
        "handedness": participant.get("handedness"), "group": meta.get("group"),
        "skin_thickness_um": thickness}})
    return folder / f"{stem}.tsv"


def export_dataset(data_dir, root=None) -> list[Path]:
    """Export every session folder (``session.json`` + ``trials.csv``) under ``data_dir``."""
    data_dir = Path(data_dir)
    root = Path(root) if root is not None else data_dir / "bids"
    out = []
    for meta in sorted(data_dir.glob("*/*/session.json")):
        if (meta.parent / "trials.csv").exists() and root not in meta.parents:
            out.append(export_session(meta.parent, root))
    return out
