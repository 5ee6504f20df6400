"""The session engine: one participant through one protocol, every step logged, nothing lost.

A session lives in ``DATA/<participant>/<session>/``:

``session.json``
    The protocol (data and hash), the participant record and group, the seed, the schedule,
    the display URL, the responder and the package versions. Written once (atomically).
``events.jsonl``
    The source of truth (:class:`experiments.logbook.EventLog`, fsynced per event): every
    state change, upload, contact, response, completed or aborted trial.
``trials.csv``
    Rebuilt from the events (atomically) after every trial.
``traces/trial-NNN.csv``
    The telemetry of each trial, streamed while it runs.

Each trial is an explicit state machine (:data:`TRANSITIONS`)::

    idle -> prompt -> prepare -> cue -> wait_contact -> playback | record -> respond -> write
         -> rewarm -> idle ...                      \\-> no_contact (aborted, re-run)
    prepare | wait_contact | playback | record -> fault -> write

``prompt`` asks the experimenter to place the sample (real trials); ``prepare`` computes and
uploads the target profile and arms the display (playback for simulated trials, record for
real ones); ``cue`` plays the sound. A :class:`~experiments.errors.DisplayError` or a faulted
recording puts the display to neutral and writes the attempt with status ``"fault"`` (and its
``fault_code``); the trial is then run again as its next attempt, and after
``max_consecutive_faults`` faults or contact time-outs in a row the session stops cleanly
(resumable: the stopped trial is the first one run on resume). SIGINT and SIGTERM put the
display to neutral, log the running attempt as aborted and a ``session_interrupted`` event, and
:meth:`Session.run` returns 1. :func:`open_session` + :meth:`Session.run` resume: the first
incomplete trial is re-run with the next attempt number, completed trials are never re-run.
"""
from __future__ import annotations

import os
import secrets
import signal
import sys
import threading
import time
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from experiments.errors import DisplayError, DisplayRestarted, SessionError, UserInputError
from experiments.logbook import now_iso as _now_iso
from experiments.responders.base import Responder, ResponderClosed, TrialStimulus
from experiments.schedule import ALGORITHM as SCHEDULE_ALGORITHM
from experiments.session_setup import (_check_capacity, _protocol_source, check_simulated_profiles,
                                       open_session_display, simulated_target_profile)
from experiments.session_files import (TraceWriter, aborted_trace_name, claim_session_folder,
                                       package_versions, schedule_sha256, trace_name)
from experiments.session_machine import (
    TRANSITIONS,
    RealClock,
    SessionInterrupted,
    StateMachine,
    TransitionError,
    VirtualClock,
    clock_for_url,
)

__all__ = [
    "Session",
    "create_session",
    "plan_session",
    "SessionPlan",
    "simulated_target_profile",
    "check_simulated_profiles",
    "open_session_display",
    "open_session",
    "SessionInterrupted",
    "TransitionError",
    "StateMachine",
    "TRANSITIONS",
    "RealClock",
    "VirtualClock",
    "clock_for_url",
    "PAUSE_ENV",
    "block_roles",
    "finished_sessions",
]

#: Environment variable naming test pause points, e.g. ``"playback:5"`` or
#: ``"upload:9,after_response:3"``: on reaching one, the engine prints ``THERMOCUE_PAUSED
#: <point> <trial_index> <attempt>`` on stderr and waits for ever (tests SIGKILL it there).
PAUSE_ENV = "THERMOCUE_TEST_PAUSE_AT"
PAUSE_POINTS = ("trial_started", "upload", "armed", "playback", "after_response", "after_write")

#: Telemetry states of a trial in contact (the display's ``State`` names).
_ACTIVE_STATES = {"PLAYING", "RECORDING"}
_TOUCH_N = 0.1   # N: summed force below which the finger is not yet touching
#: Recording fault codes that mean "nobody touched" (the attempt is aborted and re-run).
_NO_CONTACT_CODES = {"TRIAL_TIMEOUT"}
#: End reasons of a delivered trial (``TrialRecording.end_reason``).
_DELIVERED_ENDS = {"complete", "released", "max_duration"}
#: Faults after which the session stops at once instead of re-running the trial: the display
#: restarted (it lost the session's limits and neutral; a resume shakes hands again). A latched
#: fault (over-temperature, sensor) makes the device refuse ARM (FAULT_LATCHED) until an operator
#: resets it, so the consecutive-fault rule stops the session without heating again.
_FATAL_CODES = {"DEVICE_RESTARTED", "DisplayRestarted", "NO_HELLO"}


def _safe_name(text: str, what: str) -> str:
    if not text or text in (".", "..") or "/" in text or "\\" in text or "\0" in text:
        raise UserInputError(f"{what}: expected a name usable as a folder, got {text!r}")
    return text


@dataclass
class _Attempt:
    spec: object
    attempt: int
    logged_end: bool = False


