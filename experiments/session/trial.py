"""One trial of a session: one method per state of :data:`~experiments.session.machine.TRANSITIONS`.

Read beside the table::

    prompt -> prepare -> cue -> wait_contact -> playback | record -> respond -> write -> rewarm
                 \\-> fault -> write           \\-> no_contact (aborted, re-run)

:meth:`TrialSteps._prompt` (the experimenter places the sample), :meth:`~TrialSteps._prepare`
(the profile uploaded, the display armed, the finger scripted), :meth:`~TrialSteps._cue`,
:meth:`~TrialSteps._wait_contact` (the display runs the trial, the trace streams),
:meth:`~TrialSteps._contact` (``playback`` | ``record``: the recording judged),
:meth:`~TrialSteps._respond`, :meth:`~TrialSteps._write`, :meth:`~TrialSteps.rewarm`; and
the two side exits :meth:`~TrialSteps._fault` and :meth:`~TrialSteps._no_contact`.
:class:`~experiments.session.Session` holds one (``Session.steps``) and runs them
(:meth:`TrialSteps.run`).
"""
from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field

import numpy as np

from experiments.display.trial_recording import evidence_fault
from experiments.errors import DisplayError, DisplayLinkLost, DisplayRestarted
from sessionfiles.logbook import now_iso as _now_iso
from experiments.session.machine import SessionInterrupted
from experiments.session.traces import contact_force, keep_aside, keep_trace, trial_stimulus
from sessionfiles.session_files import TraceWriter, trace_name

__all__ = ["TrialSteps"]

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


@dataclass
class TrialAttempt:
    """The attempt being run and what its states pass on to the next."""

    spec: object
    attempt: int
    logged_end: bool = False
    row: dict = field(default_factory=dict)      # the trial row being filled
    block: object = None
    sample: object = None
    real: bool = False
    labelled: bool = False                        # the participant is told the sample
    profile: object = None
    writer: object = None
    contact_s: float | None = None                # device time of the first frame in contact
    contact_at_utc: str | None = None             # host UTC time that frame was read (log clock)
    ended_at_utc: str | None = None               # host UTC time the display's recording returned
    finger_C: float | None = None                 # the IR thermometer's last reading before it
    answered: list = field(default_factory=list)  # an answer given during contact

    @property
    def ctx(self) -> dict:
        return {"trial_index": self.spec.trial_index, "attempt": self.attempt}

    @property
    def trace(self):
        return trace_name(self.spec.trial_index)


