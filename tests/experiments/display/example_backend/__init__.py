"""A worked example of a display backend: a simulated Peltier pad in this process.

``example-pad://[?tau_s=S]``: a pad that follows the uploaded profile with a first-order lag of
``tau_s`` (default 0.05 s), on a virtual clock (a trial takes no wall time), 100 readings a
second. The probe rests on the skin, as a thermode's does: contact is the start of stimulation.

This folder and one entry point are the whole backend (``CONTRIBUTING.md``, "Adding a display
backend"); the contract test (``tests/experiments/display/test_contract.py``) runs it as it
runs every built-in backend.
"""
from __future__ import annotations

import math
from urllib.parse import parse_qsl

from experiments.display.base import Capabilities, Display, ProfileReceipt
from experiments.display.safety import SafetyLimits, check_profile
from experiments.display.trial_recording import TrialInProgress, TrialRecording
from experiments.display.types import DeviceEvent, DeviceInfo, Status, Telemetry
from experiments.errors import DisplayError, UserInputError

__all__ = ["ExamplePad"]

RATE_HZ = 100.0                 # readings a second
MAX_POINTS = 10_000             # the longest profile it holds
_NAN4 = (math.nan,) * 4         # no force plate


def parse_url(url: str) -> float:
    """``tau_s`` of an ``example-pad://`` URL (one line naming the option if it is wrong)."""
    rest = str(url)[len("example-pad://"):]
    head, _, query = rest.partition("?")
    if head:
        raise UserInputError(f"display: example-pad://: expected nothing before '?', got {head!r}")
    tau_s = 0.05
    for key, value in parse_qsl(query, keep_blank_values=True):
        try:
            tau_s = float(value) if key == "tau_s" else math.nan
        except ValueError:
            tau_s = math.nan
        if not 0.001 <= tau_s <= 1.0:
            raise UserInputError(f"display: example-pad://: option {key}: expected tau_s "
                                 f"between 0.001 and 1 s, got {value!r}")
    return tau_s


