"""The host's end of the display protocol's link: numbered requests, replies, heartbeats.

:class:`ProtocolLink` is what :class:`~experiments.display.thermocue.driver.ThermalDisplay`
holds below its commands (``display.link``): sequence numbers (never a type's last one; 0 kept
for the helper's silent heartbeats), writing, reading and routing frames (telemetry and events
to the armed trial, :attr:`ProtocolLink.trial`; the awaited reply to
:meth:`ProtocolLink.transact`, with its timeout and retries), the heartbeat that feeds the
device's watchdog (in the I/O loop, and in a thread or a helper process on a real clock), and
noticing a device restart (:attr:`ProtocolLink.restart`).

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
"""
from __future__ import annotations

import json
import secrets
import struct
import threading
import time

import serial

from experiments.errors import (DisplayBadReply, DisplayLinkLost, DisplayRefused,
                                DisplayRestarted, DisplayTimeout)

from . import messages as m
from .framing import FrameParser, encode_frame
from .messages import Cmd, DeviceEvent, Msg
from .neutral import decode_telemetry, event as _neutral_event

__all__ = ["ProtocolLink", "decode_reply"]

# ARM's and ABORT's reply types (0xA0, 0xA1) are also TELEMETRY's and EVENT's, whose frames carry
# the device's own numbers: a reply of these types is one only with the reply's size (4 and 0
# bytes; telemetry has 30, an event at least 11)
_REPLY_SIZE = {Cmd.ARM | m.REPLY_BIT: m.COUNTER.size, Cmd.ABORT | m.REPLY_BIT: 0}
#: Longest wait for the heartbeat helper to start (a second Python: ~30 ms on a quiet machine),
#: s; a helper not up by then is stopped and the driver's thread heartbeats instead.
HELPER_START_S = 5.0
#: The silent heartbeat (payload 0: no reply wanted) of every sequence number, encoded once.
_SILENT_HEARTBEAT = tuple(encode_frame(s, Cmd.HEARTBEAT, b"\x00") for s in range(256))
# the frame types the I/O loop routes, as plain ints (an enum member's look-up, 100 times a
# second, costs more than the comparison)
_HEARTBEAT = int(Cmd.HEARTBEAT)
_TELEMETRY = int(Msg.TELEMETRY)
_EVENT = int(Msg.EVENT)
_HEARTBEAT_REPLY = int(Cmd.HEARTBEAT | m.REPLY_BIT)
_TIME_SIZE = m.TIME.size
_decode_telemetry = decode_telemetry       # wire frame -> the contract's neutral Telemetry


def _cmd_name(cmd: int) -> str:
    try:
        return m.Cmd(cmd).name
    except ValueError:
        return f"command 0x{cmd:02x}"


def decode_reply(cmd: int, payload: bytes, decode):
    """The one checked decoder of every reply: ``decode`` (a ``struct.Struct``, whose size the
    payload must have exactly, or a function of the payload) applied to ``payload``.

    Raises
    ------
    DisplayBadReply
        A payload of the wrong size, or with a value the protocol does not have (an unknown
        state, a malformed JSON reply): one line naming the command; nothing of it is used.
    """
    try:
        if isinstance(decode, struct.Struct):
            if len(payload) != decode.size:
                raise ValueError(f"expected {decode.size} bytes")
            return decode.unpack(payload)
        return decode(payload)
    except (struct.error, ValueError, KeyError, IndexError, TypeError, UnicodeDecodeError,
            json.JSONDecodeError) as exc:
        raise DisplayBadReply(f"display: {_cmd_name(cmd)}: a reply the protocol does not have "
                              f"({len(payload)} bytes, {str(exc)[:80]}); not using it") from None