class Session:
    """A session directory and the engine that runs its trials.

    Make one with :func:`create_session` (new) or :func:`open_session` (resume), then call
    :meth:`run`.

    Attributes
    ----------
    directory : Path
    protocol : experiments.protocol.Protocol
    participant : dict
        The validated participant record.
    assignment : participants_schema.GroupAssignment or None
    group : str
    seed : int
    schedule : list of TrialSpec
    name : str
        The session's name (its folder).
    display_url : str
    clock : RealClock or VirtualClock
    responder_name : str
        The responder recorded in ``session.json`` ("" if none).
    """

    def __init__(self, directory, protocol, participant, group, seed, schedule, name, display_url,
                 *, assignment=None, clock=None, max_consecutive_faults: int = 3, out=None,
                 progress: bool = True, responder_name: str = "", profiles: dict | None = None,
                 experimenter=None):
        self.directory = Path(directory)
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
        self.show_progress = progress
        #: The experimenter's channel (terminal by default): everything the participant must
        #: not see (:mod:`experiments.responders.experimenter`).
        if experimenter is None:
            from experiments.responders.experimenter import TerminalExperimenter
            experimenter = TerminalExperimenter(out)
        self.experimenter = experimenter
        self._trial_seconds: list[float] = []   # durations of the trials run so far (for the ETA)
        self.log = None
        self.responder: Responder | None = None
        self.display = None
        self.machine = StateMachine(on_change=self._on_state)
        self._attempt: _Attempt | None = None
        self._started = time.monotonic()   # the session's first start, on this run's monotonic clock
        self._profiles = dict(profiles or {})   # (roughness_id, roughness_um) -> checked profile
        self._plans_told: set = set()   # profiles whose model decisions the experimenter was told
        #: How messages name the protocol (its file; ``session.json: protocol`` on resume).
        self.protocol_source = _protocol_source(protocol)
        self._defer = 0
        self._fatal = None          # (code, message) of a fault that stops the session
        self._pending: str | None = None
        self._pause_at = _parse_pause(os.environ.get(PAUSE_ENV, ""))
        self._last_block = None
        self._date = _psychopy_date(time.time())   # replaced by the first start's on resume

    # -- paths and context ------------------------------------------------------------------
    @property
    def participant_id(self) -> str:
        return str(self.participant["id"])

    @property
    def skin_thickness_um(self):
        return (self.participant.get("skin_thickness") or {}).get("total_um")

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
                "skin_thickness_um": self.skin_thickness_um, "sex": self.participant.get("sex"),
                # PsychoPy-style identity of every trial row (date: the session's first start)
                "date": self._date, "expName": self.protocol.name,
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
        participant's skin thickness (800 µm if the record has none) and
        ``initial_skin_temperature_C`` (else the middle of the protocol's skin-temperature range).
        """
        contact = self.protocol.contact
        if spec.mode != "simulated":
            display.sim_sample(**self.sample_for(spec))
        env = self.protocol.environment
        skin_C = self.participant.get("initial_skin_temperature_C",
                                      0.5 * (env.skin_temperature_min_C + env.skin_temperature_max_C))
        thickness_um = self.skin_thickness_um or 800.0
        display.sim_finger(press_after_s=0.3, force_N=contact.force_threshold_N + 0.5,
                           hold_s=contact.max_contact_s if spec.mode == "simulated" else contact.record_s,
                           skin_thickness_m=float(thickness_um) * 1e-6,
                           skin_temperature_C=float(skin_C))
        self.log_event("emulated_touch", trial_index=spec.trial_index, skin_temperature_C=skin_C)

    # -- logging --------------------------------------------------------------------------
    @contextmanager
    def _critical(self):
        """No signal interrupts a log append or a file rewrite; it is raised right after."""
        self._defer += 1
        try:
            yield
        finally:
            self._defer -= 1
            if self._defer == 0 and self._pending is not None:
                reason, self._pending = self._pending, None
                raise SessionInterrupted(reason)

    def log_event(self, kind: str, **fields) -> dict | None:
        """Append an event to ``events.jsonl`` (fsynced). Used by responders too."""
        if self.log is None or self.log.closed:
            return None
        with self._critical():
            return self.log.append(kind, **fields)

    def _on_state(self, old: str, new: str, **context) -> None:
        self.log_event("state", **{"from": old, "to": new}, **context)

    def _say(self, text: str) -> None:
        """A progress line (silenced by ``--quiet``)."""
        if self.show_progress:
            self._report(text)

    def _report(self, text: str) -> None:
        """An error, a warning or the reason a run stopped: printed even with ``--quiet``.

        Goes to the experimenter's channel (never to the participant's screen)."""
        self.experimenter.tell(text)

    def _pause(self, point: str, spec, attempt: int) -> None:
        if (point, spec.trial_index) in self._pause_at:
            print(f"THERMOCUE_PAUSED {point} {spec.trial_index} {attempt}", file=sys.stderr, flush=True)
            while True:  # the test kills us here
                time.sleep(3600)

    # -- the run --------------------------------------------------------------------------
    def run(self, responder: Responder, display=None) -> int:
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
        from experiments.logbook import EventLog, log_shortfall, read_events, replay

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
        since = _seconds_since_first_start(events)
        self._started = time.monotonic() - since
        self._date = _psychopy_date(time.time() - since)
        try:
            with EventLog(self.events_path) as log:
                if log.repaired:
                    self._report(f"repaired: {log.repaired}")
                self.log = log
                old_handlers = self._install_signals()
                try:
                    return self._run(responder, display, progress)
                finally:
                    self._restore_signals(old_handlers)
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
        import errno
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
        except _STOPS as exc:
            self._interrupted(_reason(exc))
            return 1

    def _guarded(self, disp, todo, progress) -> int:
        """Run the trials; on an interruption or an error, neutral first (display still open)."""
        try:
            return self._run_trials(disp, todo, progress)
        except _STOPS as exc:
            self._interrupted(_reason(exc))
            return 1
        except Exception as exc:
            self._defer += 1
            try:
                self._neutral(disp)
                # best effort: the error may be the disk itself (full, read-only), and the
                # clean-up must not raise in its turn and hide it
                a = self._attempt
                if a is not None and not a.logged_end:
                    _best_effort(lambda: self._abort_attempt(a.spec.trial_index, a.attempt,
                                                             reason="error"))
                _best_effort(lambda: self.log_event("session_error",
                                                    message=f"{type(exc).__name__}: {exc}"))
            finally:
                self._defer -= 1
                self._pending = None
            raise

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
        _check_capacity(self.protocol, self._profiles, display, self.protocol_source)

    @property
    def finished(self) -> bool:
        """Whether ``events.jsonl`` records the session as finished."""
        from experiments.logbook import read_events, replay
        if not self.events_path.exists():
            return False
        events, _ = read_events(self.events_path, warn=False)
        return bool(replay(events).finished)

    def _run_trials(self, disp, todo, progress) -> int:
        self.display = disp
        info = getattr(disp, "info", None)
        self.log_event("display_opened", url=self.display_url,
                       device_id=getattr(info, "device_id", None), firmware=getattr(info, "firmware", None),
                       capabilities=list(getattr(info, "capabilities", ()) or ()))
        disp.set_neutral(self.protocol.display.neutral_C)
        faults = 0
        queue = list(todo)
        while queue:
            spec = queue[0]
            attempt = progress.next_attempt(spec.trial_index)
            progress.attempts[spec.trial_index] = attempt
            outcome = self._run_trial(disp, spec, attempt)
            if outcome == "ok":
                faults = 0
                queue.pop(0)
            else:  # "fault" (written as such) or "no_contact" (aborted): the same trial again
                faults += 1
            if self._fatal is not None:
                return self._stop_fatal(disp, queue)
            if faults >= self.max_consecutive_faults:
                self.machine.go("idle")
                self.machine.go("stopped")
                self._neutral(disp)
                self.log_event("session_stopped", reason=f"{faults} consecutive faults",
                               n_completed=self.n_trials - len(queue))
                self._report(f"stopped after {faults} consecutive faults; resume with "
                             f"`thermocue resume {self.directory}`")
                return 1
            if queue:
                self._rewarm()
            self.machine.go("idle")
        self.machine.go("finished")
        self._neutral(disp)
        self._write_trials()
        self._export_bids()          # (before session_finished: that stays the log's last event)
        self.log_event("session_finished", n_completed=self.n_trials)
        self._write_trials()
        self._say(f"session finished: {self.n_trials} trials, {_clock_text(self._elapsed())} since "
                  f"its first start; data in {self.directory}")
        if self.responder is not None:
            self.responder.show_text("Thank you: the session is finished.")
        return 0

    # -- one trial --------------------------------------------------------------------------
    def _elapsed(self) -> float:
        """Seconds since the session's first start (its first ``session_started`` event)."""
        return time.monotonic() - self._started

    def _progress_text(self, spec) -> str:
        text = (f"trial {spec.trial_index} of {self.n_trials} | block {spec.block} | "
                f"elapsed {_clock_text(self._elapsed())}")
        if self._trial_seconds:   # the mean trial of this run so far, times the trials left
            left = self.n_trials - spec.trial_index + 1
            eta = left * sum(self._trial_seconds) / len(self._trial_seconds)
            text += f" | about {_clock_text(eta)} left"
        return text

    def _run_trial(self, disp, spec, attempt: int) -> str:
        ctx = {"trial_index": spec.trial_index, "attempt": attempt}
        self.machine.go("prompt", **ctx)
        trace = self.traces_dir / trace_name(spec.trial_index)
        self._attempt = _Attempt(spec, attempt)
        self.log_event("trial_started", **ctx, **{k: v for k, v in spec.to_dict().items()
                                                 if k != "trial_index"})
        started_at = _now_iso()
        self._pause("trial_started", spec, attempt)
        t_trial = time.monotonic()
        text = self._progress_text(spec)
        self._say(text + (f" | attempt {attempt}" if attempt > 1 else ""))
        self.responder.progress(text)   # the experimenter's; responders do not show it
        block = self.protocol.block(spec.block)
        sample = self.protocol.sample(spec.roughness_id)
        shown = self.protocol.presentation
        if spec.block != self._last_block and block.instructions:
            self.responder.show_instructions(block.instructions, shown.instructions_min_s,
                                             shown.instructions_key)
        self._last_block = spec.block
        real = spec.mode != "simulated"
        # Two audiences: the sample to place is the experimenter's (terminal or their screen);
        # the participant's screen only says "please wait" (or names the sample where the
        # block gives feedback before an unanswered touch: familiarisation).
        labelled = block.feedback and not block.response
        if real:
            ask = (f"trial {spec.trial_index}/{self.n_trials}: place sample {sample.label} "
                   f"(Ra {sample.roughness_um:g} µm), then confirm on the participant's keyboard")
            (self.experimenter.tell if self.responder.human else self._say)(ask)
            self.responder.please_wait()
            self.responder.prompt_experimenter(ask)
            self.log_event("sample_placed", **ctx, sample=sample.label)
        if labelled:
            self.responder.show_label(f"This is sample {sample.label}")
        elif not real:
            self.responder.please_wait()
        row = {"started_at": started_at, "protocol_hash": self.protocol.hash,
               "mode": spec.mode, "block": spec.block,
               "psychopyVersion": getattr(self.responder, "psychopy_version", None)}
        self.machine.go("prepare", **ctx)
        profile = None
        try:
            if real:
                disp.arm(mode="record", force_threshold_N=self.protocol.contact.force_threshold_N,
                         max_duration_s=self.protocol.contact.record_s)
            else:
                profile = self._target_profile(spec)
                row["profile_skin_thickness_um"] = profile.parameters.get("skin_thickness_um")
                row["target_side"] = profile.parameters["target_side"]
                row["pad_resistance_m2K_W"] = profile.parameters["pad_resistance_m2K_W"]
                row["profile_resistance_m2K_W"] = profile.parameters.get("resistance_m2K_per_W")
                row["profile_resistance_source"] = profile.parameters["resistance_source"]
                row["rate_limited_max_change_C"] = profile.parameters["rate_limited_max_change_C"]
                self._pause("upload", spec, attempt)
                disp.upload_profile(np.asarray(profile.times), np.asarray(profile.temperature))
                self.log_event("profile_uploaded", **ctx, content_hash=profile.content_hash,
                               n_points=len(profile.times), method=profile.method,
                               error_bound_C=profile.error_bound,
                               skin_thickness_um=row["profile_skin_thickness_um"],
                               skin_thickness_source=profile.parameters["skin_thickness_source"],
                               target_side=row["target_side"],
                               pad_resistance_m2K_W=row["pad_resistance_m2K_W"],
                               resistance_m2K_W=row["profile_resistance_m2K_W"],
                               resistance_source=row["profile_resistance_source"],
                               rate_limited_max_change_C=row["rate_limited_max_change_C"],
                               parameters=profile.parameters)
                disp.arm(mode="playback", force_threshold_N=self.protocol.contact.force_threshold_N,
                         max_duration_s=self.protocol.contact.max_contact_s)
            self.log_event("armed", **ctx, mode="record" if real else "playback")
            self._pause("armed", spec, attempt)
            self.responder.touch(spec, disp)
        except DisplayError as exc:
            return self._fault(disp, spec, attempt, row, exc)
        self.machine.go("cue", **ctx)
        played = bool(self.responder.cue())
        row["cue_played"] = played
        self.log_event("cue", **ctx, played=played)
        self.machine.go("wait_contact", **ctx)
        if not self.traces_dir.is_dir():
            from experiments.logbook import ensure_dir
            ensure_dir(self.traces_dir)
        if trace.exists():   # never overwritten: the log cannot explain it, so keep it aside
            aside = _unused(trace.with_name(f"{trace.stem}.replaced-before-attempt-{attempt}.csv"))
            os.replace(trace, aside)
            self.log_event("trace_kept_aside", **ctx, trace_file=f"traces/{aside.name}")
            self._report(f"repaired: {trace} existed before trial {spec.trial_index} attempt "
                         f"{attempt} started; kept as {aside.name}")
        writer = TraceWriter(trace)
        active = "record" if real else "playback"

        contact = []
        finger_before = [None]   # the radiation thermometer's last reading before contact, °C
        # [presentation] answer_during_contact: the question goes up at contact and the answer
        # is taken as soon as it is given (the recording runs on to its end regardless).
        early = block.response and shown.answer_during_contact
        answered = []

        def on_frame(frame):
            # Runs at the telemetry rate inside the driver's read loop: no fsync here (a slow
            # callback lets the serial buffer overrun); contact is logged once the trial ends.
            writer.write(frame)
            if early and contact and not answered:
                got = self.responder.poll_answer(spec)
                if got is not None:
                    answered.append(got)
            if not contact:
                if frame.state in _ACTIVE_STATES:
                    contact.append(float(frame.device_time_s))
                    if early:
                        self.responder.begin_answer(spec)
                    self._pause("playback", spec, attempt)
                elif sum(frame.forces_N) < _TOUCH_N:   # not yet touching: the IR reads bare skin
                    finger_before[0] = frame.finger_C

        timeout = (self.protocol.contact.trial_timeout_s + self.protocol.contact.max_contact_s + 5.0)
        try:
            try:
                rec = disp.run_trial(timeout_s=timeout, on_telemetry=on_frame)
            finally:
                writer.close()
        except DisplayError as exc:
            return self._fault(disp, spec, attempt, row, exc)
        if contact:
            self.machine.go(active, **ctx, device_time_s=contact[0])
        row.update(self._recording_fields(rec))
        row["contact_force_N"] = self._contact_force(writer, rec)   # Eq. 5's force (issue 12)
        self._skin_temperature(row, ctx, finger_before[0])
        self.log_event("recording", **ctx, status=rec.status, fault_code=rec.fault_code,
                       contact_time_s=rec.contact_time_s, frames=rec.frames,
                       frames_lost=rec.frames_lost, tracking_rms_C=rec.tracking_rms_C)
        if rec.contact_time_s is None and (rec.status == "aborted" or rec.fault_code in _NO_CONTACT_CODES):
            return self._no_contact(disp, spec, attempt, rec)
        if rec.status == "ok":
            rec = self._check_delivered(rec, real)
        if rec.status != "ok":
            return self._fault(disp, spec, attempt, row, None, rec=rec)
        if self.machine.state == "wait_contact":   # contact seen by the device only
            self.machine.go(active, **ctx, device_time_s=rec.contact_time_s)
        self.machine.go("respond", **ctx)
        if labelled:
            self.responder.show_label(None)
        if block.response:
            stimulus = self._stimulus(spec, writer, rec, profile, sample)
            response = answered[0] if answered else self.responder.respond(spec, stimulus)
            self.log_event("response", **ctx, **response.to_dict(),
                           during_contact=bool(answered))
            row.update(response_id=response.response_id, rt_s=response.rt_s,
                       correct=int(response.response_id == spec.roughness_id),
                       response_source=response.source)
            if block.feedback:   # only where the protocol's block says so
                right = response.response_id == spec.roughness_id
                self.responder.feedback(("Correct" if right else "Not correct")
                                        + f": it was sample {sample.label}", shown.feedback_s)
                self.log_event("feedback", **ctx, correct=int(right))
        self._trial_seconds.append(time.monotonic() - t_trial)
        self._pause("after_response", spec, attempt)
        self.machine.go("write", **ctx)
        row.update(status="ok", trace_file=f"traces/{trace.name}", finished_at=_now_iso())
        self._complete(spec, attempt, row)
        self._pause("after_write", spec, attempt)
        return "ok"

    def _check_delivered(self, rec, real: bool):
        """The recording as a flagged attempt unless the display delivered the trial.

        A trial is ``ok`` only with a contact, an end by completion, release or the maximum
        duration, and (playback) a tracking error within ``[simulation] max_tracking_error_C``;
        anything else is written as a fault and run again (the driver already checks the
        device's own account; this holds every display to the same rule).
        """
        import dataclasses
        end = getattr(rec, "end_reason", "complete")
        why = None
        if rec.contact_time_s is None:
            why = "NOT_DELIVERED", "ok without a contact"
        elif end is not None and end not in _DELIVERED_ENDS:
            why = "NOT_DELIVERED", f"ok with end reason {end!r}"
        elif not real:
            err = rec.tracking_max_C
            limit = self.protocol.simulation.max_tracking_error_C
            if err is not None and np.isfinite(err) and err > limit:
                why = ("TRACKING_ERROR", f"contact temperature {err:.3g} °C off the target "
                       f"(simulation.max_tracking_error_C = {limit:g})")
        if why is None:
            return rec
        try:
            return dataclasses.replace(rec, status="fault", fault_code=why[0], fault_message=why[1])
        except TypeError:   # a display's own recording type: same fields, set in place
            rec.status, rec.fault_code, rec.fault_message = "fault", why[0], why[1]
            return rec

    def _skin_temperature(self, row: dict, ctx: dict, finger_C) -> None:
        """Log the skin temperature measured just before touching (§3.2 of the paper).

        The display's radiation thermometer reads the approaching finger; its last reading before
        the first touch (summed force under ``_TOUCH_N``) goes into the trial row as
        ``skin_temperature_C``. A reading outside the protocol's
        ``environment`` range is kept and flagged with a ``skin_temperature_out_of_range`` event
        (the experimenter decides whether to rewarm longer; the trial is not discarded).
        """
        env = self.protocol.environment
        if not env.measure_skin_temperature or finger_C is None:
            return
        value = round(float(finger_C), 2)
        row["skin_temperature_C"] = value
        inside = env.skin_temperature_min_C <= value <= env.skin_temperature_max_C
        row["skin_temperature_in_range"] = int(inside)
        if not inside:
            self.log_event("skin_temperature_out_of_range", **ctx, skin_temperature_C=value,
                           expected_min_C=env.skin_temperature_min_C,
                           expected_max_C=env.skin_temperature_max_C)
            # Shown to the experimenter at the time, who must confirm to go on (asked on the
            # terminal; with none to ask, logged as unconfirmed and listed by the report).
            self._report(f"warning: trial {ctx['trial_index']}: skin temperature {value:.2f} °C, "
                         f"outside {env.skin_temperature_min_C:g}-{env.skin_temperature_max_C:g} °C")
            # Asked when a person answers; a simulated participant's session (a cohort, the
            # paper's reproduction) is never held up by a question nobody is there to answer.
            if self.responder is None or getattr(self.responder, "human", True):
                answer = self.experimenter.confirm(
                    f"trial {ctx['trial_index']}: skin temperature {value:.2f} °C is out of "
                    "range; keep this trial and go on?")
                said = {True: "yes", False: "no", None: "unasked (no terminal)"}[answer]
            else:
                answer, said = None, "unasked (simulated participant)"
            self.log_event("skin_temperature_confirmation", **ctx, answer=said)
            if answer is False:
                raise SessionInterrupted("experimenter stopped: skin temperature out of range")

    def _recording_fields(self, rec) -> dict:
        # contact_onset_s: the display's clock at contact (a time stamp, not a duration);
        # contact_duration_s: from contact to the end of the recording.
        touched = rec.contact_time_s is not None
        return {"tracking_rms_C": rec.tracking_rms_C, "tracking_max_C": rec.tracking_max_C,
                "contact_onset_s": rec.contact_time_s,
                "contact_duration_s": float(getattr(rec, "duration_s", 0.0)) if touched else None,
                "frames": rec.frames, "frames_lost": rec.frames_lost, "fault_code": rec.fault_code}

    @staticmethod
    def _contact_force(writer, rec) -> float | None:
        """Mean summed force the display's four sensors measured over the contact, N."""
        if rec.contact_time_s is None or not writer.time_s:
            return None
        from experiments.responders.base import contact_force
        value = contact_force(np.asarray(writer.time_s, dtype=float) - float(rec.contact_time_s),
                              writer.forces_N)
        return None if value is None else round(value, 2)

    def _stimulus(self, spec, writer, rec, profile, sample) -> TrialStimulus:
        t = np.asarray(writer.time_s, dtype=float)
        if rec.contact_time_s is not None and t.size:
            t = t - float(rec.contact_time_s)
        forces = np.asarray(writer.forces_N, dtype=float).reshape(-1, 4)
        material = self.protocol.material
        sample_info = None
        if spec.mode != "simulated":
            sample_info = {"label": sample.label, "material": material.name,
                           "roughness_m": sample.roughness_m, "thickness_m": material.thickness_m,
                           "temperature_C": self.protocol.environment.room_temperature_C}
        return TrialStimulus(mode=spec.mode, roughness_id=spec.roughness_id,
                             roughness_um=spec.roughness_um, time_s=t,
                             target_C=np.asarray(writer.target_C, dtype=float),
                             contact_C=np.asarray(writer.contact_C, dtype=float), forces_N=forces,
                             profile_parameters=None if profile is None else dict(profile.parameters),
                             sample=sample_info, status=rec.status)

    def _target_profile(self, spec):
        """The target profile of a simulated trial (:func:`simulated_target_profile`): the one
        checked when the session was made or reopened (:func:`check_simulated_profiles`)."""
        key = (spec.roughness_id, spec.roughness_um)
        if key not in self._profiles:
            self._profiles[key] = simulated_target_profile(
                self.protocol, self.participant, self.group, self.skin_thickness_um,
                spec.roughness_id, spec.roughness_um)
        if key not in self._plans_told:
            # the scene planner's decisions, once per profile, to the experimenter (issue 12)
            from stimuli.planner import plan_line
            self._plans_told.add(key)
            self._say(f"profile {spec.roughness_id}# ({spec.roughness_um:g} um): "
                      + plan_line(self._profiles[key].parameters.get("plan")))
        return self._profiles[key]

    def _complete(self, spec, attempt: int, row: dict) -> None:
        with self._critical():
            self.log_event("trial_completed", trial_index=spec.trial_index, attempt=attempt, row=row)
            self._attempt.logged_end = True
            self._write_trials()
        if row.get("status") == "ok":
            # Never whether the answer was right: on the console responder the participant reads
            # this terminal (feedback is the block's, through the responder).
            answer = row.get("response_id")
            self._say(f"trial {spec.trial_index}: ok" + ("" if answer is None else ", answer logged"))

    def _fault(self, disp, spec, attempt, row, exc, rec=None) -> str:
        ctx = {"trial_index": spec.trial_index, "attempt": attempt}
        if exc is None:
            code, message = rec.fault_code or "fault", rec.fault_message
        else:
            code, message = getattr(exc, "code", None), str(exc)
            if isinstance(code, int):   # DisplayRefused: the device's code, named like a device fault
                from experiments.hardware.messages import error_name
                code = error_name(code)
            elif code is None:
                code = type(exc).__name__
        if isinstance(exc, DisplayRestarted) or str(code) in _FATAL_CODES:
            self._fatal = (str(code), message)
        self.machine.go("fault", **ctx)
        self.log_event("display_fault", **ctx, fault_code=str(code), message=message)
        self._neutral(disp)
        self.machine.go("write", **ctx)
        kept = self._keep_trace(spec.trial_index, attempt, "fault")
        row.update(status="fault", fault_code=str(code), finished_at=_now_iso(),
                   trace_file=None if kept is None else f"traces/{kept.name}")
        self._complete(spec, attempt, row)
        self._report(f"trial {spec.trial_index}: display fault {code}: {message}")
        return "fault"

    def _stop_fatal(self, disp, queue) -> int:
        """Stop the session after a fault that no re-run can cure (resumable once fixed)."""
        code, message = self._fatal
        self.machine.go("idle")
        self.machine.go("stopped")
        self._neutral(disp)
        advice = "the display restarted: resume to shake hands with it again"
        self.log_event("session_stopped", reason=f"display fault {code}", message=message,
                       n_completed=self.n_trials - len(queue))
        self._report(f"stopped: {advice} (`thermocue resume {self.directory}`)")
        return 1

    def _no_contact(self, disp, spec, attempt, rec) -> str:
        ctx = {"trial_index": spec.trial_index, "attempt": attempt}
        self.machine.go("no_contact", **ctx)
        self._neutral(disp)
        self._abort_attempt(spec.trial_index, attempt, reason="no_contact",
                            fault_code=rec.fault_code)
        self._report(f"trial {spec.trial_index}: no contact within "
                     f"{self.protocol.contact.trial_timeout_s:g} s; the trial will be run again")
        return "no_contact"

    def _abort_attempt(self, trial_index: int, attempt: int, reason: str, fault_code=None) -> None:
        """Log an attempt as aborted and keep its trace under an ``aborted`` name."""
        kept = self._keep_trace(trial_index, attempt, "aborted")
        with self._critical():
            self.log_event("trial_aborted", trial_index=trial_index, attempt=attempt, reason=reason,
                           fault_code=fault_code,
                           trace_file=None if kept is None else f"traces/{kept.name}")
            if self._attempt is not None and self._attempt.spec.trial_index == trial_index \
                    and self._attempt.attempt == attempt:
                self._attempt.logged_end = True
            self._write_trials()

    def _keep_trace(self, trial_index: int, attempt: int, kind: str):
        """Move an unfinished attempt's trace out of the way of the next attempt.

        Returns the kept file (also when a kill came between this rename and the event that
        records it), or None if the attempt never started its trace.
        """
        from experiments.logbook import fsync_dir
        trace = self.traces_dir / trace_name(trial_index)
        if trace.exists():
            kept = self.traces_dir / aborted_trace_name(trial_index, attempt, kind)
            os.replace(trace, kept)
            fsync_dir(self.traces_dir)
            return kept
        earlier = sorted(self.traces_dir.glob(aborted_trace_name(trial_index, attempt, "*")))
        return earlier[0] if earlier else None

    def _write_trials(self) -> None:
        from experiments.logbook import read_events, trials_from_events, write_trials_csv
        events, _ = read_events(self.events_path, warn=False)
        rows = trials_from_events(events)
        aborted = {(e.get("trial_index"), e.get("attempt")): e.get("trace_file")
                   for e in events if e.get("event") == "trial_aborted"}
        for row in rows:  # an aborted row's trace_file comes from its event
            if row.get("status") == "aborted":
                row["trace_file"] = aborted.get((row.get("trial_index"), row.get("attempt")))
            else:
                row.setdefault("trace_file", None)
        write_trials_csv(self.trials_path, rows)

    def _export_bids(self) -> None:
        """The finished session as BIDS behavioural data in ``DATA/bids/`` (:mod:`experiments.bids`).

        A failure is reported and logged, never fatal: ``trials.csv`` is the session's record."""
        from experiments.bids import export_session
        try:
            path = export_session(self.directory)
        except (OSError, ValueError, KeyError) as exc:
            self.log_event("bids_export_failed", message=f"{type(exc).__name__}: {exc}")
            self._report(f"warning: BIDS export failed ({exc}); run `thermocue export-bids` later")
            return
        self.log_event("bids_exported", path=str(path))

    def _rewarm(self) -> None:
        self.machine.go("rewarm")
        seconds = self.protocol.contact.rewarm_s
        self.responder.rewarm(0.0 if self.clock.virtual else seconds)

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

    # -- interruption -------------------------------------------------------------------------
    def _install_signals(self):
        if threading.current_thread() is not threading.main_thread():
            return None

        def handler(signum, frame):
            name = signal.Signals(signum).name
            if self._defer:
                self._pending = name
                return
            raise SessionInterrupted(name)

        old = {}
        for sig in (signal.SIGINT, signal.SIGTERM):
            old[sig] = signal.signal(sig, handler)
        return old

    def _restore_signals(self, old) -> None:
        if old:
            for sig, h in old.items():
                signal.signal(sig, h)

    def _interrupted(self, reason: str) -> None:
        if self.machine.state == "interrupted":
            return  # already handled with the display open
        # Further signals must not cut the clean-up short.
        self._defer += 1
        try:
            if self.display is not None:
                self._neutral(self.display)
            a = self._attempt
            if a is not None and not a.logged_end:
                self._abort_attempt(a.spec.trial_index, a.attempt, reason="interrupted")
            if self.machine.can("interrupted"):
                self.machine.go("interrupted")
            self.log_event("session_interrupted", reason=reason)
            self._write_trials()
        finally:
            self._defer -= 1
            self._pending = None
        self._report(f"session interrupted ({reason}); display neutral; resume with "
                     f"`thermocue resume {self.directory}`")


