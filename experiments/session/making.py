"""Making sessions: plan and write a new one, reopen one to resume, list the finished ones.

:func:`plan_session` validates the inputs, builds the schedule and checks every simulated
profile without writing anything (:class:`SessionPlan`); :meth:`SessionPlan.write` claims the
folder and writes ``session.json`` (:mod:`experiments.session.store`); :func:`create_session`
does both. :func:`open_session` reads a session back from its ``session.json`` to resume it.
"""
from __future__ import annotations

import secrets
from dataclasses import dataclass
from pathlib import Path

from experiments.errors import SessionError, UserInputError
from experiments.session.engine import Session
from experiments.session.machine import clock_for_url
from experiments.session.setup import check_capacity, protocol_source, check_schedule_profiles
from experiments.session.store import read_session_json, write_session_json
from sessionfiles.session_files import claim_session_folder

__all__ = ["SessionPlan", "plan_session", "create_session", "open_session", "finished_sessions"]


def _safe_name(text: str, what: str) -> str:
    if not text or text in (".", "..") or "/" in text or "\\" in text or "\0" in text:
        raise UserInputError(f"{what}: expected a name usable as a folder, got {text!r}")
    return text


def _next_session_name(folder: Path, after: str | None = None) -> str:
    n = 1
    if after is not None and after[1:].isdigit():
        n = int(after[1:]) + 1
    while _taken(folder / f"S{n:02d}"):
        n += 1
    return f"S{n:02d}"


def _taken(directory: Path) -> bool:
    """Whether a folder is (or may be) a session: anything but the leftover of a claim that
    was killed before ``session.json`` (nothing, or only an empty ``events.jsonl``), which
    :func:`~sessionfiles.session_files.claim_session_folder` claims again."""
    if not directory.exists():
        return False
    if not directory.is_dir():
        return True
    for entry in directory.iterdir():
        if entry.name != "events.jsonl" or entry.stat().st_size > 0:
            return True
    return False


@dataclass
class SessionPlan:
    """A new session checked and planned, nothing written yet (:func:`plan_session`).

    Open the display (:func:`open_session_display`), check it (:meth:`check_display`), then
    :meth:`write` the session folder: a bad ``--display`` leaves no folder behind.
    """

    protocol: object
    participant: object           # participants_schema.Participant
    participant_path: str
    assignment: object
    seed: int
    schedule: list
    directory: Path
    display_url: str
    clock: object
    responder_name: str
    max_consecutive_faults: int
    profiles: dict
    out: object = None
    auto_name: bool = False       # the name was chosen here (S01, S02, ...): take the next if taken
    durable: bool = True          # fsync the session's writes (False: a simulated study only)

    @property
    def name(self) -> str:
        return self.directory.name

    @property
    def participant_id(self) -> str:
        return self.directory.parent.name

    def check_display(self, display) -> None:
        """The simulated profiles against the open display's capacity (ProtocolError)."""
        check_capacity(self.protocol, self.profiles, display, protocol_source(self.protocol))

    def write(self) -> "Session":
        """Write ``session.json`` and ``traces/``; return the :class:`Session`.

        Raises
        ------
        SessionError
            The folder has become a session in the meantime.
        """
        protocol, assignment = self.protocol, self.assignment
        # claimed atomically, log locked, before session.json is written: of two
        # runs for one participant, one gets the folder; an automatic name moves on to the next
        while True:
            try:
                log = claim_session_folder(self.directory, durable=self.durable)
                break
            except SessionError:
                if not self.auto_name:
                    raise
                self.directory = self.directory.parent / _next_session_name(
                    self.directory.parent, after=self.directory.name)
        directory = self.directory
        try:
            write_session_json(directory, self)
        finally:
            # written under the lock; once session.json exists no other run claims the folder,
            # and Session.run takes the lock again
            log.close()
        session = Session(directory, protocol, self.participant, assignment.group, self.seed,
                          self.schedule, self.name, self.display_url, assignment=assignment,
                          clock=self.clock, max_consecutive_faults=self.max_consecutive_faults,
                          out=self.out, responder_name=self.responder_name,
                          profiles=self.profiles, durable=self.durable)
        for w in assignment.warnings:
            session._report(f"warning: {w}")
        session._say(f"{self.participant_id}: {assignment.describe()}")
        return session


