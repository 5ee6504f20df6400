"""Fault injection over the three backends: does a lying device get anything unsafe or untrue through?

One concept: attacks on ``emulator://`` (the Python emulator, in process), the thermocue protocol on
a pty (``thermocue emulator``, behind a proxy that rewrites its frames: a device that lies),
``qemu-firmware://`` (the C firmware under QEMU) and ``tcs2://`` (the TCS II emulator on a pty);
each attack runs a real ``thermocue run`` process with a short protocol, and counts:

* ``safety``: a commanded temperature (every trace's ``target_C``) outside the protocol's
  ``[display] min_C``-``max_C`` or changing within any 0.1 s by more than ``max_rate_C_per_s`` ×
  0.1 s + 0.01 °C (the protocol's rate window), a second host that could open the device's port while the session held it, or a trial
  logged ``ok`` during which the device lost its host or tripped a limit (the thermocue emulators:
  their own logs name how each contact ended; a lying device: no trial may be ok; the TCS II: an
  ok trial whose trace reads above ``max_C``);
* ``undelivered_ok``: an ``ok`` trial without telemetry covering its contact (no trace, no frames,
  no tracking value, or a trace shorter than 90 % of the contact it logs);
* ``tracebacks`` (``Traceback`` on the host's stderr), ``hangs`` (a host still running after
  ``HANG_S``), ``orphans`` (a process started by the host still alive 5 s after the host ended,
  found by an environment marker in ``/proc``; the host is also killed with SIGKILL and SIGHUP).

Usage::

    nice .venv/bin/python benchmarks/fault_injection.py --out DIR [--only NAME ...] [--quick]

Prints a table (one row per attack) and writes ``DIR/fault_injection.json``. Exit status 0 when
every count is 0. ``--quick`` runs the fast subset the default test suite runs
(``tests/experiments/test_fault_injection_bench.py``).
"""
from __future__ import annotations

import argparse
import csv
import json
import math
import os
import signal
import subprocess
import sys
import time
import uuid
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests" / "experiments"))
sys.path.insert(0, str(ROOT / "benchmarks"))
from _session_helpers import write_protocol  # noqa: E402  (the session tests' short protocol)

P01 = ROOT / "participants" / "examples" / "P01.json"
HANG_S = 240.0
COUNTS = ("safety", "undelivered_ok", "tracebacks", "hangs", "orphans")


@dataclass
class Attack:
    """One attack: ``backend`` kind, ``name``, what it does, and its parameters."""

    backend: str                 # emulator | thermocue-pty | qemu | tcs2
    name: str
    what: str
    faults: str = ""             # the emulator's fault SPEC (URL or --faults)
    lie: str = ""                # thermocue-pty: the proxy's rewrite (see LIES)
    kill: int = 0                # a signal sent to the host mid-session (0: none)
    second_host: bool = False    # a second program opens the port while the session holds it
    quick: bool = False          # in the default suite's subset
    ok_allowed: bool = True      # False: the device lies on every trial, no trial may be ok


