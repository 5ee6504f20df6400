"""The one reader of finished session folders: what ``analyze``, ``export-bids``, ``calibrate``
and ``resume`` accept from disk (one concept; standard library only, so :mod:`analysis` uses it).

A session folder (``DATA/<participant>/<session>/``) holds ``session.json``, ``events.jsonl``,
``trials.csv`` and ``traces/``. Before any of them is parsed (the first three checks are one
file's, :mod:`sessionfiles.file_read`, re-exported here):

* **Regular files only.** Each file is ``stat``-ed (through a symbolic link) and opened with
  ``O_NONBLOCK``; a FIFO, a device (``/dev/zero``, ``/dev/urandom`` linked in), a socket or a
  folder in a file's place is refused by name, without a read that could block or never end.
* **Size bounds** (:data:`MAX_BYTES`): a larger file is refused before it is read.
* **Encoding**: UTF-8, with or without a byte-order mark. UTF-16/32 (a byte-order mark, or NUL
  bytes between the characters) and 8-bit encodings (Latin-1: a byte that is not UTF-8 in a
  complete line) are refused naming the file and the byte offset. A crash can only leave a torn
  last line or a run of NUL bytes at the end (a power cut); those stay *damage*, read up to
  (:mod:`sessionfiles.logformat`), not refusals.
* **Identity**: ``session.json``'s participant and session are checked against the log's
  ``session_started`` (a ``session.json`` copied from another session is refused: its data
  would be filed under another id); folder names that differ from both are reported, and the
  files' identity is used.
* **Duplicates** (:func:`read_session_folders`): two folders holding the same session (same
  participant, session and event log, e.g. a copied participant folder kept as a backup) are
  read once; the copy is reported. A copy whose log is a prefix of the other's (a backup taken
  mid-session) is reported too. Two folders claiming one session with logs that diverge are
  refused.
* **Values** (:func:`row_problem`): every trial row against the trial table's domain
  (:data:`DOMAIN`): status, sample and response ids, ``correct`` recomputed from the answer,
  finite non-negative times, physical roughness and thickness, no NUL bytes.

A refusal is a :class:`SessionFileError` (a :class:`~sessionfiles.errors.UserInputError`: one line
naming the file and the field, exit 2). What is only skipped (a folder without trial rows, an
unreadable ``session.json`` read around, a duplicate) is returned in ``notes``/``skipped`` for the
caller's report.
"""
from __future__ import annotations

import hashlib
import json
import math
import os
import stat
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Mapping

from sessionfiles.columns import MODES, TRIALS
# reading one file safely (regular files, size bounds, encoding): its own module, re-exported
from sessionfiles.file_read import (MAX_BYTES, SessionFileError, check_text, read_regular_bytes,
                                    read_text_file, refuse_special)
from sessionfiles.logformat import (LogReport, STATUSES, read_csv_prefix, read_events,
                                   trials_from_events)

__all__ = ["SessionFileError", "MAX_BYTES", "DOMAIN", "SESSION_FILES", "read_regular_bytes",
           "check_text", "read_text_file", "row_problem", "SessionFolder", "read_session_folder",
           "find_session_folders", "read_session_folders", "FolderSet", "check_special_files"]


#: The files of a session folder the reader parses (traces are read by calibration).
SESSION_FILES = ("session.json", "events.jsonl", "trials.csv")


# --------------------------------------------------------------------------- values
def _blank(v: Any) -> bool:
    return v is None or (isinstance(v, float) and math.isnan(v)) or \
        (isinstance(v, str) and v.strip() in ("", "nan", "NaN", "None", "n/a"))


def _number(v: Any) -> float | None:
    if isinstance(v, bool):
        return float(v)
    if isinstance(v, (int, float)):
        return float(v)
    try:
        return float(str(v).strip())
    except ValueError:
        return None


def _as_int(v: Any) -> int | None:
    x = _number(v)
    if x is None or not math.isfinite(x) or x != int(x):
        return None
    return int(x)


