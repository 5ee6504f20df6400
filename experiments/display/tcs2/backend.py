"""The ``tcs2://`` display backend: a QST.Lab TCS II thermode behind the session's display API.

URL grammar::

    tcs2://PORT[?zones=12345][&start=command|trigger][&tolerance_C=0.1]
    tcs2://emulator[?clock=real|virtual][&faults=FAULTS][&seed=N][&speed=K][&zones=...]...

``PORT`` is the device's serial port (``tcs2:///dev/ttyACM0``, ``tcs2://COM3``, a pty path);
``emulator`` is the TCS II emulator in this process (:mod:`.protocol_tcs2emu`). ``zones``: the
probe's zones that stimulate (default all five); ``start``: stimulation starts by the host's
``L`` command when the trial runs (default) or on the device's trigger input (``Os``);
``tolerance_C``: the largest deviation the profile compiler may leave (default the device's
0.1 °C resolution).

The probe rests on the skin and has no force sensor: contact is the start of stimulation.
Opening the device (:meth:`Tcs2Display.handshake`): ``?`` must answer ``TCS``; the display
between stimulations is muted (``F``); ``H`` gives the firmware and the probe id; ``Om`` is set
to the protocol's maximum before any temperature is sent and read back (``P``) -- a device
holding another maximum is refused; then the neutral temperature (``N``), the zones (``S``),
the start mode (``Os``), the 100 Hz display during stimulation (``Ob``); ``P`` must show all of
it and ``Q`` no error. A profile is compiled to segments (:mod:`.profile_compiler`), sent by
``Uw``, enabled by ``Ue`` and read back by ``Ur``, which must equal what was sent.

A trial streams the 100 Hz temperature lines into the session's telemetry (one
:class:`~experiments.display.types.Telemetry` a line: contact = the mean of the stimulating
zones, ambient = the neutral sensor; no force, no skin thermometer: NaN) and polls ``Q``. A
silent device, a line that is not text, a half line, a reply the protocol does not have, a zone
error: the host sends ``A`` (abort to neutral) and the trial ends as a flagged
:class:`~experiments.display.trial_recording.TrialRecording`, never ``ok``.

The TCS II has no watchdog: a host that dies mid-profile leaves the device playing the uploaded
profile to its end (every point of which was checked against the protocol's range and rate)
and returning to neutral.
"""
from __future__ import annotations

import functools
import hashlib
import threading

import numpy as np

from experiments.errors import DisplayError, SafetyLimitError, UserInputError

from ..base import (Capabilities, Display, ProfileReceipt, handshake_or_close,
                            open_serial_port)
from ..types import DeviceInfo, Status
from ..safety import SafetyLimits
from ..trial_recording import TrialRecording
from . import commands as cmd
from .commands import ReplyError
from .link import LineLink
from .profile_compiler import MAX_SEGMENTS, MAX_SEGMENT_STEPS, RESOLUTION_C, compile_profile
from .trial import TcsTrial
from .watch import NEUTRAL_TOLERANCE_C, RETURN_S, IdleWatch, over_temperature, stop_and_verify
from .url import URL_GRAMMAR, parse_tcs2_url

__all__ = ["Tcs2Display", "parse_tcs2_url", "URL_GRAMMAR"]

#: Abort attempts after a fault (each waits up to 0.5 s for the device to answer).
ABORT_ATTEMPTS = 3
#: What a TCS II does not have of the thermocue display (``Capabilities.lacks``): its probe
#: measures its zones and the neutral (skin-side) temperature only; it reports zone errors but
#: latches no stuck-sensor fault; the host cannot reach past ``Om`` (the device's own maximum),
#: lower a trip for a test, or test a host-silence watchdog (it has none); its samples carry
#: no device time.
TCS2_LACKS = ("finger_thermometer", "heat_sink_thermometer", "stuck_sensor_rule", "raw_setpoint",
              "trip_test", "host_watchdog", "device_clock")


def _locked(method):
    """Run ``method`` holding the display's I/O lock (the idle watch never reads meanwhile)."""
    @functools.wraps(method)
    def wrapper(self, *args, **kwargs):
        with self._io:
            return method(self, *args, **kwargs)
    return wrapper