ATTACKS = [
    Attack("emulator", "clean", "no fault (the baseline)"),
    Attack("emulator", "disconnect_once", "the link drops at 3 s (once: the retry is ok)",
           faults="disconnect@3"),
    Attack("emulator", "disconnect_every", "the link drops 3 s into every connection",
           faults="disconnect@3*"),
    Attack("emulator", "stall", "the firmware hangs 1 s mid-trial (watchdog)", faults="stall@3+1"),
    Attack("emulator", "overtemp", "the Peltier driver sticks at full heating for 2 s",
           faults="overtemp@2+2", quick=True),
    Attack("emulator", "overtemp_dead_relay", "heating stuck and a relay that never opens",
           faults="overtemp@3+2,dead_relay"),
    Attack("emulator", "late_watchdog", "the watchdog trips after 2 s of silence, not 90 ms",
           faults="late_watchdog=2,stall@3+0.5"),
    Attack("emulator", "sensor_range", "the contact sensor reads 150 °C for 0.3 s",
           faults="sensor_range@3+0.3"),
    Attack("emulator", "stuck_sensor", "the contact sensor freezes for 0.3 s",
           faults="stuck_sensor@3+0.3"),
    Attack("emulator", "reboot", "the device power-cycles at 3 s", faults="reboot@3"),
    Attack("emulator", "noisy_link", "drops, bit flips and junk on the line",
           faults="drop=0.002,corrupt=0.001,garbage=0.05"),
    Attack("thermocue-pty", "short_status", "every STATUS reply 3 bytes short", lie="short_status",
           ok_allowed=False),
    Attack("thermocue-pty", "unknown_state", "every STATUS reply with state byte 9",
           lie="unknown_state", ok_allowed=False),
    Attack("thermocue-pty", "absurd_temperature", "telemetry says the pad is at 200 °C",
           lie="absurd_temperature", ok_allowed=False),
    Attack("thermocue-pty", "silent_telemetry", "the device plays but never streams",
           lie="no_telemetry", ok_allowed=False),
    Attack("thermocue-pty", "second_host", "another program opens the port mid-session",
           second_host=True),
    Attack("thermocue-pty", "host_sigkill", "the host is killed (SIGKILL) mid-session",
           kill=signal.SIGKILL),
    Attack("emulator", "host_sighup_real_clock", "SIGHUP of a host on the real clock (heartbeat "
           "helper)", kill=signal.SIGHUP),
    Attack("qemu", "clean", "the C firmware under QEMU, no fault"),
    Attack("qemu", "host_sigkill", "the host is killed (SIGKILL) mid-session", kill=signal.SIGKILL),
    Attack("qemu", "host_sighup", "the host gets SIGHUP mid-session", kill=signal.SIGHUP),
    Attack("tcs2", "clean", "the TCS II emulator, no fault"),
    Attack("tcs2", "overheat", "zone 3 heats towards 55 °C 0.5 s into stimulation 1",
           faults="overheat@1:0.5:3", quick=True),
    Attack("tcs2", "runon", "stimulation 1 goes on at 50 °C for 14 s after its profile",
           faults="runon@1:0"),
    Attack("tcs2", "silence", "the device falls silent 0.5 s into stimulation 2",
           faults="silent@2:0.5"),
    Attack("tcs2", "disconnect", "the port fails 0.5 s into stimulation 1",
           faults="disconnect@1:0.5"),
    Attack("tcs2", "halfline_garbage", "half lines, binary junk, unknown lines, a zone error",
           faults="halfline@1:0.5,garbage@2:0.3,unknown@3:0.2,zone@4:0.5:2"),
    Attack("tcs2", "om_cap", "the device holds a lower maximum than the host asks for",
           faults="om_cap=40"),
    Attack("tcs2", "second_host", "another program opens the port mid-session", second_host=True),
    Attack("tcs2", "host_sigkill", "the host is killed (SIGKILL) mid-session", kill=signal.SIGKILL),
]


# --------------------------------------------------------------------------- protocols
def tcs2_protocol(folder: Path) -> Path:
    """The TCS II protocol cut short: 4 simulated trials of 2 s, no rewarm."""
    text = (ROOT / "experiments" / "protocols" / "roughness_recognition_tcs2.toml").read_text()
    for old, new in (("max_contact_s = 20.0", "max_contact_s = 2.0"),
                     ("record_s = 20.0", "record_s = 2.0"), ("rewarm_s = 30.0", "rewarm_s = 0.0"),
                     ("duration_s = 20.0", "duration_s = 2.0"), ("repetitions = 6", "repetitions = 1"),
                     ('name = "roughness_recognition_tcs2"', 'name = "fib_tcs2"')):
        assert old in text, old
        text = text.replace(old, new)
    head, _, rest = text.partition('[[blocks]]\nname = "familiarise"')
    text = head + rest[rest.index("[[blocks]]"):]
    path = folder / "tcs2.toml"
    path.write_text(text, encoding="utf-8")
    return path


