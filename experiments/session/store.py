"""``session.json``: written once when a session is made, checked (not trusted) on resume.

:func:`write_session_json` writes it (atomically); :func:`read_session_json` reads it back
into a :class:`StoredSession`: every field typed and bounded by ``session.schema.json``
(beside this module; the one validation stack, :mod:`participants_schema.schema_check`),
each planned trial by ``trial.schema.json``, the protocol copy against its hash, the schedule against
``build_schedule(protocol, participant id, seed)``, and the whole against the log's
``session_started`` event (the log is the session's record). Every problem is one line naming
the file and the field (:class:`~experiments.errors.SessionError`, exit 2).
"""
from __future__ import annotations

import json
import sys
from dataclasses import dataclass
from pathlib import Path

from experiments.errors import SessionError
from participants_schema.schema_check import check_against_schema
from sessionfiles.logbook import now_iso as _now_iso
from experiments.schedule import ALGORITHM as SCHEDULE_ALGORITHM
from experiments.schedule import TRIAL_SCHEMA
from sessionfiles.session_files import package_versions, schedule_sha256

__all__ = ["SESSION_FORMAT", "StoredSession", "block_roles", "write_session_json",
           "read_session_json", "record_display"]

#: The schema of ``session.json`` (Draft 2020-12); each planned trial in it: ``TRIAL_SCHEMA``.
SCHEMA_PATH = Path(__file__).with_name("session.schema.json")

#: The ``format`` field of ``session.json``.
SESSION_FORMAT = "thermocue-session/1"


def block_roles(protocol) -> list[dict]:
    """Per block: ``name``, ``mode``, ``scored``, ``response``, ``feedback`` (session.json)."""
    return [{"name": b.name, "mode": b.mode, "scored": bool(b.scored), "response": bool(b.response),
             "feedback": bool(b.feedback)} for b in protocol.blocks]


def write_session_json(directory: Path, plan) -> None:
    """Write ``directory/session.json`` for a :class:`~experiments.session.SessionPlan`, and
    ``traces/``."""
    from sessionfiles.logbook import atomic_write_json, ensure_dir
    from experiments.session.setup import protocol_source

    protocol, assignment, durable = plan.protocol, plan.assignment, plan.durable
    atomic_write_json(directory / "session.json", durable=durable, obj={
        "format": SESSION_FORMAT,
        "session": plan.name,
        "created_at": _now_iso(),
        "participant_id": plan.participant_id,
        "participant": plan.participant.record(),
        "participant_file": str(plan.participant_path),
        "group": assignment.group,
        "group_assignment": assignment.to_dict(),
        "protocol_name": protocol.name,
        # a packaged protocol by its file's name: not where this copy of the code is installed
        "protocol_file": None if protocol.path is None else protocol_source(protocol),
        "protocol_hash": protocol.hash,
        "protocol": protocol.data,
        "seed": plan.seed,
        "schedule": [s.to_dict() for s in plan.schedule],
        "schedule_algorithm": SCHEDULE_ALGORITHM,
        # What each block is (analysis reads this, not block names).
        "blocks": block_roles(protocol),
        "display_url": plan.display_url,
        "responder": plan.responder_name,
        "clock": "virtual" if plan.clock.virtual else "real",
        "max_consecutive_faults": plan.max_consecutive_faults,
        "versions": package_versions(),
    })
    ensure_dir(directory / "traces", durable=durable)



def record_display(directory: Path, url: str, info, *, durable: bool = True) -> dict:
    """Add the display just opened to ``session.json``'s ``displays`` list (atomically).

    Each entry: ``url``, ``device_id``, ``firmware``, ``image_id`` (the running image's id from
    HELLO: the reference firmware's GNU build id, ``emulator-<version>``, the TCS II's firmware
    version; ``""`` when the device states none) and ``opened_at``. A resumed or reconnected
    session adds one entry per opening, so the file says which device and image ran it.
    """
    from sessionfiles.logbook import atomic_write_json

    path = Path(directory) / "session.json"
    entry = {"url": url, "device_id": getattr(info, "device_id", None),
             "firmware": getattr(info, "firmware", None),
             "image_id": getattr(info, "image_id", "") or "", "opened_at": _now_iso()}
    try:
        meta = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise SessionError(f"{path}: expected a readable session.json to record the display in, "
                           f"got {exc}") from None
    displays = meta.get("displays")
    meta["displays"] = (displays if isinstance(displays, list) else []) + [entry]
    atomic_write_json(path, meta, durable=durable)
    return entry

@dataclass
class StoredSession:
    """A checked ``session.json`` (:func:`read_session_json`).

    Attributes
    ----------
    path : Path
        The file.
    protocol : Protocol
        Parsed from the stored copy (its hash checked).
    participant : participants_schema.Participant
    group, name, display_url, responder : str
    seed, max_consecutive_faults : int
    schedule : list of TrialSpec
    source : str
        How messages name the stored protocol (``<path>: protocol``).
    """

    path: Path
    protocol: object
    participant: object
    group: str
    name: str
    seed: int
    schedule: list
    display_url: str
    responder: str
    max_consecutive_faults: int
    source: str
    clock: str | None = None      # "real" | "virtual" as the session ran (None: not stored)