#: Each checked column of a trial row: (kind, lower, upper, what), from the column table
#: (:data:`sessionfiles.columns.TRIALS`). kind "int"/"float" (``lower <= value <= upper``; None:
#: unbounded; floats must be finite) or "flag" (0/1). Blank cells pass (whether a value is
#: required is the analysis' contract, not the domain's), except where ``row_problem`` says
#: otherwise. The bounds of roughness and skin thickness are the protocol's own
#: (experiments.protocol): Ra beyond 1 cm is no surface finish, and a fingertip's skin is at most
#: 1 cm thick.
DOMAIN = {c.name: (c.kind, *c.domain) for c in TRIALS if c.domain}
#: Columns whose cell is never blank in a row the session wrote (``Column.blank`` is False).
NOT_BLANK = tuple(c.name for c in TRIALS if not c.blank)
_FLAGS = {"true": 1, "false": 0, "1": 1, "0": 0, "1.0": 1, "0.0": 0}


def _flag(v: Any) -> int | None:
    if isinstance(v, bool):
        return int(v)
    if isinstance(v, (int, float)):
        return int(v) if v in (0, 1) else None
    return _FLAGS.get(str(v).strip().lower())


def row_problem(row: Mapping[str, Any], samples: Iterable[int] | None = None) -> tuple[str, str, Any] | None:
    """The first value of a trial row outside the trial table's domain, or None.

    Parameters
    ----------
    row : mapping
        Column -> value (CSV text or the event's JSON value).
    samples : iterable of int, optional
        The protocol's sample ids (default 1-4): ``roughness_id`` and ``response_id`` must be
        one of them.

    Returns
    -------
    (column, expected, value) or None
        ``expected`` is ``"expected ..."``; the caller adds where and ``got <value!r>``.
    """
    ids = sorted(set(samples)) if samples else [1, 2, 3, 4]
    for column, value in row.items():
        if isinstance(value, str) and "\x00" in value:
            return str(column), f"expected text without NUL bytes", value
    status = row.get("status")
    if "status" in row and (_blank(status) or str(status).strip() not in STATUSES):
        return "status", f"expected one of {', '.join(STATUSES)}", status
    mode = row.get("mode")
    if "mode" in row and not _blank(mode) and str(mode).strip() not in MODES:
        return "mode", f"expected one of {', '.join(MODES)}", mode
    for column in NOT_BLANK:
        if column in row and _blank(row[column]):
            return column, "expected a value (the session writes one in every row)", row[column]
    for column, (kind, lo, hi, what) in DOMAIN.items():
        value = row.get(column)
        # a missing number is an empty cell in trials.csv (the writer's only form of it; rows
        # rebuilt from the events carry None or NaN): a "nan", "None" or "n/a" text in a checked
        # column was not written by a session
        if value is None or (isinstance(value, float) and math.isnan(value)) \
                or (isinstance(value, str) and not value.strip()):
            continue
        if kind == "flag":
            ok = _flag(value) is not None
        elif kind == "int":
            x = _as_int(value)
            ok = x is not None and (lo is None or x >= lo) and (hi is None or x <= hi)
        else:
            x = _number(value)
            ok = x is not None and math.isfinite(x) and (lo is None or x >= lo) \
                and (hi is None or x <= hi)
        if not ok:
            return column, f"expected {what}", value
    choice = f"one of {', '.join(map(str, ids))}"
    rough = row.get("roughness_id")
    if "roughness_id" in row:
        r = _as_int(rough)
        if r is None or r not in ids:
            return "roughness_id", f"expected {choice}", rough
    answer = row.get("response_id")
    a = None
    if not _blank(answer):
        a = _as_int(answer)
        if a is None or a not in ids:
            return "response_id", f"expected {choice} or blank", answer
    said = row.get("correct")
    if not _blank(said):
        c = _flag(said)
        r = _as_int(rough)
        if a is None:
            return "correct", f"expected blank for a row without response_id", said
        if r is not None and c != int(a == r):
            return "correct", f"expected {int(a == r)} for response_id {a} on roughness_id {r}", said
    return None


