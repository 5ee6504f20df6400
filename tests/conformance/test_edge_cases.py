"""The spec's edge cases, on both backends (frames by hand, ``raw``: a just powered-up device).

Each was a place where the firmware and the emulator disagreed, or where one of them broke:
a refused UPLOAD_BEGIN left the old profile playable (firmware), a partial frame was never
abandoned (emulator), the sim bench answered before a HELLO (both), a huge JSON exponent held
the firmware's bench for ~10^9 steps, and nonsense sim values were accepted (roughness −1, a
fault lasting 1e30 s, a JSON array for an object) or killed the emulator. Expected values are
the spec's (``docs/display-protocol.md``: §1, §3, requirement 2 of §6, the sim bench of §3/§9).
"""
from __future__ import annotations

import time
import zlib

import numpy as np
import pytest

from experiments.display.thermocue import messages as m
from experiments.display.thermocue.framing import encode_frame


def _hello(raw, seq):
    fr = raw.command(seq, m.Cmd.HELLO, m.HELLO_REQ.pack(2))
    assert fr is not None and fr.type == 0x81
    return fr


def _nak(fr, cmd, code):
    assert fr is not None, "no reply"
    assert fr.type == 0xFF, f"expected NAK {code.name}, got type 0x{fr.type:02x} {fr.payload!r}"
    assert m.NAK_HEAD.unpack_from(fr.payload) == (cmd, code), fr.payload


def _commit(raw, seq, values):
    v = np.asarray(values, dtype="<i2")
    assert raw.command(seq, m.Cmd.UPLOAD_BEGIN, m.UPLOAD_BEGIN.pack(len(v), 10000)).type == 0x90
    raw.command(seq + 1, m.Cmd.UPLOAD_CHUNK, m.UPLOAD_CHUNK_HEAD.pack(0, len(v)) + v.tobytes())
    fr = raw.command(seq + 2, m.Cmd.UPLOAD_COMMIT, m.COMMIT.pack(zlib.crc32(v.tobytes())))
    assert fr.type == 0x92


def test_a_refused_upload_begin_discards_the_committed_profile(raw):
    """§3: in IDLE, UPLOAD_BEGIN discards any committed profile, also when it refuses n or dt
    (the host's way of leaving a refused profile nowhere, §6)."""
    _hello(raw, 1)
    _commit(raw, 2, [3200] * 50)
    st = m.Status.decode(raw.command(5, m.Cmd.STATUS).payload)
    assert st.profile_points == 50
    _nak(raw.command(6, m.Cmd.UPLOAD_BEGIN, m.UPLOAD_BEGIN.pack(1, 10000)),
         m.Cmd.UPLOAD_BEGIN, m.Err.OUT_OF_RANGE)
    assert m.Status.decode(raw.command(7, m.Cmd.STATUS).payload).profile_points == 0
    _nak(raw.command(8, m.Cmd.ARM, m.ARM.pack(0, 200, 5000)), m.Cmd.ARM,
         m.Err.PROFILE_INCOMPLETE)


@pytest.mark.parametrize("cmd", [m.Cmd.SIM_SAMPLE, m.Cmd.SIM_FINGER, m.Cmd.SIM_FAULT],
                         ids=["SIM_SAMPLE", "SIM_FINGER", "SIM_FAULT"])
def test_sim_commands_before_hello_are_refused(raw, cmd):
    """Requirement 2: before a HELLO only HELLO, HEARTBEAT, STATUS, ABORT and CLEAR_FAULT."""
    payload = {m.Cmd.SIM_SAMPLE: dict(temperature_C=20.0),
               m.Cmd.SIM_FINGER: dict(press_after_s=0.1, force_N=2.0, hold_s=1.0),
               m.Cmd.SIM_FAULT: dict(spec="overtemp@100+1")}[cmd]
    _nak(raw.command(3, cmd, m.encode_json(payload)), cmd, m.Err.NO_HELLO)
    _hello(raw, 4)
    assert raw.command(5, cmd, m.encode_json(payload)).type == cmd | 0x80