_STOPS = (SessionInterrupted, KeyboardInterrupt, ResponderClosed)


def _best_effort(call) -> None:
    """Run a clean-up write; a failing disk (OSError) must not raise over the first error."""
    try:
        call()
    except OSError as exc:
        if isinstance(exc, DisplayError):
            raise


def _unused(path: Path) -> Path:
    """``path``, or ``path`` with ``.2``, ``.3``, ... before the suffix: a name not taken."""
    n, out = 1, path
    while out.exists():
        n += 1
        out = path.with_name(f"{path.stem}.{n}{path.suffix}")
    return out


def _reason(exc) -> str:
    return getattr(exc, "reason", None) or str(exc) or type(exc).__name__


def _parse_pause(text: str) -> set:
    out = set()
    for item in filter(None, (p.strip() for p in text.split(","))):
        point, _, index = item.partition(":")
        if point not in PAUSE_POINTS or not index.isdigit():
            raise UserInputError(f"{PAUSE_ENV}: expected point:trial_index with point one of "
                                 f"{PAUSE_POINTS}, got {item!r}")
        out.add((point, int(index)))
    return out


def _seconds_since_first_start(events) -> float:
    """Seconds from the log's first ``session_started`` event to now (0 if none)."""
    import datetime as _dt
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


def _psychopy_date(epoch_s: float) -> str:
    """PsychoPy's ``data.getDateStr()`` form of a time, e.g. ``2026-11-22_14h05.09.123`` (local)."""
    t = time.localtime(epoch_s)
    return time.strftime("%Y-%m-%d_%Hh%M.%S", t) + f".{int((epoch_s % 1) * 1000):03d}"