def limits_of(proto: Path) -> dict:
    import tomllib
    d = tomllib.loads(proto.read_text())["display"]
    return {"min_C": d["min_C"], "max_C": d["max_C"], "rate": d["max_rate_C_per_s"]}


# --------------------------------------------------------------------------- processes
def _marked(marker: str) -> list:
    """PIDs of live processes whose environment holds ``FIB_MARK=marker``."""
    needle = f"FIB_MARK={marker}".encode()
    out = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/environ", "rb") as fh:
                env = fh.read()
            with open(f"/proc/{entry}/stat") as fh:
                state = fh.read().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if needle in env.split(b"\0") and state != "Z":
            out.append(int(entry))
    return out


def start_server(folder: Path, *args) -> tuple:
    """``thermocue emulator ARGS`` on a pty (not marked: the benchmark's, not the host's)."""
    proc = subprocess.Popen([sys.executable, "-m", "experiments", "emulator", "--quiet", *args],
                            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    path = proc.stdout.readline().strip()
    if not path.startswith("/dev/"):
        proc.kill()
        raise RuntimeError(f"emulator did not start: {proc.stderr.read()[-300:]}")
    return proc, path


def stop(proc) -> None:
    if proc is not None and proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def second_host(url: str) -> bool:
    """Whether another program could open ``url`` (it must be refused while a session holds it)."""
    code = ("import sys\nfrom experiments.display import open_display\nfrom experiments.errors "
            "import DisplayError\ntry:\n    d = open_display(sys.argv[1])\nexcept DisplayError:\n"
            "    sys.exit(3)\nd.close()\nsys.exit(0)\n")
    p = subprocess.run([sys.executable, "-c", code, url], cwd=ROOT, capture_output=True, text=True,
                       timeout=60)
    return p.returncode == 0


def run_host(attack: Attack, proto: Path, url: str, data: Path, counts: dict, notes: list) -> None:
    """``thermocue run`` as its own process: hang, traceback and orphan counts, the attack's signal
    or second host while it runs."""
    marker = uuid.uuid4().hex
    env = dict(os.environ, FIB_MARK=marker, PYTHONDONTWRITEBYTECODE="1")
    clock = ("real" if attack.name == "host_sighup_real_clock" or attack.backend == "qemu"
             or attack.lie else "virtual")
    argv = [sys.executable, "-m", "experiments", "run", str(proto), "--participant", str(P01),
            "--display", url, "--responder", "simulated", "--data", str(data), "--clock", clock,
            "--quiet"]
    host = subprocess.Popen(argv, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    try:
        if attack.kill or attack.second_host:
            _wait_for_trial(data, host, 120.0)
            if attack.second_host and host.poll() is None and second_host(url):
                counts["safety"] += 1
                notes.append("a second host opened the port while the session held it")
            if attack.kill and host.poll() is None:
                host.send_signal(attack.kill)
        try:
            _, err = host.communicate(timeout=HANG_S)
        except subprocess.TimeoutExpired:
            counts["hangs"] += 1
            notes.append(f"host still running after {HANG_S:g} s")
            host.kill()
            _, err = host.communicate()
    finally:
        if host.poll() is None:
            host.kill()
            host.wait()
    if "Traceback" in (err or ""):
        counts["tracebacks"] += 1
        notes.append("traceback: " + err.strip().splitlines()[-1][:200])
    deadline = time.monotonic() + 5.0
    left = _marked(marker)
    while left and time.monotonic() < deadline:
        time.sleep(0.1)
        left = _marked(marker)
    if left:
        counts["orphans"] += len(left)
        notes.append(f"orphans after the host ended: {left}")
        for pid in left:
            try:
                os.kill(pid, signal.SIGKILL)
            except OSError:
                pass
    counts["exit"] = host.returncode


def _wait_for_trial(data: Path, host, limit_s: float) -> None:
    """Until the session's first trial has started (its events log names it)."""
    deadline = time.monotonic() + limit_s
    while time.monotonic() < deadline and host.poll() is None:
        for ev in data.glob("*/*/events.jsonl"):
            if '"trial_started"' in ev.read_text(errors="replace"):
                time.sleep(0.3)
                return
        time.sleep(0.1)


# --------------------------------------------------------------------------- the session's record
def _rows(session: Path) -> list:
    path = session / "trials.csv"
    if not path.exists():
        return []
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def _trace(session: Path, name: str) -> list:
    if not name or not (session / name).exists():
        return []
    with open(session / name, newline="") as fh:
        return list(csv.DictReader(fh))


def _num(x) -> float:
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan


def commanded_violations(trace: list, lim: dict) -> int:
    """Samples of ``target_C`` outside the safe range, or changing by more than the rate limit
    × 0.1 s + 0.01 °C within any 0.1 s (the protocol's rate window, docs/display-protocol.md);
    samples in FAULT are not commanded ones."""
    # in FAULT the relay is open and the device drops its set-point to neutral at once: a safe
    # state, not a commanded change (those samples are left out)
    trace = [r for r in trace if r.get("state") != "FAULT"]
    t = [_num(r.get("time_s")) for r in trace]
    y = [_num(r.get("target_C")) for r in trace]
    bad = sum(1 for v in y if math.isfinite(v) and not lim["min_C"] - 1e-9 <= v <= lim["max_C"] + 1e-9)
    j = 0
    for i in range(len(y)):
        while j < i and t[i] - t[j] > 0.1 + 1e-9:
            j += 1
        for k in range(j, i):
            if all(map(math.isfinite, (y[i], y[k], t[i], t[k]))) and \
                    abs(y[i] - y[k]) > lim["rate"] * 0.1 + 0.01 + 1e-9:
                bad += 1
                break
    return bad


def judge_session(attack: Attack, data: Path, lim: dict, counts: dict, notes: list,
                  device_log: Path | None) -> None:
    """Count the session's safety violations and undelivered ``ok`` trials."""
    sessions = sorted(data.glob("*/*/trials.csv"))
    if not sessions:
        return
    session = sessions[0].parent
    rows = _rows(session)
    counts["attempts"] = len(rows)
    counts["ok"] = sum(r["status"] == "ok" for r in rows)
    for r in rows:
        trace = _trace(session, r.get("trace_file", ""))
        n = commanded_violations(trace, lim)
        if n:
            counts["safety"] += 1
            notes.append(f"trial {r['trial_index']} attempt {r['attempt']}: {n} commanded samples "
                         f"outside the range or rate")
        if r["status"] != "ok":
            continue
        contact = _num(r.get("contact_duration_s"))
        t = [_num(x.get("time_s")) for x in trace]
        span = (max(t) - min(t)) if t else 0.0
        if not trace or _num(r.get("frames")) < 1 or not math.isfinite(_num(r.get("tracking_max_C"))) \
                or (math.isfinite(contact) and span < 0.9 * contact - 0.02):
            counts["undelivered_ok"] += 1
            notes.append(f"trial {r['trial_index']} ok without telemetry covering its contact "
                         f"(frames {r.get('frames')}, trace {span:.2f} s of {contact} s)")
        if not attack.ok_allowed:
            counts["safety"] += 1
            notes.append(f"trial {r['trial_index']} ok from a device that lies on every trial")
        hot = [_num(x.get("contact_C")) for x in trace]
        if any(v > lim["max_C"] + 0.5 for v in hot if math.isfinite(v)):
            counts["safety"] += 1
            notes.append(f"trial {r['trial_index']} ok with the probe at {max(hot):.1f} °C")
    if device_log is not None and device_log.exists():
        _against_device_log(session, rows, device_log, counts, notes)


def _against_device_log(session: Path, rows: list, log: Path, counts: dict, notes: list) -> None:
    """Every ok trial is a contact the device ended itself (complete, released, max duration)."""
    from fault_campaign import device_trials, ok_rows_by_run
    by_run = ok_rows_by_run(session)
    for run_log, ti, att, t in by_run:
        ends = device_trials(Path(run_log) if run_log else log)
        t = None if t is None else float(t)
        end = None if t is None else next((v for k, v in ends.items() if abs(k - t) <= 0.011), None)
        if end != "end":
            counts["safety"] += 1
            notes.append(f"trial {ti} attempt {att} ok; the device ended that contact {end!r}")


# --------------------------------------------------------------------------- the lying device
def lie(kind: str):
    """The proxy's rewrite: a thermocue device whose frames lie (short replies, absurd values,
    no telemetry)."""
    from experiments.display.thermocue import messages as m
    R = m.REPLY_BIT

    def rewrite(fr):
        keep = [(fr.seq, fr.type, fr.payload)]
        if kind == "short_status" and fr.type == m.Cmd.STATUS | R:
            return [(fr.seq, fr.type, fr.payload[:-3])]
        if kind == "unknown_state" and fr.type == m.Cmd.STATUS | R:
            return [(fr.seq, fr.type, bytes([9]) + fr.payload[1:])]
        if kind in ("absurd_temperature", "no_telemetry") and fr.type == m.Msg.TELEMETRY \
                and len(fr.payload) == m.TELEMETRY.size:
            if kind == "no_telemetry":
                return []
            return [(fr.seq, fr.type, _hot(m, fr.type, fr.payload))]
        return keep
    return rewrite


def _hot(m, typ, payload: bytes) -> bytes:
    """A telemetry frame whose contact temperature reads 200 °C (the rest unchanged)."""
    fields = list(m.TELEMETRY.unpack(payload))
    fields[3] = 20000                             # contact, centi-°C
    return m.TELEMETRY.pack(*fields)


# --------------------------------------------------------------------------- one attack
def run_attack(attack: Attack, folder: Path, samples=(1, 2, 3)) -> dict:
    """Set the device up, run the host, judge what it logged; the attack's counts and notes."""
    folder.mkdir(parents=True, exist_ok=True)
    counts = {k: 0 for k in COUNTS}
    notes: list = []
    servers, proxy, device_log = [], None, None
    t0 = time.monotonic()
    try:
        if attack.backend == "tcs2":
            proto = tcs2_protocol(folder)
            args = ["--model", "tcs2", "--speed", "10", "--seed", "3"]
            if attack.faults:
                args += ["--faults", attack.faults]
            proc, path = start_server(folder, *args)
            servers.append(proc)
            url = f"tcs2://{path}"
        else:
            proto = write_protocol(folder, contact_s=1.0, real_samples=(), sim_samples=samples)
            if attack.backend == "emulator":
                device_log = folder / "device.jsonl"
                clock = "real" if attack.kill else "virtual"
                url = (f"emulator://?clock={clock}&seed=7&log={device_log}"
                       + (f"&faults={attack.faults}" if attack.faults else ""))
            elif attack.backend == "qemu":
                url = "qemu-firmware://"
            else:                                   # the thermocue protocol on a pty
                device_log = folder / "device.jsonl"
                # behind the proxy (a thread of this process) the device runs on the real clock: a
                # virtual-clock pty races ahead of a host whose heartbeats the proxy delays
                proc, path = start_server(folder, "--clock", "real" if attack.lie else "virtual",
                                          "--log", str(device_log))
                servers.append(proc)
                url = path
                if attack.lie:
                    from experiments.emulators.thermocue.frame_proxy import FrameProxy
                    proxy = FrameProxy(path, lie(attack.lie))
                    url = proxy.path
        lim = limits_of(proto)
        data = folder / "data"
        run_host(attack, proto, url, data, counts, notes)
        judge_session(attack, data, lim, counts, notes,
                      device_log if attack.backend == "emulator" else None)
        if attack.backend == "thermocue-pty" and device_log is not None and not attack.lie:
            _pty_against_log(data, device_log, counts, notes)
    finally:
        if proxy is not None:
            proxy.close()
        for proc in servers:
            stop(proc)
    counts["seconds"] = round(time.monotonic() - t0, 1)
    return {"backend": attack.backend, "attack": attack.name, "what": attack.what, **counts,
            "notes": notes}


def _pty_against_log(data: Path, log: Path, counts: dict, notes: list) -> None:
    """On a pty the device's log is the server's: every ok contact ended by the device itself."""
    from fault_campaign import device_trials
    sessions = sorted(data.glob("*/*/trials.csv"))
    if not sessions:
        return
    ends = device_trials(log)
    for r in _rows(sessions[0].parent):
        if r["status"] != "ok":
            continue
        t = _num(r.get("contact_onset_s"))
        end = next((v for k, v in ends.items() if abs(k - t) <= 0.011), None)
        if end != "end":
            counts["safety"] += 1
            notes.append(f"trial {r['trial_index']} ok; the device ended that contact {end!r}")


def machine() -> str:
    import platform
    cpu = next((ln.split(":", 1)[1].strip() for ln in open("/proc/cpuinfo")
                if ln.startswith("model name")), platform.processor())
    return (f"{cpu} x{os.cpu_count()}, {platform.system()} {platform.release()}, Python "
            f"{platform.python_version()}, load {os.getloadavg()[0]:.2f}")


def table(results: list) -> str:
    head = ("| backend | attack | attempts | ok | exit | " + " | ".join(COUNTS) + " | s |\n"
            "|---|---|---:|---:|---:|" + "---:|" * len(COUNTS) + "---:|")
    lines = [head]
    for r in results:
        lines.append(f"| {r['backend']} | {r['attack']} | {r.get('attempts', 0)} | {r.get('ok', 0)} "
                     f"| {r.get('exit')} | " + " | ".join(str(r[k]) for k in COUNTS)
                     + f" | {r['seconds']} |")
    total = {k: sum(r[k] for r in results) for k in COUNTS}
    lines.append("| **all** | " + f"{len(results)} attacks | | | | "
                 + " | ".join(f"**{total[k]}**" for k in COUNTS) + " | |")
    return "\n".join(lines)


def main(argv=None) -> int:
    import shutil
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", required=True, type=Path)
    ap.add_argument("--only", nargs="*", default=None,
                    help="attacks by BACKEND/NAME or BACKEND (default: all)")
    ap.add_argument("--quick", action="store_true", help="the default suite's fast subset")
    ns = ap.parse_args(argv)
    attacks = [a for a in ATTACKS if not ns.quick or a.quick]
    if ns.only:
        attacks = [a for a in attacks if a.backend in ns.only or f"{a.backend}/{a.name}" in ns.only]
    if shutil.which("qemu-system-arm") is None and any(a.backend == "qemu" for a in attacks):
        print("qemu-system-arm is not installed here (scripts/setup installs it)", file=sys.stderr)
        return 2
    ns.out.mkdir(parents=True, exist_ok=True)
    results, started = [], machine()
    for a in attacks:
        r = run_attack(a, ns.out / f"{a.backend}-{a.name}", (1,) if ns.quick else (1, 2, 3))
        results.append(r)
        bad = {k: r[k] for k in COUNTS if r[k]}
        print(f"{a.backend:14s} {a.name:22s} {r['seconds']:6.1f} s  attempts {r.get('attempts', 0):2d} "
              f"ok {r.get('ok', 0):2d}  {bad or 'clean'}", flush=True)
        for n in r["notes"]:
            print("    !", n, flush=True)
    report = {"machine_at_start": started, "machine_at_end": machine(), "attacks": results,
              "totals": {k: sum(r[k] for r in results) for k in COUNTS}}
    tmp = ns.out / ".fault_injection.json.tmp"
    tmp.write_text(json.dumps(report, indent=1))
    tmp.replace(ns.out / "fault_injection.json")
    print(table(results))
    return 0 if not any(report["totals"].values()) else 1


if __name__ == "__main__":
    sys.exit(main())
