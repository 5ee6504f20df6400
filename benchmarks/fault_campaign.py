"""Fault campaign against the emulated display: does anything unsafe or untrue get through?

One concept (a script of ~520 lines): the campaign and its injected faults; its probed child
processes and their checks against the device's log are in ``campaign_child.py``.

Runs real ``thermocue run`` / ``thermocue resume`` processes on ``emulator://`` (virtual clock)
and checks, against the device's own log and a per-tick probe of the emulated pad, that:

* no trial is logged ``ok`` that the device did not deliver (a contact it saw and a trial it
  ended itself: complete, released or maximum duration -- not a watchdog, fault or abort);
* no setpoint goes above the protocol's ``max_C``; the pad is never above the 45 °C hard
  maximum for longer than one 10 ms tick;
* no traceback and no hang (every process ends within its time limit);
* no bad input is accepted silently (every mutated protocol, participant or session.json is
  refused with one line naming the file and field, exit 2);
* nothing is lost: after kills, disk-full, a device restart and concurrent runs, every scheduled
  trial ends ``ok`` exactly once and the log explains every file.

Parts: ``faults`` (every fault kind the emulator injects, timed episodes, resumed until done),
``kills`` (SIGKILL at random moments, resumed), ``fuzz`` (mutated inputs), ``disk`` (a small tmpfs
filling up, a file-size limit, a folder remounted read-only mid-session; tmpfs parts need root),
``restart`` (the display power-cycles mid-session), ``concurrent`` (two runs of one participant).

Usage::

    nice .venv/bin/python benchmarks/fault_campaign.py --out campaign [--scale 1.0] [--parts ...]

``--scale`` multiplies the number of sessions, kills and mutations (1.0: >= 1,000 faulted
trials, >= 50 kills, >= 200 mutations). Writes ``OUT/report.json`` and prints a summary.
"""
from __future__ import annotations

import argparse
import json
import os
import random
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))
# the probed child processes and the ground truth (fault_injection.py imports the latter from here)
from campaign_child import (CHILD_TIMEOUT_S, P01, Totals, check_session, child,  # noqa: E402,F401
                            device_trials, ok_rows_by_run, write_protocol)


# --------------------------------------------------------------------------- parts
def fault_spec(kind: str, rng: random.Random, horizon_s: float) -> str:
    at = [round(rng.uniform(1.0, horizon_s), 2) for _ in range(rng.randint(2, 5))]
    if kind == "drop":
        return ",".join([f"drop=0.9@{a}+{rng.choice((0.1, 0.3, 0.6))}" for a in at] + ["drop=0.002"])
    if kind == "corrupt":
        return ",".join([f"corrupt=0.3@{a}+0.2" for a in at] + ["corrupt=0.001"])
    if kind == "garbage":
        return f"garbage={rng.choice((0.02, 0.1, 0.3))}"
    if kind == "delay":
        return ",".join(f"delay={rng.choice((0.02, 0.05, 0.2))}@{a}+1" for a in at)
    if kind == "disconnect":
        return ",".join(f"disconnect@{a}+{rng.choice((0.05, 0.2, 0.5))}" for a in at)
    if kind == "stall":
        return ",".join(f"stall@{a}+{rng.choice((0.05, 0.3, 1.0))}" for a in at)
    if kind in ("stuck_sensor", "sensor_range"):
        return f"{kind}@{at[0]}+{rng.choice((0.05, 0.3))}"
    if kind == "overtemp":              # long enough for the pad to reach the 45 °C trip
        return f"overtemp@{at[0]}" + rng.choice(("+0.3", "+2", ""))
    if kind == "reboot":
        return f"reboot@{at[0]}"
    raise ValueError(kind)


KINDS = ("drop", "corrupt", "garbage", "delay", "disconnect", "stall", "stuck_sensor",
         "sensor_range", "overtemp", "reboot")


