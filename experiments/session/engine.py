"""The session engine: :class:`Session` runs one participant through one protocol.

One concept (~500 lines): the session-level state machine and the state a run carries.

The session-level states of :data:`~experiments.session.machine.TRANSITIONS` live here
(``idle`` between trials, ``finished``, ``stopped``, ``interrupted``: :meth:`Session.run`);
each trial's states are the methods of its :class:`~experiments.session.trial.TrialSteps`
(``Session.steps``, which holds the session it runs for). Every state
change is logged; a log append or a file rewrite is never cut by a signal
(:mod:`experiments.session.signals`); a fault or an interruption puts the display to neutral
first. How a run ends early (faults in a row, a lost link, a restarted display) and a trial
given up are :class:`~experiments.session.stops.RunStops`' (``Session.stops``). See
:mod:`experiments.session` for the files a session writes.
"""
from __future__ import annotations

import datetime as _dt
import errno
import logging
import os
import time
from pathlib import Path

from experiments.errors import DisplayError, SessionError, UserInputError
from sessionfiles.logbook import EventLog, log_shortfall, read_events, replay
from experiments.responders.base import Responder
from experiments.responders.hand import press
from experiments.display.base import Display
from experiments.session.hooks import SessionHooks, hooks_from_env
from experiments.session.machine import StateMachine, clock_for_url
from experiments.session.planning import SessionProfiles
from experiments.session.setup import protocol_source, open_session_display
from experiments.session.signals import STOPS, SignalGuard, stop_reason
from experiments.session.store import record_display
from experiments.session.traces import keep_trace
from experiments.session.trials_table import TrialsTable
from experiments.session.stops import RunStops
from experiments.session.trial import TrialSteps, TrialAttempt, clock_text
from sessionfiles.session_files import schedule_sha256
from participants_schema import skin_um
from experiments.monitor.time_left import TimeLeft

__all__ = ["Session"]

#: Progress lines (trial n of N, elapsed, time left, the planner's word on each profile).
_log = logging.getLogger("thermocue.session")


