"""The host side: :class:`ThermalDisplay` over any pyserial URL, and :func:`open_display`.

One concept (~560 lines): the display's commands as the host sends them.

The display's commands (handshake, neutral, upload, arm, run a trial, status, the emulator's
"sim" commands) on the link it holds, :attr:`ThermalDisplay.link` (:class:`~.link.ProtocolLink`:
numbered requests, replies, heartbeats); the armed trial's book-keeping and the recording it yields are in
:mod:`.trial_recording`.

One port, one lock, one parser. Commands are request/reply with a sequence number, a timeout and
bounded retries (every command is safe to retry: the device answers a repeated sequence number
with its cached reply instead of acting twice). Each connection numbers its commands from a random
start, and HELLO makes the device forget the replies it kept, so a host that reconnects is never
answered with an earlier host's replies; the handshake checks that the device holds exactly the
limits and neutral temperature it was sent. Telemetry and events that arrive while waiting for
a reply are routed to the armed trial, never held in bulk.

Heartbeats and partly received frames: :mod:`.link`.

Failure policy: a refused command raises :class:`DisplayRefused` (with the device's code); no
answer after the retries raises :class:`DisplayTimeout`; a dead link raises :class:`DisplayError`
— in each case after a best-effort ABORT, and the device's own watchdog returns the pad to neutral
within 100 ms of the host falling silent. A trial that goes wrong ends as a
:class:`TrialRecording` with ``status="fault"`` and a fault code rather than an exception.
"""
from __future__ import annotations

import dataclasses

import serial

from experiments.errors import (DisplayBadReply, DisplayError, DisplayFaultLatched, DisplayLinkLost, DisplayRestarted, DisplayTimeout,
                                SafetyLimitError, UserInputError)

from . import messages as m
from .link import ProtocolLink
from ..base import (Capabilities, EmulatedDisplay, ProfileReceipt, check_serial_url,
                    handshake_or_close, open_serial_port)
from . import neutral, upload
from .handshake import (decode_hello, device_capabilities, protocol_capabilities,
                        refuse_text_device, send_limits)
from .messages import Cmd, Mode
from ..types import DeviceInfo, Status
from ..safety import SafetyLimits
from ..trial_recording import (ACTIVE_STATES, ContactEvent, TrialRecording, not_delivered,
                              TrialInProgress, evidence_fault)

__all__ = ["ThermalDisplay", "TrialRecording", "ContactEvent"]

def _json_object(payload: bytes) -> dict:
    """A sim command's reply: a JSON object (anything else is a bad reply)."""
    obj = m.decode_json(payload)
    if not isinstance(obj, dict):
        raise ValueError(f"expected a JSON object, got {type(obj).__name__}")
    return obj