class ProtocolLink:
    """Requests, replies and heartbeats on one port (held by ``ThermalDisplay`` as ``link``).

    Parameters
    ----------
    port : serial.SerialBase
    reply_timeout_s, retries, heartbeat_s, host_stall_s, stale_s
        As :class:`~experiments.display.thermocue.driver.ThermalDisplay` documents them.

    Attributes
    ----------
    lock : threading.RLock
        Held by whoever does I/O (a command, the trial loop); the heartbeat thread only
        drains the input when nobody holds it.
    parser : FrameParser
    clock : callable
        The loop's clock, s: device time on a virtual clock, else ``time.monotonic``.
    virtual : bool
    dev_time : float, s
        The latest device time seen.
    trial : TrialInProgress or None
        The armed trial, to which telemetry and events are routed.
    handshaken : bool
        A HELLO was answered on this link: a NO_HELLO refusal then means a restart.
    restart : str or None
        Why the device is thought to have restarted since the handshake.
    error : Exception or None
        A link failure seen by a thread other than the caller's (raised by :meth:`check`).
    heartbeats_sent, max_tx_gap_s
        As :class:`~experiments.display.thermocue.driver.ThermalDisplay` documents them.
    """

    def __init__(self, port, *, reply_timeout_s: float = 0.25, retries: int = 3,
                 heartbeat_s: float = 0.01, host_stall_s: float = 2.0, stale_s: float = 0.2):
        self.port = port
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
        self.lock = threading.RLock()
        self.parser = FrameParser()
        # a random start: a host that reconnects must not repeat its predecessor's numbers
        self._seq = secrets.randbelow(256)
        self._last_seq_by_type: dict[int, int] = {}
        # the loop's clock, s: a port whose device runs on a virtual clock says so by offering
        # device_clock() (a function returning device seconds, or None on a real clock); every
        # other port (a serial device, a pty) runs on wall time
        device_clock = getattr(port, "device_clock", None)
        device_clock = device_clock() if callable(device_clock) else None
        self.virtual = device_clock is not None
        self.clock = device_clock if self.virtual else time.monotonic
        # ... and may offer read_frames(): read() as decoded frames when nothing can damage them
        self._read_direct = getattr(port, "read_frames", None) if self.virtual else None
        self.dev_time = 0.0
        self._hb_clock = -1e9
        self._hb_dev = -1e9
        self.trial = None
        self.handshaken = False
        self._hb_thread = None
        self._hb_stop = threading.Event()
        self.error: Exception | None = None
        self.restart: str | None = None

    # ------------------------------------------------------------------ low level
    def _next_seq(self, mtype: int) -> int:
        with self._wlock:
            return self._take_seq(mtype)

    def _take_seq(self, mtype: int) -> int:
        """The next sequence number for a frame of type ``mtype`` (``_wlock`` held)."""
        s = (self._seq + 1) & 0xFF
        last = self._last_seq_by_type.get(mtype)
        if last == s:                                   # never repeat a type's last number
            s = (s + 1) & 0xFF
        if s == 0 and mtype == _HEARTBEAT:              # 0: the helper's silent heartbeats
            s = 1 if last != 1 else 2
        self._seq = s
        self._last_seq_by_type[mtype] = s
        return s

    def _write(self, data: bytes) -> None:
        with self._wlock:
            self._write_locked(data)

    def _write_heartbeat(self) -> None:
        """A silent heartbeat, numbered and written under one hold of ``_wlock``."""
        with self._wlock:
            self._write_locked(_SILENT_HEARTBEAT[self._take_seq(_HEARTBEAT)])

    def _write_locked(self, data: bytes) -> None:
        try:
            self.port.write(data)
        except (serial.SerialException, OSError) as exc:
            self.error = exc
            raise DisplayLinkLost(f"display: link lost while writing: {exc}") from exc
        now = time.monotonic()
        if self._last_tx > 0:
            self.max_tx_gap_s = max(self.max_tx_gap_s, now - self._last_tx)
        self._last_tx = now

    def read_frames(self):
        try:
            port = self.port
            if self.virtual:                    # the emulator returns what one wait produced
                parser = self.parser
                read_direct = self._read_direct
                if read_direct is not None and not parser.buffered:
                    frames = read_direct(65536)
                    if frames is not None:
                        parser.frames += len(frames)
                        return frames
                data = port.read(65536)
                return parser.feed(data) if data else (
                    parser.drop_candidate() if parser.buffered else [])
            n = port.in_waiting
            data = port.read(n if n > 0 else 1)
            if n <= 0 and data:
                n = port.in_waiting             # the rest of what arrived with the first byte
                if n > 0:
                    data += port.read(n)
        except (serial.SerialException, OSError) as exc:
            self.error = exc
            raise DisplayLinkLost(f"display: link lost while reading: {exc}") from exc
        self._touch()
        if not data:
            return self._stale_candidate() if self.parser.buffered else []
        return self.parser.feed(data)

    def _stale_candidate(self):
        """Give up on a partial frame only once the parser has made no progress for ``stale_s``.

        The rest of a frame split by the kernel may take a while on a loaded machine; a
        candidate whose length field is garbage is abandoned after ``stale_s`` (and sooner by
        itself once enough later bytes arrive for its CRC to fail).
        """
        p = self.parser
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

    def heartbeat_if_due(self) -> None:
        self._alive = time.monotonic()          # _touch(), inline: the I/O loop's every turn
        if self._hb_proc is not None:
            self._hb_proc.ping()
        c = self.clock()
        period = self.heartbeat_s
        if (c - self._hb_clock >= period or self.dev_time - self._hb_dev >= period
                or (not self.virtual and self._alive - self._last_tx >= period)):
            self._hb_clock, self._hb_dev = c, self.dev_time
            # silent (no reply wanted): telemetry or the next reply shows the device is alive
            self._write_heartbeat()

    def dispatch(self, fr) -> None:
        """Route a frame that is not the awaited reply."""
        self.dispatch_all((fr,))

    def dispatch_all(self, frames) -> None:
        """Route frames that are not an awaited reply, in order (the I/O loop's batch of a read:
        one call for all of them, the commonest, telemetry, first)."""
        for fr in frames:
            t = fr.type
            if t == _TELEMETRY:
                try:
                    tel = _decode_telemetry(fr.payload)
                except Exception:    # a frame with a good CRC but a wrong layout: count, go on
                    self.parser.bad_frames += 1
                    continue
                t_s = tel[1]                                    # device_time_s
                if t_s < self.dev_time - 0.05:                 # telemetry is never a cached reply
                    self.restarted(f"its time went back from {self.dev_time:.3f} s to "
                                    f"{t_s:.3f} s")
                self.dev_time = t_s
                trial = self.trial
                if trial is not None:
                    trial.last_frame_clock = self.clock()
                    trial.telemetry(tel)
            elif t == _EVENT:
                try:
                    ev = _neutral_event(DeviceEvent.decode(fr.payload))
                except Exception:
                    self.parser.bad_frames += 1
                    continue
                self.dev_time = max(self.dev_time, ev.device_time_s)
                if self.trial is not None:
                    self.trial.event(ev)
            elif t == _HEARTBEAT_REPLY and len(fr.payload) == _TIME_SIZE:
                # not a restart test: a retried heartbeat is answered from the device's cache
                self.dev_time = max(self.dev_time, m.TIME.unpack(fr.payload)[0] * 1e-6)

    def restarted(self, why: str) -> None:
        """Note a device restart: the next command raises :class:`DisplayRestarted`."""
        if self.restart is None:
            self.restart = why
        if self.trial is not None and self.trial.fault is None:
            self.trial.fault, self.trial.fault_msg = "DEVICE_RESTARTED", f"display restarted: {why}"
            self.trial.ended = True

    def transact(self, cmd: int, payload: bytes = b"", *, timeout_s: float | None = None,
                  retries: int | None = None) -> bytes:
        """Send a command, return the reply payload; raise on refusal or silence."""
        timeout_s = self.reply_timeout_s if timeout_s is None else timeout_s
        retries = self.retries if retries is None else retries
        with self.lock:
            seq = self._next_seq(cmd)
            frame = encode_frame(seq, cmd, payload)
            want = (cmd | m.REPLY_BIT) & 0xFF
            size = _REPLY_SIZE.get(want)
            for attempt in range(retries + 1):
                self._write(frame)
                self._hb_clock, self._hb_dev = self.clock(), self.dev_time  # any frame feeds the watchdog
                deadline = self.clock() + timeout_s
                while self.clock() < deadline:
                    answer = None
                    for fr in self.read_frames():      # dispatch every other frame, even after
                        if answer is None and fr.seq == seq and (
                                (fr.type == want and (size is None or len(fr.payload) == size))
                                or (fr.type == Msg.NAK and fr.payload[:1] == bytes([cmd]))):
                            answer = fr
                        else:
                            self.dispatch(fr)
                    if answer is not None:
                        if answer.type == want:
                            return answer.payload
                        if len(answer.payload) < m.NAK_HEAD.size:
                            raise DisplayBadReply(
                                f"display: {Cmd(cmd).name}: a NAK of {len(answer.payload)} "
                                f"byte(s), not the protocol's (refused command, code, text); "
                                f"not using it")
                        _, code = m.NAK_HEAD.unpack_from(answer.payload)
                        text = answer.payload[m.NAK_HEAD.size:].decode("utf-8", "replace")
                        if code == m.Err.NO_HELLO and cmd != Cmd.HELLO and self.handshaken:
                            self.restarted(f"{Cmd(cmd).name} refused with NO_HELLO")
                            raise DisplayRestarted(
                                f"display: restarted since the handshake ({Cmd(cmd).name} "
                                f"refused: NO_HELLO); it no longer holds this session's "
                                f"limits and neutral: stop, and resume to shake hands again")
                        raise DisplayRefused(f"display: {Cmd(cmd).name} refused: "
                                             f"{m.error_name(code)} ({text})", code=code,
                                             code_name=m.error_name(code))
                    self.heartbeat_if_due()
            raise DisplayTimeout(f"display: {Cmd(cmd).name}: expected a reply within "
                                 f"{timeout_s} s, got none after {retries + 1} attempts")

    def ask(self, cmd: int, decode, payload: bytes = b"", **kw):
        """:meth:`transact`, its reply decoded by :func:`decode_reply` (checked)."""
        return decode_reply(cmd, self.transact(cmd, payload, **kw), decode)

    # ------------------------------------------------------------------ the heartbeat
    def start_heartbeat(self) -> None:
        """Start the background heartbeat (not needed, and not started, on a virtual clock).

        A helper process on a port with a file descriptor, else a thread (module docstring).
        """
        if self.virtual or self._hb_thread is not None:
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
            else:                             # up before the display is handed over (a
                if not self._hb_proc.wait_ready(HELPER_START_S):    # loaded machine: ~0.1 s)
                    self._hb_proc.stop(wait_s=0.0)
                    self._hb_proc = None      # it did not start: the thread heartbeats
            self._alive = time.monotonic()    # (this is the I/O thread)
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
            helper = self._hb_proc is not None and self._hb_proc.ready and self._hb_proc.running
            try:
                # the I/O thread alive (or merely busy: a GIL-holding main thread still counts)
                # and nothing written for half a period: heartbeat, whoever holds the I/O lock
                if (not helper and now - self._alive <= self.host_stall_s
                        and now - self._last_tx >= period / 2):
                    self._write_heartbeat()
                    self.heartbeats_sent += 1
                if not self.lock.acquire(blocking=False):
                    continue                   # the I/O thread is reading
                try:                           # nobody reads: keep the input drained
                    if self.port.in_waiting:
                        for fr in self.parser.feed(self.port.read(self.port.in_waiting)):
                            self.dispatch(fr)
                finally:
                    self.lock.release()
            except Exception as exc:           # reported by the next call in the main thread
                self.error = exc
                return

    # ------------------------------------------------------------------ link errors
    def check(self) -> None:
        if self.error is not None:
            exc, self.error = self.error, None
            raise DisplayLinkLost(f"display: link lost: {exc}")