# --------------------------------------------------------------------------- folders
@dataclass
class SessionFolder:
    """One session folder as read (every file checked; see the module's docstring).

    Attributes
    ----------
    path : Path
    meta : dict or None
        ``session.json`` (None: missing or unusable; ``notes`` says why).
    events : list of dict
        The event log up to its first damaged line (``[]`` without a log).
    events_report : LogReport or None
    trials_csv : bytes or None
        ``trials.csv``'s content (no byte-order mark), for :func:`read_csv_prefix`.
    participant, session : str
        The session's identity: ``session.json`` and the log's ``session_started`` (which must
        agree), else the folder names.
    log_hash : str
        SHA-256 of ``events.jsonl`` (of ``trials.csv`` when there is no log; ``""`` neither).
    notes : list of str
        What was worked around, one line each naming the file.
    """

    path: Path
    meta: dict | None = None
    events: list = field(default_factory=list)
    events_report: LogReport | None = None
    trials_csv: bytes | None = None
    participant: str = ""
    session: str = ""
    log_hash: str = ""
    notes: list = field(default_factory=list)
    raw_events: bytes | None = None
    _rows: tuple | None = field(default=None, repr=False)

    @property
    def samples(self) -> list[int] | None:
        """The stored protocol's sample ids (None when not stored)."""
        protocol = (self.meta or {}).get("protocol")
        listed = protocol.get("samples") if isinstance(protocol, dict) else None
        if not isinstance(listed, list):
            return None
        ids = [s.get("id") for s in listed if isinstance(s, dict)]
        ids = [i for i in ids if isinstance(i, int) and not isinstance(i, bool)]
        return ids or None

    def trial_rows(self) -> tuple[list[dict], str, list[int]]:
        """``(rows, source file name, line of each row)``: ``trials.csv``'s rows, or the log's
        when the table is missing or lacks trials the log has (then ``"events.jsonl"``).
        Read once; what was damaged is added to ``notes``."""
        if self._rows is None:
            self._rows = self._read_rows()
        return self._rows

    def _read_rows(self) -> tuple[list[dict], str, list[int]]:
        csv_rows: list[dict] = []
        csv_lines: list[int] = []
        if self.trials_csv is not None:
            header, rows, lines, damage = read_csv_prefix(self.path / "trials.csv", self.trials_csv)
            self.notes.extend(damage)
            if header and any(h.strip() for h in header):
                names = [h.strip() for h in header]
                csv_rows = [dict(zip(names, r)) for r in rows]
                csv_lines = lines
        sources: list = []
        damage: list = []
        ev_rows = trials_from_events(self.events, sources=sources, damage=damage)
        self.notes.extend(f"{self.path / 'events.jsonl'}: {d}" for d in damage)
        lines = [self.events_report.event_lines[i] for i in sources] if self.events_report else []

        def keys(rows):
            return {(str(_as_int(r.get("trial_index"))), str(_as_int(r.get("attempt")) or 1))
                    for r in rows}
        if csv_rows and not (keys(ev_rows) - keys(csv_rows)):
            return csv_rows, "trials.csv", csv_lines
        if ev_rows:
            return ev_rows, "events.jsonl", lines
        return csv_rows, "trials.csv", csv_lines

    def check_rows(self, rows: list[dict], source: str, lines: list[int]) -> None:
        """Refuse the first row outside :data:`DOMAIN` (:class:`SessionFileError`)."""
        samples = self.samples
        for row, line in zip(rows, lines):
            problem = row_problem(row, samples)
            if problem:
                column, expected, value = problem
                raise SessionFileError(f"{self.path / source}: {column}: {expected} (line {line}), "
                                       f"got {value!r}")


def _identity_of(meta: Mapping | None) -> dict:
    if not meta:
        return {}
    found = {}
    participant = meta.get("participant_id")
    if participant is None and isinstance(meta.get("participant"), dict):
        participant = meta["participant"].get("id")
    if participant is not None:
        found["participant"] = participant
    if meta.get("session") is not None:
        found["session"] = meta["session"]
    return found


def _check_label(value: Any, where: str, name: str) -> str:
    if not isinstance(value, (str, int)) or isinstance(value, bool) or not str(value).strip() \
            or any(ord(c) < 32 for c in str(value)) or not any(c.isalnum() for c in str(value)) \
            or "/" in str(value) or len(str(value)) > 64:
        raise SessionFileError(f"{where}: {name}: expected a name with letters or digits (no "
                               f"slash, no control character), got {value!r}")
    return str(value).strip()