def run_until_done(folder: Path, proto: Path, T: Totals, rng: random.Random, first_faults: str,
                   label: str, more_faults=None, max_runs=12, data=None, extra=()):
    """``thermocue run`` then ``resume`` (new emulator each time) until the session finishes."""
    data = data or folder / "data"
    logs = []
    seed = rng.randrange(1_000_000)
    log = folder / f"dev-{len(logs) + 1}.jsonl"
    url = f"emulator://?clock=virtual&seed={seed}&faults={first_faults}&log={log}"
    code, err, _ = child(["run", proto, "--participant", P01, "--display", url, "--responder",
                          "simulated", "--data", data, "--seed", seed, "--quiet", *extra], folder, T)
    logs.append(log)
    session = data / "P01" / "S01"
    if not (session / "session.json").exists():
        T.note(f"{label}: no session folder ({err.strip()[:200]})")
        return None, logs
    runs = 1
    while code != 0 and runs < max_runs:
        if code not in (1, None):
            T.note(f"{label}: exit {code}: {err.strip()[:200]}")
        faults = more_faults(rng) if more_faults else ""
        log = folder / f"dev-{len(logs) + 1}.jsonl"
        url = f"emulator://?clock=virtual&seed={rng.randrange(1_000_000)}&faults={faults}&log={log}"
        code, err, _ = child(["resume", session, "--display", url, "--responder", "simulated",
                              "--quiet"], folder, T)
        logs.append(log)
        runs += 1
    return session, logs


def part_faults(out: Path, T: Totals, scale: float, rng: random.Random):
    n_sessions = max(len(KINDS), int(round(70 * scale)))
    for i in range(n_sessions):
        kind = KINDS[i % len(KINDS)]
        folder = out / "faults" / f"{i:03d}-{kind}"
        folder.mkdir(parents=True)
        proto = write_protocol(folder, real_reps=1, sim_reps=3)        # 16 trials
        spec = fault_spec(kind, rng, 30.0)
        T.fault_kinds[kind] = T.fault_kinds.get(kind, 0) + 1
        session, logs = run_until_done(folder, proto, T, rng, spec, f"faults {i} {spec}",
                                       more_faults=lambda r, k=kind: fault_spec(k, r, 20.0)
                                       if r.random() < 0.5 else "")
        T.c["sessions"] += 1
        if session is not None:
            check_session(session, logs, T, 16, f"faults {i} ({spec})")
        if kind == "reboot":
            T.c["restarts"] += 1
        print(f"faults {i + 1}/{n_sessions} {kind}: attempts {T.c['trial_attempts']}, "
              f"ok {T.c['ok_trials']}, undelivered ok {T.c['ok_not_delivered']}", flush=True)


def part_restart(out: Path, T: Totals, scale: float, rng: random.Random):
    for i, at in enumerate((2.0, 4.5, 7.3, 11.0)[:max(2, int(4 * scale))]):
        folder = out / "restart" / f"{i}"
        folder.mkdir(parents=True)
        proto = write_protocol(folder, real_reps=1, sim_reps=1)        # 8 trials
        log = folder / "dev-1.jsonl"
        seed = rng.randrange(1000)
        code, err, _ = child(["run", proto, "--participant", P01, "--display",
                              f"emulator://?clock=virtual&seed={seed}&faults=reboot@{at}&log={log}",
                              "--responder", "simulated", "--data", folder / "data", "--seed", seed,
                              "--quiet"], folder, T)
        T.c["restarts"] += 1
        if code != 1 or "display restarted" not in err:
            T.c["restart_unnoticed"] += 1
            T.note(f"restart at {at}: exit {code}: {err.strip()[:200]}")
        session = folder / "data" / "P01" / "S01"
        logs = [log]
        log2 = folder / "dev-2.jsonl"
        child(["resume", session, "--display", f"emulator://?clock=virtual&seed=9&log={log2}",
               "--responder", "simulated", "--quiet"], folder, T)
        logs.append(log2)
        check_session(session, logs, T, 8, f"restart at {at}")