def finished_sessions(folder: Path) -> list[Path]:
    """The finished sessions (``session_finished`` logged) in a participant's folder."""
    from sessionfiles.logbook import read_events, replay
    out = []
    for events in sorted(Path(folder).glob("*/events.jsonl")):
        try:
            if replay(read_events(events, warn=False)[0]).finished:
                out.append(events.parent)
        except (OSError, ValueError, SessionError):
            continue
    return out


def _clock_named_in(url: str) -> str | None:
    """``"virtual"`` or ``"real"`` when the URL's query names the clock, else None."""
    from experiments.display.url import url_options
    value = url_options(url).get("clock")
    return value if value in ("virtual", "real") else None


def unfinished_sessions(folder: Path) -> list[Path]:
    """The sessions in a participant's folder that started and did not finish (running now, or
    interrupted, stopped or killed: resumable)."""
    from sessionfiles.logbook import read_events, replay
    out = []
    for events in sorted(Path(folder).glob("*/events.jsonl")):
        try:
            log = read_events(events, warn=False)[0]
            if log and not replay(log).finished:
                out.append(events.parent)
        except (OSError, ValueError, SessionError):
            continue
    return out


def _refuse_existing(directory: Path) -> None:
    events = directory / "events.jsonl"
    if (directory / "session.json").exists() or (events.exists() and events.stat().st_size > 0):
        raise SessionError(f"{directory}: expected a new session folder, got an existing one "
                           f"(resume it with `thermocue resume {directory}` or choose --session)")


def plan_session(protocol, participant_path, data_dir, display_url: str, *, seed: int | None = None,
                 session_name: str | None = None, responder_name: str = "", clock: str = "auto",
                 max_consecutive_faults: int = 3, out=None, durable: bool = True) -> SessionPlan:
    """Validate the inputs, plan the schedule and check every simulated profile; write nothing.

    Parameters are those of :func:`create_session`.

    Raises
    ------
    ProtocolError, ParticipantError, SessionError
        Bad files, a simulated profile the display would refuse
        (:func:`check_schedule_profiles`), or a session folder that already exists.
    """
    from experiments.protocol import load_protocol
    from experiments.schedule import build_schedule
    from participants_schema import Participant, assign_group

    if not hasattr(protocol, "hash"):
        protocol = load_protocol(protocol)
    participant = Participant.read(participant_path)
    from experiments.calibration.writeback import check_calibration_samples
    if any(b.mode == "simulated" for b in protocol.blocks):
        check_calibration_samples(participant, [s.roughness_um for s in protocol.samples],
                                  source=str(participant_path))
    assignment = assign_group(participant, protocol.grouping)   # None: the paper's 800 µm rule
    if seed is None:
        seed = secrets.randbelow(2**31)
    schedule = build_schedule(protocol, participant.id, seed)
    pid = _safe_name(participant.id, f"{participant_path}: id")
    stem = Path(participant_path).stem
    if stem != pid:   # P09.json holding "id": "P01" would write into P01's folder
        raise SessionError(f"{participant_path}: id: expected {stem!r} (the file's name), got "
                           f"{pid!r}: rename the file or correct the id")
    folder = Path(data_dir) / pid
    name = _safe_name(session_name, "--session") if session_name else _next_session_name(folder)
    directory = folder / name
    _refuse_existing(directory)
    clock_obj = clock_for_url(display_url, clock)
    profiles = check_schedule_profiles(protocol, participant, assignment.group, schedule)
    return SessionPlan(protocol, participant, str(participant_path), assignment, seed, schedule,
                       directory, display_url, clock_obj, responder_name, max_consecutive_faults,
                       profiles, out=out, auto_name=not session_name, durable=durable)