def check_special_files(folder) -> None:
    """Refuse a session folder whose session files, or whose ``traces/`` entries, are not
    regular files (FIFO, device, socket), before anything opens them."""
    folder = Path(folder)
    for name in SESSION_FILES:
        p = folder / name
        if os.path.lexists(p):
            try:
                mode = os.stat(p).st_mode
            except FileNotFoundError:      # a dangling link: reported where it is read
                continue
            if not stat.S_ISREG(mode):
                refuse_special(p, mode)
    traces = folder / "traces"
    if traces.is_dir():
        for entry in os.scandir(traces):
            try:
                mode = os.stat(entry.path).st_mode
            except FileNotFoundError:
                continue
            if not stat.S_ISREG(mode) and not stat.S_ISDIR(mode):
                refuse_special(Path(entry.path), mode)


def read_session_folder(folder) -> SessionFolder:
    """Read and check one session folder (see the module's docstring).

    Raises
    ------
    SessionFileError
        A special file, an oversized file, another encoding, a ``session.json`` that names
        another participant or session than the log.
    """
    folder = Path(folder)
    check_special_files(folder)
    sf = SessionFolder(path=folder)
    raw: dict[str, bytes] = {}
    for name in SESSION_FILES:
        p = folder / name
        if not os.path.lexists(p):
            continue
        if not p.exists():
            sf.notes.append(f"{p}: a symbolic link to nothing ({os.readlink(p)}); not read")
            continue
        raw[name] = check_text(read_regular_bytes(p), p)
    if "session.json" in raw:
        meta_path = folder / "session.json"
        try:
            meta = json.loads(raw["session.json"].decode("utf-8"))
        except (ValueError, UnicodeDecodeError) as exc:
            why = getattr(exc, "msg", str(exc)).split("\n")[0]
            sf.notes.append(f"{meta_path}: not valid JSON ({why}); participant and session taken "
                            f"from the event log or the folder names")
        else:
            if isinstance(meta, dict):
                sf.meta = meta
            else:
                sf.notes.append(f"{meta_path}: expected a JSON object, got {type(meta).__name__}; "
                                f"participant and session taken from the event log or the folder "
                                f"names")
    if "events.jsonl" in raw:
        sf.raw_events = raw["events.jsonl"]
        sf.events, sf.events_report = read_events(folder / "events.jsonl", on_damage="stop",
                                                  warn=False, data=raw["events.jsonl"])
        sf.notes.extend(sf.events_report.damage)
        sf.log_hash = hashlib.sha256(raw["events.jsonl"]).hexdigest()
    if "trials.csv" in raw:
        sf.trials_csv = raw["trials.csv"]
        if not sf.log_hash:
            sf.log_hash = hashlib.sha256(raw["trials.csv"]).hexdigest()
    started = next((e for e in sf.events if e.get("event") == "session_started"), None)
    from_log = {k: started.get(k) for k in ("participant", "session")
                if started is not None and started.get(k) is not None}
    from_meta = _identity_of(sf.meta)
    meta_path, log_path = folder / "session.json", folder / "events.jsonl"
    for key, field_name in (("participant", "participant_id"), ("session", "session")):
        if key in from_log:
            from_log[key] = _check_label(from_log[key], f"{log_path}", f"session_started.{key}")
        if key in from_meta:
            from_meta[key] = _check_label(from_meta[key], f"{meta_path}", field_name)
        if key in from_log and key in from_meta and from_log[key] != from_meta[key]:
            raise SessionFileError(
                f"{meta_path}: {field_name}: expected {from_log[key]!r} (the {key} of "
                f"{log_path.name}'s session_started), got {from_meta[key]!r}; a session.json "
                f"from another session?")
    if sf.meta and started is not None:
        for key in ("protocol_hash", "seed"):
            a, b = sf.meta.get(key), started.get(key)
            if a is not None and b is not None and a != b:
                raise SessionFileError(f"{meta_path}: {key}: expected {b!r} (as {log_path.name}'s "
                                       f"session_started), got {a!r}")
    names = {"participant": folder.parent.name, "session": folder.name}
    ident = {k: from_meta.get(k, from_log.get(k)) for k in names}
    for key in names:
        if ident[key] is None:
            ident[key] = names[key]
            if raw:
                sf.notes.append(f"{folder}: {key}: neither session.json nor the event log names "
                                f"it; taken from the folder name {names[key]!r}")
    if (ident["participant"], ident["session"]) != (names["participant"], names["session"]) \
            and (from_meta or from_log):
        sf.notes.append(f"{folder}: folder names {names['participant']}/{names['session']} differ "
                        f"from the session's own {ident['participant']}/{ident['session']} "
                        f"(session.json, events.jsonl); read as "
                        f"{ident['participant']}/{ident['session']}")
    sf.participant, sf.session = str(ident["participant"]), str(ident["session"])
    return sf


