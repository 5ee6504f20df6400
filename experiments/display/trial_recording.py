"""The armed trial as the host sees it: streamed book-keeping and the finished recording.

:class:`TrialInProgress` follows one armed trial frame by frame (telemetry counters, contact, tracking
error against the uploaded profile, how and when it ended) without keeping the frames;
:class:`TrialRecording` is what :meth:`ThermalDisplay.run_trial
<experiments.display.thermocue.driver.ThermalDisplay.run_trial>` returns; :func:`not_delivered` judges a
trial against the device's own account and :func:`evidence_fault` against its telemetry
(``docs/display-protocol.md`` §5, "A delivered trial"): every backend and the session judge
with these two.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from .types import DeviceEvent, Status, Telemetry

__all__ = ["ContactEvent", "TrialRecording", "DELIVERED_ENDS", "evidence_fault", "NO_TELEMETRY",
           "NO_TRACKING", "MAX_FRAME_LOSS"]

ACTIVE_STATES = ("ARMED", "PLAYING", "RECORDING")


@dataclass(frozen=True)
class ContactEvent:
    """The moment the summed force crossed the threshold (device clock, s) and the force, N."""

    device_time_s: float
    force_N: float | None = None


@dataclass(frozen=True)
class TrialRecording:
    """How one trial went on the display.

    Parameters
    ----------
    status : str
        ``"ok"``, ``"fault"`` or ``"aborted"``.
    fault_code, fault_message : str or None
        Device codes (``WATCHDOG``, ``OVER_TEMPERATURE``, ``SENSOR_FAILURE``, ``SENSOR_STUCK``)
        or host codes (``LINK_TIMEOUT``, ``LINK_LOST``, ``TRIAL_TIMEOUT``, ``TELEMETRY_LOSS``,
        ``NO_TELEMETRY``, ``NO_TRACKING``, ``BAD_REPLY``, ...: ``docs/display-protocol.md`` §7).
    contact_time_s : float or None, s
        Device time of contact.
    frames, frames_lost : int
        Telemetry frames received, and missing from the device's numbering.
    tracking_rms_C, tracking_max_C : float, °C
        Contact temperature minus the uploaded target during playback (NaN in record mode).
    mode : str
        ``"playback"`` or ``"record"``.
    end_reason : str or None
        ``complete``, ``released``, ``max_duration``, ``aborted``, ``fault``.
    duration_s : float, s
        Contact to end.
    bad_frames : int
        Frames rejected by the CRC check during the trial.
    contact_frames : int or None
        Frames in an active state (playing, recording) from the contact on: the telemetry that
        covers the stimulation (None: not counted apart, ``frames`` stands for it).
    """

    status: str
    fault_code: str | None
    fault_message: str | None
    contact_time_s: float | None
    frames: int
    frames_lost: int
    tracking_rms_C: float
    tracking_max_C: float
    mode: str = "playback"
    end_reason: str | None = None
    duration_s: float = 0.0
    bad_frames: int = 0
    contact_frames: int | None = None

    def to_dict(self) -> dict:
        return asdict(self)


class TrialInProgress:
    """Book-keeping of the armed trial (frames are streamed, not kept)."""

    def __init__(self, mode, profile):
        self.mode = mode
        self.dt, self.target = profile if profile else (None, None)
        self.n_target = len(self.target) if self.target else 0
        self.counter0 = 0                # the device's frame counter at ARM (set from its reply)
        self.last_counter = 0
        self.frames = 0
        self.active_frames = 0           # frames in PLAYING / RECORDING: the contact covered
        self.pending: list = []          # frames before run_trial() attaches a callback
        self.callback = None
        self.pending_events: list = []   # events before run_trial() or poll() attach on_event
        self.on_event = None
        self.contact_s = None
        self.contact_force = None
        self.ready = False
        self.active_seen = False
        self.ended = False
        self.end_reason = None
        self.end_time_s = None
        self.fault = None
        self.fault_msg = None
        self.sq = 0.0
        self.n_track = 0
        self.max_err = 0.0
        self.last_frame_clock = None
        self.bad0 = 0

    def telemetry(self, fr: Telemetry) -> None:
        counter = fr.counter
        if counter <= self.last_counter:
            return                       # a stale frame from before arming
        self.last_counter = counter
        self.frames += 1
        st = fr.state
        if st == "PLAYING" or st == "RECORDING":
            self.active_seen = True
            self.active_frames += 1
            contact_s = self.contact_s
            if contact_s is None:        # CONTACT event lost: the first active frame bounds it
                self.contact_s = contact_s = fr.device_time_s
            tgt = self.target
            if st == "PLAYING" and tgt is not None:
                x = (fr.device_time_s - contact_s) / self.dt
                i = int(x)
                if i >= self.n_target - 1:
                    y = tgt[-1]
                elif i < 0:
                    y = tgt[0]
                else:
                    y = tgt[i] + (x - i) * (tgt[i + 1] - tgt[i])
                e = fr.contact_C - y
                self.sq += e * e
                self.n_track += 1
                e = abs(e)
                if e > self.max_err:
                    self.max_err = e
        elif st == "FAULT" and self.fault is None:
            self.fault = fr.fault or "FAULT"
            self.ended = True
            self.end_time_s = fr.device_time_s
        elif st == "IDLE" and (self.active_seen or self.ready):
            self.ended = True
            if self.end_time_s is None:
                self.end_time_s = fr.device_time_s
        callback = self.callback
        if callback is not None:
            callback(fr)
        elif len(self.pending) < 5000:
            self.pending.append(fr)

    def event(self, ev: DeviceEvent) -> None:
        k = ev.kind
        if k == "READY":
            self.ready = True
        elif k == "CONTACT":
            self.contact_s = ev.device_time_s
            try:
                self.contact_force = float(ev.text.split()[0])
            except (ValueError, IndexError):
                pass
        elif k == "END":
            self.ended = True
            self.end_reason = ev.reason
            self.end_time_s = ev.device_time_s
        elif k in ("FAULT", "WATCHDOG"):
            if self.fault is None:
                self.fault = ev.reason or k
                self.fault_msg = ev.text
            self.ended = True
            self.end_reason = "fault"
            self.end_time_s = ev.device_time_s
        if self.on_event is not None:
            self.on_event(ev)
        elif len(self.pending_events) < 1000:
            self.pending_events.append(ev)

    def attach_on_event(self, on_event) -> None:
        """Send ``on_event`` every event from now on, after those received before, in order."""
        if on_event is None or self.on_event is not None:
            self.on_event = on_event or self.on_event
            return
        for ev in self.pending_events:
            on_event(ev)
        self.pending_events = []
        self.on_event = on_event

    def take_status(self, st: Status) -> None:
        """Take the device's own account of the trial (a STATUS after its end).

        STATUS survives a burst that ate the events and telemetry: its end reason and contact
        time decide, not what was seen on the link.
        """
        if st.contact_time_s is not None:
            self.contact_s = st.contact_time_s
            self.active_seen = True
        if st.state not in ACTIVE_STATES:
            self.end_reason = st.end_reason
        if st.state == "FAULT" and self.fault is None:
            self.fault = st.fault or "FAULT"
        elif self.end_reason == "fault" and self.fault is None:
            # the WATCHDOG or FAULT event was lost: the device still says why
            self.fault = st.fault or "FAULT"
            self.fault_msg = (f"the device ended the trial by a fault ({self.fault}); "
                              f"its event was lost on the link")

    def recording(self, status: str, code, msg, bad_frames: int) -> "TrialRecording":
        """The :class:`TrialRecording` of this trial, judged ``status`` (``code``, ``msg``),
        with ``bad_frames`` frames that failed their layout during it."""
        expected = self.last_counter - self.counter0
        lost = max(0, expected - self.frames)
        rms = math.sqrt(self.sq / self.n_track) if self.n_track else float("nan")
        mx = self.max_err if self.n_track else float("nan")
        dur = (self.end_time_s - self.contact_s) if (self.end_time_s is not None and
                                                     self.contact_s is not None) else 0.0
        return TrialRecording(status, code, msg, self.contact_s if self.active_seen else None,
                              self.frames, lost, rms, mx, self.mode, self.end_reason,
                              max(0.0, dur), bad_frames, self.active_frames)


#: How a delivered trial ends (the device's end reasons other than aborted and fault).
DELIVERED_ENDS = ("complete", "released", "max_duration")


def not_delivered(st: Status | None, tr: TrialInProgress) -> str | None:
    """Why the device's own account does not show the armed trial delivered (None: it does).

    Delivered means: the device is idle again, it saw a contact since ARM, and it ended the
    trial by completion, release or the maximum duration (never by a fault, a watchdog trip
    or an abort) -- docs/display-protocol.md §5, "A delivered trial".
    """
    if st is None:
        return "no STATUS from the device after the trial"
    if st.state in ACTIVE_STATES:
        return f"the device is still {st.state} after the trial's end"
    if st.contact_time_s is None:
        return "the device saw no contact since ARM"
    if tr.end_reason not in DELIVERED_ENDS:
        return f"the device ended the trial with reason {tr.end_reason!r}"
    return None


#: Host fault codes of a trial the telemetry does not show delivered (docs/display-protocol.md §7).
NO_TELEMETRY = "NO_TELEMETRY"
NO_TRACKING = "NO_TRACKING"
#: Default bound of the fraction of telemetry frames a delivered trial may lose.
MAX_FRAME_LOSS = 0.01


def evidence_fault(rec, max_frame_loss: float = MAX_FRAME_LOSS) -> tuple | None:
    """Why ``rec``'s telemetry does not show its trial delivered: ``(code, message)``, or None.

    The one rule every backend and the session apply to a trial the device calls delivered
    (docs/display-protocol.md §5): no frame covering the contact is ``NO_TELEMETRY``; more than
    ``max_frame_loss`` of the expected frames missing is ``TELEMETRY_LOSS``; a playback without a
    tracking value (no frame to compare with the profile) is ``NO_TRACKING``. A device that says
    "complete" proves nothing by itself: the pad's temperature during the contact is the
    evidence.
    """
    covered = getattr(rec, "contact_frames", None)
    frames = int(getattr(rec, "frames", 0) or 0)
    covered = frames if covered is None else int(covered)
    if covered <= 0:
        return NO_TELEMETRY, (f"no telemetry covering the contact ({frames} frames in all): the "
                              f"trial's delivery is not shown")
    lost = int(getattr(rec, "frames_lost", 0) or 0)
    expected = frames + lost
    if expected > 0 and lost > max_frame_loss * expected:
        return "TELEMETRY_LOSS", f"{lost} of {expected} frames lost"
    rms = getattr(rec, "tracking_rms_C", math.nan)
    if getattr(rec, "mode", "playback") == "playback" and not (
            isinstance(rms, (int, float)) and math.isfinite(rms)):
        return NO_TRACKING, ("no tracking value: no telemetry during the playback to compare "
                             "with the uploaded profile")
    return None
