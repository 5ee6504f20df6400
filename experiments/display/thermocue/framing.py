"""Frames on the serial line: layout, CRC-8 and CRC-16/CCITT, and a resynchronising stream parser.

Layout of one frame (all integers little-endian; protocol version 2)::

    0xA5 0x5A | length u16 | seq u8 | type u8 | hcrc u8 | payload (length bytes) | crc u16

``hcrc`` is CRC-8/SMBUS (polynomial 0x07, initial value 0, no reflection, no final xor; check
value 0xF4 for ``b"123456789"``) over ``length, seq, type``: a receiver rejects a damaged header --
above all a damaged length -- as soon as it has the 7 header bytes, instead of waiting for up to
:data:`MAX_PAYLOAD` bytes to check the CRC (the device's watchdog would fire meanwhile). ``crc`` is
CRC-16/CCITT-FALSE (polynomial 0x1021, initial value 0xFFFF, no reflection, no final xor; check
value 0x29B1 for ``b"123456789"``) over ``length .. payload``. The parser never raises on bad
input: it skips to the next start-of-frame marker, counts what it skipped, and goes on.
"""
from __future__ import annotations

import binascii
import struct
from typing import NamedTuple

__all__ = ["SOF", "MAX_PAYLOAD", "HEADER_SIZE", "OVERHEAD", "Frame", "crc8", "crc16",
           "encode_frame", "FrameParser"]

SOF = b"\xa5\x5a"
#: Largest payload a frame may carry, bytes (an upload chunk of 512 samples fits).
MAX_PAYLOAD = 1100
_HEADER = struct.Struct("<2sHBB")   # marker, length, seq, type; then the header's CRC-8
HEADER_SIZE = _HEADER.size + 1      # 7
OVERHEAD = HEADER_SIZE + 2          # header + CRC


def _crc8_table() -> bytes:
    table = bytearray(256)
    for i in range(256):
        c = i
        for _ in range(8):
            c = ((c << 1) ^ 0x07) & 0xFF if c & 0x80 else (c << 1) & 0xFF
        table[i] = c
    return bytes(table)


_CRC8 = _crc8_table()


def crc8(data: bytes) -> int:
    """CRC-8/SMBUS of ``data`` (polynomial 0x07, initial value 0): the header check.

    It detects every error of up to 3 bits (and every burst of up to 8) in the 4 header bytes.

    Examples
    --------
    >>> hex(crc8(b"123456789"))
    '0xf4'
    """
    c = 0
    for b in data:
        c = _CRC8[c ^ b]
    return c


def crc16(data: bytes, crc: int = 0xFFFF) -> int:
    """CRC-16/CCITT-FALSE of ``data`` (``binascii.crc_hqx`` with initial value 0xFFFF).

    Examples
    --------
    >>> hex(crc16(b"123456789"))
    '0x29b1'
    """
    return binascii.crc_hqx(data, crc)


class Frame(NamedTuple):
    """One decoded frame: sequence number, message type, payload bytes."""

    seq: int
    type: int
    payload: bytes


def encode_frame(seq: int, msg_type: int, payload: bytes = b"") -> bytes:
    """The bytes of one frame.

    Parameters
    ----------
    seq : int
        Sequence number, 0..255.
    msg_type : int
        Message type, 0..255 (see :mod:`experiments.display.thermocue.messages`).
    payload : bytes
        At most :data:`MAX_PAYLOAD` bytes.

    Raises
    ------
    ValueError
        If a field is out of range.
    """
    if len(payload) > MAX_PAYLOAD:
        raise ValueError(f"frame: payload: expected at most {MAX_PAYLOAD} bytes, got {len(payload)}")
    if not (0 <= seq <= 255 and 0 <= msg_type <= 255):
        raise ValueError(f"frame: seq/type: expected 0..255, got {seq!r}/{msg_type!r}")
    head = _HEADER.pack(SOF, len(payload), seq, msg_type)[2:]
    body = head + bytes((crc8(head),)) + payload
    return SOF + body + struct.pack("<H", binascii.crc_hqx(body, 0xFFFF))


class FrameParser:
    """Incremental decoder of a byte stream into :class:`Frame` objects.

    Feed it whatever the port returned; it returns the complete frames found and keeps the rest.
    Garbage, truncated frames and CRC failures are skipped by searching for the next start marker
    after the first byte of the bad candidate, so one corrupted byte costs at most the frames it
    touched. A candidate whose header fails its CRC-8 (or claims more than :data:`MAX_PAYLOAD`
    bytes) is rejected as soon as its header is in: a damaged length never holds the parser.

    Attributes
    ----------
    bytes_skipped : int
        Bytes discarded while resynchronising.
    bad_frames : int
        Candidate frames rejected (bad header, bad CRC or impossible length).
    frames : int
        Frames decoded.
    """

    __slots__ = ("_buf", "bytes_skipped", "bad_frames", "frames")

    def __init__(self):
        self._buf = bytearray()
        self.bytes_skipped = 0
        self.bad_frames = 0
        self.frames = 0

    def reset(self) -> None:
        """Forget buffered bytes (after a port reset)."""
        self._buf.clear()

    @property
    def buffered(self) -> int:
        """Bytes held waiting for the rest of a frame."""
        return len(self._buf)

    def drop_candidate(self) -> list[Frame]:
        """Give up on a partial frame that never completed (its rest was lost on the line).

        Call it when a read timed out with bytes still buffered: the parser skips one byte and
        resynchronises on what it holds, returning any frames found in it.
        """
        if not self._buf:
            return []
        del self._buf[:1]
        self.bytes_skipped += 1
        self.bad_frames += 1
        return self.feed(b"")

    def feed(self, data: bytes) -> list[Frame]:
        """Add bytes; return the frames completed by them (possibly none)."""
        buf = self._buf
        buf += data
        out: list[Frame] = []
        crc_hqx = binascii.crc_hqx
        crc8_table = _CRC8
        pos = 0
        n = len(buf)
        while True:
            start = buf.find(SOF, pos)
            if start < 0:
                # keep a trailing 0xA5 that may begin the next marker
                keep = 1 if n > pos and buf[-1] == 0xA5 else 0
                self.bytes_skipped += n - pos - keep
                del buf[:n - keep]
                return out
            if start > pos:
                self.bytes_skipped += start - pos
            if n - start < HEADER_SIZE:
                break
            length = buf[start + 2] | (buf[start + 3] << 8)
            c = 0
            for i in range(start + 2, start + 6):
                c = crc8_table[c ^ buf[i]]
            if length > MAX_PAYLOAD or c != buf[start + 6]:
                self.bad_frames += 1
                self.bytes_skipped += 1
                pos = start + 1
                continue
            end = start + HEADER_SIZE + length + 2
            if end > n:
                break
            body = bytes(buf[start + 2:end - 2])
            if crc_hqx(body, 0xFFFF) != (buf[end - 2] | (buf[end - 1] << 8)):
                self.bad_frames += 1
                self.bytes_skipped += 1
                pos = start + 1
                continue
            out.append(Frame(body[2], body[3], body[5:]))
            self.frames += 1
            pos = end
        del buf[:start]
        return out