def test_a_partial_frame_is_abandoned_after_0_2_s(raw):
    """§1: a candidate that never completes is abandoned after 0.2 s without progress. A header
    promising 1000 bytes, of which 10 came: the STATUS sent after the pause is answered (it is
    not swallowed as the rest of the dead frame)."""
    _hello(raw, 1)
    raw.port.write(encode_frame(9, m.Cmd.STATUS, bytes(1000))[:17])
    fr = None
    for seq in (20, 21, 22):                   # the device's 0.2 s is device time (QEMU may lag)
        time.sleep(0.6)
        fr = raw.command(seq, m.Cmd.STATUS, timeout_s=1.0)
        if fr is not None:
            break
    assert fr is not None and fr.type == 0xA2 and len(fr.payload) == m.STATUS_REPLY.size


def test_a_huge_json_exponent_is_refused_at_once(raw):
    """Sim JSON numbers are bounded: 1e999999999 is not a temperature (and costs no 10^9 steps)."""
    _hello(raw, 1)
    payload = b'{"temperature_C":1e999999999}'
    fr = raw.command(2, m.Cmd.SIM_SAMPLE, payload, timeout_s=3.0)
    _nak(fr, m.Cmd.SIM_SAMPLE, m.Err.BAD_ARGUMENT)
    fr = raw.command(3, m.Cmd.STATUS)                # still answering
    assert fr is not None and fr.type == 0xA2


NONSENSE = [
    (m.Cmd.SIM_SAMPLE, b'{"temperature_C":20.0,"roughness_m":-1}'),
    (m.Cmd.SIM_SAMPLE, b'{"temperature_C":20.0,"thickness_m":-0.003}'),
    (m.Cmd.SIM_SAMPLE, b'{"temperature_C":75.0}'),
    (m.Cmd.SIM_FINGER, b'{"press_after_s":0.1,"force_N":2.0,"hold_s":1e30}'),
    (m.Cmd.SIM_FINGER, b'{"press_after_s":-1,"force_N":2.0,"hold_s":1.0}'),
    (m.Cmd.SIM_FINGER, b'{"press_after_s":0.1,"force_N":"2","hold_s":1.0}'),
    (m.Cmd.SIM_FAULT, b'{"spec":"overtemp+1e30"}'),
    (m.Cmd.SIM_FAULT, b'{"spec":"overtemp@1e30"}'),
    (m.Cmd.SIM_FAULT, b'{"spec":"stuck_sensor@1+x"}'),
    (m.Cmd.SIM_SAMPLE, b'[20.0]'),
    (m.Cmd.SIM_FINGER, b'[1, 2, 3]'),
    (m.Cmd.SIM_FAULT, b'"overtemp"'),
    (m.Cmd.SIM_FINGER, b'7'),
]


@pytest.mark.parametrize("cmd,payload", NONSENSE, ids=[p.decode() for _, p in NONSENSE])
def test_nonsense_sim_values_are_refused(raw, cmd, payload):
    """A value the bench would never carry out, or not a JSON object: NAK BAD_ARGUMENT, and the
    device still answers (and is still idle, no fault injected)."""
    _hello(raw, 1)
    _nak(raw.command(2, cmd, payload), cmd, m.Err.BAD_ARGUMENT)
    st = m.Status.decode(raw.command(3, m.Cmd.STATUS).payload)
    assert st.state == "IDLE" and st.last_fault is None


def test_sensible_sim_values_are_still_accepted(raw):
    """The bounds refuse nonsense only: a half-space sample (thickness null), a day-long fault
    scheduled far ahead, a finger at the ends of its ranges."""
    _hello(raw, 1)
    for seq, cmd, payload in (
            (2, m.Cmd.SIM_SAMPLE, b'{"temperature_C":20.0,"roughness_m":1.6e-6,"thickness_m":null}'),
            (3, m.Cmd.SIM_SAMPLE, b'{"temperature_C":60,"thickness_m":3e-3}'),
            (4, m.Cmd.SIM_FINGER, b'{"press_after_s":0,"force_N":20,"hold_s":86400}'),
            (5, m.Cmd.SIM_FAULT, b'{"spec":"stuck_sensor@86000+400"}')):
        fr = raw.command(seq, cmd, payload)
        assert fr is not None and fr.type == cmd | 0x80, (payload, fr)
