"""Every reply is decoded by one checked decoder: a reply of the wrong size or with an unknown
value is a ``BAD_REPLY`` naming the command, never ``struct.error`` or ``ValueError``.

Attacks: the real emulator behind a real pty whose replies are rewritten (``_device_proxy``):
a 1-byte NAK, a short STATUS, an unknown state byte, short SET_LIMITS / SET_NEUTRAL /
UPLOAD_CHUNK acks; at the handshake, during an upload, mid-trial, and through
``thermocue clear-fault``.
"""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from _device_proxy import FrameProxy, start_emulator, stop
from experiments.display import open_display
from experiments.display.thermocue import messages as m
from experiments.errors import DisplayError

R = m.REPLY_BIT
T = np.arange(0, 0.5001, 0.01)


def _keep(fr):
    return [(fr.seq, fr.type, fr.payload)]


def _on(reply_of, change):
    """Rewrite the replies to one command with ``change(payload) -> (type, payload)``."""
    def rewrite(fr):
        if fr.type == reply_of | R and not (reply_of == m.Cmd.ARM and len(fr.payload) != 4):
            t, p = change(fr.payload)
            return [(fr.seq, t, p)]
        return _keep(fr)
    return rewrite


ATTACKS = {
    "nak_1_byte": (m.Cmd.SET_NEUTRAL, lambda p: (m.Msg.NAK, bytes([m.Cmd.SET_NEUTRAL])), "SET_NEUTRAL"),
    "short_status": (m.Cmd.STATUS, lambda p: (m.Cmd.STATUS | R, p[:-3]), "STATUS"),
    "unknown_state": (m.Cmd.STATUS, lambda p: (m.Cmd.STATUS | R, bytes([9]) + p[1:]), "STATUS"),
    "short_set_limits": (m.Cmd.SET_LIMITS, lambda p: (m.Cmd.SET_LIMITS | R, p[:4]), "SET_LIMITS"),
    "short_set_neutral": (m.Cmd.SET_NEUTRAL, lambda p: (m.Cmd.SET_NEUTRAL | R, p[:1]), "SET_NEUTRAL"),
}


@pytest.fixture(scope="module")
def emulator(tmp_path_factory):
    proc, path = start_emulator(tmp_path_factory.mktemp("emu"))
    yield path
    stop(proc)


def _one_line_bad_reply(exc, command):
    msg = str(exc)
    assert "\n" not in msg and command in msg and "reply the protocol does not have" in msg \
        or f"{command}: a NAK of 1 byte" in msg, msg
    assert getattr(exc, "code", None) == "BAD_REPLY"


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(ATTACKS))
def test_a_bad_reply_at_the_handshake_is_one_line_naming_the_command(emulator, name):
    cmd, change, command = ATTACKS[name]
    with FrameProxy(emulator, _on(cmd, change)) as dev:
        with pytest.raises(DisplayError) as exc:
            open_display(dev.path).close()
    _one_line_bad_reply(exc.value, command)


@pytest.mark.slow
def test_a_short_upload_chunk_ack_refuses_the_upload(emulator):
    with FrameProxy(emulator, _on(m.Cmd.UPLOAD_CHUNK, lambda p: (m.Cmd.UPLOAD_CHUNK | R, p[:6]))) as dev:
        with open_display(dev.path) as d:
            with pytest.raises(DisplayError) as exc:
                d.upload_profile(T, np.full(T.size, 31.0))
            _one_line_bad_reply(exc.value, "UPLOAD_CHUNK")
            with pytest.raises(Exception):      # nothing playable was kept
                d.arm("playback")


class _Switch:
    """Rewrite STATUS replies only while ``on`` (the attack starts mid-session)."""

    def __init__(self, change):
        self.on, self.change = False, change

    def __call__(self, fr):
        if self.on and fr.type == m.Cmd.STATUS | R:
            t, p = self.change(fr.payload)
            return [(fr.seq, t, p)]
        return _keep(fr)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["short_status", "unknown_state"])
def test_a_bad_status_mid_trial_faults_the_trial_and_leaves_the_pad_neutral(emulator, name):
    sw = _Switch(ATTACKS[name][1])
    with FrameProxy(emulator, sw) as dev, open_display(dev.path) as d:
        d.upload_profile(T, np.full(T.size, 31.0))
        for _ in range(4):           # a loaded machine may trip the watchdog: a trial that ends
            d.arm("playback", max_duration_s=5.0)
            d.sim_finger(press_after_s=0.05, hold_s=5.0)
            sw.on = True              # the trial's closing STATUS is the bad one
            rec = d.run_trial(timeout_s=10.0)
            sw.on = False
            if rec.fault_code != "WATCHDOG":
                break
        assert rec.status == "fault" and rec.fault_code == "BAD_REPLY", rec
        assert "STATUS" in rec.fault_message
        d.wait(0.1)
        st = d.status()
        assert st.state == "IDLE" and abs(st.setpoint_C - 32.0) < 1.5   # ABORT: back to neutral


@pytest.mark.slow
@pytest.mark.parametrize("name", ["short_status", "unknown_state"])
def test_clear_fault_on_a_bad_status_is_one_line(emulator, name):
    cmd, change, command = ATTACKS[name]
    with FrameProxy(emulator, _on(cmd, change)) as dev:
        r = subprocess.run([str(Path(sys.executable).with_name("thermocue")), "clear-fault", dev.path, "--yes"],
                           capture_output=True, text=True, timeout=60)
    assert r.returncode == 1, (r.stdout, r.stderr)
    assert "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert "STATUS" in r.stderr and "reply the protocol does not have" in r.stderr
