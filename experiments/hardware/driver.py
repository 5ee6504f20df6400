"""The host side: :class:`ThermalDisplay` over any pyserial URL, and :func:`open_display`.

One concept in one class (about 700 lines, kept whole on purpose): the host's end of the display
protocol on one port -- the request/reply transaction with its retries, the heartbeat that feeds
the device's watchdog, and the commands built on them. The armed trial's book-keeping and the
recording it yields are in :mod:`.trial_recording`.

One port, one lock, one parser. Commands are request/reply with a sequence number, a timeout and
bounded retries (every command is safe to retry: the device answers a repeated sequence number
with its cached reply instead of acting twice). Each connection numbers its commands from a random
start, and HELLO makes the device forget the replies it kept, so a host that reconnects is never
answered with an earlier host's replies; the handshake checks that the device holds exactly the
limits and neutral temperature it was sent. Telemetry and events that arrive while waiting for
a reply are routed to the armed trial, never held in bulk.

Heartbeats (timing budget in ``docs/display-protocol.md`` §6): on a port with a file descriptor
(serial device, pty) a helper process (:mod:`.heartbeat`) writes a silent heartbeat every
``heartbeat_s`` (10 ms) -- no thread of ours, and so no GIL-holding main thread (a PsychoPy
window, a slow telemetry callback, a long C call), can hold it back. Elsewhere (``emulator://``)
a dedicated thread does the same without waiting for the I/O lock. Every command and every pass
of the I/O loop also counts (any valid frame feeds the watchdog). Both stop heartbeating when the
thread doing I/O has shown no sign of life for ``host_stall_s`` (2 s): a hung host program still
lets the device's watchdog take the pad to neutral. On a virtual clock the I/O thread heartbeats
in device time.

A frame read only in part waits for its rest for ``stale_s`` (0.2 s of wall time) before the
parser gives up on it: a pty hands a frame over in pieces when the kernel's buffers wrap, and a
loaded machine may take tens of ms to deliver the second piece.

Failure policy: a refused command raises :class:`DisplayRefused` (with the device's code); no
answer after the retries raises :class:`DisplayTimeout`; a dead link raises :class:`DisplayError`
— in each case after a best-effort ABORT, and the device's own watchdog returns the pad to neutral
within 100 ms of the host falling silent. A trial that goes wrong ends as a
:class:`TrialRecording` with ``status="fault"`` and a fault code rather than an exception.
"""
from __future__ import annotations

import math
import secrets
import threading
import time
import zlib

import numpy as np
import serial

from experiments.errors import (DisplayError, DisplayRefused, DisplayRestarted, DisplayTimeout,
                                SafetyLimitError, UserInputError)

from . import messages as m
from .framing import FrameParser, encode_frame
from .messages import (Cmd, CommitAck, DeviceEvent, DeviceInfo, Mode, Msg, Status,
                       Telemetry, UploadAck)
from .safety import SafetyLimits, check_profile
from .trial_recording import (_ACTIVE, _END_NAMES, ContactEvent, TrialRecording, _not_delivered,
                              _Trial)

__all__ = ["ThermalDisplay", "open_display", "TrialRecording", "ContactEvent"]

CHUNK = 512                    # samples per upload chunk
# ARM's and ABORT's reply types (0xA0, 0xA1) are also TELEMETRY's and EVENT's, whose frames carry
# the device's own numbers: a reply of these types is one only with the reply's size (4 and 0
# bytes; telemetry has 30, an event at least 11)
_REPLY_SIZE = {Cmd.ARM | m.REPLY_BIT: m.COUNTER.size, Cmd.ABORT | m.REPLY_BIT: 0}
#: The silent heartbeat (payload 0: no reply wanted) of every sequence number, encoded once.
_SILENT_HEARTBEAT = tuple(encode_frame(s, Cmd.HEARTBEAT, b"\x00") for s in range(256))


