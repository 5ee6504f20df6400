import binascii
import struct

import pytest
from hypothesis import given, settings, strategies as st

from experiments.display.thermocue.framing import (HEADER_SIZE, MAX_PAYLOAD, OVERHEAD, SOF, Frame,
                                          FrameParser, crc8, crc16, encode_frame)


def test_crc16_ccitt_false_check_value():
    # the catalogue check value of CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF) for "123456789"
    assert crc16(b"123456789") == 0x29B1


def test_crc16_matches_a_bitwise_reference():
    def ref(data):
        crc = 0xFFFF
        for b in data:
            crc ^= b << 8
            for _ in range(8):
                crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else crc << 1
                crc &= 0xFFFF
        return crc
    for data in (b"", b"\x00", b"\xa5\x5a\x10\x00", bytes(range(256))):
        assert crc16(data) == ref(data)


def test_layout_of_one_frame():
    f = encode_frame(7, 0x22, b"\x01\x02")
    assert len(f) == 2 + OVERHEAD and HEADER_SIZE == 7
    assert f[:2] == SOF
    assert struct.unpack("<HBB", f[2:6]) == (2, 7, 0x22)
    assert f[6] == crc8(f[2:6])
    assert f[7:9] == b"\x01\x02"
    assert struct.unpack("<H", f[9:]) == (binascii.crc_hqx(f[2:9], 0xFFFF),)


