"""One thermal cue per routine: what the Builder component's generated code calls.

The generated script holds a :class:`ThermalCue` under the component's name; the routine sets
its ``status``/``tStart`` attributes like any component's, and PsychoPy's pause loop finds its
``device`` (``dispatchMessages``). Per routine: :meth:`prepare` (profile, upload),
:meth:`start` (clock burst, arm), :meth:`poll` each frame, :meth:`end` (neutral, recording,
second clock burst, the data columns). :meth:`stop` is the quit handler.

No PsychoPy import here: the device and the clocks are passed in.
"""
from __future__ import annotations

import math

from experiments.errors import DisplayError
from experiments.responders.hand import press

from .profiles import file_profile, load_protocol_for_cue, protocol_profile

__all__ = ["ThermalCue", "TRIGGERS", "ROUTINE_START_THRESHOLD_N"]

#: Trigger names (the component's "trigger" choice).
TRIGGERS = ("contact force", "routine start")
#: The smallest force the protocol carries (0.01 N): with the finger already resting on the pad,
#: the profile starts as soon as the pad is at its first sample (the firmware has no way to
#: start a profile without a touch).
ROUTINE_START_THRESHOLD_N = 0.01


#: The columns :meth:`ThermalCue.end` writes (``<name>.`` prefixed), all in every row.
COLUMNS = ("status", "fault_code", "fault_message", "end_reason", "contact_routine_s",
           "contact_global_s", "contact_device_s", "contact_force_N", "contact_duration_s",
           "contact_duration_device_s", "armed_routine_s", "tracking_rms_C", "tracking_max_C",
           "frames", "frames_lost", "clock_status", "clock_offset_s", "clock_drift_ppm",
           "clock_uncertainty_s", "clock_rtt_s", "trigger", "force_threshold_N",
           "profile_source", "profile_duration_s")