def find_session_folders(root) -> list[Path]:
    """Folders under ``root`` holding any of :data:`SESSION_FILES` (any kind of file: a FIFO
    named ``trials.csv`` is found, then refused by name). Symbolic links to folders are not
    followed (no loops); ``root`` itself may be a session folder."""
    root = Path(root)
    found = []
    for here, dirs, files in os.walk(root, followlinks=False):
        dirs.sort()
        present = set(files) | {d for d in dirs if d in SESSION_FILES}
        if present & set(SESSION_FILES):
            found.append(Path(here))
    return sorted(found)


@dataclass
class FolderSet:
    """Session folders read under a data folder (:func:`read_session_folders`).

    Attributes
    ----------
    folders : list of SessionFolder
        One per session (duplicates left out).
    skipped : list of (Path, str)
        Folders not read as a session of their own, with the reason (a duplicate).
    """

    folders: list
    skipped: list


def read_session_folders(root, exclude: Iterable = ()) -> FolderSet:
    """Read every session folder under ``root`` (:func:`read_session_folder`), duplicates once.

    ``exclude``: folders (e.g. an output folder inside ``root``) not searched.

    Raises
    ------
    SessionFileError
        From any folder; or two folders holding one session (participant and session) whose
        event logs diverge.
    """
    excluded = [Path(p).resolve() for p in exclude]
    paths = [p for p in find_session_folders(root)
             if not any(p.resolve() == e or e in p.resolve().parents for e in excluded)]
    read = [read_session_folder(p) for p in paths]
    kept: dict[tuple, SessionFolder] = {}
    skipped: list = []
    for sf in read:
        key = (sf.participant, sf.session)
        other = kept.get(key)
        if other is None or not sf.log_hash and not other.log_hash:
            if other is not None:       # two folders with no file at all: both read
                key = (*key, str(sf.path))
            kept[key] = sf
            continue
        def named_right(f):
            return (f.path.parent.name, f.path.name) == (f.participant, f.session)
        if not sf.log_hash or not other.log_hash:     # one holds neither log nor table
            keep, drop = (sf, other) if sf.log_hash else (other, sf)
            why = (f"no event log and no trials table; session {sf.participant}/{sf.session} is "
                   f"read from {keep.path}")
        elif sf.log_hash == other.log_hash:
            keep, drop = (sf, other) if named_right(sf) and not named_right(other) else (other, sf)
            why = (f"a copy of {keep.path} (same session {sf.participant}/{sf.session}, same "
                   f"event log); read once")
        else:
            a, b = other.raw_events or b"", sf.raw_events or b""
            if a and b and (a.startswith(b) or b.startswith(a)):
                keep, drop = (other, sf) if len(a) >= len(b) else (sf, other)
                why = (f"an earlier copy of {keep.path} (session {sf.participant}/{sf.session}; "
                       f"its event log is the start of the other's); read once")
            else:
                raise SessionFileError(
                    f"{other.path}, {sf.path}: session: expected one folder per session, got two "
                    f"holding {sf.participant}/{sf.session} with different event logs; keep one")
        kept[key] = keep
        skipped.append((drop.path, why))
    folders = sorted(kept.values(), key=lambda f: str(f.path))
    return FolderSet(folders=folders, skipped=sorted(skipped, key=lambda s: str(s[0])))