class TrialSteps:
    """The trial's states, run for a :class:`~experiments.session.Session` (its ``steps``).

    Parameters
    ----------
    session : Session
        Whose log, display state machine, responder, profiles and trials table the states use.
    """

    def __init__(self, session):
        self.session = session

    def run(self, disp, spec, attempt: int) -> str:
        """Run one attempt; ``"ok"``, ``"fault"`` (written) or ``"no_contact"`` (aborted)."""
        t = self._prompt(spec, attempt)
        try:
            self._prepare(disp, t)
        except DisplayError as exc:
            return self._fault(disp, t, exc)
        self._cue(t)
        try:
            rec = self._wait_contact(disp, t)
        except DisplayError as exc:
            return self._fault(disp, t, exc)
        ended = self._contact(disp, t, rec)
        if ended is not None:
            return ended
        self._respond(t, rec)
        self._write(t)
        return "ok"

    # -- the states, in the table's order -------------------------------------------------------
    def _prompt(self, spec, attempt: int) -> TrialAttempt:
        """``prompt``: the trial logged as started; the experimenter places a real sample."""
        t = TrialAttempt(spec, attempt)
        ctx = t.ctx
        self.session.machine.go("prompt", **ctx)
        self.session._attempt = t
        self.session.log_event("trial_started", **ctx, **{k: v for k, v in spec.to_dict().items()
                                                 if k != "trial_index"})
        started_at = _now_iso()
        self.session.hooks.at("trial_started", spec, attempt)
        text = self._progress_text(spec)
        self.session._say(text + (f" | attempt {attempt}" if attempt > 1 else ""))
        self.session.responder.progress(text)   # the experimenter's; responders do not show it
        t.block = block = self.session.protocol.block(spec.block)
        t.sample = sample = self.session.protocol.sample(spec.roughness_id)
        shown = self.session.protocol.presentation
        if spec.block != self.session._last_block and block.instructions:
            self.session.responder.show_instructions(block.instructions, shown.instructions_min_s,
                                             shown.instructions_key)
        self.session._last_block = spec.block
        t.real = real = spec.mode != "simulated"
        # Two audiences: the sample to place is the experimenter's (terminal or their screen);
        # the participant's screen only says "please wait" (or names the sample where the
        # block gives feedback before an unanswered touch: familiarisation).
        t.labelled = block.feedback and not block.response
        if real:
            ask = (f"trial {spec.trial_index}/{self.session.n_trials}: place sample {sample.label} "
                   f"(Ra {sample.roughness_um:g} µm), then confirm on the participant's keyboard")
            (self.session.experimenter.tell if self.session.responder.human else self.session._say)(ask)
            self.session.responder.please_wait()
            self.session.responder.prompt_experimenter(ask)
            self.session.log_event("sample_placed", **ctx, sample=sample.label)
        if t.labelled:
            self.session.responder.show_label(f"This is sample {sample.label}")
        elif not real:
            self.session.responder.please_wait()
        t.row = {"started_at_utc": started_at, "protocol_hash": self.session.protocol.hash,
                 "mode": spec.mode, "block": spec.block,
                 "psychopyVersion": getattr(self.session.responder, "psychopy_version", None),
                 "frameRate": getattr(self.session.responder, "frame_rate", None)}
        return t

    def _prepare(self, disp, t: TrialAttempt) -> None:
        """``prepare``: upload the target profile (simulated) and arm; the finger is scripted."""
        spec, ctx, row, contact = t.spec, t.ctx, t.row, self.session.protocol.contact
        self.session.machine.go("prepare", **ctx)
        if t.real:
            disp.arm(mode="record", force_threshold_N=contact.force_threshold_N,
                     max_duration_s=contact.record_s)
        else:
            t.profile = profile = self._target_profile(spec)
            row["profile_skin_thickness_um"] = profile.parameters.get("skin_thickness_um")
            row["target_side"] = profile.parameters["target_side"]
            row["pad_resistance_m2K_W"] = profile.parameters["pad_resistance_m2K_W"]
            row["profile_resistance_m2K_W"] = profile.parameters.get("resistance_m2K_per_W")
            row["profile_resistance_source"] = profile.parameters["resistance_source"]
            row["rate_limited_max_change_C"] = profile.parameters["rate_limited_max_change_C"]
            self.session.hooks.at("upload", spec, t.attempt)
            disp.upload_profile(np.asarray(profile.times), np.asarray(profile.temperature))
            self.session.log_event("profile_uploaded", **ctx, content_hash=profile.content_hash,
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
            disp.arm(mode="playback", force_threshold_N=contact.force_threshold_N,
                     max_duration_s=contact.max_contact_s)
        self.session.log_event("armed", **ctx, mode="record" if t.real else "playback")
        self.session.hooks.at("armed", spec, t.attempt)
        self.session.responder.touch(spec, disp)

    def _cue(self, t: TrialAttempt) -> None:
        """``cue``: the sound."""
        self.session.machine.go("cue", **t.ctx)
        played = bool(self.session.responder.cue())
        t.row["cue_played"] = played
        self.session.log_event("cue", **t.ctx, played=played)

    def _wait_contact(self, disp, t: TrialAttempt):
        """``wait_contact``: the display runs the trial; its telemetry streams to the trace.

        Returns the display's recording. The first frame in contact is noted (and, with
        ``[presentation] answer_during_contact``, the question goes up then)."""
        spec, attempt, ctx = t.spec, t.attempt, t.ctx
        self.session.machine.go("wait_contact", **ctx)
        if not self.session.traces_dir.is_dir():
            from sessionfiles.logbook import ensure_dir
            ensure_dir(self.session.traces_dir, durable=self.session.durable)
        trace = self.session.traces_dir / t.trace
        if trace.exists():   # never overwritten: the log cannot explain it, so keep it aside
            aside = keep_aside(trace, attempt)
            self.session.log_event("trace_kept_aside", **ctx, trace_file=f"traces/{aside.name}")
            self.session._report(f"repaired: {trace} existed before trial {spec.trial_index} attempt "
                         f"{attempt} started; kept as {aside.name}")
        t.writer = writer = TraceWriter(trace, durable=self.session.durable)
        # [presentation] answer_during_contact: the question goes up at contact and the answer
        # is taken as soon as it is given (the recording runs on to its end regardless).
        early = t.block.response and self.session.protocol.presentation.answer_during_contact
        answered = t.answered

        def on_frame(frame):
            # Runs at the telemetry rate inside the driver's read loop: no fsync here (a slow
            # callback lets the serial buffer overrun); contact is logged once the trial ends.
            writer.write(frame)
            if early and t.contact_s is not None and not answered:
                got = self.session.responder.poll_answer(spec)
                if got is not None:
                    answered.append(got)
            if t.contact_s is None:
                if frame.state in _ACTIVE_STATES:
                    t.contact_s = float(frame.device_time_s)
                    t.contact_at_utc = _now_iso()      # no write here: logged with the state
                    if early:
                        self.session.responder.begin_answer(spec)
                    self.session.hooks.at("playback", spec, attempt)
                elif sum(frame.forces_N) < _TOUCH_N:   # not yet touching: the IR reads bare skin
                    t.finger_C = frame.finger_C

        c = self.session.protocol.contact
        try:
            return disp.run_trial(timeout_s=c.trial_timeout_s + c.max_contact_s + 5.0,
                                  on_telemetry=on_frame)
        finally:
            t.ended_at_utc = _now_iso()
            writer.close()

    def _contact(self, disp, t: TrialAttempt, rec):
        """``playback`` | ``record``: the recording judged; None when it delivered the trial,
        else the outcome of :meth:`_no_contact` or :meth:`_fault`."""
        ctx, row = t.ctx, t.row
        active = "record" if t.real else "playback"
        if t.contact_s is not None:
            # logged once the trial ends: the host's times of reading the contact frame (late
            # when frames queued meanwhile) and of the recording's end ride along (the BIDS
            # events' contact/playback row)
            self.session.machine.go(active, **ctx, device_time_s=t.contact_s,
                            contact_at_utc=t.contact_at_utc, ended_at_utc=t.ended_at_utc)
        row.update(self._recording_fields(rec))
        row["contact_force_N"] = contact_force(t.writer, rec)   # Eq. 5's force
        self._skin_temperature(row, ctx, t.finger_C)
        self.session.log_event("recording", **ctx, status=rec.status, fault_code=rec.fault_code,
                       contact_time_s=rec.contact_time_s, frames=rec.frames,
                       frames_lost=rec.frames_lost, tracking_rms_C=rec.tracking_rms_C)
        if rec.contact_time_s is None and (rec.status == "aborted" or rec.fault_code in _NO_CONTACT_CODES):
            return self._no_contact(disp, t, rec)
        if rec.status == "ok":
            rec = self._check_delivered(rec, t.real)
        if rec.status != "ok":
            return self._fault(disp, t, None, rec=rec)
        if self.session.machine.state == "wait_contact":   # contact seen by the device only
            self.session.machine.go(active, **ctx, device_time_s=rec.contact_time_s,
                            ended_at_utc=t.ended_at_utc)
        return None

    def _respond(self, t: TrialAttempt, rec) -> None:
        """``respond``: the answer (blocks that ask for one) and the block's feedback."""
        spec, ctx, row, block, sample = t.spec, t.ctx, t.row, t.block, t.sample
        self.session.machine.go("respond", **ctx)
        if t.labelled:
            self.session.responder.show_label(None)
        if block.response:
            stimulus = trial_stimulus(self.session.protocol, spec, t.writer, rec, t.profile, sample)
            response = t.answered[0] if t.answered else self.session.responder.respond(spec, stimulus)
            self.session.log_event("response", **ctx, **response.to_dict(),
                           during_contact=bool(t.answered))
            row.update(response_id=response.response_id, **response.timing(),
                       answer_mode=response.answer_mode,
                       correct=int(response.response_id == spec.roughness_id),
                       response_source=response.source)
            if block.feedback:   # only where the protocol's block says so
                right = response.response_id == spec.roughness_id
                self.session.responder.feedback(("Correct" if right else "Not correct")
                                        + f": it was sample {sample.label}",
                                        self.session.protocol.presentation.feedback_s)
                self.session.log_event("feedback", **ctx, correct=int(right))
        self.session.hooks.at("after_response", spec, t.attempt)

    def _write(self, t: TrialAttempt) -> None:
        """``write``: the completed row, logged and written to ``trials.csv``."""
        self.session.machine.go("write", **t.ctx)
        t.row.update(status="ok", trace_file=f"traces/{t.trace}", finished_at_utc=_now_iso())
        self._complete(t.spec, t.attempt, t.row)
        self.session.hooks.at("after_write", t.spec, t.attempt)

    def rewarm(self) -> None:
        """``rewarm``: the finger rests between trials (not waited on a virtual clock)."""
        self.session.machine.go("rewarm")
        seconds = self.session.protocol.contact.rewarm_s
        self.session.responder.rewarm(0.0 if self.session.clock.virtual else seconds)

    # -- the side exits ----------------------------------------------------------------------
    def _fault(self, disp, t: TrialAttempt, exc, rec=None) -> str:
        """``fault`` -> ``write``: neutral, the attempt written as a fault (run again)."""
        spec, attempt, ctx, row = t.spec, t.attempt, t.ctx, t.row
        if exc is None:
            code, message = rec.fault_code or "fault", rec.fault_message
        else:
            code, message = getattr(exc, "code", None), str(exc)
            if isinstance(code, int):   # DisplayRefused: the device's code, named like a device fault
                code = getattr(exc, "code_name", None) or f"CODE_{code}"
            elif code is None:
                code = type(exc).__name__
        if isinstance(exc, DisplayRestarted) or str(code) in _FATAL_CODES:
            self.session._fatal = (str(code), message)
        lost = isinstance(exc, DisplayLinkLost) or str(code) == "LINK_LOST"
        if lost:   # the port failed: nothing more goes to it (the device's watchdog acts)
            self.session._link_lost = ("LINK_LOST", message)
        self.session.machine.go("fault", **ctx)
        self.session.log_event("display_fault", **ctx, fault_code=str(code), message=message)
        if not lost:
            self.session._neutral(disp)
        self.session.machine.go("write", **ctx)
        kept = keep_trace(self.session.traces_dir, spec.trial_index, attempt, "fault", durable=self.session.durable)
        row.update(status="fault", fault_code=str(code), finished_at_utc=_now_iso(),
                   trace_file=None if kept is None else f"traces/{kept.name}")
        self._complete(spec, attempt, row)
        if not lost:   # (a lost link is reported once, with the reconnect's outcome)
            self.session._report(f"trial {spec.trial_index}: display fault {code}: {message}")
        return "fault"

    def _no_contact(self, disp, t: TrialAttempt, rec) -> str:
        """``no_contact``: nobody touched in time; neutral, the attempt aborted (run again)."""
        self.session.machine.go("no_contact", **t.ctx)
        self.session._neutral(disp)
        self.session._abort_attempt(t.spec.trial_index, t.attempt, reason="no_contact",
                            fault_code=rec.fault_code)
        self.session._report(f"trial {t.spec.trial_index}: no contact within "
                     f"{self.session.protocol.contact.trial_timeout_s:g} s; the trial will be run again")
        return "no_contact"

    # -- what the states share -----------------------------------------------------------------
    def _complete(self, spec, attempt: int, row: dict) -> None:
        with self.session.signals.critical():
            self.session.log_event("trial_completed", trial_index=spec.trial_index, attempt=attempt, row=row)
            self.session._attempt.logged_end = True
            self.session._write_trials()
        if row.get("status") == "ok":
            # Never whether the answer was right: on the console responder the participant reads
            # this terminal (feedback is the block's, through the responder).
            answer = row.get("response_id")
            self.session._say(f"trial {spec.trial_index}: ok" + ("" if answer is None else ", answer logged"))

    def _target_profile(self, spec):
        """The target profile of a simulated trial (:class:`~experiments.session.planning.
        SessionProfiles`): the one checked when the session was made or reopened."""
        return self.session.profiles.target(self.session, spec, self.session._say)

    def _progress_text(self, spec) -> str:
        text = (f"trial {spec.trial_index} of {self.session.n_trials} | block {spec.block} | "
                f"elapsed {clock_text(self.session._elapsed())}")
        # measured trial durations, the rewarm included (thermocue monitor's estimate)
        left = self.session._time_left.seconds_left(time.time())
        if left is not None:
            text += f" | about {clock_text(left)} left"
        return text

    def _check_delivered(self, rec, real: bool):
        """The recording as a flagged attempt unless the display delivered the trial.

        A trial is ``ok`` only with a contact, an end by completion, release or the maximum
        duration, and (playback) a tracking error within ``[simulation] max_tracking_error_C``;
        anything else is written as a fault and run again (the driver already checks the
        device's own account; this holds every display to the same rule).
        """
        end = getattr(rec, "end_reason", "complete")
        why = None
        if rec.contact_time_s is None:
            why = "NOT_DELIVERED", "ok without a contact"
        elif end is not None and end not in _DELIVERED_ENDS:
            why = "NOT_DELIVERED", f"ok with end reason {end!r}"
        elif evidence_fault(rec) is not None:     # the displays' own rule, for every display
            why = evidence_fault(rec)
        elif not real:
            err = rec.tracking_max_C
            limit = self.session.protocol.simulation.max_tracking_error_C
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
        env = self.session.protocol.environment
        if not env.measure_skin_temperature or finger_C is None:
            return
        value = round(float(finger_C), 2)
        row["skin_temperature_C"] = value
        inside = env.skin_temperature_min_C <= value <= env.skin_temperature_max_C
        row["skin_temperature_in_range"] = int(inside)
        if not inside:
            self.session.log_event("skin_temperature_out_of_range", **ctx, skin_temperature_C=value,
                           expected_min_C=env.skin_temperature_min_C,
                           expected_max_C=env.skin_temperature_max_C)
            # Shown to the experimenter at the time, who must confirm to go on (asked on the
            # terminal; with none to ask, logged as unconfirmed and listed by the report).
            self.session._report(f"warning: trial {ctx['trial_index']}: skin temperature {value:.2f} °C, "
                         f"outside {env.skin_temperature_min_C:g}-{env.skin_temperature_max_C:g} °C")
            # Asked when a person answers; a simulated participant's session (a cohort, the
            # paper's reproduction) is never held up by a question nobody is there to answer.
            if self.session.responder is None or getattr(self.session.responder, "human", True):
                answer = self.session.experimenter.confirm(
                    f"trial {ctx['trial_index']}: skin temperature {value:.2f} °C is out of "
                    "range; keep this trial and go on?")
                said = {True: "yes", False: "no", None: "unasked (no terminal)"}[answer]
            else:
                answer, said = None, "unasked (simulated participant)"
            self.session.log_event("skin_temperature_confirmation", **ctx, answer=said)
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


def clock_text(seconds: float) -> str:
    """``M:SS``, or ``H:MM:SS`` from an hour on."""
    m, s = divmod(int(seconds), 60)
    h, m = divmod(m, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"
