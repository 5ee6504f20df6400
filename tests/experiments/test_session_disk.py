"""Write failures end a session cleanly.

Regression: a full disk or a folder turning read-only mid-session gave a traceback: the display
went neutral, but the clean-up itself raised again and ``session_error`` was never written.
The failures here are the kernel's own: a small tmpfs that fills up (ENOSPC, when this machine
lets us mount one) and a per-process file-size limit (EFBIG, everywhere).
"""
from __future__ import annotations

import csv
import os
import resource
import signal
import subprocess
import sys

import pytest

from _session_helpers import P01, ROOT, write_protocol

pytestmark = pytest.mark.slow


def _cli(args, limit_bytes=None):
    def pre():
        if limit_bytes is not None:
            signal.signal(signal.SIGXFSZ, signal.SIG_IGN)      # write() returns EFBIG instead
            resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, limit_bytes))
    env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1")
    return subprocess.run([sys.executable, "-m", "experiments", *map(str, args)], cwd=ROOT,
                          env=env, capture_output=True, text=True, timeout=300, preexec_fn=pre)


def _run_args(proto, data):
    return ["run", proto, "--participant", P01, "--display", "emulator://?clock=virtual&seed=1",
            "--responder", "simulated", "--data", data, "--seed", "1", "--quiet"]


def _check_stopped_then_resumed(session, proc, cause):
    err = proc.stderr.strip().splitlines()
    assert proc.returncode == 1, proc.stderr
    assert "Traceback" not in proc.stderr
    assert len(err) == 1 and cause in err[0] and str(session) in err[0], err
    assert "display neutral" in err[0] and "thermocue resume" in err[0]
    done = _cli(["resume", session, "--display", "emulator://?clock=virtual&seed=2",
                 "--responder", "simulated", "--quiet"])
    assert done.returncode == 0, done.stderr
    with open(session / "trials.csv", newline="") as fh:
        ok = [int(r["trial_index"]) for r in csv.DictReader(fh) if r["status"] == "ok"]
    assert sorted(ok) == [1, 2, 3, 4]


def test_a_file_size_limit_mid_session_ends_it_cleanly_and_it_resumes(tmp_path):
    proto = write_protocol(tmp_path, real_samples=())
    data = tmp_path / "data"
    proc = _cli(_run_args(proto, data), limit_bytes=12_000)   # a trace reaches it first
    session = data / "P01" / "S01"
    _check_stopped_then_resumed(session, proc, "file too large")
    events = (session / "events.jsonl").read_text()
    assert '"event": "session_error"' in events or '"event":"session_error"' in events


def _mount_tmpfs(path, size):
    if os.geteuid() != 0:
        return False
    path.mkdir(parents=True, exist_ok=True)
    return subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(path)],
                          capture_output=True).returncode == 0


def test_a_full_disk_mid_session_ends_it_cleanly_and_it_resumes(tmp_path):
    disk = tmp_path / "disk"
    if not _mount_tmpfs(disk, "48k"):
        pytest.skip("cannot mount a tmpfs here (needs root); the file-size test covers the path")
    try:
        proto = write_protocol(tmp_path, real_samples=())
        proc = _cli(_run_args(proto, disk / "data"))
        session = disk / "data" / "P01" / "S01"
        assert subprocess.run(["mount", "-o", "remount,size=4m", str(disk)]).returncode == 0
        _check_stopped_then_resumed(session, proc, "disk full")
    finally:
        subprocess.run(["umount", str(disk)])