def part_kills(out: Path, T: Totals, scale: float, rng: random.Random):
    n_kills = int(round(50 * scale))
    i = 0
    while T.c["kills"] < n_kills:
        folder = out / "kills" / f"{i:03d}"
        folder.mkdir(parents=True)
        proto = write_protocol(folder, real_reps=1, sim_reps=2)        # 12 trials
        data = folder / "data"
        session = data / "P01" / "S01"
        logs = []
        for step in range(30):
            log = folder / f"dev-{step + 1}.jsonl"
            url = f"emulator://?clock=virtual&seed={rng.randrange(1000)}&log={log}"
            if not (session / "session.json").exists():   # killed before the session was written
                argv = ["run", proto, "--participant", P01, "--display", url, "--responder",
                        "simulated", "--data", data, "--seed", 5, "--quiet"]
            else:
                argv = ["resume", session, "--display", url, "--responder", "simulated", "--quiet"]
            kill = rng.uniform(1.0, 4.0) if T.c["kills"] < n_kills else None
            code, err, _ = child(argv, folder, T, kill_after=kill)
            logs.append(log)
            if code is None:
                T.c["kills"] += 1
                continue
            if code == 0:
                break
            T.note(f"kills {i}: exit {code}: {err.strip()[:200]}")
        if session.exists():
            check_session(session, logs, T, 12, f"kills {i}")
            T.c["sessions"] += 1
        print(f"kills: {T.c['kills']}/{n_kills}", flush=True)
        i += 1