def _clock_text(seconds: float) -> str:
    """``M:SS``, or ``H:MM:SS`` from an hour on."""
    m, s = divmod(int(seconds), 60)
    h, m = divmod(m, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"


# --------------------------------------------------------------------------- making sessions
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
    :func:`~experiments.session_files.claim_session_folder` claims again."""
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
    participant: dict
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
    progress: bool = True
    auto_name: bool = False       # the name was chosen here (S01, S02, ...): take the next if taken

    @property
    def name(self) -> str:
        return self.directory.name

    @property
    def participant_id(self) -> str:
        return self.directory.parent.name

    def check_display(self, display) -> None:
        """The simulated profiles against the open display's capacity (ProtocolError)."""
        _check_capacity(self.protocol, self.profiles, display, _protocol_source(self.protocol))

    def write(self) -> "Session":
        """Write ``session.json`` and ``traces/``; return the :class:`Session`.

        Raises
        ------
        SessionError
            The folder has become a session in the meantime.
        """
        protocol, assignment = self.protocol, self.assignment
        # claimed atomically, log locked, before session.json is written (issue 16): of two
        # runs for one participant, one gets the folder; an automatic name moves on to the next
        while True:
            try:
                log = claim_session_folder(self.directory)
                break
            except SessionError:
                if not self.auto_name:
                    raise
                self.directory = self.directory.parent / _next_session_name(
                    self.directory.parent, after=self.directory.name)
        directory = self.directory
        try:
            self._write_meta(directory)
        finally:
            # written under the lock; once session.json exists no other run claims the folder,
            # and Session.run takes the lock again
            log.close()
        session = Session(directory, protocol, self.participant, assignment.group, self.seed,
                          self.schedule, self.name, self.display_url, assignment=assignment,
                          clock=self.clock, max_consecutive_faults=self.max_consecutive_faults,
                          out=self.out, progress=self.progress, responder_name=self.responder_name,
                          profiles=self.profiles)
        for w in assignment.warnings:
            session._report(f"warning: {w}")
        session._say(f"{self.participant_id}: {assignment.describe()}")
        return session

    def _write_meta(self, directory) -> None:
        from experiments.logbook import atomic_write_json, ensure_dir

        protocol, assignment = self.protocol, self.assignment
        atomic_write_json(directory / "session.json", {
            "format": "thermocue-session/1",
            "session": self.name,
            "created_at": _now_iso(),
            "participant_id": self.participant_id,
            "participant": self.participant,
            "participant_file": str(self.participant_path),
            "group": assignment.group,
            "group_assignment": assignment.to_dict(),
            "protocol_name": protocol.name,
            "protocol_file": None if protocol.path is None else str(protocol.path),
            "protocol_hash": protocol.hash,
            "protocol": protocol.data,
            "seed": self.seed,
            "schedule": [s.to_dict() for s in self.schedule],
            "schedule_algorithm": SCHEDULE_ALGORITHM,
            # What each block is (analysis reads this, not block names).
            "blocks": block_roles(protocol),
            "display_url": self.display_url,
            "responder": self.responder_name,
            "clock": "virtual" if self.clock.virtual else "real",
            "max_consecutive_faults": self.max_consecutive_faults,
            "versions": package_versions(),
        })
        ensure_dir(directory / "traces")


def block_roles(protocol) -> list[dict]:
    """Per block: ``name``, ``mode``, ``scored``, ``response``, ``feedback`` (session.json)."""
    return [{"name": b.name, "mode": b.mode, "scored": bool(b.scored), "response": bool(b.response),
             "feedback": bool(b.feedback)} for b in protocol.blocks]


def finished_sessions(folder: Path) -> list[Path]:
    """The finished sessions (``session_finished`` logged) in a participant's folder."""
    from experiments.logbook import read_events, replay
    out = []
    for events in sorted(Path(folder).glob("*/events.jsonl")):
        try:
            if replay(read_events(events, warn=False)[0]).finished:
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
                 max_consecutive_faults: int = 3, out=None, progress: bool = True) -> SessionPlan:
    """Validate the inputs, plan the schedule and check every simulated profile; write nothing.

    Parameters are those of :func:`create_session`.

    Raises
    ------
    ProtocolError, ParticipantError, SessionError
        Bad files, a simulated profile the display would refuse
        (:func:`check_simulated_profiles`), or a session folder that already exists.
    """
    from experiments.protocol import load_protocol
    from experiments.schedule import build_schedule
    from participants_schema import assign_group, load_participant

    if not hasattr(protocol, "hash"):
        protocol = load_protocol(protocol)
    participant = load_participant(participant_path)
    from experiments.calibration.writeback import check_calibration_samples
    if any(b.mode == "simulated" for b in protocol.blocks):
        check_calibration_samples(participant, [s.roughness_um for s in protocol.samples],
                                  source=str(participant_path))
    assignment = assign_group(participant, protocol.grouping)   # None: the paper's 800 µm rule
    if seed is None:
        seed = secrets.randbelow(2**31)
    schedule = build_schedule(protocol, str(participant["id"]), seed)
    pid = _safe_name(str(participant["id"]), f"{participant_path}: id")
    stem = Path(participant_path).stem
    if stem != pid:   # P09.json holding "id": "P01" would write into P01's folder
        raise SessionError(f"{participant_path}: id: expected {stem!r} (the file's name), got "
                           f"{pid!r}: rename the file or correct the id")
    folder = Path(data_dir) / pid
    name = _safe_name(session_name, "--session") if session_name else _next_session_name(folder)
    directory = folder / name
    _refuse_existing(directory)
    clock_obj = clock_for_url(display_url, clock)
    profiles = check_simulated_profiles(protocol, participant, assignment.group, schedule)
    return SessionPlan(protocol, participant, str(participant_path), assignment, seed, schedule,
                       directory, display_url, clock_obj, responder_name, max_consecutive_faults,
                       profiles, out=out, progress=progress, auto_name=not session_name)