class ThermalDisplay:
    """A Peltier thermal display (or its emulator) on an open pyserial port.

    Use :func:`open_display`, which also does the handshake and starts the heartbeat.

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
    heartbeats_sent : int
        Heartbeats written by the fallback heartbeat thread (not by the helper process).
    max_tx_gap_s : float, s
        Longest wall-time gap between frames this process wrote itself (commands, heartbeats
        of the I/O loop and of the thread): how long the host's own threads were held off.
    """

    def __init__(self, port, limits: SafetyLimits | None = None, *, reply_timeout_s: float = 0.25,
                 retries: int = 3, heartbeat_s: float = 0.01, max_frame_loss: float = 0.01,
                 host_stall_s: float = 2.0, stale_s: float = 0.2):
        self.port = port
        self.limits = limits or SafetyLimits()
        self.reply_timeout_s = float(reply_timeout_s)
        self.retries = int(retries)
        self.heartbeat_s = float(heartbeat_s)
        self.host_stall_s = float(host_stall_s)
        self.stale_s = float(stale_s)
        self._wlock = threading.Lock()          # writes and sequence numbers, any thread
        self._last_tx = -1e9                    # wall time of the last frame written
        self._alive = time.monotonic()          # wall time the I/O thread last did something
        self._hb_proc = None                    # HeartbeatProcess on a port with a descriptor
        self._cand_key = None                   # parser progress when a partial frame was seen
        self._cand_since = 0.0
        self.heartbeats_sent = 0                # by the heartbeat thread
        self.max_tx_gap_s = 0.0                 # longest wall-time gap between written frames
        self.max_frame_loss = float(max_frame_loss)
        self.info: DeviceInfo | None = None
        self._lock = threading.RLock()
        self._parser = FrameParser()
        # a random start: a host that reconnects must not repeat its predecessor's numbers
        self._seq = secrets.randbelow(256)
        self._last_seq_by_type: dict[int, int] = {}
        # the loop's clock, s: a port whose device runs on a virtual clock says so by offering
        # device_clock() (a function returning device seconds, or None on a real clock); every
        # other port (a serial device, a pty) runs on wall time
        device_clock = getattr(port, "device_clock", None)
        device_clock = device_clock() if callable(device_clock) else None
        self._virtual = device_clock is not None
        self._clock = device_clock if self._virtual else time.monotonic
        # ... and may offer read_frames(): read() as decoded frames when nothing can damage them
        self._read_direct = getattr(port, "read_frames", None) if self._virtual else None
        self._dev_time = 0.0
        self._hb_clock = -1e9
        self._hb_dev = -1e9
        self._trial: _Trial | None = None
        self._profile = None
        self._hb_thread = None
        self._hb_stop = threading.Event()
        self._link_error: Exception | None = None
        self._restart: str | None = None       # why we think the device restarted
        self.last_recording: TrialRecording | None = None
        self.last_contact: ContactEvent | None = None

    # ------------------------------------------------------------------ low level
    def _next_seq(self, mtype: int) -> int:
        with self._wlock:
            s = (self._seq + 1) & 0xFF
            if self._last_seq_by_type.get(mtype) == s:      # never repeat a type's last number
                s = (s + 1) & 0xFF
            if s == 0 and mtype == Cmd.HEARTBEAT:           # 0: the helper's silent heartbeats
                s = 1 if self._last_seq_by_type.get(mtype) != 1 else 2
            self._seq = s
            self._last_seq_by_type[mtype] = s
            return s

    def _write(self, data: bytes) -> None:
        with self._wlock:
            try:
                self.port.write(data)
            except (serial.SerialException, OSError) as exc:
                self._link_error = exc
                raise DisplayError(f"display: link lost while writing: {exc}") from exc
            now = time.monotonic()
            if self._last_tx > 0:
                self.max_tx_gap_s = max(self.max_tx_gap_s, now - self._last_tx)
            self._last_tx = now

    def _read_frames(self):
        try:
            port = self.port
            if self._virtual:                    # the emulator returns what one wait produced
                if self._read_direct is not None and not self._parser.buffered:
                    frames = self._read_direct(65536)
                    if frames is not None:
                        self._parser.frames += len(frames)
                        return frames
                data = port.read(65536)
                return self._parser.feed(data) if data else (
                    self._parser.drop_candidate() if self._parser.buffered else [])
            n = port.in_waiting
            data = port.read(n if n > 0 else 1)
            if n <= 0 and data:
                n = port.in_waiting             # the rest of what arrived with the first byte
                if n > 0:
                    data += port.read(n)
        except (serial.SerialException, OSError) as exc:
            self._link_error = exc
            raise DisplayError(f"display: link lost while reading: {exc}") from exc
        self._touch()
        if not data:
            return self._stale_candidate() if self._parser.buffered else []
        return self._parser.feed(data)

    def _stale_candidate(self):
        """Give up on a partial frame only once the parser has made no progress for ``stale_s``.

        The rest of a frame split by the kernel may take a while on a loaded machine; a
        candidate whose length field is garbage is abandoned after ``stale_s`` (and sooner by
        itself once enough later bytes arrive for its CRC to fail).
        """
        p = self._parser
        key = (p.frames, p.bad_frames, p.bytes_skipped, p.buffered)
        now = time.monotonic()
        if key != self._cand_key:
            self._cand_key, self._cand_since = key, now
            return []
        if now - self._cand_since < self.stale_s:
            return []
        self._cand_key = None
        return p.drop_candidate()

    def _touch(self) -> None:
        """The I/O thread is alive: say so to the heartbeat thread and helper."""
        self._alive = time.monotonic()
        if self._hb_proc is not None:
            self._hb_proc.ping()

    def _heartbeat_if_due(self) -> None:
        self._touch()
        c = self._clock()
        if (c - self._hb_clock >= self.heartbeat_s or self._dev_time - self._hb_dev >= self.heartbeat_s
                or (not self._virtual and self._alive - self._last_tx >= self.heartbeat_s)):
            self._hb_clock, self._hb_dev = c, self._dev_time
            # silent (no reply wanted): telemetry or the next reply shows the device is alive
            self._write(_SILENT_HEARTBEAT[self._next_seq(Cmd.HEARTBEAT)])

    def _dispatch(self, fr) -> None:
        """Route a frame that is not the awaited reply."""
        t = fr.type
        if t == Msg.TELEMETRY:
            try:
                tel = Telemetry.decode(fr.payload)
            except Exception:        # a frame with a good CRC but a wrong layout: count, go on
                self._parser.bad_frames += 1
                return
            if tel.device_time_s < self._dev_time - 0.05:      # telemetry is never a cached reply
                self._restarted(f"its time went back from {self._dev_time:.3f} s to "
                                f"{tel.device_time_s:.3f} s")
            self._dev_time = tel.device_time_s
            if self._trial is not None:
                self._trial.last_frame_clock = self._clock()
                self._trial.telemetry(tel)
        elif t == Msg.EVENT:
            try:
                ev = DeviceEvent.decode(fr.payload)
            except Exception:
                self._parser.bad_frames += 1
                return
            self._dev_time = max(self._dev_time, ev.device_time_s)
            if self._trial is not None:
                self._trial.event(ev)
        elif t == (Cmd.HEARTBEAT | m.REPLY_BIT) and len(fr.payload) == m.TIME.size:
            # not a restart test: a retried heartbeat is answered from the device's cache
            self._dev_time = max(self._dev_time, m.TIME.unpack(fr.payload)[0] * 1e-6)

    def _restarted(self, why: str) -> None:
        """Note a device restart: the next command raises :class:`DisplayRestarted`."""
        if self._restart is None:
            self._restart = why
        if self._trial is not None and self._trial.fault is None:
            self._trial.fault, self._trial.fault_msg = "DEVICE_RESTARTED", f"display restarted: {why}"
            self._trial.ended = True

    def _transact(self, cmd: int, payload: bytes = b"", *, timeout_s: float | None = None,
                  retries: int | None = None) -> bytes:
        """Send a command, return the reply payload; raise on refusal or silence."""
        timeout_s = self.reply_timeout_s if timeout_s is None else timeout_s
        retries = self.retries if retries is None else retries
        with self._lock:
            seq = self._next_seq(cmd)
            frame = encode_frame(seq, cmd, payload)
            want = (cmd | m.REPLY_BIT) & 0xFF
            size = _REPLY_SIZE.get(want)
            for attempt in range(retries + 1):
                self._write(frame)
                self._hb_clock, self._hb_dev = self._clock(), self._dev_time  # any frame feeds the watchdog
                deadline = self._clock() + timeout_s
                while self._clock() < deadline:
                    answer = None
                    for fr in self._read_frames():      # dispatch every other frame, even after
                        if answer is None and fr.seq == seq and (
                                (fr.type == want and (size is None or len(fr.payload) == size))
                                or (fr.type == Msg.NAK and fr.payload[:1] == bytes([cmd]))):
                            answer = fr
                        else:
                            self._dispatch(fr)
                    if answer is not None:
                        if answer.type == want:
                            return answer.payload
                        _, code = m.NAK_HEAD.unpack_from(answer.payload)
                        text = answer.payload[m.NAK_HEAD.size:].decode("utf-8", "replace")
                        if code == m.Err.NO_HELLO and cmd != Cmd.HELLO and self.info is not None:
                            self._restarted(f"{Cmd(cmd).name} refused with NO_HELLO")
                            raise DisplayRestarted(
                                f"display: restarted since the handshake ({Cmd(cmd).name} "
                                f"refused: NO_HELLO); it no longer holds this session's "
                                f"limits and neutral: stop, and resume to shake hands again")
                        raise DisplayRefused(f"display: {Cmd(cmd).name} refused: "
                                             f"{m.error_name(code)} ({text})", code=code)
                    self._heartbeat_if_due()
            raise DisplayTimeout(f"display: {Cmd(cmd).name}: expected a reply within "
                                 f"{timeout_s} s, got none after {retries + 1} attempts")

    # ------------------------------------------------------------------ session set-up
    def handshake(self) -> DeviceInfo:
        """HELLO: learn the device id, firmware, capabilities and limits; send our limits."""
        try:
            self.port.reset_input_buffer()
        except (serial.SerialException, OSError):
            pass
        self._parser.reset()
        p = self._transact(Cmd.HELLO, m.HELLO_REQ.pack(m.PROTOCOL_VERSION))
        (ver, hz, hmin, hmax, rate, neutral, wd, npts, mindt,
         boot) = m.HELLO_REPLY_HEAD.unpack_from(p)
        dev_id, fw, caps = m.decode_strings(p[m.HELLO_REPLY_HEAD.size:], 3)
        self.info = DeviceInfo(dev_id, fw, tuple(c for c in caps.split(",") if c), ver, hz,
                               hmin / 100, hmax / 100, rate / 100, neutral / 100, wd, npts,
                               mindt * 1e-6, boot)
        self._restart = None
        self._dev_time = 0.0
        lim = self.limits
        if lim.min_C < self.info.hard_min_C or lim.max_C > self.info.hard_max_C:
            raise SafetyLimitError(f"display: limits: expected a range inside the device's "
                                   f"[{self.info.hard_min_C}, {self.info.hard_max_C}] °C, got "
                                   f"[{lim.min_C}, {lim.max_C}]")
        sent = (m.centi(lim.min_C), m.centi(lim.max_C),
                min(int(round(lim.max_rate_C_per_s * 100)), 0xFFFF))
        got = m.LIMITS.unpack(self._transact(Cmd.SET_LIMITS, m.LIMITS.pack(*sent)))
        # the range lies inside the device's, so it must hold it exactly; the rate may be
        # lowered to the device's own maximum (a tighter limit, and so not a mismatch)
        want = (sent[0], sent[1], min(sent[2], rate))
        if got != want:
            raise DisplayError(
                f"display: SET_LIMITS: sent {sent[0] / 100}–{sent[1] / 100} °C at "
                f"{sent[2] / 100} °C/s, the device acknowledged {got[0] / 100}–{got[1] / 100} °C "
                f"at {got[2] / 100} °C/s (a stale reply?); not going on with limits it does "
                f"not hold")
        self.set_neutral(lim.neutral_C)
        return self.info

    def start_heartbeat(self) -> None:
        """Start the background heartbeat (not needed, and not started, on a virtual clock).

        A helper process on a port with a file descriptor, else a thread (module docstring).
        """
        if self._virtual or self._hb_thread is not None:
            return
        fd = getattr(self.port, "fd", None)
        if isinstance(fd, int) and fd >= 0 and self._hb_proc is None:
            from .heartbeat import HeartbeatProcess
            try:
                self._hb_proc = HeartbeatProcess(
                    fd, encode_frame(0, Cmd.HEARTBEAT, b"\x00"), self.heartbeat_s,
                    self.host_stall_s)
            except OSError:
                self._hb_proc = None          # no helper: the thread heartbeats
        self._hb_stop.clear()
        self._hb_thread = threading.Thread(target=self._heartbeat_loop, name="display-heartbeat",
                                           daemon=True)
        self._hb_thread.start()

    def stop_heartbeat(self) -> None:
        """Stop the background heartbeat (commands still feed the watchdog; a silent host trips it)."""
        self._hb_stop.set()
        if self._hb_thread is not None:
            self._hb_thread.join(timeout=1.0)
            self._hb_thread = None
        if self._hb_proc is not None:
            self._hb_proc.stop()
            self._hb_proc = None

    def _heartbeat_loop(self) -> None:
        period = self.heartbeat_s
        while not self._hb_stop.wait(period):
            now = time.monotonic()
            helper = self._hb_proc is not None and self._hb_proc.running
            try:
                # the I/O thread alive (or merely busy: a GIL-holding main thread still counts)
                # and nothing written for half a period: heartbeat, whoever holds the I/O lock
                if (not helper and now - self._alive <= self.host_stall_s
                        and now - self._last_tx >= period / 2):
                    self._write(_SILENT_HEARTBEAT[self._next_seq(Cmd.HEARTBEAT)])
                    self.heartbeats_sent += 1
                if not self._lock.acquire(blocking=False):
                    continue                   # the I/O thread is reading
                try:                           # nobody reads: keep the input drained
                    if self.port.in_waiting:
                        for fr in self._parser.feed(self.port.read(self.port.in_waiting)):
                            self._dispatch(fr)
                finally:
                    self._lock.release()
            except Exception as exc:           # reported by the next call in the main thread
                self._link_error = exc
                return

    # ------------------------------------------------------------------ commands
    def set_neutral(self, temperature_C: float) -> float:
        """Set the temperature held between trials; return what the device holds, °C."""
        v = self.limits.check_setpoint(temperature_C, "neutral_C")
        sent = m.centi(v)
        (held,) = m.CENTI.unpack(self._transact(Cmd.SET_NEUTRAL, m.CENTI.pack(sent)))
        if held != sent:
            raise DisplayError(f"display: SET_NEUTRAL: sent {sent / 100} °C, the device "
                               f"acknowledged {held / 100} °C (a stale reply, or limits other "
                               f"than ours); not going on with a neutral temperature it does "
                               f"not hold")
        return held / 100

    def upload_profile(self, times_s, target_C) -> CommitAck:
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
        max_pts = self.info.max_points if self.info else None
        dt, y = check_profile(times_s, target_C, self.limits, max_points=max_pts)
        q = np.round(y * 100.0).astype("<i2")
        raw = q.tobytes()
        dt_us = int(round(dt * 1e6))
        self._transact(Cmd.UPLOAD_BEGIN, m.UPLOAD_BEGIN.pack(len(q), dt_us))
        for off in range(0, len(q), CHUNK):
            body = raw[2 * off:2 * min(off + CHUNK, len(q))]
            count = len(body) // 2
            for attempt in range(self.retries + 1):
                ack = UploadAck(*m.UPLOAD_CHUNK_ACK.unpack(self._transact(
                    Cmd.UPLOAD_CHUNK, m.UPLOAD_CHUNK_HEAD.pack(off, count) + body)))
                if (ack.offset, ack.count, ack.crc32) == (off, count, zlib.crc32(body)):
                    break
            else:
                self._safe_abort()
                raise DisplayError(f"display: upload chunk at {off}: the device's checksum does "
                                   f"not match after {self.retries + 1} attempts")
        ack = CommitAck(*m.COMMIT_ACK.unpack(self._transact(Cmd.UPLOAD_COMMIT,
                                                            m.COMMIT.pack(zlib.crc32(raw)))))
        if ack.clamped:
            self._safe_abort()
            raise SafetyLimitError(f"display: profile: the device clamped {ack.clamped} samples to "
                                   f"its own range; refusing to play it")
        self._profile = (dt, (q.astype(float) / 100.0).tolist())
        return ack

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
        self._check_link()
        md = Mode.PLAYBACK if mode == "playback" else Mode.RECORD
        with self._lock:
            self._trial = _Trial(mode, self._profile if mode == "playback" else None)
            self._trial.bad0 = self._parser.bad_frames
            try:
                p = self._transact(Cmd.ARM, m.ARM.pack(md, int(round(force_threshold_N * 100)),
                                                       int(round(max_duration_s * 1000))))
            except DisplayError:
                self._trial = None
                raise
            c0 = m.COUNTER.unpack(p)[0]
            self._trial.counter0 = self._trial.last_counter = c0
            self._trial.pending = [f for f in self._trial.pending if f.counter > c0]

    def run_trial(self, timeout_s: float = 30.0, on_telemetry=None, on_event=None) -> TrialRecording:
        """Stream the armed trial until it ends, faults or times out.

        Parameters
        ----------
        timeout_s : float, s
            From the call to the end of the trial (device time on a virtual clock).
        on_telemetry : callable, optional
            Called with each :class:`Telemetry` frame, in order.
        on_event : callable, optional
            Called with each :class:`DeviceEvent` (READY, CONTACT, END, FAULT, WATCHDOG).

        Returns
        -------
        TrialRecording
        """
        tr = self._trial
        if tr is None:
            raise UserInputError("display: run_trial: expected arm() first")
        with self._lock:
            tr.callback, tr.on_event = on_telemetry, on_event
            if on_telemetry is not None:
                for fr in tr.pending:
                    on_telemetry(fr)
            tr.pending = []
            start = self._clock()
            tr.last_frame_clock = start
            host_fault = None
            try:
                while not tr.ended:
                    for fr in self._read_frames():
                        self._dispatch(fr)
                    self._heartbeat_if_due()
                    now = self._clock()
                    if now - start > timeout_s:
                        host_fault = ("TRIAL_TIMEOUT", f"no end of trial within {timeout_s} s")
                        break
                    if now - tr.last_frame_clock > max(0.3, 3 * self.reply_timeout_s):
                        st = self.status()        # telemetry silent: is the device there at all?
                        tr.last_frame_clock = self._clock()
                        if st.state not in _ACTIVE:
                            tr.ended = True
                            if st.state == "FAULT" and tr.fault is None:
                                tr.fault = st.last_fault or "FAULT"
            except DisplayTimeout as exc:
                host_fault = ("LINK_TIMEOUT", str(exc))
            except DisplayError as exc:
                host_fault = ("LINK_LOST", str(exc))
            rec = self._finish(tr, host_fault)
        self._trial = None
        self.last_recording = rec
        self.last_contact = (ContactEvent(rec.contact_time_s, tr.contact_force)
                             if rec.contact_time_s is not None else None)
        return rec

    def _finish(self, tr: _Trial, host_fault) -> TrialRecording:
        status, code, msg = "ok", None, None
        st = None
        if host_fault is None:
            # frames still in flight belong to this trial (the END event can overtake nothing,
            # but a last telemetry frame may follow it): drain briefly, then ask for the truth.
            # STATUS is the device's own account of the trial (it survives a burst that ate the
            # events and telemetry): its end reason and contact time decide, not what we saw.
            try:
                st = self.status()
                if st.contact_time_s is not None:
                    tr.contact_s = st.contact_time_s
                    tr.active_seen = True
                if st.state not in _ACTIVE:
                    tr.end_reason = _END_NAMES.get(st.end_reason, str(st.end_reason))
                if st.state == "FAULT" and tr.fault is None:
                    tr.fault = st.last_fault or "FAULT"
                elif tr.end_reason == "fault" and tr.fault is None:
                    # the WATCHDOG or FAULT event was lost: the device still says why
                    tr.fault = st.last_fault or "FAULT"
                    tr.fault_msg = (f"the device ended the trial by a fault ({tr.fault}); "
                                    f"its event was lost on the link")
            except DisplayError as exc:
                host_fault = ("LINK_TIMEOUT", str(exc))
        if tr.fault is not None:
            status, code, msg = "fault", tr.fault, tr.fault_msg or f"device fault {tr.fault}"
        elif host_fault is not None:
            status, code, msg = "fault", host_fault[0], host_fault[1]
            self._safe_abort()
        elif tr.end_reason == "aborted":
            status = "aborted"
        else:
            why = _not_delivered(st, tr)
            if why is not None:
                status, code, msg = "fault", "NOT_DELIVERED", why
                self._safe_abort()
        expected = tr.last_counter - tr.counter0
        lost = max(0, expected - tr.frames)
        if status == "ok" and expected > 0 and lost > self.max_frame_loss * expected:
            status, code, msg = "fault", "TELEMETRY_LOSS", f"{lost} of {expected} frames lost"
        rms = math.sqrt(tr.sq / tr.n_track) if tr.n_track else float("nan")
        mx = tr.max_err if tr.n_track else float("nan")
        dur = (tr.end_time_s - tr.contact_s) if (tr.end_time_s is not None and
                                                 tr.contact_s is not None) else 0.0
        return TrialRecording(status, code, msg, tr.contact_s if tr.active_seen else None,
                              tr.frames, lost, rms, mx, tr.mode, tr.end_reason, max(0.0, dur),
                              self._parser.bad_frames - tr.bad0)

    def abort(self) -> None:
        """Stop whatever runs; the device returns to neutral (and leaves FAULT)."""
        self._transact(Cmd.ABORT)
        if self._trial is not None:
            self._trial.ended = True
            self._trial.end_reason = "aborted"

    def _safe_abort(self) -> None:
        try:
            self._transact(Cmd.ABORT, retries=1)
        except DisplayError:
            pass                 # link gone: the device's watchdog takes the pad to neutral

    def status(self) -> Status:
        """The device's state, sensors and last trial (one STATUS round trip).

        Raises
        ------
        DisplayRestarted
            If the boot id differs from the handshake's (the device restarted).
        """
        st = Status.decode(self._transact(Cmd.STATUS))
        if self.info is not None and st.boot_id != self.info.boot_id:
            self._restarted(f"boot id {st.boot_id:08x}, not {self.info.boot_id:08x} as at HELLO")
        if self._restart is not None:
            raise DisplayRestarted(f"display: restarted since the handshake ({self._restart}); "
                                   f"it no longer holds this session's limits and neutral: "
                                   f"stop, and resume to shake hands again")
        return st

    def clear_fault(self) -> None:
        """Operator reset of a latched fault (over-temperature, sensor): FAULT -> IDLE.

        Never called by a session: a latched fault stops it, and a person decides.
        """
        self._transact(Cmd.CLEAR_FAULT, m.CLEAR_FAULT_MAGIC)

    def heartbeat(self) -> float:
        """One acknowledged heartbeat; return the device time, s."""
        t = m.TIME.unpack(self._transact(Cmd.HEARTBEAT))[0] * 1e-6
        self._dev_time = max(self._dev_time, t)
        return t

    def is_awake(self) -> bool:
        """Whether the display answers (one heartbeat, one attempt); never raises.

        PsychoPy's devices offer the same check (``isAwake``) before an experiment starts.
        """
        try:
            m.TIME.unpack(self._transact(Cmd.HEARTBEAT, retries=0))
            return True
        except DisplayError:
            return False

    def wait(self, seconds: float) -> None:
        """Let ``seconds`` pass (device time on a virtual clock) while keeping the link alive."""
        with self._lock:
            end = self._clock() + seconds
            while self._clock() < end:
                for fr in self._read_frames():
                    self._dispatch(fr)
                self._heartbeat_if_due()

    def _check_link(self) -> None:
        if self._link_error is not None:
            exc, self._link_error = self._link_error, None
            raise DisplayError(f"display: link lost: {exc}")

    def poll(self, on_telemetry=None, on_event=None) -> bool:
        """Route what has arrived, without waiting; return whether the armed trial has ended.

        For a caller with its own loop (PsychoPy's frame loop) in place of :meth:`run_trial`'s:
        call it often, then :meth:`run_trial` once it returns True (or after :meth:`abort`) to
        get the :class:`TrialRecording`. The callbacks are attached to the armed trial as
        :meth:`run_trial` attaches them (telemetry received before is replayed first).
        """
        self._check_link()
        with self._lock:
            tr = self._trial
            if tr is not None and on_telemetry is not None and tr.callback is None:
                for fr in tr.pending:
                    on_telemetry(fr)
                tr.pending, tr.callback = [], on_telemetry
            if tr is not None and on_event is not None:
                tr.on_event = on_event
            try:
                while self._virtual or self.port.in_waiting > 0:
                    for fr in self._read_frames():
                        self._dispatch(fr)
                    if self._virtual:
                        break
            except (serial.SerialException, OSError) as exc:
                self._link_error = exc
                raise DisplayError(f"display: link lost while reading: {exc}") from exc
            self._heartbeat_if_due()
        return tr is not None and tr.ended

    # ------------------------------------------------------------------ emulator-only
    def _sim(self, cmd, args: dict) -> dict:
        if self.info is None or "sim" not in self.info.capabilities:
            raise DisplayError("display: sim commands need the emulator (capability 'sim'); "
                               f"this device offers {self.info.capabilities if self.info else ()}")
        return m.decode_json(self._transact(cmd, m.encode_json(args)))

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
        """Emulator: inject faults now (SPEC as in :mod:`experiments.hardware.faults`, times from now)."""
        return self._sim(Cmd.SIM_FAULT, dict(spec=spec))

    # ------------------------------------------------------------------ lifetime
    def close(self) -> None:
        """Stop the heartbeat, put the display to neutral (best effort), close the port."""
        self.stop_heartbeat()
        if self.port.is_open:
            if self._link_error is None:
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


def open_display(url: str, limits: SafetyLimits | None = None, **options) -> ThermalDisplay:
    """Open a display by pyserial URL, shake hands, start the heartbeat.

    Parameters
    ----------
    url : str
        A device path (``/dev/ttyUSB0``), a pty path, or ``emulator://[?...]``.
    limits : SafetyLimits, optional
    **options
        ``baudrate`` (default 115200) and the keyword arguments of :class:`ThermalDisplay`.

    Raises
    ------
    DisplayError
        If the port cannot be opened or the device does not answer the handshake.
    """
    baud = options.pop("baudrate", 115200)
    try:
        port = serial.serial_for_url(url, baudrate=baud, timeout=0.01, write_timeout=1.0)
    except (serial.SerialException, OSError, ValueError) as exc:
        raise DisplayError(f"display: cannot open {url!r}: {exc}") from exc
    disp = ThermalDisplay(port, limits, **options)
    try:
        disp.handshake()
    except BaseException:
        try:
            port.close()
        except Exception:
            pass
        raise
    disp.start_heartbeat()
    return disp