class Tcs2Display(Display, scheme="tcs2"):
    """A QST.Lab TCS II (or its emulator) as a thermocue display (see the module docstring).

    Parameters
    ----------
    port : serial.SerialBase
    limits : SafetyLimits
    zones : tuple of int
        Zones that stimulate.
    start : {"command", "trigger"}
    tolerance_C : float, °C
        The profile compiler's bound.
    name : str
        The port, for messages.

    Attributes
    ----------
    compiled : CompiledProfile or None
        The segments uploaded and read back (None: nothing playable).
    tracking_profile : tuple or None
        ``(step_s, target_C list)`` of the uploaded target, for the tracking error.
    script : tuple or None
        The emulated participant's ``(press_after_s, hold_s)`` (:meth:`sim_finger`).
    """

    description = "QST.Lab TCS II thermode (ASCII serial); tcs2://emulator: its emulator here"
    url_grammar = URL_GRAMMAR
    example_urls = (("tcs2://emulator", "TCS II (emulator)"), ("tcs2://{port}", "TCS II on {port}"))

    def __init__(self, port, limits: SafetyLimits | None = None, *, zones=(1, 2, 3, 4, 5),
                 start: str = "command", tolerance_C: float = RESOLUTION_C, name: str = "?"):
        self.port = port
        self.limits = limits or SafetyLimits()
        self.zones = tuple(zones)
        self.start = start
        self.tolerance_C = float(tolerance_C)
        self.name = name
        self.link = LineLink(port, name)
        self.info: DeviceInfo | None = None
        self.max_C: float | None = None
        self.neutral_C: float | None = None
        self.emulated = False
        self.compiled = None
        self._cache: dict = {}
        self.tracking_profile = None              # (dt, target list) for the tracking error
        self._trial = None
        self.script = None               # the emulated participant: (press_after_s, hold_s)
        self._io = threading.RLock()      # the link: commands, trials and the idle watch
        self._watch = None                # IdleWatch on a real clock, after the handshake
        self._off_since = None            # when the probe was first seen off neutral, idle
        self.idle_fault = None            # (code, message) the idle watch found, for arm()
        self.last_recording: TrialRecording | None = None
        self.trials = 0

    # ------------------------------------------------------------------ the registry's calls
    @classmethod
    def check_url(cls, url: str) -> None:
        parse_tcs2_url(url)

    @classmethod
    def open(cls, url: str, limits: SafetyLimits | None = None, **options) -> "Tcs2Display":
        """Open ``url``, shake hands (see the module docstring) and return the display.

        Raises
        ------
        UserInputError
            A malformed URL, or a protocol range the TCS II cannot hold.
        DisplayError
            The port cannot be opened, or the device does not answer or is refused.
        """
        pyurl, opts = parse_tcs2_url(url)
        baud = options.pop("baudrate", 115200)
        if options:
            raise UserInputError(f"display: {url!r}: unknown option(s) {sorted(options)}")
        port = open_serial_port(pyurl, baud)
        disp = handshake_or_close(cls(port, limits, name=str(url).split("?", 1)[0], **opts), port)
        if not disp.link.virtual:
            disp._watch = IdleWatch(disp)     # between trials, on a real clock
        return disp

    @classmethod
    def availability(cls) -> tuple:
        """Whether a USB serial port is here (the TCS II's, in computer-control mode)."""
        from ..ports import port_availability
        return port_availability("the TCS II (USB, computer-control mode)")

    @classmethod
    def url_availability(cls, url: str) -> tuple:
        """``tcs2://emulator`` needs no port (the TCS II emulator in software); any other URL
        needs the TCS II's (:meth:`availability`)."""
        if str(url)[len("tcs2://"):].partition("?")[0] == "emulator":
            return True, ""
        return cls.availability()

    @classmethod
    def declared_capabilities(cls) -> Capabilities:
        """What a TCS II offers (its specification, as the host uses it)."""
        return Capabilities(
            contact_detection="stimulus_start", force_sensing=False, telemetry_hz=100.0,
            max_profile_points=MAX_SEGMENTS * MAX_SEGMENT_STEPS + 1, min_profile_step_s=0.001,
            safe_range_C=cmd.SETPOINT_RANGE_C, max_rate_C_per_s=999.9, modes=("playback",),
            scripted_bench=False,
            notes="resting probe, no force plate: simulated trials only (contact = start of "
                  "stimulation); profiles as ≤ 999 linear segments",
            lacks=TCS2_LACKS)

    @property
    def capabilities(self) -> Capabilities:
        c = self.declared_capabilities()
        if self.info is None:
            return c
        return Capabilities(
            contact_detection=c.contact_detection, force_sensing=False, telemetry_hz=100.0,
            max_profile_points=c.max_profile_points, min_profile_step_s=c.min_profile_step_s,
            safe_range_C=(cmd.SETPOINT_RANGE_C[0], self.max_C), max_rate_C_per_s=c.max_rate_C_per_s,
            modes=("playback",), scripted_bench=self.emulated,
            notes=f"probe {self.info.device_id}, firmware {self.info.firmware}", lacks=c.lacks)

    # ------------------------------------------------------------------ handshake
    def _refuse(self, field: str, expected: str, got) -> None:
        raise DisplayError(f"display {self.name}: {field}: expected {expected}, got {got!r}; "
                           f"not using this device")

    def _params(self) -> dict:
        (line,) = self.link.ask("P", skip=cmd.is_temperature_line)
        return cmd.parse_parameters(line)

    def handshake(self) -> DeviceInfo:
        """Identify the device, set and read back its maximum, neutral, zones and start mode.

        Raises
        ------
        DisplayError
            No answer, a device that is not a TCS, another maximum than the protocol's, a
            setting not held, a zone error (one line naming the port and the field).
        """
        lim = self.limits
        if not cmd.SETPOINT_RANGE_C[0] <= lim.max_C <= cmd.SETPOINT_RANGE_C[1]:
            raise UserInputError(f"display: limits.max_C: expected {cmd.SETPOINT_RANGE_C[0]:g}–"
                                 f"{cmd.SETPOINT_RANGE_C[1]:g} °C for the TCS II, got {lim.max_C}")
        if not cmd.NEUTRAL_RANGE_C[0] <= lim.neutral_C <= cmd.NEUTRAL_RANGE_C[1]:
            raise UserInputError(f"display: limits.neutral_C: expected {cmd.NEUTRAL_RANGE_C[0]:g}–"
                                 f"{cmd.NEUTRAL_RANGE_C[1]:g} °C for the TCS II, got {lim.neutral_C}")
        try:
            self.link.drain()
            (ident,) = self.link.ask("?", skip=cmd.is_temperature_line)
            if ident.strip() != "TCS":
                self._refuse("'?' reply", "'TCS'", ident)
            self.link.send("A")                       # nothing running from an earlier host
            self.link.send("F")                       # no display between stimulations
            self.link.drain()
            help_lines = self.link.ask_until_quiet("H", skip=cmd.is_temperature_line)
            about = cmd.parse_help(help_lines)
            # the maximum first: no temperature is sent before the device holds it
            self.link.send(cmd.fmt_max(lim.max_C))
            p = self._params()
            if abs(p["max_C"] - round(lim.max_C, 1)) > 1e-9:
                self._refuse("maximum temperature (Om, read back by P)",
                             f"the protocol's {lim.max_C:g} °C", f"{p['max_C']:g} °C")
            self.max_C = p["max_C"]
            self.link.send(cmd.fmt_neutral(lim.neutral_C))
            self.link.send(cmd.fmt_zones(self.zones))
            self.link.send(cmd.fmt_profile_enable(()))
            self.link.send("Ose" if self.start == "trigger" else "Osd")
            self.link.send("Ob")
            p = self._params()
            want = {"neutral_C": round(lim.neutral_C, 1), "max_C": self.max_C, "zones": self.zones,
                    "profile_zones": (), "trigger_in": self.start == "trigger"}
            for key, value in want.items():
                if p[key] != value:
                    self._refuse(f"P reply: {key}", repr(value), p[key])
            self.neutral_C = p["neutral_C"]
            self._check_errors("at the handshake")
        except ReplyError as exc:
            raise DisplayError(f"{exc}; not using this device") from None
        except ValueError as exc:                     # a command the host refuses to format
            raise UserInputError(f"display: {exc}") from None
        self.emulated = "thermocue-emulator" in about["firmware"]
        # the TCS II's ASCII protocol has no version, and the device no watchdog: None
        self.info = DeviceInfo(
            device_id=about["probe_id"], firmware=about["firmware"], image_id=about["firmware"],
            capabilities=("playback", "sim") if self.emulated else ("playback",),
            telemetry_hz=100.0, hard_min_C=cmd.SETPOINT_RANGE_C[0], hard_max_C=self.max_C,
            max_rate_C_per_s=999.9, neutral_C=self.neutral_C,
            max_points=MAX_SEGMENTS * MAX_SEGMENT_STEPS + 1, min_dt_s=0.001,
            protocol=None, watchdog_s=None)
        return self.info

    def _check_errors(self, when: str) -> None:
        (line,) = self.link.ask("Q", skip=cmd.is_temperature_line)
        errs = cmd.parse_errors(line)
        if any(errs):
            bad = ", ".join(("neutral" if i == 0 else f"zone {i}") + f" error {e}"
                            for i, e in enumerate(errs) if e)
            raise DisplayError(f"display {self.name}: Q {when}: {bad}")

    # ------------------------------------------------------------------ between trials
    def check_idle(self) -> None:
        """One look at the probe while the host expects neutral (``Oe``); stop what is wrong.

        A zone above the maximum is ``OVER_TEMPERATURE`` at once; a stimulating zone off the
        neutral temperature for :data:`~.watch.RETURN_S` is ``STIMULATION_RUNNING``. Either is
        stopped (``A``, verified) and kept in :attr:`idle_fault` for the next :meth:`arm`.
        """
        with self._io:
            if self._trial is not None or self.max_C is None:
                return
            (line,) = self.link.ask("Oe")
            try:
                temps = cmd.parse_temperatures(line)
            except ReplyError as exc:
                raise DisplayError(str(exc)) from None
            now = self.link.clock()
            why = over_temperature(temps, self.max_C)
            code = "OVER_TEMPERATURE"
            if why is None:
                off = [z for z in self.zones if abs(temps[z] - self.neutral_C) > NEUTRAL_TOLERANCE_C]
                if not off:
                    self._off_since = None
                    return
                if self._off_since is None:
                    self._off_since = now
                    return
                if now - self._off_since < RETURN_S:
                    return
                code = "STIMULATION_RUNNING"
                why = (", ".join(f"zone {z} at {temps[z]:.1f} °C" for z in off) +
                       f", not at neutral {self.neutral_C:g} °C for {now - self._off_since:.1f} s "
                       f"after the trial")
            self._off_since = None
            outcome = stop_and_verify(self)
            if self.idle_fault is None:
                self.idle_fault = (code, f"between trials: {why}; {outcome}")

    @_locked
    def set_neutral(self, temperature_C: float) -> float:
        """Hold the probe at ``temperature_C`` (°C, 0.1 °C steps) between stimulations."""
        v = self.limits.check_setpoint(temperature_C, "neutral_C")
        if self.max_C is not None and v > self.max_C:
            raise SafetyLimitError(f"display: neutral_C: expected ≤ the maximum {self.max_C} °C, "
                                   f"got {v}")
        try:
            self.link.send(cmd.fmt_neutral(v))
            p = self._params()
        except ValueError as exc:
            raise UserInputError(f"display: {exc}") from None
        if abs(p["neutral_C"] - round(v, 1)) > 1e-9:
            raise DisplayError(f"display {self.name}: N: sent {round(v, 1)} °C, the device holds "
                               f"{p['neutral_C']} °C")
        self.neutral_C = p["neutral_C"]
        return self.neutral_C

    def compile(self, times_s, target_C):
        """The segments the device will play for a target (cached by content)."""
        t = np.asarray(times_s, dtype=float)
        y = np.asarray(target_C, dtype=float)
        key = (hashlib.sha1(t.tobytes() + y.tobytes()).hexdigest(), self.neutral_C,
               self.tolerance_C, self.max_C, self.limits)
        c = self._cache.get(key)
        if c is None:
            c = compile_profile(t, y, tolerance_C=self.tolerance_C, limits=self.limits,
                                start_C=self.neutral_C, max_C=self.max_C,
                                name=f"display {self.name}: profile")
            if len(self._cache) > 64:
                self._cache.clear()
            self._cache[key] = c
        return c

    def check_profile_capacity(self, times_s, target_C) -> None:
        """Whether the device can play a target within the tolerance (compiled now and kept
        for the upload); the session asks before its folder is written.

        Raises
        ------
        UserInputError, SafetyLimitError
            As :func:`~.profile_compiler.compile_profile`.
        """
        self.compile(times_s, target_C)

    @_locked
    def upload_profile(self, times_s, target_C) -> ProfileReceipt:
        """Compile, send by ``Uw``, enable by ``Ue``, read back by ``Ur`` and compare.

        The profile starts where the probe rests (the neutral temperature).

        Raises
        ------
        SafetyLimitError
            The target leaves the protocol's range or rate (nothing is sent).
        UserInputError
            No segments within the tolerance (one line: the bound).
        DisplayError
            The device does not hold what was sent.
        """
        c = self.compile(times_s, target_C)
        if any(s.end_dC > round(self.max_C * 10) for s in c.segments):   # never above Om
            raise SafetyLimitError(f"display {self.name}: profile: a segment ends above the "
                                   f"maximum {self.max_C} °C")
        text = cmd.fmt_profile(self.zones, c.segments)
        try:
            self.link.drain(0.02)           # nothing left from the last trial is a reply to Ur
            self.link.send(text)
            self.link.send(cmd.fmt_profile_enable(self.zones))
            back = cmd.parse_profile_lines(self.link.ask("Ur", n=5, skip=cmd.is_temperature_line))
            sent = tuple((s.steps, s.end_dC) for s in c.segments)
            for z in range(1, cmd.ZONES + 1):
                enabled, seg = back[z]
                if z in self.zones and (not enabled or seg != sent):
                    raise DisplayError(f"display {self.name}: Ur: zone {z} holds "
                                       f"{len(seg)} segments (enabled={enabled}), not the "
                                       f"{len(sent)} sent; profile not used")
                if z not in self.zones and enabled:
                    raise DisplayError(f"display {self.name}: Ur: zone {z} plays a profile it "
                                       f"was not given")
        except (ReplyError, DisplayError) as exc:
            self.compiled = None           # nothing is armed with a profile not verified ...
            try:                            # ... and the device plays none (best effort)
                self.link.send(cmd.fmt_profile_enable(()))
            except DisplayError:
                pass
            self.safe_abort()
            raise DisplayError(str(exc)) from None
        t = np.asarray(times_s, dtype=float)
        self.compiled = c
        dt = (t[-1] - t[0]) / (t.size - 1)
        self.tracking_profile = (dt, [float(v) for v in np.asarray(target_C)])
        return ProfileReceipt(points=int(t.size), step_s=dt, crc32=None, clamped=0,
                              max_deviation_C=c.max_deviation_C, segments=c.count)

    # ------------------------------------------------------------------ trials
    @_locked
    def arm(self, mode: str = "playback", force_threshold_N: float = 2.0,
            max_duration_s: float = 20.0) -> None:
        """Get ready to stimulate (the TCS II has no force threshold: contact is the start)."""
        if mode != "playback":
            raise UserInputError(f"display {self.name}: arm.mode: expected 'playback' (the TCS II "
                                 f"has no force plate for real samples), got {mode!r}")
        if self.compiled is None:
            raise UserInputError("display: arm: expected a profile uploaded before a playback trial")
        if not (isinstance(max_duration_s, (int, float)) and 0 < max_duration_s <= 3600):
            raise UserInputError(f"display: arm.max_duration_s: expected 0 < value ≤ 3600, got "
                                 f"{max_duration_s!r}")
        self.link.drain(0.03)               # lines left from an earlier, faulted trial
        self.check_idle()                   # what the probe does now, on any clock
        if self.idle_fault is not None:
            (code, msg), self.idle_fault = self.idle_fault, None
            exc = DisplayError(f"display {self.name}: {code}: {msg}")
            exc.code = code
            raise exc
        self._trial = TcsTrial(self, max_duration_s)

    def sim_finger(self, press_after_s: float = 0.3, force_N: float = 2.0, hold_s: float = 20.0,
                   skin_thickness_m: float = 650e-6, skin_temperature_C: float = 35.5) -> dict:
        """Emulator: the participant starts the stimulation ``press_after_s`` after arming (by
        command, or the trigger input) and stops it after ``hold_s``; the probe already rests
        on the skin, so force and skin are not modelled."""
        if not self.emulated:
            raise DisplayError("display: sim commands need the emulator; this is a TCS II "
                               f"({self.info.firmware if self.info else '?'})")
        self.script = (float(press_after_s), float(hold_s))
        return {"start_s": float(press_after_s)}

    def sim_sample(self, *args, **kwargs) -> dict:
        """The TCS II has no bench for real samples."""
        raise DisplayError("display: the TCS II has no bench for real samples (record mode)")

    @_locked
    def run_trial(self, timeout_s: float = 30.0, on_telemetry=None, on_event=None) -> TrialRecording:
        """Start the stimulation (or wait for the trigger) and stream it to its end."""
        run = self._trial
        if run is None:
            raise UserInputError("display: run_trial: expected arm() first")
        run.attach(on_telemetry, on_event)
        while not run.done:
            run.pump(timeout_s)
        return self._finish(run)

    @_locked
    def poll(self, on_telemetry=None, on_event=None) -> bool:
        """Route what has arrived without waiting; return whether the armed trial has ended."""
        run = self._trial
        if run is None:
            return False
        run.attach(on_telemetry, on_event)
        if not run.done:
            run.pump(None, wait=False)
        return run.done

    def _finish(self, run) -> TrialRecording:
        self._trial = None
        self.script = None
        self.trials += 1
        rec = run.recording()
        self.last_recording = rec
        return rec

    @_locked
    def abort(self) -> None:
        """Stop the stimulation; the probe returns to neutral."""
        self.link.send("A")
        if self._trial is not None and not self._trial.done:
            self._trial.end("aborted")

    def safe_abort(self) -> None:
        """``A`` until the device shows it is listening (it answers ``?``), then ``A`` once
        more: an abort sent while the device was not listening is not lost. Never raises."""
        for _ in range(ABORT_ATTEMPTS):
            try:
                self.link.send("A")
                if self.link.expect("?", "TCS", 0.5):
                    self.link.send("A")
                    return
            except DisplayError:
                if self.link.lost:
                    return                # the port is gone: nothing more can be sent

    @_locked
    def status(self) -> Status:
        """Temperatures (``E``) and errors (``Q``) now, as a :class:`Status`."""
        try:
            (line,) = self.link.ask("Oe")
            temps = cmd.parse_temperatures(line)
            self._check_errors("in status")
        except ReplyError as exc:
            raise DisplayError(str(exc)) from None
        zone = float(np.mean([temps[z] for z in self.zones]))
        last = self.last_recording
        # no device clock (the host's), no skin thermometer, no force plate: None
        return Status(state="IDLE" if self._trial is None else "ARMED", fault=None,
                      device_time_s=self.link.clock(), setpoint_C=self.neutral_C, contact_C=zone,
                      ambient_C=temps[0], finger_C=None, forces_N=None, neutral_C=self.neutral_C,
                      profile_points=(0 if self.tracking_profile is None
                                      else len(self.tracking_profile[1])),
                      contact_time_s=last.contact_time_s if last else None,
                      end_reason=last.end_reason if last else None, trials=self.trials)

    @_locked
    def heartbeat(self) -> float:
        """One ``?`` round trip; return the host's clock (the TCS II has no clock of its own)."""
        self.link.ask("?", skip=cmd.is_temperature_line)
        return self.link.clock()

    @_locked
    def is_awake(self) -> bool:
        """Whether the device answers ``?`` (never raises)."""
        try:
            return self.link.ask("?", skip=cmd.is_temperature_line, timeout_s=0.3) == ["TCS"]
        except DisplayError:
            return False

    def close(self) -> None:
        """Stop the idle watch, abort to neutral (best effort) and close the port."""
        if self._watch is not None:
            self._watch.stop()
            self._watch = None
        if self.port.is_open:
            if not self.link.lost:
                self.safe_abort()
            try:
                self.port.close()
            except Exception:
                pass