def create_session(protocol, participant_path, data_dir, display_url: str, *, seed: int | None = None,
                   session_name: str | None = None, responder_name: str = "", clock: str = "auto",
                   max_consecutive_faults: int = 3, out=None, progress: bool = True) -> Session:
    """Validate the inputs, plan the schedule and write a new session directory.

    Every simulated profile is computed and checked against the protocol's display limits
    first (:func:`check_simulated_profiles`): nothing is written for a protocol whose profiles
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
    progress : bool
        Progress lines on stderr (errors and stop reasons are printed regardless).

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
                        progress=progress).write()


def open_session(session_dir, *, display_url: str | None = None, clock: str | None = None,
                 out=None, progress: bool = True) -> Session:
    """Reopen a session directory to resume it (same protocol, participant, seed, schedule).

    ``session.json`` is checked, not trusted: the protocol copy against its hash, the seed (an
    integer ≥ 0), the schedule against ``build_schedule(protocol, participant id, seed)``, and
    every simulated profile against the display limits (:func:`check_simulated_profiles`).

    Parameters
    ----------
    display_url : str, optional
        Default: the stored one.
    clock : {"auto", "real", "virtual"}, optional
        Default (None or "auto"): from the display URL actually used (virtual iff it says
        ``clock=virtual``), as for a new session.

    Raises
    ------
    SessionError
        No ``session.json``, a damaged or edited one (naming the field).
    """
    import json

    from experiments.protocol import parse_protocol
    from experiments.schedule import TrialSpec, build_schedule
    from participants_schema import validate_participant

    directory = Path(session_dir)
    path = directory / "session.json"
    if not directory.is_dir():
        raise SessionError(f"{directory}: expected a session folder, got no such folder")
    try:
        meta = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise SessionError(f"{path}: expected a session.json, got no such file") from None
    except (OSError, ValueError) as exc:
        raise SessionError(f"{path}: expected valid JSON, got {exc}") from None
    if not isinstance(meta, dict):
        raise SessionError(f"{path}: expected a JSON object, got {type(meta).__name__}")
    for key in ("session", "participant", "protocol", "protocol_hash", "seed", "schedule",
                "display_url", "group"):
        if key not in meta:
            raise SessionError(f"{path}: {key}: expected a value, got nothing")
    # the scalar fields through the protocol's own table reader (typed, bounded, one line)
    from experiments.errors import ProtocolError
    from experiments.protocol import TableReader
    table = TableReader(str(path), meta, "")
    try:
        table.string("session")
        table.string("protocol_hash")
        table.integer("seed", ge=0)
        table.integer("max_consecutive_faults", 3, ge=1, le=1000,
                      why="faults in a row before a session stops")
        table.string("responder", "", nonempty=False)
    except ProtocolError as exc:
        raise SessionError(str(exc)) from None
    source = f"{path}: protocol"
    protocol = parse_protocol(meta["protocol"], source=source,
                              path=Path(meta["protocol_file"]) if meta.get("protocol_file") else None)
    if protocol.hash != meta["protocol_hash"]:
        raise SessionError(f"{path}: protocol_hash: expected {protocol.hash} (the stored protocol's "
                           f"hash), got {meta['protocol_hash']!r}")
    participant = validate_participant(meta["participant"], source=f"{path}: participant")
    seed = meta["seed"]
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise SessionError(f"{path}: seed: expected an integer ≥ 0, got {seed!r}")
    if not isinstance(meta["schedule"], list):
        raise SessionError(f"{path}: schedule: expected a list of trials, got "
                           f"{type(meta['schedule']).__name__}")
    try:
        schedule = [TrialSpec.from_dict(d) for d in meta["schedule"]]
    except (TypeError, ValueError, KeyError, AttributeError) as exc:
        raise SessionError(f"{path}: schedule: expected a list of trials, got {exc}") from None
    # Sessions written before the field existed used the first algorithm.
    made_by = meta.get("schedule_algorithm", "thermocue-schedule-v1")
    expected = build_schedule(protocol, str(participant["id"]), seed)
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
        raise SessionError(f"{path}: schedule: expected the schedule of the stored protocol, "
                           f"participant {participant['id']} and seed {seed} ({len(expected)} "
                           f"trials; trial {diff + 1}: {want}), got {len(schedule)} trials "
                           f"(trial {diff + 1}: {got})")
    group = meta["group"]
    groups = None if protocol.grouping is None else (protocol.grouping.below, protocol.grouping.above)
    if not isinstance(group, str) or (groups is not None and group not in groups):
        raise SessionError(f"{path}: group: expected " + (f"one of {groups}" if groups else "a name")
                           + f", got {group!r}")
    _check_against_log(directory, path, meta, participant, schedule)
    if not isinstance(meta["display_url"], str) or not meta["display_url"]:
        raise SessionError(f"{path}: display_url: expected a URL, got {meta['display_url']!r}")
    url = display_url or meta["display_url"]
    clock_obj = clock_for_url(url, clock or "auto")
    profiles = check_simulated_profiles(protocol, participant, group, schedule, source=source)
    session = Session(directory, protocol, participant, group, seed, schedule,
                      meta["session"], url, clock=clock_obj,
                      max_consecutive_faults=meta.get("max_consecutive_faults", 3), out=out,
                      progress=progress, responder_name=meta.get("responder") or "",
                      profiles=profiles)
    session.protocol_source = source
    return session


def _check_against_log(directory: Path, path: Path, meta: dict, participant: dict, schedule) -> None:
    """Refuse a ``session.json`` that differs from the log's ``session_started`` (issue 16).

    The log is the source of truth: a session.json replaced by another run, or edited by hand
    (seed, schedule, protocol, group, participant, name), must not steer a resume.
    """
    from experiments.logbook import read_events

    events_path = directory / "events.jsonl"
    if not events_path.exists():
        return
    events, _ = read_events(events_path, warn=False)
    started = next((e for e in events if e.get("event") == "session_started"), None)
    if started is None:
        return
    stored = {"session": meta["session"], "participant": str(participant["id"]),
              "group": meta["group"], "seed": meta["seed"],
              "protocol_hash": meta["protocol_hash"], "schedule_sha256": schedule_sha256(schedule)}
    for key, value in stored.items():
        if key in started and started[key] != value:
            raise SessionError(f"{path}: {key}: expected {started[key]!r} as in {events_path.name}'s "
                               f"session_started (line {started.get('seq', '?')}), got {value!r}; "
                               f"the log is the session's record: restore session.json")

