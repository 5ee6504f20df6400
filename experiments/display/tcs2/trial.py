"""One armed trial on a TCS II: start it, stream its 100 Hz lines, poll ``Q``, end and judge it.

:class:`TcsTrial` is what :meth:`~.backend.Tcs2Display.run_trial` and
:meth:`~.backend.Tcs2Display.poll` advance: before the start it waits until every stimulating
zone rests within :data:`READY_TOLERANCE_C` of the profile's start (``Oe``, up to
:data:`READY_S`), asks ``Q``, sends ``L`` (or pulses the emulator's trigger input, or waits for
the device's); each temperature line becomes a :class:`~experiments.display.types.Telemetry`
frame (time: the first line's arrival plus 10 ms a line); ``Q`` is asked every
:data:`Q_EVERY_S` and once after the stream ends. A silent device, garbage, a half line, an
unknown reply or a zone error end it as a fault after ``A`` (:meth:`~.backend.Tcs2Display.
safe_abort`); :meth:`TcsTrial.recording` judges it.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from experiments.errors import DisplayError, DisplayTimeout

from ..types import DeviceEvent, Telemetry
from ..trial_recording import TrialInProgress, TrialRecording, evidence_fault
from . import commands as cmd
from .commands import ReplyError
from .profile_compiler import STEP_S, segments_to_samples
from .watch import over_temperature, stop_and_verify

__all__ = ["TcsTrial", "SILENCE_S", "Q_EVERY_S", "READY_TOLERANCE_C", "READY_S", "END_FRACTION"]

#: Stream silence that ends a trial (or, before the profile's end, faults it), s.
SILENCE_S = 0.3
#: How often ``Q`` is asked during a stimulation, s.
Q_EVERY_S = 0.5
_NAN4 = (math.nan,) * 4
#: The probe counts as resting at the profile's start within this, °C ...
READY_TOLERANCE_C = 0.2
#: ... and must get there within this after arming, s.
READY_S = 10.0
#: A stream that stops after this fraction of the profile's lines ended with the profile.
END_FRACTION = 0.9



class TcsTrial:
    """One armed trial on a :class:`~.backend.Tcs2Display` (see the module docstring).

    Parameters
    ----------
    disp : Tcs2Display
        The display, its profile compiled and uploaded.
    max_duration_s : float, s
        The trial's longest stimulation (a longer profile is stopped by ``A``).
    """

    def __init__(self, disp, max_duration_s: float):
        self.d = disp
        c = disp.compiled
        self.duration_s = min(c.duration_s, max_duration_s)
        self.cut = max_duration_s < c.duration_s - 1e-9
        self.checked = False           # Q asked before the start
        self.knots = (c.start_C, c.segments)
        self.tr = TrialInProgress("playback", disp.tracking_profile)
        self.armed_at = disp.link.clock()
        self.started_at = None        # when L was sent / the trigger pulsed
        self.contact_s = None
        self.last_line_at = None
        self.next_q = None
        self.q_pending = 0
        self.frames = 0
        self.done = False
        self.end_reason = None
        self.fault = None
        self.deadline = None

    @property
    def script(self):
        """The emulated participant's (press_after_s, hold_s), set after arming, or None."""
        return self.d.script

    def attach(self, on_telemetry, on_event) -> None:
        if on_telemetry is not None and self.tr.callback is None:
            for fr in self.tr.pending:
                on_telemetry(fr)
            self.tr.pending, self.tr.callback = [], on_telemetry
        if on_event is not None:
            self.tr.attach_on_event(on_event)

    def end(self, reason: str, fault=None) -> None:
        if self.done:
            return
        self.done = True
        self.end_reason = reason
        if fault is not None:
            self.fault = fault
            self.d.safe_abort()
        elif self.q_pending:
            self._collect_pending_q()
            if self.fault is not None:
                return                  # a late reply to Q showed an error: ended as a fault
        now = self.d.link.clock()
        named = reason if reason in ("complete", "released", "max_duration", "aborted") else "fault"
        self.tr.event(DeviceEvent("END", now, named, fault[0] if fault else ""))

    def _collect_pending_q(self) -> None:
        """Read the replies to ``Q`` still on their way (up to 0.5 s), so that none is taken
        for the reply to a later command; one showing an error faults the trial."""
        link = self.d.link
        end = link.clock() + 0.5
        try:
            while self.q_pending and link.clock() < end:
                line = link.line(0.05)
                if line is None or cmd.is_temperature_line(line):
                    continue
                errs = cmd.parse_errors(line)
                self.q_pending -= 1
                if any(errs):
                    self.done = False
                    self._zone_fault(errs)
                    return
        except (ReplyError, DisplayError):
            pass                        # the next command's reply check will say what is wrong

    def pump(self, timeout_s, wait: bool = True) -> None:
        """Advance the trial: start it when due, read lines, poll Q, end it."""
        link = self.d.link
        try:
            now = link.clock()
            if self.deadline is None and timeout_s is not None:
                self.deadline = now + timeout_s
            if self.started_at is None:
                press = self.script[0] if self.script else 0.0
                if now - self.armed_at < press:
                    link.line(min(0.01, press - (now - self.armed_at))) if wait else None
                    return
                self._start()
                return
            lines = [link.line(0.01)] if wait else link.poll_lines()
            for line in lines:
                if line is None:
                    continue
                self._line(line)
                if self.done:
                    return
            self._timers(link.clock())
        except ReplyError as exc:
            self.end("fault", ("BAD_REPLY", str(exc)))
        except DisplayTimeout as exc:
            self.end("fault", ("LINK_TIMEOUT", str(exc)))
        except DisplayError as exc:
            self.end("fault", ("LINK_LOST", str(exc)))

    def _start(self) -> None:
        link = self.d.link
        # the probe must rest at the profile's start (the neutral temperature) before it plays:
        # asked by Oe, within 0.2 °C on every stimulating zone, for up to READY_S
        if not self.checked:               # a zone still in error from before: say so now
            (line,) = link.ask("Q", skip=cmd.is_temperature_line)
            errs = cmd.parse_errors(line)
            if any(errs):
                self._zone_fault(errs)
                return
            self.checked = True
        (line,) = link.ask("Oe", skip=None)
        temps = cmd.parse_temperatures(line)
        start_C = self.knots[0]
        if any(abs(temps[z] - start_C) > READY_TOLERANCE_C for z in self.d.zones):
            if link.clock() - self.armed_at > READY_S:
                self.end("fault", ("NOT_READY", f"the probe did not reach {start_C:g} °C within "
                                   f"{READY_S:g} s (zones at "
                                   f"{', '.join(f'{temps[z]:.2f}' for z in self.d.zones)} °C)"))
            else:
                link.line(0.05)           # let it settle (and the clock run)
            return
        if self.d.start == "trigger":
            if self.script is not None:
                link.send("#T")        # the emulator's trigger input, pulsed by the script
        else:
            link.send("L")
        self.started_at = link.clock()

    def _timers(self, now: float) -> None:
        if self.contact_s is None:
            wait = (self.deadline - self.started_at) if self.d.start == "trigger" else SILENCE_S
            if self.deadline is not None and now > self.deadline:
                wait = 0.0
            if now - self.started_at > wait:
                if self.d.start == "trigger":
                    self.end("aborted")      # nobody triggered: no contact, run it again
                else:
                    self.end("fault", ("LINK_TIMEOUT", f"no temperatures within {SILENCE_S:g} s "
                                       f"of L: the device is silent"))
            return
        played = self.frames * STEP_S          # device time, from the 100 Hz lines
        if self.script is not None and self.script[1] < self.duration_s and played >= self.script[1]:
            self.d.link.send("A")          # the participant answered and stopped it
            self.end("released")
            return
        if now >= self.next_q:
            if self.q_pending:
                self.end("fault", ("LINK_TIMEOUT", "no reply to Q during the stimulation"))
                return
            self.d.link.send("Q")
            self.q_pending += 1
            self.next_q = now + Q_EVERY_S
        if now - self.last_line_at > SILENCE_S:
            # the stream stopped: at the profile's end (lines lost on the way are counted),
            # or before it (the device fell silent)
            if played >= END_FRACTION * self.duration_s and not self.d.link.partial:
                self._confirm_end()
            elif self.d.link.partial:
                self.end("fault", ("HALF_LINE", f"a line cut off ({self.d.link.partial[:20]!r}) "
                                   f"and {SILENCE_S:g} s of silence, {played:.2f} s into the profile"))
            else:
                self.end("fault", ("LINK_TIMEOUT", f"the device fell silent {played:.2f} s into a "
                                   f"{self.duration_s:g} s profile"))

    def _confirm_end(self) -> None:
        """The stream stopped at the profile's end: the device must answer Q without error."""
        link = self.d.link
        link.send("Q")
        end = link.clock() + 0.5
        while link.clock() < end:
            line = link.line(0.05)
            if line is None:
                continue
            if cmd.is_temperature_line(line):
                continue
            errs = cmd.parse_errors(line)
            if self.q_pending:
                self.q_pending -= 1
                if any(errs):
                    self._zone_fault(errs)
                    return
                continue
            if any(errs):
                self._zone_fault(errs)
            else:
                self.end("complete")
            return
        self.end("fault", ("LINK_TIMEOUT", "no reply to Q after the profile"))

    def _zone_fault(self, errs) -> None:
        bad = ", ".join(("neutral" if i == 0 else f"zone {i}") + f" error {e}"
                        for i, e in enumerate(errs) if e)
        self.end("fault", ("ZONE_ERROR", f"Q: {bad}"))

    def _line(self, line: str) -> None:
        now = self.d.link.clock()
        try:
            temps = cmd.parse_temperatures(line)
        except ReplyError:
            temps = None
        if temps is None:
            try:
                errs = cmd.parse_errors(line)
            except ReplyError:
                raise ReplyError(f"display {self.d.name}: expected a temperature line or a Q "
                                 f"reply during the stimulation, got {line[:40]!r}") from None
            self.q_pending = max(0, self.q_pending - 1)
            if any(errs):
                self._zone_fault(errs)
            return
        hot = over_temperature(temps, self.d.max_C)
        if hot is not None:             # a safety input: stopped at once, not at the profile's end
            self.done, self.end_reason = True, "fault"
            self.fault = ("OVER_TEMPERATURE", f"{hot}; {stop_and_verify(self.d)}")
            self.tr.event(DeviceEvent("END", now, 4, "OVER_TEMPERATURE"))
            return
        if self.contact_s is None:
            if self.started_at is None:
                return                  # the display between stimulations (muted; stale)
            self.contact_s = now
            self.next_q = now + Q_EVERY_S
            self.tr.event(DeviceEvent("CONTACT", now, None, "stimulus start"))
        self.frames += 1
        self.last_line_at = now
        t_rel = (self.frames - 1) * STEP_S
        t = self.contact_s + t_rel
        start_C, segs = self.knots
        sp = float(segments_to_samples(start_C, segs, [t_rel])[0])
        zone = float(np.mean([temps[z] for z in self.d.zones]))
        self.tr.telemetry(Telemetry(self.frames, t, sp, zone, temps[0], math.nan, _NAN4,
                                    "PLAYING", None))
        if self.frames * STEP_S >= self.duration_s - 1e-9:
            self.last_line_at = now
            if self.cut:                  # the trial's maximum duration, before the profile's end
                self.d.link.send("A")
                self.end("max_duration")
            else:                         # the last expected line: the end is confirmed by Q
                self._confirm_end()

    def recording(self) -> TrialRecording:
        tr = self.tr
        played = self.frames * STEP_S
        if self.end_reason in ("complete", "max_duration"):
            expected = int(round(self.duration_s / STEP_S))
        elif self.contact_s is not None and self.last_line_at is not None:
            expected = self.frames
        else:
            expected = 0
        lost = max(0, expected - self.frames)
        rms = math.sqrt(tr.sq / tr.n_track) if tr.n_track else float("nan")
        mx = tr.max_err if tr.n_track else float("nan")
        status, code, msg = "ok", None, None
        if self.fault is not None:
            status, (code, msg) = "fault", self.fault
        elif self.end_reason == "aborted":
            status = "aborted"
        rec = TrialRecording(status, code, msg, self.contact_s, self.frames, lost, rms, mx,
                             "playback", self.end_reason, played if self.contact_s else 0.0, 0,
                             tr.active_frames)
        why = evidence_fault(rec) if status == "ok" else None
        if why is not None:           # the rule every backend applies (trial_recording)
            self.d.safe_abort()
            rec = dataclasses.replace(rec, status="fault", fault_code=why[0], fault_message=why[1])
        return rec