def test_crc8_matches_a_bitwise_reference():
    # CRC-8/SMBUS: poly 0x07, init 0, no reflection, no final xor; catalogue check value 0xF4
    def ref(data):
        crc = 0
        for b in data:
            crc ^= b
            for _ in range(8):
                crc = ((crc << 1) ^ 0x07) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
        return crc
    assert crc8(b"123456789") == ref(b"123456789") == 0xF4
    for data in (b"", b"\x00", b"\x01\x00\x00\x02", bytes(range(256))):
        assert crc8(data) == ref(data)
    # every error of up to 3 bits in a 4-byte header changes the check
    import itertools
    head = b"\x01\x00\x07\x02"
    for k in (1, 2, 3):
        for bits in itertools.combinations(range(32), k):
            h = bytearray(head)
            for b in bits:
                h[b // 8] ^= 1 << (b % 8)
            assert crc8(bytes(h)) != crc8(head), bits


def test_encode_refuses_bad_fields():
    with pytest.raises(ValueError, match="payload"):
        encode_frame(0, 1, bytes(MAX_PAYLOAD + 1))
    with pytest.raises(ValueError, match="seq"):
        encode_frame(256, 1)


def test_one_flipped_bit_loses_only_that_frame():
    frames = [encode_frame(i, 0xA0, bytes([i]) * 30) for i in range(5)]
    stream = bytearray(b"".join(frames))
    stream[len(frames[0]) + 10] ^= 0x04          # inside frame 1's payload
    p = FrameParser()
    got = p.feed(bytes(stream))
    assert [f.seq for f in got] == [0, 2, 3, 4]
    assert p.bad_frames >= 1


def test_a_frame_ending_in_the_marker_byte_leaves_nothing_behind():
    # regression (found by hypothesis): a CRC ending in 0xA5 was kept as a possible marker,
    # which made bytes_skipped negative
    f = next(encode_frame(s, 1, b"x") for s in range(256) if encode_frame(s, 1, b"x")[-1] == 0xA5)
    p = FrameParser()
    assert len(p.feed(f)) == 1 and p.buffered == 0 and p.bytes_skipped == 0


def test_a_frame_that_never_completes_is_abandoned_on_timeout():
    # a frame whose rest never comes (the link dropped it) holds the parser until the driver
    # gives up on it; what followed is then found in what the parser holds
    real = encode_frame(1, 0x81, b"ok")
    cut = encode_frame(9, 0x11, bytes(900))[:HEADER_SIZE + 10]
    p = FrameParser()
    assert p.feed(cut + real) == []
    assert p.drop_candidate() == [Frame(1, 0x81, b"ok")]
    assert p.bytes_skipped == len(cut) and p.buffered == 0


@pytest.mark.parametrize("bit", range(16, 8 * HEADER_SIZE))     # length, seq, type, hcrc
def test_a_flipped_header_bit_is_rejected_at_once(bit):
    # a flipped bit in the length (or seq, type) must not make the receiver wait for up to
    # 1100 bytes before the CRC check: the device's watchdog fires meanwhile (audit 34)
    bad = bytearray(encode_frame(0, 0x02, b"\x00"))
    bad[bit // 8] ^= 1 << (bit % 8)
    good = encode_frame(0, 0x02, b"\x00")
    p = FrameParser()
    assert p.feed(bytes(bad) + good) == [Frame(0, 0x02, b"\x00")]
    assert p.bytes_skipped == len(bad) and p.buffered == 0 and p.bad_frames >= 1


frames_st = st.lists(st.tuples(st.integers(0, 255), st.integers(0, 255), st.binary(max_size=64)),
                     max_size=12)


@settings(max_examples=300, deadline=None)
@given(frames=frames_st, cuts=st.lists(st.integers(0, 2000), max_size=8))
def test_round_trip_whatever_the_chunking(frames, cuts):
    stream = b"".join(encode_frame(*f) for f in frames)
    p = FrameParser()
    out, pos = [], 0
    for c in sorted(set(min(c, len(stream)) for c in cuts)) + [len(stream)]:
        out += p.feed(stream[pos:c])
        pos = c
    assert out == [Frame(*f) for f in frames]
    assert p.bytes_skipped == 0 and p.bad_frames == 0


@settings(max_examples=300, deadline=None)
@given(data=st.binary(max_size=3000))
def test_never_raises_on_arbitrary_bytes(data):
    p = FrameParser()
    decoded = 0
    for i in range(0, len(data), 97):
        for fr in p.feed(data[i:i + 97]):
            assert 0 <= fr.seq <= 255 and len(fr.payload) <= MAX_PAYLOAD
            decoded += len(fr.payload) + OVERHEAD
        # every byte fed is in a decoded frame, skipped, or still buffered
        assert decoded + p.bytes_skipped + p.buffered == min(i + 97, len(data))


@settings(max_examples=300, deadline=None)
@given(frames=frames_st, junk=st.lists(st.binary(min_size=1, max_size=40), max_size=12))
def test_resynchronises_after_garbage_between_frames(frames, junk):
    # garbage between frames: every frame is recovered, in order (garbage that happens to form a
    # valid frame -- probability ~2^-16 per candidate -- would show up as an extra frame)
    parts = []
    for i, f in enumerate(frames):
        if i < len(junk):
            parts.append(junk[i])
        parts.append(encode_frame(*f))
    parts.append(b"\xa5" * 3)                      # trailing marker fragments
    parts += [encode_frame(0, 0, b"end")] * 3        # padding lets stalled candidates finish
    p = FrameParser()
    got = p.feed(b"".join(parts))
    while p.buffered:
        got += p.drop_candidate()
    want = [Frame(*f) for f in frames] + [Frame(0, 0, b"end")] * 3
    it = iter(got)
    assert all(any(g == w for g in it) for w in want)   # want is a subsequence of got


no_marker = st.binary(min_size=1, max_size=40).map(lambda b: b.replace(b"\xa5", b"\x00"))


@settings(max_examples=300, deadline=None)
@given(frames=frames_st, junk=st.lists(st.one_of(no_marker, st.tuples(frames_st, st.integers(0))),
                                       max_size=12))
def test_skips_exactly_the_bytes_injected(frames, junk):
    # between the frames: garbage (no marker byte in it) or a frame with one bit flipped in its
    # payload or CRC; the parser must skip exactly those bytes and decode every real frame
    parts, injected = [], 0
    for i, f in enumerate(frames):
        if i < len(junk):
            j = junk[i]
            if isinstance(j, tuple):
                fs, k = j
                seq, typ, pl = fs[0] if fs else (1, 2, b"x")
                damaged = bytearray(encode_frame(seq, typ, pl))
                k %= 8 * (len(damaged) - HEADER_SIZE)
                damaged[HEADER_SIZE + k // 8] ^= 1 << (k % 8)
                j = bytes(damaged)
            parts.append(j)
            injected += len(j)
        parts.append(encode_frame(*f))
    parts += [encode_frame(0, 0, b"end")] * 3        # lets a candidate inside the junk finish
    p = FrameParser()
    stream = b"".join(parts)
    got = []
    for i in range(0, len(stream), 61):
        got += p.feed(stream[i:i + 61])
    while p.buffered:
        got += p.drop_candidate()
    assert got == [Frame(*f) for f in frames] + [Frame(0, 0, b"end")] * 3
    assert p.bytes_skipped == injected