def create_session(protocol, participant_path, data_dir, display_url: str, *, seed: int | None = None,
                   session_name: str | None = None, responder_name: str = "", clock: str = "auto",
                   max_consecutive_faults: int = 3, out=None, durable: bool = True) -> Session:
    """Validate the inputs, plan the schedule and write a new session directory.

    Every simulated profile is computed and checked against the protocol's display limits
    first (:func:`check_schedule_profiles`): nothing is written for a protocol whose profiles
    the display would refuse. The display itself is not opened here (``thermocue run`` opens it,
    :func:`open_session_display`, between :func:`plan_session` and :meth:`SessionPlan.write`).

    Parameters
    ----------
    protocol : str, Path or Protocol
        A protocol file, the name of a packaged protocol, or a loaded protocol.
    participant_path : str or Path
        The participant record (JSON).
    data_dir : str or Path
        ``DATA``; the session goes to ``DATA/<participant id>/<session name>/``.
    display_url : str
        pyserial URL of the display (``emulator://?clock=virtual``, a pty, ``/dev/ttyUSB0``).
    seed : int, optional
        Default: a random seed (stored).
    session_name : str, optional
        Default: the first free ``S01``, ``S02``, ...
    responder_name : str
        Recorded in ``session.json`` (``thermocue resume`` uses it by default).
    clock : {"auto", "real", "virtual"}
    out : file, optional
        The experimenter's channel (default stderr): errors, warnings, why a run stopped.
        Progress lines are logged on ``thermocue.session`` (INFO) instead.
    durable : bool
        Fsync every write (default). False only for a simulated study on a virtual clock,
        recomputed from its seed: the same files in the same order, without the fsyncs.

    Returns
    -------
    Session

    Raises
    ------
    ProtocolError, ParticipantError, SessionError
        Bad files, a simulated profile the display would refuse, or a session folder that
        already exists.
    """
    return plan_session(protocol, participant_path, data_dir, display_url, seed=seed,
                        session_name=session_name, responder_name=responder_name, clock=clock,
                        max_consecutive_faults=max_consecutive_faults, out=out,
                        durable=durable).write()


def open_session(session_dir, *, display_url: str | None = None, clock: str | None = None,
                 out=None, durable: bool = True) -> Session:
    """Reopen a session directory to resume it (same protocol, participant, seed, schedule).

    ``session.json`` is checked, not trusted: the protocol copy against its hash, the seed (an
    integer ≥ 0), the schedule against ``build_schedule(protocol, participant id, seed)``, and
    every simulated profile against the display limits (:func:`check_schedule_profiles`).

    Parameters
    ----------
    display_url : str, optional
        Default: the stored one.
    clock : {"auto", "real", "virtual"}, optional
        Default (None): the clock the display URL names (``clock=virtual`` or ``clock=real``
        in its query), else the clock the session ran on (``session.json``'s ``clock``): a
        resume never switches a virtual-clock session to the real clock, or back, unless told.
        ``"auto"``: from the display URL actually used (virtual iff it says ``clock=virtual``),
        as for a new session.
    durable : bool
        As for :func:`create_session`.

    Raises
    ------
    SessionError
        No ``session.json``, a damaged or edited one (naming the field).
    """
    stored = read_session_json(session_dir, out=out)
    url = display_url or stored.display_url
    if clock is None:
        named = _clock_named_in(url)
        clock = named or stored.clock or "auto"
    clock_obj = clock_for_url(url, clock)
    profiles = check_schedule_profiles(stored.protocol, stored.participant, stored.group,
                                        stored.schedule, source=stored.source)
    session = Session(Path(session_dir), stored.protocol, stored.participant, stored.group,
                      stored.seed, stored.schedule, stored.name, url, clock=clock_obj,
                      max_consecutive_faults=stored.max_consecutive_faults, out=out,
                      responder_name=stored.responder, profiles=profiles, durable=durable)
    session.protocol_source = stored.source
    return session