def read_session_json(directory, *, out=None) -> StoredSession:
    """Read and check ``directory/session.json`` (see the module's docstring).

    ``out`` receives the one warning this can give (a schedule made by another algorithm,
    resumed unchecked; default stderr).

    Raises
    ------
    SessionError
        No folder, no or a damaged ``session.json``, an edited field (naming it).
    """
    from experiments.protocol import parse_protocol
    from experiments.schedule import TrialSpec, build_schedule
    from participants_schema import Participant

    directory = Path(directory)
    path = directory / "session.json"
    if not directory.is_dir():
        raise SessionError(f"{directory}: expected a session folder, got no such folder")
    try:
        meta = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise SessionError(f"{path}: expected a session.json, got no such file") from None
    except (OSError, ValueError) as exc:
        raise SessionError(f"{path}: expected valid JSON, got {exc}") from None
    check_against_schema(meta, SCHEMA_PATH, str(path), SessionError)
    seed, responder, clock = meta["seed"], meta.get("responder", ""), meta.get("clock")
    max_faults = meta.get("max_consecutive_faults", 3)
    source = f"{path}: protocol"
    protocol = parse_protocol(meta["protocol"], source=source,
                              path=Path(meta["protocol_file"]) if meta.get("protocol_file") else None)
    if protocol.hash != meta["protocol_hash"]:
        _fail(path, "protocol_hash", f"{protocol.hash} (the stored protocol's hash)",
              repr(meta["protocol_hash"]))
    participant = Participant.from_record(meta["participant"], source=f"{path}: participant")
    for i, d in enumerate(meta["schedule"]):     # strictly: no key but the trial's six
        check_against_schema(d, TRIAL_SCHEMA, str(path), SessionError, at=f"schedule[{i}]")
    schedule = [TrialSpec.from_checked(d) for d in meta["schedule"]]
    # Sessions written before the field existed used the first algorithm.
    made_by = meta.get("schedule_algorithm", "thermocue-schedule-v1")
    expected = build_schedule(protocol, participant.id, seed)
    if made_by != SCHEDULE_ALGORITHM:
        # A newer thermocue cannot rebuild an older algorithm's schedule: the stored one is
        # used (it is what the participant has been given so far), unchecked, and said so.
        print(f"thermocue: {path}: schedule_algorithm: made by {made_by!r}, this version builds "
              f"{SCHEDULE_ALGORITHM!r}; resuming with the stored schedule unchecked",
              file=out or sys.stderr, flush=True)
    elif schedule != expected:
        diff = next((i for i, (a, b) in enumerate(zip(schedule, expected)) if a != b),
                    min(len(schedule), len(expected)))
        got = meta["schedule"][diff] if diff < len(schedule) else "nothing"
        want = expected[diff].to_dict() if diff < len(expected) else "nothing"
        _fail(path, "schedule", f"the schedule of the stored protocol, participant "
                                f"{participant.id} and seed {seed} ({len(expected)} trials; "
                                f"trial {diff + 1}: {want})",
              f"{len(schedule)} trials (trial {diff + 1}: {got})")
    group = meta["group"]
    groups = None if protocol.grouping is None else (protocol.grouping.below, protocol.grouping.above)
    if groups is not None and group not in groups:
        _fail(path, "group", f"one of {groups}", repr(group))
    check_against_log(directory, path, meta, participant, schedule)
    return StoredSession(path, protocol, participant, group, meta["session"], seed, schedule,
                         meta["display_url"], responder or "", max_faults, source, clock)


def _fail(path: Path, field: str, what: str, got: str):
    raise SessionError(f"{path}: {field}: expected {what}, got {got}")


def check_against_log(directory: Path, path: Path, meta: dict, participant, schedule) -> None:
    """Refuse a ``session.json`` that differs from the log's ``session_started``.

    The log is the source of truth: a session.json replaced by another run, or edited by hand
    (seed, schedule, protocol, group, participant, name), must not steer a resume.
    """
    from sessionfiles.logbook import read_events

    events_path = directory / "events.jsonl"
    if not events_path.exists():
        return
    events, _ = read_events(events_path, warn=False)
    started = next((e for e in events if e.get("event") == "session_started"), None)
    if started is None:
        return
    stored = {"session": meta["session"], "participant": participant.id,
              "group": meta["group"], "seed": meta["seed"],
              "protocol_hash": meta["protocol_hash"], "schedule_sha256": schedule_sha256(schedule)}
    for key, value in stored.items():
        if key in started and started[key] != value:
            raise SessionError(f"{path}: {key}: expected {started[key]!r} as in {events_path.name}'s "
                               f"session_started (line {started.get('seq', '?')}), got {value!r}; "
                               f"the log is the session's record: restore session.json")
