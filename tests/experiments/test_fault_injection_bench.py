"""The fault-injection benchmark (benchmarks/fault_injection.py) cannot rot: its fast attacks on
the in-process emulator and the TCS II emulator on a pty run here (two real ``thermocue run``
hosts at once, one trial on the emulator), the QEMU ones with the slow tests; every count is 0
and each attack did what it claims (the fault reached a trial: it is not ``ok``)."""
from __future__ import annotations

import shutil
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))
import fault_injection as fi  # noqa: E402


def _attack(backend, name):
    return next(a for a in fi.ATTACKS if (a.backend, a.name) == (backend, name))


def _clean(r):
    assert {k: r[k] for k in fi.COUNTS} == {k: 0 for k in fi.COUNTS}, r["notes"]


@pytest.mark.slow      # two whole sessions in subprocesses: 24 s at load 17
def test_the_benchmark_s_fast_attacks_count_nothing_unsafe(tmp_path):
    quick = [a for a in fi.ATTACKS if a.quick]
    assert {a.backend for a in quick} == {"emulator", "tcs2"}
    with ThreadPoolExecutor(len(quick)) as pool:
        results = list(pool.map(lambda a: fi.run_attack(a, tmp_path / a.backend, (1,)), quick))
    for a, r in zip(quick, results):
        _clean(r)
        # the fault hit: the attacked attempt faulted, so fewer ok than attempts, exit 1 or a retry
        assert r["attempts"] > r["ok"], (a.name, r)


def test_the_judge_counts_a_commanded_jump_and_an_out_of_range_target():
    lim = {"min_C": 15.0, "max_C": 42.0, "rate": 10.0}
    ok = [{"time_s": f"{i / 100:.2f}", "target_C": f"{32 + 0.1 * i:.2f}"} for i in range(50)]
    assert fi.commanded_violations(ok, lim) == 0                   # 10 °C/s exactly
    jump = ok[:10] + [{"time_s": "0.10", "target_C": "34.0"}]      # 2 °C in 10 ms
    assert fi.commanded_violations(jump, lim) == 1
    assert fi.commanded_violations([{"time_s": "0", "target_C": "42.5"}], lim) == 1
    tripped = ok[:10] + [{"time_s": "0.10", "target_C": "32.0", "state": "FAULT"}]
    assert fi.commanded_violations(tripped, lim) == 0      # the device's own safe state


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("qemu-system-arm") is None, reason="qemu-system-arm missing")
def test_the_benchmark_on_the_c_firmware_under_qemu_kills_the_host_and_leaves_no_orphan(tmp_path):
    r = fi.run_attack(_attack("qemu", "host_sigkill"), tmp_path / "qemu", (1,))
    _clean(r)
    assert r["exit"] == -9, r            # killed mid-session, QEMU running: none of it survived
    assert list((tmp_path / "qemu" / "data").glob("*/*/events.jsonl")), "no session started"