class ThermalCue:
    """A thermal cue played on the display during a routine.

    Parameters
    ----------
    name : str
        The component's name (prefix of the data columns).
    device : ThermalCueDevice
    source : {"protocol sample", "profile file"}
    protocol : str, Path or Protocol, optional
        For the profile, the default force threshold and maximum contact duration.
    participant : str or Path, optional
        The participant's JSON record (``source="protocol sample"``).
    sample : int, optional
        The protocol's sample id (may be changed per routine by :meth:`prepare`).
    profile_file : str or Path, optional
        CSV with ``time_s``, ``target_C`` (``source="profile file"``).
    trigger : {"contact force", "routine start"}
    force_threshold_N : float, optional, N
        Default: the protocol's ``[contact] force_threshold_N`` (2 N without a protocol).
    duration_s : float, optional, s
        Longest contact; default the protocol's ``max_contact_s`` (else the profile's length).
    simulate_touch : bool
        Emulator only: script a finger that presses ``touch_after_s`` after arming (a dry run
        with no one at the display).
    touch_after_s : float, s
    """

    def __init__(self, name, device, *, source="protocol sample", protocol=None, participant=None,
                 sample=None, profile_file=None, trigger="contact force", force_threshold_N=None,
                 duration_s=None, simulate_touch=False, touch_after_s=0.5):
        if source not in ("protocol sample", "profile file"):
            raise ValueError(f"{name}: source: expected 'protocol sample' or 'profile file', "
                             f"got {source!r}")
        if trigger not in TRIGGERS:
            raise ValueError(f"{name}: trigger: expected one of {TRIGGERS}, got {trigger!r}")
        self.name = name
        self.device = device
        self.source = source
        proto = protocol if protocol not in (None, "") else device.protocol
        self.protocol = load_protocol_for_cue(proto) if proto is not None else None
        self.participant = participant
        self.sample = sample
        self.profile_file = profile_file
        self.trigger = trigger
        self.force_threshold_N = _opt_float(force_threshold_N)
        self.duration_s = _opt_float(duration_s)
        self.simulate_touch = bool(simulate_touch)
        self.touch_after_s = float(touch_after_s)
        self.profile = None
        self._cache = {}
        self.status = None
        self.tStart = self.tStop = None
        self.armed_clock_s = None
        self.contact = None            # the ContactResponse of this routine, once seen
        self.ended = False
        self.link_error = None

    # -------------------------------------------------------------- per routine
    def prepare(self, sample=None, participant=None, profile_file=None):
        """Make (or reuse) the profile for this routine and upload it to the display."""
        if sample is not None:
            self.sample = sample
        if participant is not None:
            self.participant = participant
        if profile_file is not None:
            self.profile_file = profile_file
        if self.source == "protocol sample":
            if self.protocol is None:
                raise ValueError(f"{self.name}: protocol: expected a protocol to take sample "
                                 f"{self.sample!r} from, got none")
            key = ("p", str(self.participant), str(self.sample))
            if key not in self._cache:
                self._cache[key] = protocol_profile(self.protocol, self.participant, self.sample)
        else:
            key = ("f", str(self.profile_file))
            if key not in self._cache:
                self._cache[key] = file_profile(self.profile_file)
        self.profile = self._cache[key]
        self.device.uploadProfile(self.profile.times_s, self.profile.target_C)
        self.contact, self.ended, self.armed_clock_s, self.link_error = None, False, None, None
        return self.profile

    def threshold_N(self) -> float:
        if self.trigger == "routine start":
            return ROUTINE_START_THRESHOLD_N
        if self.force_threshold_N is not None:
            return self.force_threshold_N
        return self.protocol.contact.force_threshold_N if self.protocol is not None else 2.0

    def max_duration_s(self) -> float:
        if self.duration_s is not None:
            return self.duration_s
        if self.protocol is not None:
            return self.protocol.contact.max_contact_s
        return self.profile.duration_s + 1.0

    def start(self, clock):
        """Map the clocks, arm the display (it waits for contact), script a finger if asked."""
        dev = self.device
        dev.resetClockMap()
        dev.syncClock()
        dev.arm(forceThreshold_N=self.threshold_N(), maxDuration_s=self.max_duration_s())
        self.armed_clock_s = clock.getTime()
        if self.simulate_touch:
            # a finger already resting (routine start) presses at once, with the threshold's force
            press(dev.display, sample=None,
                  press_after_s=0.0 if self.trigger == "routine start" else self.touch_after_s,
                  force_N=max(self.threshold_N(), 2.0) + 0.5, hold_s=self.max_duration_s() + 1.0)

    def poll(self) -> bool:
        """Each frame: route the display's messages; True once its trial has ended.

        A link that fails ends the cue (True); :meth:`end` records the fault, and the device's
        watchdog has the pad at neutral within 100 ms of the host falling silent.
        """
        try:
            self.ended = self.device.dispatchMessages()
        except DisplayError as exc:
            self.link_error = str(exc)
            self.ended = True
            return True
        if self.contact is None:
            for r in self.device.responses:
                if r.kind == "contact":
                    self.contact = r
                    break
        return self.ended

    @property
    def touched(self) -> bool:
        """Whether contact has been made in this routine."""
        return self.contact is not None

    def end(self, clock, global_clock=None) -> dict:
        """End the routine's cue: neutral, the recording, and the data columns.

        Parameters
        ----------
        clock : psychopy.core.Clock
            The routine's clock: ``contact_routine_s`` is on it.
        global_clock : psychopy.core.Clock, optional
            The experiment's clock: ``contact_global_s`` is on it.

        Returns
        -------
        dict
            ``<name>.<column>`` → value, for ``thisExp.addData``.
        """
        dev = self.device
        cols = {}
        if self.armed_clock_s is None:         # the routine ended before the cue started
            dev.neutral()
            self.ended = True
            return {f"{self.name}.{k}": ("not_started" if k == "status" else "") for k in COLUMNS}
        try:
            rec = dev.finishTrial()
        except DisplayError as exc:
            dev.neutral()
            rec = None
            cols["fault_message"] = self.link_error or str(exc)
        if rec is not None and rec.fault_code is not None:
            cols["fault_message"] = rec.fault_message
        if rec is not None and rec.fault_code not in ("LINK_LOST", "LINK_TIMEOUT"):
            try:
                dev.syncClock()               # second burst: the drift over the trial
            except DisplayError as exc:
                cols["fault_message"] = str(exc)
        cmap = dev.clockMap
        mapped = cmap is not None and cmap.unmapped is None
        if rec is not None:
            cols.update(status=rec.status, fault_code=rec.fault_code, end_reason=rec.end_reason,
                        tracking_rms_C=rec.tracking_rms_C, tracking_max_C=rec.tracking_max_C,
                        frames=rec.frames, frames_lost=rec.frames_lost,
                        contact_duration_device_s=rec.duration_s,
                        contact_device_s=rec.contact_time_s)
            # A duration beside the routine's times is on PsychoPy's clock: the device's span
            # through the map's rate; none when the device's clock is not mapped.
            if mapped and rec.duration_s is not None and rec.contact_time_s is not None:
                cols["contact_duration_s"] = rec.duration_s / (1.0 + cmap.drift)
        else:
            cols.update(status="fault", fault_code="LINK_LOST")
        contact_dev = rec.contact_time_s if rec is not None else None
        if contact_dev is not None and mapped:
            host = cmap.to_host(contact_dev)
            cols["contact_routine_s"] = clock.getTime() - (dev.clockNow() - host)
            if global_clock is not None:
                cols["contact_global_s"] = global_clock.getTime() - (dev.clockNow() - host)
        if self.contact is not None:
            cols["contact_force_N"] = self.contact.force_N
        if cmap is None:
            cols["clock_status"] = "unmapped: no clock burst"
        elif not mapped:
            cols["clock_status"] = f"unmapped: {cmap.unmapped}"
        else:
            cols.update(clock_status="mapped", clock_offset_s=cmap.offset_s,
                        clock_drift_ppm=cmap.drift * 1e6, clock_uncertainty_s=cmap.uncertainty_s)
        cols["clock_rtt_s"] = dev.firstBurst.rtt_median_s if dev.firstBurst else None
        cols.update(armed_routine_s=self.armed_clock_s, trigger=self.trigger,
                    force_threshold_N=self.threshold_N(),
                    profile_source=self.profile.source if self.profile else None,
                    profile_duration_s=self.profile.duration_s if self.profile else None)
        self.ended = True
        # Every column in every row, empty where there is no value (PsychoPy writes None as
        # the text "None").
        out = {k: cols.get(k) for k in COLUMNS}
        out.update(cols)
        return {f"{self.name}.{k}": ("" if v is None else v) for k, v in out.items()}

    def stop(self) -> None:
        """Neutral now (the quit handler; never raises)."""
        self.device.neutral()


def _opt_float(v):
    if v in (None, "", "None"):
        return None
    f = float(v)
    if not math.isfinite(f):
        raise ValueError(f"expected a finite number, got {v!r}")
    return f