class Session:
    """A session directory and the engine that runs its trials.

    Make one with :func:`create_session` (new) or :func:`open_session` (resume), then call
    :meth:`run`.

    Attributes
    ----------
    directory : Path
    protocol : experiments.protocol.Protocol
    participant : participants_schema.Participant
        The validated participant, read once (``Participant.read``).
    assignment : participants_schema.GroupAssignment or None
    group : str
    seed : int
    schedule : list of TrialSpec
    name : str
        The session's name (its folder).
    display_url : str
    clock : RealClock or VirtualClock
    experimenter : experiments.responders.experimenter.Experimenter
        The experimenter's channel (``out``: its stream; default stderr): the sample to place,
        faults, warnings and why a run stopped. Progress lines are logged instead
        (``thermocue.session``, :meth:`_say`).
    responder_name : str
        The responder recorded in ``session.json`` ("" if none).
    hooks : SessionHooks
        Called at the trial's pause points (tests; default from ``THERMOCUE_TEST_PAUSE_AT``).
    durable : bool
        Whether the session's writes are fsynced (default True; False only for a simulated
        study on a virtual clock, recomputed from its seed: same files, same bytes, no fsync).
    """

    def __init__(self, directory, protocol, participant, group, seed, schedule, name, display_url,
                 *, assignment=None, clock=None, max_consecutive_faults: int = 3, out=None,
                 responder_name: str = "", profiles: dict | None = None,
                 experimenter=None, hooks: SessionHooks | None = None, durable: bool = True):
        self.directory = Path(directory)
        self.durable = bool(durable)
        self.protocol = protocol
        self.participant = participant
        self.group = group
        self.assignment = assignment
        self.seed = seed
        self.schedule = list(schedule)
        self.name = name
        self.display_url = display_url
        self.responder_name = responder_name
        self.clock = clock if clock is not None else clock_for_url(display_url)
        self.max_consecutive_faults = int(max_consecutive_faults)
        self.out = out
        #: The experimenter's channel (terminal by default): everything the participant must
        #: not see (:mod:`experiments.responders.experimenter`).
        if experimenter is None:
            from experiments.responders.experimenter import TerminalExperimenter
            experimenter = TerminalExperimenter(out)
        self.experimenter = experimenter
        #: The time left, from the trial durations measured in the log (the monitor's estimate)
        self._time_left = self._new_time_left()
        #: trials.csv, rebuilt from events.jsonl after every trial (made anew by each run)
        self._trials_table = TrialsTable(self.events_path, self.trials_path, durable=durable)
        self.log = None
        self.responder: Responder | None = None
        self.display = None
        self.machine = StateMachine(on_change=self._on_state)
        self._attempt: TrialAttempt | None = None
        self._started = time.monotonic()   # the session's first start, on this run's monotonic clock
        #: The checked target profiles, by (roughness_id, roughness_um).
        self.profiles = SessionProfiles(profiles)
        #: How messages name the protocol (its file; ``session.json: protocol`` on resume).
        self.protocol_source = protocol_source(protocol)
        self.signals = SignalGuard()
        self._fatal = None          # (code, message) of a fault that stops the session
        self._link_lost = None      # (code, message): the display's port failed in this attempt
        self._given_up: set[int] = set()   # trials given up in this run ([contact] max_attempts)
        self._reopened = []         # displays opened again after a lost link (closed at the end)
        #: Called at the trial's pause points (:mod:`experiments.session.hooks`; tests).
        self.hooks = hooks if hooks is not None else hooks_from_env()
        self._last_block = None
        #: The trial's states (prompt ... rewarm), run for this session.
        self.steps = TrialSteps(self)
        #: How the run ends early (faults, a lost link, a restarted display), a trial given up.
        self.stops = RunStops(self)
        self._date = _psychopy_date(time.time())   # replaced by the first start's on resume
        self._exp_start = _psychopy_exp_start(time.time())

    # -- paths and context ------------------------------------------------------------------
    @property
    def participant_id(self) -> str:
        return self.participant.id

    @property
    def n_trials(self) -> int:
        return len(self.schedule)

    @property
    def events_path(self) -> Path:
        return self.directory / "events.jsonl"

    @property
    def trials_path(self) -> Path:
        return self.directory / "trials.csv"

    @property
    def traces_dir(self) -> Path:
        return self.directory / "traces"

    def _context(self) -> dict:
        from experiments import thermocue_version
        return {"session": self.name, "participant": self.participant_id, "group": self.group,
                "protocol": self.protocol.name, "protocol_hash": self.protocol.hash,
                "seed": self.seed, "n_trials": self.n_trials,
                "schedule_sha256": schedule_sha256(self.schedule),
                "skin_thickness_um": skin_um(self.participant.measured_skin_m),
                "sex": self.participant.sex,
                # PsychoPy-style identity of every trial row (date: the session's first start)
                "date": self._date, "expName": self.protocol.name, "expStart": self._exp_start,
                "protocol_version": self.protocol.version, "thermocue_version": thermocue_version()}

    def sample_for(self, spec) -> dict:
        """The physical sample of a trial: material, roughness (m), thickness (m), temperature (°C)."""
        sample = self.protocol.sample(spec.roughness_id)
        return {"material": self.protocol.material.name, "roughness_m": sample.roughness_m,
                "thickness_m": self.protocol.material.thickness_m,
                "temperature_C": self.protocol.environment.room_temperature_C}

    def emulated_touch(self, spec, display) -> None:
        """Stand in for a person's hand on the emulator: place the sample, press the finger.

        The finger presses 0.3 s after arming with 0.5 N more than the protocol's threshold
        and stays for ``max_contact_s`` (simulated trials) or ``record_s`` (real ones), with the
        participant's measured skin thickness and ``initial_skin_temperature_C`` (else the middle
        of the protocol's skin-temperature range).
        """
        contact = self.protocol.contact
        env = self.protocol.environment
        skin_C = self.participant.initial_skin_temperature_C
        if skin_C is None:
            skin_C = 0.5 * (env.skin_temperature_min_C + env.skin_temperature_max_C)
        reply = press(display, sample=None if spec.mode == "simulated" else self.sample_for(spec),
                      press_after_s=0.3, force_N=contact.force_threshold_N + 0.5,
                      hold_s=contact.max_contact_s if spec.mode == "simulated" else contact.record_s,
                      skin_thickness_m=self.participant.measured_skin_m,
                      skin_temperature_C=float(skin_C))
        self.log_event("emulated_touch", trial_index=spec.trial_index, skin_temperature_C=skin_C)
        self.log_finger_model(spec.trial_index, reply)

    def log_finger_model(self, trial_index: int, reply: dict) -> None:
        """Log what models the emulated finger's touch (:func:`..responders.hand.finger_model`):
        the ``emulated_finger_model`` event, when the emulator says."""
        from experiments.responders.hand import finger_model
        model = finger_model(reply)
        if model is not None:
            self.log_event("emulated_finger_model", trial_index=int(trial_index), **model)

    # -- logging --------------------------------------------------------------------------
    def log_event(self, kind: str, **fields) -> dict | None:
        """Append an event to ``events.jsonl`` (fsynced). Used by responders too."""
        if self.log is None or self.log.closed:
            return None
        with self.signals.critical():
            event = self.log.append(kind, **fields)
        self._time_left.feed(event)
        return event

    def _new_time_left(self, events=()) -> TimeLeft:
        rewarm_s = 0.0 if self.clock.virtual else self.protocol.contact.rewarm_s
        return TimeLeft({s.trial_index: s.mode for s in self.schedule}, rewarm_s).feed_all(events)

    def _elapsed(self) -> float:
        """Seconds since the session's first start (its first ``session_started`` event)."""
        return time.monotonic() - self._started

    def _on_state(self, old: str, new: str, **context) -> None:
        self.log_event("state", **{"from": old, "to": new}, **context)

    def _say(self, text: str) -> None:
        """A progress line: logged at INFO on ``thermocue.session`` (the CLI prints it on
        stderr; ``--quiet`` silences it) and shown on the experimenter's window if one is open."""
        if _log.isEnabledFor(logging.INFO):     # a study's sessions: the logger is off
            _log.info(text)
            self.experimenter.progress(text)

    def _report(self, text: str) -> None:
        """An error, a warning or the reason a run stopped: printed even with ``--quiet``.

        Goes to the experimenter's channel (never to the participant's screen)."""
        self.experimenter.tell(text)

    # -- the run --------------------------------------------------------------------------
    def run(self, responder: Responder, display: Display | None = None) -> int:
        """Run (or resume) the session to its end.

        Parameters
        ----------
        responder : Responder
        display : open display, optional
            Default: opened from :attr:`display_url` with the protocol's safety limits.

        Returns
        -------
        int
            0 when every trial is done; 1 when interrupted or stopped after repeated faults
            (the session can be resumed).
        """
        self._trials_table = TrialsTable(self.events_path, self.trials_path,   # read afresh
                                         durable=self.durable)
        events = []
        if self.events_path.exists():
            events, _report = read_events(self.events_path, warn=False)
        missing = log_shortfall(events, self.trials_path, self.traces_dir)
        if missing:
            more = f" and {len(missing) - 3} more" if len(missing) > 3 else ""
            raise SessionError(
                f"{self.events_path}: expected the record of everything in trials.csv and "
                f"traces/, got a log without {'; '.join(missing[:3])}{more}: it was cut or "
                f"replaced by an older copy; restore it from a backup (nothing was changed)")
        progress = replay(events)
        self._time_left = self._new_time_left(events)
        since = _seconds_since_first_start(events)
        self._started = time.monotonic() - since
        self._date = _psychopy_date(time.time() - since)
        self._exp_start = _psychopy_exp_start(time.time() - since)
        try:
            with EventLog(self.events_path, durable=self.durable) as log:
                if log.repaired:
                    self._report(f"repaired: {log.repaired}")
                self.log = log
                old_handlers = self.signals.install()
                try:
                    return self._run(responder, display, progress)
                finally:
                    self.signals.restore(old_handlers)
                    self.log = None
        except OSError as exc:
            if isinstance(exc, DisplayError):
                raise
            return self._write_failed(exc)

    def _write_failed(self, exc: OSError) -> int:
        """A file of the session could not be written (disk full, read-only): one line, exit 1.

        The display was put to neutral where the error was caught (:meth:`_guarded`); what
        could be logged was logged; every file is as a crash would leave it, so the session
        resumes once the cause is fixed.
        """
        cause = {errno.ENOSPC: "disk full", errno.EROFS: "read-only file system",
                 errno.EDQUOT: "disk quota exceeded", errno.EFBIG: "file too large",
                 errno.EACCES: "permission denied", errno.EPERM: "permission denied",
                 errno.EIO: "I/O error"}.get(exc.errno, exc.strerror or type(exc).__name__)
        where = exc.filename or self.directory
        self._report(f"{where}: cannot write ({cause}); display neutral, session stopped; "
                     f"free the disk and resume with `thermocue resume {self.directory}`")
        return 1

    def _run(self, responder, display, progress) -> int:
        resumed = progress.session is not None
        kind = "session_resumed" if resumed else "session_started"
        if progress.finished:
            self._report(f"session {self.directory} is already finished; nothing to do")
            return 0
        try:
            self.log_event(kind, **self._context(), responder=responder.name,
                           display_url=self.display_url, clock="virtual" if self.clock.virtual else "real")
            for trial_index, attempt in progress.open_attempts:
                self._abort_attempt(trial_index, attempt, reason="killed")
            self._write_trials()
            todo = [s for s in self.schedule if progress.completed.get(s.trial_index) != "ok"]
            self._say(f"{self.participant_id}/{self.name}: {len(todo)} of {self.n_trials} trials to run"
                      + (" (resumed)" if resumed else ""))
            self.responder = responder
            self.experimenter.open()
            try:
                responder.begin_session(self)
            except BaseException:
                self.experimenter.close()
                raise
            try:
                if display is None:
                    try:
                        opened = self._open_display()
                    except DisplayError as exc:
                        if isinstance(exc, UserInputError):
                            raise
                        self.log_event("display_error", step="open", message=str(exc))
                        self._report(f"{exc}; nothing was run: resume with `thermocue resume "
                                     f"{self.directory} --display URL`")
                        return 1
                    with opened as disp:
                        return self._guarded(disp, todo, progress)
                return self._guarded(display, todo, progress)
            finally:
                try:
                    responder.end_session()
                finally:
                    self.experimenter.close()
        except STOPS as exc:
            self._interrupted(stop_reason(exc))
            return 1

    def _guarded(self, disp, todo, progress) -> int:
        """Run the trials; on an interruption or an error, neutral first (display still open)."""
        try:
            return self._run_trials(disp, todo, progress)
        except STOPS as exc:
            self._interrupted(stop_reason(exc))
            return 1
        except Exception as exc:
            with self.signals.shielded():
                self._neutral(disp)
                # best effort: the error may be the disk itself (full, read-only), and the
                # clean-up must not raise in its turn and hide it
                a = self._attempt
                if a is not None and not a.logged_end:
                    _best_effort(lambda: self._abort_attempt(a.spec.trial_index, a.attempt,
                                                             reason="error"))
                _best_effort(lambda: self.log_event("session_error",
                                                    message=f"{type(exc).__name__}: {exc}"))
            raise
        finally:
            for again in self._reopened:
                try:
                    again.close()
                except Exception:
                    pass
            self._reopened = []

    def _open_display(self):
        disp = open_session_display(self.protocol, self.display_url, source=self.protocol_source)
        try:
            self.check_display(disp)
        except BaseException:
            disp.close()
            raise
        return disp

    def check_display(self, display) -> None:
        """Check the simulated profiles against an open display's capacity (points, step).

        Raises
        ------
        ProtocolError
            Naming the protocol and ``simulation.duration_s`` or ``simulation.rate_Hz``.
        """
        self.profiles.check_display(self.protocol, display, self.protocol_source)

    @property
    def finished(self) -> bool:
        """Whether ``events.jsonl`` records the session as finished."""
        if not self.events_path.exists():
            return False
        events, _ = read_events(self.events_path, warn=False)
        return bool(replay(events).finished)

    def _run_trials(self, disp, todo, progress) -> int:
        self.display = disp
        info = getattr(disp, "info", None)
        self.log_event("display_opened", url=self.display_url,
                       device_id=getattr(info, "device_id", None), firmware=getattr(info, "firmware", None),
                       capabilities=list(getattr(info, "capabilities", ()) or ()),
                       image_id=getattr(info, "image_id", "") or "")
        record_display(self.directory, self.display_url, info, durable=self.durable)
        disp.set_neutral(self.protocol.display.neutral_C)
        faults = 0
        queue = list(todo)
        tries: dict[int, int] = {}      # attempts of each trial in this run (start or resume)
        while queue:
            spec = queue[0]
            attempt = progress.next_attempt(spec.trial_index)
            progress.attempts[spec.trial_index] = attempt
            outcome = self.steps.run(disp, spec, attempt)
            gave_up = False
            if outcome == "ok":
                faults = 0
                queue.pop(0)
            else:  # "fault" (written as such) or "no_contact" (aborted): the same trial again,
                faults += 1  # up to [contact] max_attempts attempts in this run
                tries[spec.trial_index] = tries.get(spec.trial_index, 0) + 1
                if tries[spec.trial_index] >= self.protocol.contact.max_attempts:
                    queue.pop(0)
                    self.stops.give_up(spec.trial_index, tries[spec.trial_index])
                    gave_up = True
            if self._fatal is not None:
                return self.stops.after_fatal(disp, queue)
            lost = self._link_lost is not None
            if lost:
                disp = self.stops.reconnect(disp, spec.trial_index)
                if disp is None:
                    return self.stops.after_link_lost(queue)
            if faults >= self.max_consecutive_faults:
                # (a lost link that connecting again cured counts too: a link that drops on every
                # attempt stops the session here instead of retrying one trial for ever)
                return self.stops.after_faults(disp, faults, queue)
            if lost and not gave_up:
                self.machine.go("idle")
                continue          # the same trial at once, no rewarm (still a consecutive fault)
            if queue:
                self.steps.rewarm()
            self.machine.go("idle")
        self.machine.go("finished")
        self._neutral(disp)
        self._write_trials()
        self._export_bids()          # (before session_finished: that stays the log's last event)
        self.log_event("session_finished", n_completed=self.stops.n_completed([]),
                       n_given_up=len(self._given_up))
        self._write_trials()
        given_up = (f" ({len(self._given_up)} given up after {self.protocol.contact.max_attempts} "
                    f"attempts: trial {', '.join(map(str, sorted(self._given_up)))})"
                    if self._given_up else "")
        self._say(f"session finished: {self.n_trials} trials{given_up}, "
                  f"{clock_text(self._elapsed())} since its first start; data in {self.directory}")
        if self.responder is not None:
            self.responder.show_text("Thank you: the session is finished.")
        return 0

    def _abort_attempt(self, trial_index: int, attempt: int, reason: str, fault_code=None) -> None:
        """Log an attempt as aborted and keep its trace under an ``aborted`` name."""
        kept = keep_trace(self.traces_dir, trial_index, attempt, "aborted", durable=self.durable)
        with self.signals.critical():
            self.log_event("trial_aborted", trial_index=trial_index, attempt=attempt, reason=reason,
                           fault_code=fault_code,
                           trace_file=None if kept is None else f"traces/{kept.name}")
            if self._attempt is not None and self._attempt.spec.trial_index == trial_index \
                    and self._attempt.attempt == attempt:
                self._attempt.logged_end = True
            self._write_trials()

    def _write_trials(self) -> None:
        """``trials.csv`` rebuilt from the event log (:class:`.trials_table.TrialsTable`)."""
        self._trials_table.write()

    def _export_bids(self) -> None:
        """The finished session as BIDS behavioural data in ``DATA/bids/`` (:mod:`experiments.bids`).

        A failure is reported and logged, never fatal: ``trials.csv`` is the session's record."""
        from experiments.bids import export_session
        try:
            path = export_session(self.directory, durable=self.durable)
        except (OSError, ValueError, KeyError) as exc:
            self.log_event("bids_export_failed", message=f"{type(exc).__name__}: {exc}")
            self._report(f"warning: BIDS export failed ({exc}); run `thermocue export-bids` later")
            return
        # relative to the session folder: the log must not depend on where the data folder is
        self.log_event("bids_exported", path=_relative_to(path, self.directory))

    def _neutral(self, disp) -> None:
        """Display to neutral whatever state it is in (errors logged, never raised)."""
        for step, call in (("abort", lambda: disp.abort()),
                           ("set_neutral", lambda: disp.set_neutral(self.protocol.display.neutral_C))):
            try:
                call()
            except DisplayError as exc:
                _best_effort(lambda: self.log_event("display_error", step=step, message=str(exc)))
            except Exception as exc:  # an interrupted driver may be in any state
                _best_effort(lambda: self.log_event("display_error", step=step,
                                                    message=f"{type(exc).__name__}: {exc}"))

    def _interrupted(self, reason: str) -> None:
        if self.machine.state == "interrupted":
            return  # already handled with the display open
        # Further signals must not cut the clean-up short.
        with self.signals.shielded():
            if self.display is not None:
                self._neutral(self.display)
            a = self._attempt
            if a is not None and not a.logged_end:
                self._abort_attempt(a.spec.trial_index, a.attempt, reason="interrupted")
            if self.machine.can("interrupted"):
                self.machine.go("interrupted")
            self.log_event("session_interrupted", reason=reason)
            self._write_trials()
        self._report(f"session interrupted ({reason}); display neutral; resume with "
                     f"`thermocue resume {self.directory}`")


