"""The fault campaign's probed child processes and their ground truth (``fault_campaign.py``).

:func:`child` runs ``thermocue ARGV`` in a child whose emulated device is probed every tick
(setpoints above the protocol's maximum, the pad above 45 °C); :class:`Totals` counts the whole
campaign; :func:`device_trials`, :func:`ok_rows_by_run` and :func:`check_session` compare a
session's trials with what the device's own log says it delivered.
"""
from __future__ import annotations

import json
import os
import resource
import signal
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests" / "experiments"))
from _session_helpers import write_protocol as _mini_protocol  # noqa: E402  (one protocol text)

P01 = ROOT / "participants" / "examples" / "P01.json"
HARD_MAX_C = 45.0
PROTOCOL_MAX_C = 42.0
CHILD_TIMEOUT_S = 300

# --------------------------------------------------------------------------- the child process
CHILD = r"""
import json, os, sys, atexit
sys.path.insert(0, os.environ["CAMPAIGN_ROOT"])
from experiments.emulators.thermocue.device import Device
stats = {"ticks": 0, "sp_above_max": 0, "pad_above_45_ticks": 0, "pad_above_45_longest": 0,
         "max_pad_C": 0.0, "max_sp_C": 0.0}
run = [0]
limit = float(os.environ["CAMPAIGN_MAX_C"])
orig = Device.step
def step(self):
    orig(self)
    stats["ticks"] += 1
    sp, pad = self.sp, self.plant.pad
    if sp > limit + 1e-9 and self.hello:
        stats["sp_above_max"] += 1
    if sp > stats["max_sp_C"]:
        stats["max_sp_C"] = sp
    if pad > stats["max_pad_C"]:
        stats["max_pad_C"] = pad
    if pad > 45.0:
        run[0] += 1
        stats["pad_above_45_ticks"] += 1
        stats["pad_above_45_longest"] = max(stats["pad_above_45_longest"], run[0])
    else:
        run[0] = 0
Device.step = step
def dump():
    with open(os.environ["CAMPAIGN_STATS"], "w") as fh:
        json.dump(stats, fh)
atexit.register(dump)
from experiments.cli import main
sys.exit(main(sys.argv[1:]))
"""


class Totals:
    """Counters of the whole campaign."""

    def __init__(self):
        self.c = {k: 0 for k in (
            "processes", "sessions", "trial_attempts", "ok_trials", "ok_not_delivered",
            "device_ticks", "setpoints_above_protocol_max", "pad_ticks_above_45C",
            "pad_above_45C_longest_ticks", "tracebacks", "hangs", "fuzzed_inputs",
            "fuzz_clean_refusals", "silent_acceptances", "unclear_messages", "kills",
            "sessions_incomplete", "trials_not_ok_once", "log_shortfalls", "disk_cases",
            "disk_unclean", "restarts", "restart_unnoticed", "concurrent_pairs",
            "concurrent_mixed")}
        self.c["max_pad_C"] = 0.0
        self.notes: list[str] = []
        self.fault_kinds: dict[str, int] = {}

    def note(self, text):
        self.notes.append(text)
        print("  !", text, flush=True)


def write_protocol(folder: Path, real_reps=1, sim_reps=2) -> Path:
    """The campaign's protocol: the session tests' short protocol (1 s contacts), more blocks."""
    return _mini_protocol(folder, contact_s=1.0, rewarm_s=0.0, real_reps=real_reps,
                          sim_reps=sim_reps, name="campaign.toml", protocol_name="campaign",
                          title="Fault campaign")