class ExamplePad(Display, scheme="example-pad"):
    """A simulated pad (see the module docstring)."""

    description = "worked example: a simulated Peltier pad in this process (CONTRIBUTING.md)"
    url_grammar = "example-pad://[?tau_s=S]"
    example_urls = (("example-pad://", "Simulated pad (worked example)"),)

    def __init__(self, limits: SafetyLimits | None, tau_s: float):
        self.limits = limits or SafetyLimits()
        self.tau_s = tau_s
        self.neutral_C = self.pad_C = self.setpoint_C = self.limits.neutral_C
        self.t_s = 0.0
        self.counter = 0
        self.trials = 0
        self.profile = None          # (step_s, target_C list)
        self.trial = None            # TrialInProgress of the armed trial
        self.started_s = None        # when the armed trial's stimulation started
        self.last: TrialRecording | None = None
        self.closed = False

    # ------------------------------------------------------------ what the registry calls
    @classmethod
    def check_url(cls, url: str) -> None:
        parse_url(url)

    @classmethod
    def open(cls, url: str, limits: SafetyLimits | None = None, **options) -> "ExamplePad":
        if options:
            raise UserInputError(f"display: example-pad://: unknown option(s) {sorted(options)}")
        pad = cls(limits, parse_url(url))
        caps = cls.declared_capabilities()
        pad.info = DeviceInfo(device_id="EXAMPLE-PAD", firmware="example 1.0",
                              capabilities=("playback",), telemetry_hz=RATE_HZ,
                              hard_min_C=caps.safe_range_C[0], hard_max_C=caps.safe_range_C[1],
                              max_rate_C_per_s=caps.max_rate_C_per_s, neutral_C=pad.neutral_C,
                              max_points=MAX_POINTS, min_dt_s=caps.min_profile_step_s,
                              protocol=None, watchdog_s=None)    # no wire protocol, no watchdog
        return pad

    @classmethod
    def declared_capabilities(cls) -> Capabilities:
        return Capabilities(contact_detection="stimulus_start", force_sensing=False,
                            telemetry_hz=RATE_HZ, max_profile_points=MAX_POINTS,
                            min_profile_step_s=1.0 / RATE_HZ, safe_range_C=(10.0, 44.0),
                            max_rate_C_per_s=10.0, modes=("playback",),
                            notes="simulated, virtual clock; a worked example")

    # ------------------------------------------------------------ between trials
    def set_neutral(self, temperature_C: float) -> float:
        self.neutral_C = self.setpoint_C = self.limits.check_setpoint(temperature_C, "neutral_C")
        return self.neutral_C

    def upload_profile(self, times_s, target_C) -> ProfileReceipt:
        step_s, target = check_profile(times_s, target_C, self.limits, max_points=MAX_POINTS)
        self.profile = (step_s, [float(v) for v in target])
        return ProfileReceipt(points=len(target), step_s=step_s, crc32=None)

    # ------------------------------------------------------------ a trial
    def arm(self, mode: str = "playback", force_threshold_N: float = 2.0,
            max_duration_s: float = 20.0) -> None:
        if mode != "playback":
            raise UserInputError(f"display: arm.mode: expected 'playback', got {mode!r}")
        if self.profile is None:
            raise UserInputError("display: arm: expected a profile uploaded before a playback trial")
        self.trial = TrialInProgress(mode, self.profile)
        self.trial.counter0 = self.trial.last_counter = self.counter
        self.started_s = None
        self.trials += 1
        self.trial.event(DeviceEvent("READY", self.t_s))

    def _tick(self) -> None:
        """One reading: the stimulation starts at the first, follows the profile, then ends."""
        tr, (step_s, target) = self.trial, self.profile
        if self.started_s is None:
            self.started_s = self.t_s
            tr.event(DeviceEvent("CONTACT", self.t_s, None, "stimulus start"))
        i = int(round((self.t_s - self.started_s) / step_s))
        playing = i < len(target)
        self.setpoint_C = target[i] if playing else self.neutral_C
        self.pad_C += (self.setpoint_C - self.pad_C) * (1.0 - math.exp(-1.0 / (RATE_HZ * self.tau_s)))
        self.counter += 1
        tr.telemetry(Telemetry(self.counter, self.t_s, self.setpoint_C, self.pad_C, math.nan,
                               math.nan, _NAN4, "PLAYING" if playing else "IDLE", None))
        if not playing:
            tr.event(DeviceEvent("END", self.t_s, "complete"))
        self.t_s += 1.0 / RATE_HZ

    def _attach(self, on_telemetry, on_event) -> None:
        tr = self.trial
        if on_telemetry is not None and tr.callback is None:
            for fr in tr.pending:
                on_telemetry(fr)
            tr.pending, tr.callback = [], on_telemetry
        tr.attach_on_event(on_event)

    def poll(self, on_telemetry=None, on_event=None) -> bool:
        if self.trial is None:
            return False
        self._attach(on_telemetry, on_event)
        if not self.trial.ended:
            self._tick()
        return self.trial.ended

    def run_trial(self, timeout_s: float = 30.0, on_telemetry=None, on_event=None) -> TrialRecording:
        tr = self.trial
        if tr is None:
            raise UserInputError("display: run_trial: expected arm() first")
        self._attach(on_telemetry, on_event)
        end_s = self.t_s + timeout_s
        while not tr.ended and self.t_s < end_s:
            self._tick()
        self.trial = None
        if not tr.ended:
            status, code, msg = "fault", "TRIAL_TIMEOUT", f"no end of trial within {timeout_s} s"
        elif tr.end_reason == "aborted":
            status, code, msg = "aborted", None, None
        else:
            status, code, msg = "ok", None, None
        rms = math.sqrt(tr.sq / tr.n_track) if tr.n_track else math.nan
        self.last = TrialRecording(status, code, msg, tr.contact_s, tr.frames, 0, rms,
                                   tr.max_err if tr.n_track else math.nan, tr.mode, tr.end_reason,
                                   max(0.0, (tr.end_time_s or tr.contact_s or 0.0)
                                       - (tr.contact_s or 0.0)))
        return self.last

    def abort(self) -> None:
        self.setpoint_C = self.neutral_C
        if self.trial is not None and not self.trial.ended:
            self.trial.event(DeviceEvent("END", self.t_s, "aborted"))

    # ------------------------------------------------------------ state and lifetime
    def status(self) -> Status:
        last = self.last
        return Status(state="ARMED" if self.trial is not None else "IDLE", fault=None,
                      device_time_s=self.t_s, setpoint_C=self.setpoint_C, contact_C=self.pad_C,
                      ambient_C=None, finger_C=None, forces_N=None, neutral_C=self.neutral_C,
                      profile_points=len(self.profile[1]) if self.profile else 0,
                      contact_time_s=last.contact_time_s if last else None,
                      end_reason=last.end_reason if last else None, trials=self.trials)

    def heartbeat(self) -> float:
        if self.closed:
            raise DisplayError("display example-pad://: closed")
        return self.t_s

    def close(self) -> None:
        self.abort()
        self.trial = None
        self.closed = True