def _relative_to(path, folder) -> str:
    """``path`` relative to ``folder``, with forward slashes (``../../bids/sub-P01/...``)."""
    return Path(os.path.relpath(Path(path).resolve(), Path(folder).resolve())).as_posix()


def _best_effort(call) -> None:
    """Run a clean-up write; a failing disk (OSError) must not raise over the first error."""
    try:
        call()
    except OSError as exc:
        if isinstance(exc, DisplayError):
            raise


def _seconds_since_first_start(events) -> float:
    """Seconds from the log's first ``session_started`` event to now (0 if none)."""
    for e in events:
        if e.get("event") == "session_started" and isinstance(e.get("time"), str):
            try:
                t0 = _dt.datetime.fromisoformat(e["time"].replace("Z", "+00:00"))
            except ValueError:
                return 0.0
            if t0.tzinfo is None:
                t0 = t0.replace(tzinfo=_dt.timezone.utc)
            return max(0.0, (_dt.datetime.now(_dt.timezone.utc) - t0).total_seconds())
    return 0.0


def _psychopy_exp_start(epoch_s: float) -> str:
    """PsychoPy's ``expStart`` form of a time (local, with its UTC offset), e.g.
    ``2026-11-22 14h05.09.123456 +0100``."""
    import datetime as _dt
    return _dt.datetime.fromtimestamp(epoch_s).astimezone().strftime("%Y-%m-%d %Hh%M.%S.%f %z")


def _psychopy_date(epoch_s: float) -> str:
    """PsychoPy's ``data.getDateStr()`` form of a time, e.g. ``2026-11-22_14h05.09.123`` (local)."""
    t = time.localtime(epoch_s)
    return time.strftime("%Y-%m-%d_%Hh%M.%S", t) + f".{int((epoch_s % 1) * 1000):03d}"