def child(argv, folder: Path, T: Totals, *, limit_bytes=None, timeout=CHILD_TIMEOUT_S, kill_after=None):
    """Run ``thermocue ARGV`` in a probed child; return (returncode, stderr, stats or None)."""
    T.c["processes"] += 1
    stats = folder / f"stats-{T.c['processes']}.json"
    env = dict(os.environ, CAMPAIGN_ROOT=str(ROOT), CAMPAIGN_STATS=str(stats),
               CAMPAIGN_MAX_C=str(PROTOCOL_MAX_C), PYTHONDONTWRITEBYTECODE="1")

    def pre():
        if limit_bytes is not None:
            signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
            resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, limit_bytes))
    proc = subprocess.Popen([sys.executable, "-c", CHILD, *map(str, argv)], cwd=ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=pre)
    try:
        out, err = proc.communicate(timeout=kill_after if kill_after is not None else timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, err = proc.communicate()
        if kill_after is None:
            T.c["hangs"] += 1
            T.note(f"hang: {' '.join(map(str, argv))[:200]}")
        return None, err, None
    if "Traceback" in err:
        T.c["tracebacks"] += 1
        T.note(f"traceback: {' '.join(map(str, argv))[:160]}: {err.strip().splitlines()[-1][:200]}")
    st = None
    if stats.exists():
        st = json.loads(stats.read_text())
        T.c["device_ticks"] += st["ticks"]
        T.c["setpoints_above_protocol_max"] += st["sp_above_max"]
        T.c["pad_ticks_above_45C"] += st["pad_above_45_ticks"]
        T.c["pad_above_45C_longest_ticks"] = max(T.c["pad_above_45C_longest_ticks"],
                                                 st["pad_above_45_longest"])
        T.c["max_pad_C"] = max(T.c["max_pad_C"], st["max_pad_C"])
        stats.unlink()
    return proc.returncode, err, st


# --------------------------------------------------------------------------- ground truth
def device_trials(log: Path):
    """{contact time since the last power-up (s, 2 decimals): how the device ended it}."""
    out = {}
    if not log.exists():
        return out
    boot = 0.0
    recs = [json.loads(line) for line in log.read_text().splitlines() if line.strip()]
    states = [r for r in recs if r["event"] in ("state", "reboot")]
    for i, r in enumerate(states):
        if r["event"] == "reboot":
            boot = r["t_s"]
            continue
        if r.get("why") == "contact":
            end = None
            for s in states[i + 1:]:
                if s["event"] == "reboot":
                    end = "reboot"
                    break
                if s.get("old") in ("PLAYING", "RECORDING"):
                    end = s.get("why")
                    break
            out[round(r["t_s"] - boot, 2)] = end
    return out


def ok_rows_by_run(session: Path):
    """[(device log of the run, trial_index, attempt, contact_time_s)] of every ok trial.

    Each run's ``session_started``/``session_resumed`` event names its display URL, and so the
    emulator's log (``log=PATH``) that holds the device's account of that run.
    """
    import urllib.parse
    from sessionfiles.logbook import read_events
    events, _ = read_events(session / "events.jsonl", warn=False)
    log, out = None, []
    for e in events:
        if e["event"] in ("session_started", "session_resumed"):
            query = urllib.parse.urlsplit(e.get("display_url", "")).query.replace("+", "%2B")
            log = urllib.parse.parse_qs(query).get("log", [None])[-1]
        elif e["event"] == "trial_completed" and e["row"].get("status") == "ok":
            row = e["row"]          # the trial row names it contact_onset_s (contact_time_s before)
            out.append((log, e["trial_index"], e["attempt"],
                        row.get("contact_onset_s", row.get("contact_time_s"))))
    return out


def check_session(session: Path, logs: list, T: Totals, n_trials: int, label: str):
    """Compare the session's ok trials with the device logs of its runs; check completeness."""
    from sessionfiles.logbook import log_shortfall, read_events
    truth = {}
    rows = ok_rows_by_run(session)
    T.c["ok_trials"] += len(rows)
    for log, ti, att, t in rows:
        if log not in truth:
            truth[log] = device_trials(Path(log)) if log else {}
        ends = truth[log]
        end = None if t is None else ends.get(round(float(t), 2))
        if end is None and t is not None:          # rounding at the boundary
            end = ends.get(round(float(t) + 0.005, 2)) or ends.get(round(float(t) - 0.005, 2))
        if end != "end":
            T.c["ok_not_delivered"] += 1
            T.note(f"{label}: trial {ti} attempt {att} ok, device says {end!r} (contact {t})")
    events, _ = read_events(session / "events.jsonl", warn=False)
    T.c["trial_attempts"] += sum(1 for e in events if e["event"] == "trial_started")
    ok = [r[1] for r in rows]
    finished = any(e["event"] == "session_finished" for e in events)
    if not finished:
        T.c["sessions_incomplete"] += 1
        T.note(f"{label}: not finished")
    elif sorted(ok) != list(range(1, n_trials + 1)):
        T.c["trials_not_ok_once"] += 1
        T.note(f"{label}: ok trials {sorted(ok)}")
    if log_shortfall(events, session / "trials.csv", session / "traces"):
        T.c["log_shortfalls"] += 1
        T.note(f"{label}: log shortfall")