class ThermalDisplay(EmulatedDisplay, scheme="serial"):
    """A Peltier thermal display of the thermocue protocol (or its emulator) on a pyserial port.

    The display backend for a serial device path (``/dev/ttyUSB0``, a pty) and pyserial URLs.
    Open it with :func:`experiments.display.open_display` (or :meth:`open`), which also does
    the handshake and starts the heartbeat.

    Parameters
    ----------
    port : serial.SerialBase
        Opened with ``serial.serial_for_url``.
    limits : SafetyLimits
    reply_timeout_s : float, s
        How long to wait for each reply (wall time; device time on a virtual clock).
    retries : int
        Extra attempts after a timeout.
    heartbeat_s : float, s
        Longest host silence before a heartbeat is sent (default 0.01).
    host_stall_s : float, s
        The heartbeat thread stops when the I/O thread has been silent this long (default 2).
    stale_s : float, s
        How long a partly received frame waits for its rest on a real port (default 0.2).
    max_frame_loss : float
        Fraction of telemetry frames a trial may lose before it is reported as a fault.

    Attributes
    ----------
    link : ProtocolLink
        The link below the commands (:mod:`.link`): numbered requests, replies, heartbeats.
    heartbeats_sent : int
        Heartbeats written by the fallback heartbeat thread (not by the helper process).
    max_tx_gap_s : float, s
        Longest wall-time gap between frames this process wrote itself (commands, heartbeats
        of the I/O loop and of the thread): how long the host's own threads were held off.
    """

    description = "thermocue display protocol (reference firmware, or any device speaking it)"
    _probe_text = True     # look for a TCS II before the first frame (an OS serial port only)
    url_grammar = "/dev/ttyUSB0 | COM3 | PTY_PATH | pyserial URL"
    example_urls = (("{port}", "Thermal display on {port}"),)

    @classmethod
    def check_url(cls, url: str) -> None:
        """A pyserial URL pyserial cannot read is refused in one line (``hwgrep://[``)."""
        check_serial_url(url)

    def __init__(self, port, limits: SafetyLimits | None = None, *, reply_timeout_s: float = 0.25,
                 retries: int = 3, heartbeat_s: float = 0.01, max_frame_loss: float = 0.01,
                 host_stall_s: float = 2.0, stale_s: float = 0.2):
        self.port = port
        self.link = ProtocolLink(port, reply_timeout_s=reply_timeout_s, retries=retries,
                                 heartbeat_s=heartbeat_s, host_stall_s=host_stall_s,
                                 stale_s=stale_s)
        self.limits = limits or SafetyLimits()
        self.max_frame_loss = float(max_frame_loss)
        self.info: DeviceInfo | None = None     # the handshake's answer, neutral
        self.hello: m.DeviceInfo | None = None  # ... as the protocol's HELLO reply (boot id)
        self._profile = None
        self._held_limits: SafetyLimits | None = None   # what the device acknowledged at HELLO
        self._uploaded = False                  # an UPLOAD_BEGIN went out on this connection
        self.last_recording: TrialRecording | None = None
        self.last_contact: ContactEvent | None = None

    # ------------------------------------------------------------------ the link's
    @property
    def heartbeats_sent(self) -> int:
        """Heartbeats written by the fallback heartbeat thread (:class:`~.link.ProtocolLink`)."""
        return self.link.heartbeats_sent

    @property
    def max_tx_gap_s(self) -> float:
        """Longest wall-time gap between frames this process wrote, s (:class:`~.link.ProtocolLink`)."""
        return self.link.max_tx_gap_s

    def start_heartbeat(self) -> None:
        """Start the background heartbeat (:meth:`.link.ProtocolLink.start_heartbeat`)."""
        self.link.start_heartbeat()

    def stop_heartbeat(self) -> None:
        """Stop the background heartbeat (:meth:`.link.ProtocolLink.stop_heartbeat`)."""
        self.link.stop_heartbeat()

    # ------------------------------------------------------------------ backend
    @classmethod
    def availability(cls) -> tuple:
        """Whether a USB serial port (the display's cable) is plugged in (``display/ports.py``)."""
        from ..ports import port_availability
        return port_availability("the display's USB-serial cable")

    @classmethod
    def open(cls, url: str, limits: SafetyLimits | None = None, **options) -> "ThermalDisplay":
        """Open ``url`` with pyserial, shake hands, start the heartbeat.

        Parameters
        ----------
        url : str
            A device path (``/dev/ttyUSB0``), a pty path, ``emulator://[?...]`` or another
            pyserial URL.
        limits : SafetyLimits, optional
        **options
            ``baudrate`` (default 115200) and the keyword arguments of :class:`ThermalDisplay`.

        Raises
        ------
        DisplayError
            If the port cannot be opened or the device does not answer the handshake, or answers
            it with numbers the host refuses (:class:`~.handshake.HandshakeRefused`).
        """
        port = open_serial_port(url, options.pop("baudrate", 115200))
        disp = handshake_or_close(cls(port, limits, **options), port)
        disp.start_heartbeat()
        return disp

    @classmethod
    def declared_capabilities(cls) -> Capabilities:
        """The protocol's ranges (a device declares its own at the handshake)."""
        return protocol_capabilities()

    @property
    def capabilities(self) -> Capabilities:
        """What the opened device declared at the handshake (before it: the protocol's ranges)."""
        return protocol_capabilities() if self.info is None else device_capabilities(self.info)

    @property
    def port_name(self) -> str:
        """The port's path or URL, for messages."""
        return str(getattr(self.port, "port", None) or getattr(self.port, "name", None) or "?")

    # ------------------------------------------------------------------ session set-up
    def handshake(self) -> DeviceInfo:
        """HELLO: learn the device id, firmware, capabilities and limits; send our limits."""
        self._refuse_text_device()
        try:
            self.port.reset_input_buffer()
        except (serial.SerialException, OSError):
            pass
        self.link.parser.reset()
        self._hello()
        self._refuse_latched_fault()
        self.link.restart = None
        self.link.dev_time = 0.0
        lim = self.limits
        send_limits(self.link, self.info, lim)
        self._held_limits = lim
        self._profile = None                     # a playback needs an upload on this connection
        self._uploaded = False
        self.set_neutral(lim.neutral_C)
        return self.info

    def _refuse_text_device(self) -> None:
        """Before any binary frame on an OS serial port: refuse a TCS II (:func:`.handshake.
        refuse_text_device`); not for a port this class knows to be the firmware."""
        if self._probe_text and isinstance(self.port, serial.Serial):
            try:
                refuse_text_device(self.port, self.port_name)
            except (serial.SerialException, OSError) as exc:
                self.link.error = exc
                raise DisplayLinkLost(f"display: cannot use {self.port_name}: {exc}") from exc

    def _hello(self) -> DeviceInfo:
        """One HELLO round trip, the reply checked (:func:`~.handshake.decode_hello`); sets
        :attr:`info` (neutral) and the boot id."""
        wire = decode_hello(self.link.transact(Cmd.HELLO, m.HELLO_REQ.pack(m.PROTOCOL_VERSION)),
                            self.port_name)
        self.hello = wire
        self.info = neutral.device_info(wire)
        self.link.handshaken = True
        return self.info

    def _read_status(self) -> m.Status:
        """One STATUS round trip, as the device answers it (no check against the handshake)."""
        return self.link.ask(Cmd.STATUS, m.Status.decode)

    def wire_status(self) -> m.Status:
        """One STATUS round trip as the protocol's reply (:class:`.messages.Status`: numeric
        end reason, boot id), for the protocol's conformance tests; callers use :meth:`status`."""
        return self._read_status()

    def _refuse_latched_fault(self) -> None:
        """Stop at the handshake, with what to do, if the device is latched in FAULT.

        A latched fault (over-temperature, sensor failure or stuck sensor) happened before this
        connection, possibly with nobody watching; the device refuses limits and ARM until an
        operator resets it, and thermocue never does that on its own.
        """
        st = self._read_status()
        if st.state == "FAULT":
            raise DisplayFaultLatched(
                f"display: {self.port_name} is latched in FAULT ({st.last_fault or 'no code'}) "
                f"from before this connection: its Peltier relay is open and it refuses to be "
                f"armed. Check the pad and its sensors, then reset it as the operator with "
                f"`thermocue clear-fault {self.port_name}`, or power-cycle it; no session starts "
                f"on a faulted display", code=st.last_fault)

    # ------------------------------------------------------------------ commands
    def set_neutral(self, temperature_C: float) -> float:
        """Set the temperature held between trials; return what the device holds, °C."""
        v = self.limits.check_setpoint(temperature_C, "neutral_C")
        sent = m.centi(v)
        (held,) = self.link.ask(Cmd.SET_NEUTRAL, m.CENTI, m.CENTI.pack(sent))
        if held != sent:
            raise DisplayError(f"display: SET_NEUTRAL: sent {sent / 100} °C, the device "
                               f"acknowledged {held / 100} °C (a stale reply, or limits other "
                               f"than ours); not going on with a neutral temperature it does "
                               f"not hold")
        return held / 100

    def upload_profile(self, times_s, target_C) -> ProfileReceipt:
        """Check, upload in CRC-verified chunks, and commit a target profile.

        Parameters
        ----------
        times_s : array_like, s
            Uniform from 0, step ≥ 1 ms.
        target_C : array_like, °C

        Raises
        ------
        SafetyLimitError
            Before anything is sent, if a sample is out of range or the rate is too high.
        DisplayError
            If the device keeps returning a chunk checksum that does not match.
        """
        self._profile = None
        try:
            return self._upload(times_s, target_C)
        except BaseException:
            # refused (by our check, by the device's clamping, a chunk that never matched, a
            # link error): the device must not keep a profile we refused, nor an older one
            self._discard_profile()
            raise

    def _upload(self, times_s, target_C) -> ProfileReceipt:
        if self._held_limits is not None and self.limits != self._held_limits:
            raise SafetyLimitError(f"display: limits: changed since the handshake (the device "
                                   f"holds {self._held_limits}, the host now has {self.limits}); "
                                   f"refusing to upload: open the display again with the new "
                                   f"limits")
        dt, y, q = upload.quantize(times_s, target_C, self.limits,
                                   self.info.max_points if self.info else None)
        self._uploaded = True
        receipt, self._profile = upload.send(self.link, dt, y, q)
        return receipt

    def _discard_profile(self) -> None:
        """Leave the device with no committed profile (best effort; never raises;
        :func:`.upload.discard`). Nothing is sent when this connection has uploaded nothing (a
        refusal by the host's own check then sends nothing at all)."""
        self._profile = None
        if self.info is None or self.link.error is not None or not self._uploaded:
            return
        upload.discard(self.link, self.info.min_dt_s)

    def arm(self, mode: str = "playback", force_threshold_N: float = 2.0,
            max_duration_s: float = 20.0) -> None:
        """Arm a trial: the device waits for the summed force to cross the threshold.

        ``"playback"`` starts the uploaded profile at contact; ``"record"`` leaves the Peltier at
        neutral and records the contact sensor from contact.
        """
        if mode not in ("playback", "record"):
            raise UserInputError(f"display: arm.mode: expected 'playback' or 'record', got {mode!r}")
        for name, v, hi in (("force_threshold_N", force_threshold_N, 600.0),
                            ("max_duration_s", max_duration_s, 3600.0)):
            if not isinstance(v, (int, float)) or not (0 < v <= hi):
                raise UserInputError(f"display: arm.{name}: expected 0 < value ≤ {hi}, got {v!r}")
        if mode == "playback" and self._profile is None:
            raise UserInputError("display: arm: expected a profile uploaded before a playback trial")
        self.link.check()
        md = Mode.PLAYBACK if mode == "playback" else Mode.RECORD
        with self.link.lock:
            self.link.trial = TrialInProgress(mode, self._profile if mode == "playback" else None)
            self.link.trial.bad0 = self.link.parser.bad_frames
            try:
                (c0,) = self.link.ask(Cmd.ARM, m.COUNTER, m.ARM.pack(
                    md, int(round(force_threshold_N * 100)), int(round(max_duration_s * 1000))))
            except DisplayError:
                self.link.trial = None
                raise
            self.link.trial.counter0 = self.link.trial.last_counter = c0
            self.link.trial.pending = [f for f in self.link.trial.pending if f.counter > c0]

    def run_trial(self, timeout_s: float = 30.0, on_telemetry=None, on_event=None) -> TrialRecording:
        """Stream the armed trial until it ends, faults or times out.

        Parameters
        ----------
        timeout_s : float, s
            From the call to the end of the trial (device time on a virtual clock).
        on_telemetry : callable, optional
            Called with each :class:`Telemetry` frame, in order.
        on_event : callable, optional
            Called with each :class:`DeviceEvent` (READY, CONTACT, END, FAULT, WATCHDOG) of the
            armed trial, those received since :meth:`arm` first (a READY that arrived while
            the caller drew its cue is not lost).

        Returns
        -------
        TrialRecording
        """
        tr = self.link.trial
        if tr is None:
            raise UserInputError("display: run_trial: expected arm() first")
        with self.link.lock:
            tr.callback = on_telemetry
            tr.attach_on_event(on_event)
            if on_telemetry is not None:
                for fr in tr.pending:
                    on_telemetry(fr)
            tr.pending = []
            clock, read, dispatch = self.link.clock, self.link.read_frames, self.link.dispatch_all
            heartbeat = self.link.heartbeat_if_due
            silent_s = max(0.3, 3 * self.link.reply_timeout_s)   # telemetry this quiet: ask STATUS
            start = clock()
            tr.last_frame_clock = start
            host_fault = None
            try:
                while not tr.ended:
                    dispatch(read())
                    heartbeat()
                    now = clock()
                    if now - start > timeout_s:
                        host_fault = ("TRIAL_TIMEOUT", f"no end of trial within {timeout_s} s")
                        break
                    if now - tr.last_frame_clock > silent_s:
                        st = self.status()        # telemetry silent: is the device there at all?
                        tr.last_frame_clock = self.link.clock()
                        if st.state not in ACTIVE_STATES:
                            tr.ended = True
                            if st.state == "FAULT" and tr.fault is None:
                                tr.fault = st.fault or "FAULT"
            except DisplayTimeout as exc:
                host_fault = ("LINK_TIMEOUT", str(exc))
            except DisplayBadReply as exc:
                host_fault = ("BAD_REPLY", str(exc))
            except DisplayError as exc:
                host_fault = ("LINK_LOST", str(exc))
            rec = self._finish(tr, host_fault)
        self.link.trial = None
        self.last_recording = rec
        self.last_contact = (ContactEvent(rec.contact_time_s, tr.contact_force)
                             if rec.contact_time_s is not None else None)
        return rec

    def _finish(self, tr: TrialInProgress, host_fault) -> TrialRecording:
        status, code, msg = "ok", None, None
        st = None
        if host_fault is None:
            # frames still in flight belong to this trial (the END event can overtake nothing,
            # but a last telemetry frame may follow it): drain briefly, then ask for the truth.
            # STATUS is the device's own account of the trial (it survives a burst that ate the
            # events and telemetry): its end reason and contact time decide, not what we saw.
            try:
                st = self.status()
                tr.take_status(st)
            except DisplayLinkLost as exc:
                host_fault = ("LINK_LOST", str(exc))
            except DisplayBadReply as exc:
                host_fault = ("BAD_REPLY", str(exc))
            except DisplayError as exc:
                host_fault = ("LINK_TIMEOUT", str(exc))
        if tr.fault is not None:
            status, code, msg = "fault", tr.fault, tr.fault_msg or f"device fault {tr.fault}"
        elif host_fault is not None:
            status, code, msg = "fault", host_fault[0], host_fault[1]
            if self.link.error is None:
                self._safe_abort()     # (a lost port takes nothing more: the watchdog acts)
        elif tr.end_reason == "aborted":
            status = "aborted"
        else:
            why = not_delivered(st, tr)
            if why is not None:
                status, code, msg = "fault", "NOT_DELIVERED", why
                self._safe_abort()
        rec = tr.recording(status, code, msg, self.link.parser.bad_frames - tr.bad0)
        why = evidence_fault(rec, self.max_frame_loss) if status == "ok" else None
        if why is not None:
            self._safe_abort()
            rec = dataclasses.replace(rec, status="fault", fault_code=why[0], fault_message=why[1])
        return rec

    def abort(self) -> None:
        """Stop whatever runs; the device returns to neutral (and leaves FAULT)."""
        self.link.transact(Cmd.ABORT)
        if self.link.trial is not None:
            self.link.trial.ended = True
            self.link.trial.end_reason = "aborted"

    def _safe_abort(self) -> None:
        try:
            self.link.transact(Cmd.ABORT, retries=1)
        except DisplayError:
            pass                 # link gone: the device's watchdog takes the pad to neutral

    def status(self) -> Status:
        """The device's state, sensors and last trial (one STATUS round trip).

        Raises
        ------
        DisplayRestarted
            If the boot id differs from the handshake's (the device restarted).
        """
        st = self._read_status()
        if self.hello is not None and st.boot_id != self.hello.boot_id:
            self.link.restarted(f"boot id {st.boot_id:08x}, not {self.hello.boot_id:08x} as at HELLO")
        if self.link.restart is not None:
            raise DisplayRestarted(f"display: restarted since the handshake ({self.link.restart}); "
                                   f"it no longer holds this session's limits and neutral: "
                                   f"stop, and resume to shake hands again")
        return neutral.status(st)

    def set_trip(self, temperature_C: float) -> float:
        """Lower the device's over-temperature trip (°C) for a test (``thermocue check``);
        return the trip it holds. The device never raises it above its own, and restores its
        own at HELLO, at power-up and when the host falls silent; send a value at or above the
        device's own trip (45 °C) to restore it at once. IDLE only."""
        p = self.link.transact(Cmd.SET_TRIP, m.CENTI.pack(int(round(temperature_C * 100))))
        return m.CENTI.unpack(p)[0] / 100.0

    def clear_fault(self) -> None:
        """Operator reset of a latched fault (over-temperature, sensor): FAULT -> IDLE.

        Never called by a session: a latched fault stops it, and a person decides.
        """
        self.link.transact(Cmd.CLEAR_FAULT, m.CLEAR_FAULT_MAGIC)

    @classmethod
    def operator_reset(cls, url: str, baudrate: int = 115200) -> tuple[str, str | None, str]:
        """The operator's reset of a display latched in FAULT (:func:`.operator_reset.reset`).

        Returns
        -------
        (state_before, fault, state_after) : tuple of str, str or None, str
        """
        from .operator_reset import reset
        return reset(cls, url, baudrate)

    def heartbeat(self) -> float:
        """One acknowledged heartbeat; return the device time, s."""
        t = self.link.ask(Cmd.HEARTBEAT, m.TIME)[0] * 1e-6
        self.link.dev_time = max(self.link.dev_time, t)
        return t

    def is_awake(self) -> bool:
        """Whether the display answers (one heartbeat, one attempt); never raises.

        PsychoPy's devices offer the same check (``isAwake``) before an experiment starts.
        """
        try:
            self.link.ask(Cmd.HEARTBEAT, m.TIME, retries=0)
            return True
        except DisplayError:
            return False

    def wait(self, seconds: float) -> None:
        """Let ``seconds`` pass (device time on a virtual clock) while keeping the link alive."""
        with self.link.lock:
            end = self.link.clock() + seconds
            while self.link.clock() < end:
                for fr in self.link.read_frames():
                    self.link.dispatch(fr)
                self.link.heartbeat_if_due()

    def poll(self, on_telemetry=None, on_event=None) -> bool:
        """Route what has arrived, without waiting; return whether the armed trial has ended.

        For a caller with its own loop (PsychoPy's frame loop) in place of :meth:`run_trial`'s:
        call it often, then :meth:`run_trial` once it returns True (or after :meth:`abort`) to
        get the :class:`TrialRecording`. The callbacks are attached to the armed trial as
        :meth:`run_trial` attaches them (telemetry received before is replayed first).
        """
        self.link.check()
        with self.link.lock:
            tr = self.link.trial
            if tr is not None and on_telemetry is not None and tr.callback is None:
                for fr in tr.pending:
                    on_telemetry(fr)
                tr.pending, tr.callback = [], on_telemetry
            if tr is not None and on_event is not None:
                tr.attach_on_event(on_event)
            try:
                while self.link.virtual or self.port.in_waiting > 0:
                    for fr in self.link.read_frames():
                        self.link.dispatch(fr)
                    if self.link.virtual:
                        break
            except (serial.SerialException, OSError) as exc:
                self.link.error = exc
                raise DisplayLinkLost(f"display: link lost while reading: {exc}") from exc
            self.link.heartbeat_if_due()
        return tr is not None and tr.ended

    # ------------------------------------------------------------------ emulator-only
    def _sim(self, cmd, args: dict) -> dict:
        if self.info is None or "sim" not in self.info.capabilities:
            raise DisplayError("display: sim commands need the emulator (capability 'sim'); "
                               f"this device offers {self.info.capabilities if self.info else ()}")
        return self.link.ask(cmd, _json_object, m.encode_json(args))

    def sim_sample(self, material: str = "stainless_steel", roughness_m: float = 1.6e-6,
                   thickness_m: float | None = 3e-3, temperature_C: float = 20.0) -> dict:
        """Emulator: place a passive sample for record-mode trials (SI lengths, °C)."""
        return self._sim(Cmd.SIM_SAMPLE, dict(material=material, roughness_m=roughness_m,
                                              thickness_m=thickness_m, temperature_C=temperature_C))

    def sim_finger(self, press_after_s: float = 0.3, force_N: float = 2.0, hold_s: float = 20.0,
                   skin_thickness_m: float = 650e-6, skin_temperature_C: float = 35.5) -> dict:
        """Emulator: script the finger (approach, press, hold, release).

        If the display is armed but not yet at its starting temperature, the script's clock
        starts when it is (the participant waits for the cue).
        """
        return self._sim(Cmd.SIM_FINGER, dict(press_after_s=press_after_s, force_N=force_N,
                                              hold_s=hold_s, skin_thickness_m=skin_thickness_m,
                                              skin_temperature_C=skin_temperature_C))

    def sim_fault(self, spec: str) -> dict:
        """Emulator: inject faults now (SPEC as in ``docs/display-protocol.md``, times from now)."""
        return self._sim(Cmd.SIM_FAULT, dict(spec=spec))

    # ------------------------------------------------------------------ lifetime
    def close(self) -> None:
        """Stop the heartbeat, put the display to neutral (best effort), close the port."""
        self.stop_heartbeat()
        if self.port.is_open:
            if self.link.error is None:
                self._safe_abort()
            try:
                self.port.close()
            except Exception:
                pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False