def _mutations_protocol(text: str, rng: random.Random):
    import re
    lines = text.splitlines()
    numeric = [i for i, ln in enumerate(lines) if re.match(r"^\w+ = -?[0-9.]+$", ln)]
    keys = [i for i, ln in enumerate(lines) if re.match(r"^\w+ = ", ln)]
    kind = rng.choice(("nan", "inf", "-inf", "neg", "huge", "string", "delete", "unknown",
                       "utf8", "truncate", "bigint", "bool"))
    if kind in ("nan", "inf", "-inf", "neg", "huge", "string", "bigint", "bool") and numeric:
        i = rng.choice(numeric)
        k = lines[i].split(" = ")[0]
        val = {"nan": "nan", "inf": "inf", "-inf": "-inf", "neg": "-5.0", "huge": "1e308",
               "string": '"many"', "bigint": "100000000000", "bool": "true"}[kind]
        if kind == "neg" and k in ("room_temperature_C", "material_temperature_C", "margin_um",
                                   "rewarm_s", "id"):
            val = "-1e6"
        lines[i] = f"{k} = {val}"
        return f"{kind} {k}", "\n".join(lines).encode()
    if kind == "delete":
        i = rng.choice(keys)
        k = lines[i].split(" = ")[0]
        if k in ("label", "order", "title", "margin_um", "method", "rewarm_s"):
            k, i = lines[keys[0]].split(" = ")[0], keys[0]   # optional key: delete a required one
        del lines[i]
        return f"delete {k}", "\n".join(lines).encode()
    if kind == "unknown":
        i = rng.choice(keys)
        lines.insert(i + 1, "colour = 'red'")
        return "unknown key", "\n".join(lines).encode()
    data = "\n".join(lines).encode()
    if kind == "utf8":
        at = rng.randrange(len(data))
        return "non-utf8 byte", data[:at] + b"\xff" + data[at:]
    at = rng.randrange(20, len(data) // 2)
    return "truncated", data[:at] + b"\n[[blocks]]\nname = "


def _mutations_participant(record: dict, rng: random.Random):
    import copy
    r = copy.deepcopy(record)
    kind = rng.choice(("nan", "inf", "neg", "huge", "string", "delete", "consent", "utf8",
                       "layers"))
    paths = [("skin_thickness", "epidermis_um"), ("skin_thickness", "dermis_um"),
             ("skin_thickness", "total_um"), ("initial_skin_temperature_C",), ("age",)]
    p = rng.choice(paths)
    tgt = r
    for k in p[:-1]:
        tgt = tgt[k]
    if kind in ("nan", "inf", "neg", "huge", "string"):
        tgt[p[-1]] = "@@"
        val = {"nan": "NaN", "inf": "Infinity", "neg": "-5", "huge": "1e308",
               "string": '"thick"'}[kind]
        return f"{kind} {'.'.join(p)}", json.dumps(r).replace('"@@"', val).encode()
    if kind == "delete":
        del r["skin_thickness"]["total_um"]
        return "delete total_um", json.dumps(r).encode()
    if kind == "consent":
        r["consent"]["given"] = False
        return "no consent", json.dumps(r).encode()
    if kind == "layers":
        r["skin_thickness"]["epidermis_um"] = 5000
        return "layer thicker than total", json.dumps(r).encode()
    data = json.dumps(r).encode()
    at = rng.randrange(len(data))
    return "non-utf8 byte", data[:at] + b"\xc3\x28" + data[at:]


def _fuzz_one(argv, path: Path, what: str, T: Totals, folder: Path):
    T.c["fuzzed_inputs"] += 1
    code, err, _ = child(argv, folder, T, timeout=120)
    lines = err.strip().splitlines()
    if code == 2 and len(lines) == 1 and str(path) in lines[0] and "expected" in lines[0]:
        T.c["fuzz_clean_refusals"] += 1
    elif code in (0, 1) and "Traceback" not in err:
        T.c["silent_acceptances"] += 1
        T.note(f"fuzz accepted ({what}): exit {code}: {err.strip()[:160]}")
    elif code is not None and "Traceback" not in err:
        T.c["unclear_messages"] += 1
        T.note(f"fuzz unclear ({what}): exit {code}: {err.strip()[:200]}")


def part_fuzz(out: Path, T: Totals, scale: float, rng: random.Random):
    n = int(round(200 * scale))
    base = out / "fuzz"
    base.mkdir(parents=True)
    proto_text = write_protocol(base, real_reps=1, sim_reps=1).read_text()
    record = json.loads(P01.read_text())
    # a session to edit for the session.json mutations
    good = base / "good"
    good.mkdir()
    gp = write_protocol(good, real_reps=1, sim_reps=1)
    child(["run", gp, "--participant", P01, "--display",
           "emulator://?clock=virtual&seed=1&faults=sensor_range@3", "--responder", "simulated",
           "--data", good / "data", "--seed", 3, "--quiet"], good, T)
    session = good / "data" / "P01" / "S01"
    meta0 = json.loads((session / "session.json").read_text())
    for i in range(n):
        folder = base / f"{i:03d}"
        folder.mkdir()
        which = i % 3
        if which == 0:
            what, data = _mutations_protocol(proto_text, rng)
            path = folder / "campaign.toml"
            path.write_bytes(data)
            argv = ["run", path, "--participant", P01, "--display", "emulator://?clock=virtual",
                    "--responder", "simulated", "--data", folder / "data", "--seed", 1, "--quiet"]
        elif which == 1:
            what, data = _mutations_participant(record, rng)
            path = folder / "P.json"
            path.write_bytes(data)
            argv = ["run", write_protocol(folder), "--participant", path, "--display",
                    "emulator://?clock=virtual", "--responder", "simulated", "--data",
                    folder / "data", "--seed", 1, "--quiet"]
        else:
            copy = folder / "S01"
            shutil.copytree(session, copy)
            meta = json.loads(json.dumps(meta0))
            field = rng.choice(("seed", "group", "session", "max_consecutive_faults",
                                "schedule", "protocol_hash", "participant"))
            if field == "seed":
                meta["seed"] = rng.choice((meta["seed"] + 1, -1, "x", None))
            elif field == "group":
                meta["group"] = "B" if meta["group"] == "A" else "A"
            elif field == "session":
                meta["session"] = "S09"
            elif field == "max_consecutive_faults":
                meta["max_consecutive_faults"] = rng.choice(("many", 0, 10**9, 2.5))
            elif field == "schedule":
                meta["schedule"] = meta["schedule"][::-1]
            elif field == "protocol_hash":
                meta["protocol_hash"] = "0" * 64
            else:
                meta["participant"]["skin_thickness"]["total_um"] = "NaN-HERE"
            text = json.dumps(meta).replace('"NaN-HERE"', "NaN")
            path = copy / "session.json"
            path.write_text(text)
            what = f"session.json {field}"
            argv = ["resume", copy, "--display", "emulator://?clock=virtual", "--responder",
                    "simulated", "--quiet"]
        _fuzz_one(argv, path, what, T, folder)
        if (i + 1) % 25 == 0:
            print(f"fuzz {i + 1}/{n}: clean {T.c['fuzz_clean_refusals']}, accepted "
                  f"{T.c['silent_acceptances']}, unclear {T.c['unclear_messages']}", flush=True)


def _mount(path: Path, size: str) -> bool:
    path.mkdir(parents=True, exist_ok=True)
    return os.geteuid() == 0 and subprocess.run(
        ["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(path)],
        capture_output=True).returncode == 0


def _disk_case(label, T: Totals, code, err, session: Path, folder: Path, cause: str, resume_argv):
    T.c["disk_cases"] += 1
    # the stop is one line; the trials' own warnings before it ("thermocue: warning: ...") are
    # not part of it
    lines = [ln for ln in err.strip().splitlines() if not ln.startswith("thermocue: warning:")]
    if not (code == 1 and len(lines) == 1 and cause in lines[0] and "display neutral" in lines[0]):
        T.c["disk_unclean"] += 1
        T.note(f"disk {label}: exit {code}: {err.strip()[:300]}")
    code, err, _ = child(resume_argv, folder, T)
    if code != 0:
        T.note(f"disk {label}: resume exit {code}: {err.strip()[:200]}")


def _disk_tmpfs(base: Path, T: Totals, size: str) -> bool:
    """A session on a tmpfs of ``size``, then resumed on it enlarged; False if none mounts."""
    folder = base / f"tmpfs-{size}"
    mnt = folder / "mnt"
    if not _mount(mnt, size):
        T.note("disk: cannot mount a tmpfs (not root?): tmpfs cases skipped")
        return False
    try:
        proto = write_protocol(folder, real_reps=1, sim_reps=2)
        log1 = folder / "dev-1.jsonl"
        code, err, _ = child(["run", proto, "--participant", P01, "--display",
                              f"emulator://?clock=virtual&seed=1&log={log1}", "--responder",
                              "simulated", "--data", mnt / "data", "--seed", 1, "--quiet"],
                             folder, T)
        session = mnt / "data" / "P01" / "S01"
        subprocess.run(["mount", "-o", "remount,size=8m", str(mnt)], check=True)
        if code == 0:
            T.note(f"disk tmpfs {size}: the session fit; no failure exercised")
            return True
        if not session.exists():          # nothing could be claimed: a one-line refusal
            T.c["disk_cases"] += 1
            if code not in (1, 2) or len(err.strip().splitlines()) != 1:
                T.c["disk_unclean"] += 1
                T.note(f"disk tmpfs {size} (no folder): exit {code}: {err.strip()[:300]}")
            return True
        log2 = folder / "dev-2.jsonl"
        _disk_case(f"tmpfs {size}", T, code, err, session, folder, "disk full",
                   ["resume", session, "--display", f"emulator://?clock=virtual&seed=2&log={log2}",
                    "--responder", "simulated", "--quiet"])
        check_session(session, [log1, log2], T, 12, f"disk tmpfs {size}")
        return True
    finally:
        subprocess.run(["umount", str(mnt)], capture_output=True)


def _disk_fsize(base: Path, T: Totals, limit: int) -> None:
    """A session whose files may not grow beyond ``limit`` bytes (RLIMIT_FSIZE), then resumed."""
    folder = base / f"fsize-{limit}"
    folder.mkdir()
    proto = write_protocol(folder, real_reps=1, sim_reps=2)
    log1 = folder / "dev-1.jsonl"
    code, err, _ = child(["run", proto, "--participant", P01, "--display",
                          f"emulator://?clock=virtual&seed=1&log={log1}", "--responder",
                          "simulated", "--data", folder / "data", "--seed", 1, "--quiet"],
                         folder, T, limit_bytes=limit)
    session = folder / "data" / "P01" / "S01"
    log2 = folder / "dev-2.jsonl"
    _disk_case(f"file size {limit}", T, code, err, session, folder, "file too large",
               ["resume", session, "--display", f"emulator://?clock=virtual&seed=2&log={log2}",
                "--responder", "simulated", "--quiet"])
    check_session(session, [log1, log2], T, 12, f"disk fsize {limit}")


def _disk_readonly(base: Path, T: Totals) -> None:
    """A folder turning read-only mid-session (real clock, so there is a "mid"), then resumed."""
    folder = base / "readonly"
    mnt = folder / "mnt"
    if not _mount(mnt, "8m"):
        return
    try:
        proto = write_protocol(folder, real_reps=0 or 1, sim_reps=1)
        T.c["processes"] += 1
        env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1")
        proc = subprocess.Popen([sys.executable, "-m", "experiments", "run", str(proto),
                                 "--participant", str(P01), "--display", "emulator://?seed=1",
                                 "--responder", "simulated", "--data", str(mnt / "data"),
                                 "--seed", "1", "--quiet"], cwd=ROOT, env=env, text=True,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        # wait for the session to be under way (its event log holds a trial_started), however
        # loaded the machine is; a fixed sleep found no folder yet at load 7
        sdir = mnt / "data" / "P01" / "S01"
        deadline = time.monotonic() + 120.0
        while time.monotonic() < deadline and proc.poll() is None:
            log = sdir / "events.jsonl"
            if log.exists() and b"trial_started" in log.read_bytes():
                break
            time.sleep(0.2)
        # the session folder turns read-only under the running process (a bind mount of it
        # onto itself, remounted read-only: new files and renames fail with EROFS; the
        # whole tmpfs cannot be remounted read-only while files are open for writing)
        subprocess.run(["mount", "--bind", str(sdir), str(sdir)], check=True)
        subprocess.run(["mount", "-o", "remount,bind,ro", str(sdir)], check=True)
        try:
            _, err = proc.communicate(timeout=120)
        except subprocess.TimeoutExpired:
            proc.kill()
            _, err = proc.communicate()
            T.c["hangs"] += 1
        if "Traceback" in err:
            T.c["tracebacks"] += 1
            T.note(f"read-only: traceback: {err.strip().splitlines()[-1][:200]}")
        subprocess.run(["umount", str(sdir)], check=True)
        session = mnt / "data" / "P01" / "S01"
        _disk_case("read-only", T, proc.returncode, err, session, folder,
                   "read-only file system",
                   ["resume", session, "--display", "emulator://?clock=virtual&seed=2",
                    "--responder", "simulated", "--quiet"])
    finally:
        subprocess.run(["umount", str(mnt)], capture_output=True)


def part_disk(out: Path, T: Totals, scale: float, rng: random.Random):
    """Full disks (small tmpfs), file-size limits and a folder turning read-only mid-session."""
    base = out / "disk"
    base.mkdir(parents=True)
    for size in ("24k", "48k", "96k", "160k"):
        if not _disk_tmpfs(base, T, size):
            break
    for limit in (9000, 12000, 20000):
        _disk_fsize(base, T, limit)
    _disk_readonly(base, T)


def part_concurrent(out: Path, T: Totals, scale: float, rng: random.Random):
    base = out / "concurrent"
    base.mkdir(parents=True)
    env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1")
    for i in range(max(4, int(round(12 * scale)))):
        folder = base / f"{i:02d}"
        folder.mkdir()
        proto = write_protocol(folder, real_reps=1, sim_reps=0 or 1)
        named = i % 3 == 2
        procs = []
        for seed in (100 + i, 200 + i):
            argv = [sys.executable, "-m", "experiments", "run", str(proto), "--participant",
                    str(P01), "--display", f"emulator://?clock=virtual&seed={seed}",
                    "--responder", "simulated", "--data", str(folder / "data"), "--seed",
                    str(seed), "--quiet"] + (["--session", "S01"] if named else [])
            procs.append(subprocess.Popen(argv, cwd=ROOT, env=env, text=True,
                                          stdout=subprocess.PIPE, stderr=subprocess.PIPE))
            T.c["processes"] += 1
        res = [p.communicate(timeout=CHILD_TIMEOUT_S) for p in procs]
        codes = [p.returncode for p in procs]
        T.c["concurrent_pairs"] += 1
        for _, err in res:
            if "Traceback" in err:
                T.c["tracebacks"] += 1
                T.note(f"concurrent {i}: traceback {err.strip().splitlines()[-1][:200]}")
        from sessionfiles.logbook import read_events
        mixed = False
        for d in sorted((folder / "data" / "P01").iterdir()):
            meta = json.loads((d / "session.json").read_text())
            events, _ = read_events(d / "events.jsonl", warn=False)
            started = [e for e in events if e["event"] == "session_started"]
            if len(started) != 1 or started[0]["seed"] != meta["seed"]:
                mixed = True
        if named and sorted(codes) != [0, 2]:
            mixed = True
        if not named and codes != [0, 0]:
            mixed = True
        if mixed:
            T.c["concurrent_mixed"] += 1
            T.note(f"concurrent {i} (named={named}): exits {codes}: "
                   f"{[e.strip()[:120] for _, e in res]}")


PARTS = {"faults": part_faults, "restart": part_restart, "kills": part_kills, "fuzz": part_fuzz,
         "disk": part_disk, "concurrent": part_concurrent}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", required=True, type=Path)
    ap.add_argument("--scale", type=float, default=1.0)
    ap.add_argument("--seed", type=int, default=20261124)
    ap.add_argument("--parts", nargs="*", default=list(PARTS), choices=list(PARTS))
    ns = ap.parse_args(argv)
    if ns.out.exists():
        shutil.rmtree(ns.out)
    ns.out.mkdir(parents=True)
    T = Totals()
    rng = random.Random(ns.seed)
    t0 = time.monotonic()
    timings = {}
    for name in ns.parts:
        t = time.monotonic()
        print(f"== {name}", flush=True)
        PARTS[name](ns.out, T, ns.scale, rng)
        timings[name] = round(time.monotonic() - t, 1)
    report = dict(counts=T.c, fault_kinds=T.fault_kinds, notes=T.notes, seconds=timings,
                  total_s=round(time.monotonic() - t0, 1), scale=ns.scale, seed=ns.seed,
                  load_average=os.getloadavg(), cpus=os.cpu_count())
    (ns.out / "report.json").write_text(json.dumps(report, indent=2))
    print(json.dumps(report["counts"], indent=2))
    bad = (T.c["ok_not_delivered"] + T.c["setpoints_above_protocol_max"] + T.c["tracebacks"]
           + T.c["hangs"] + T.c["silent_acceptances"] + T.c["sessions_incomplete"]
           + T.c["trials_not_ok_once"] + T.c["log_shortfalls"] + T.c["disk_unclean"]
           + T.c["restart_unnoticed"] + T.c["concurrent_mixed"]
           + (T.c["pad_above_45C_longest_ticks"] > 1))
    print(f"fault campaign: {'PASS' if not bad else 'FAIL'} in {report['total_s']} s")
    return 0 if not bad else 1


if __name__ == "__main__":
    sys.exit(main())
