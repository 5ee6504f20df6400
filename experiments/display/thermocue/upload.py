"""A target profile's way to the device: checked, sent in CRC-verified chunks, committed.

What :meth:`~.driver.ThermalDisplay.upload_profile` does on its link (:class:`~.link.
ProtocolLink`): :func:`quantize` checks the profile against the limits before anything is sent,
:func:`send` uploads and commits it, :func:`discard` leaves the device with no profile.
"""
from __future__ import annotations

import zlib

import numpy as np

from experiments.errors import DisplayError, SafetyLimitError

from . import messages as m
from .messages import Cmd, CommitAck, UploadAck
from ..base import ProfileReceipt
from ..safety import check_profile

__all__ = ["CHUNK", "quantize", "send", "discard"]

CHUNK = 512                    # samples per upload chunk


def quantize(times_s, target_C, limits, max_points):
    """The checked profile: its step (s), its samples (°C) and their wire form (centi-°C).

    Raises
    ------
    SafetyLimitError
        If a sample is out of range or the rate is too high (:func:`~..safety.check_profile`).
    """
    dt, y = check_profile(times_s, target_C, limits, max_points=max_points)
    return dt, y, np.round(y * 100.0).astype("<i2")


def send(link, dt: float, y, q) -> tuple[ProfileReceipt, tuple]:
    """UPLOAD_BEGIN, the chunks (each retried, up to the link's ``retries``, until its checksum
    matches), UPLOAD_COMMIT.

    Returns
    -------
    (receipt, profile) : ProfileReceipt, (step_s, samples held in °C)

    Raises
    ------
    DisplayError
        If the device keeps returning a chunk checksum that does not match.
    SafetyLimitError
        If the device clamped samples to its own range.
    """
    retries = link.retries
    raw = q.tobytes()
    dt_us = int(round(dt * 1e6))
    link.transact(Cmd.UPLOAD_BEGIN, m.UPLOAD_BEGIN.pack(len(q), dt_us))
    for off in range(0, len(q), CHUNK):
        body = raw[2 * off:2 * min(off + CHUNK, len(q))]
        count = len(body) // 2
        for attempt in range(retries + 1):
            ack = UploadAck(*link.ask(Cmd.UPLOAD_CHUNK, m.UPLOAD_CHUNK_ACK,
                                      m.UPLOAD_CHUNK_HEAD.pack(off, count) + body))
            if (ack.offset, ack.count, ack.crc32) == (off, count, zlib.crc32(body)):
                break
        else:
            raise DisplayError(f"display: upload chunk at {off}: the device's checksum does "
                               f"not match after {retries + 1} attempts")
    ack = CommitAck(*link.ask(Cmd.UPLOAD_COMMIT, m.COMMIT_ACK, m.COMMIT.pack(zlib.crc32(raw))))
    if ack.clamped:
        raise SafetyLimitError(f"display: profile: the device clamped {ack.clamped} samples to "
                               f"its own range; refusing to play it")
    held = q.astype(float) / 100.0
    receipt = ProfileReceipt(points=ack.points, step_s=dt, crc32=ack.crc32, clamped=ack.clamped,
                             max_deviation_C=float(np.max(np.abs(held - y))), segments=None)
    return receipt, (dt, held.tolist())


def discard(link, min_dt_s: float) -> None:
    """Leave the device with no committed profile (best effort; never raises).

    An UPLOAD_BEGIN discards any profile on every device of this protocol; one of two samples
    at the smallest step that is never completed leaves nothing ARM could play (ARM in
    playback is then refused, PROFILE_INCOMPLETE, until a new commit).
    """
    dt_us = max(1000, int(round(min_dt_s * 1e6)))
    try:
        link.transact(Cmd.UPLOAD_BEGIN, m.UPLOAD_BEGIN.pack(2, dt_us), retries=1)
    except DisplayError:
        pass     # link gone: this host arms nothing without a new upload on a new connection
