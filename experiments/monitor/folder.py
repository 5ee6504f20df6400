"""A session folder followed as it is written: what the monitor's page shows.

:class:`FolderView` reads ``session.json`` (the schedule, the blocks, the contact threshold),
follows ``events.jsonl`` (the source of truth: states, trials, faults) and the running attempt's
trace, and keeps what the page needs: the finished attempts as rows, the live trace, the
status (state, trial n of N by block, elapsed, time left) and what is wrong with the folder, if
anything, in one sentence (:attr:`FolderView.problem`). It never writes and never raises for a
missing, damaged or half-written folder: it says so and tries again at the next :meth:`poll`.
"""
from __future__ import annotations

import json
import time
from pathlib import Path

from experiments.monitor.faults import explain
from experiments.monitor.tail import LineTail, Restarted
from experiments.monitor.time_left import TimeLeft, event_seconds
from experiments.monitor.trace import LiveTrace, fault_marker, read_trace
from sessionfiles.session_reader import read_regular_bytes

__all__ = ["FolderView", "page_state"]

#: The session's machine states (experiments.session.machine) in the page's words.
_MACHINE_WORDS = {"idle": "between trials", "prompt": "trial starting (sample placed)",
                  "prepare": "arming the display", "cue": "touch cue", "wait_contact":
                  "waiting for the touch", "record": "recording the touch", "playback":
                  "playing the profile", "respond": "waiting for the answer", "write":
                  "writing the trial", "rewarm": "rewarming the finger", "fault":
                  "display fault", "no_contact": "no contact", "finished": "session finished",
                  "stopped": "session stopped"}
#: The display's states (its telemetry) in the page's five words.
_DEVICE_WORDS = {"IDLE": "neutral", "ARMED": "armed", "PLAYING": "playing",
                 "RECORDING": "recording", "FAULT": "fault"}


def page_state(machine: str | None, device: str | None, armed: bool) -> str:
    """neutral, armed, playing, recording or fault."""
    if machine == "fault":
        return "fault"
    if machine in ("cue", "wait_contact", "record", "playback") and device in _DEVICE_WORDS:
        return _DEVICE_WORDS[device]
    if armed and machine in ("prepare", "cue", "wait_contact"):
        return "armed"
    return "neutral"


class FolderView:
    """What the page shows of ``folder``, brought up to date by :meth:`poll`."""

    def __init__(self, folder):
        self.folder = Path(folder)
        self.meta: dict | None = None
        self.meta_version = 0
        self.generation = 0                      # bumped when the log must be read afresh
        self.problem: str | None = None
        self.events = LineTail(self.folder / "events.jsonl", same_name=True)
        self.damaged_at: int | None = None       # line of events.jsonl the view stopped at
        self.rows: list[dict] = []
        self.live: LiveTrace | None = None
        self.version = 0                         # bumped by every event taken
        self._faults: dict = {}                  # (trial, attempt) -> (code, message)
        self._s = {"machine": None, "device": None, "armed": False, "trial": None,
                   "attempt": None, "block": None, "started_s": None, "ended_s": None,
                   "end": None, "last_fault": None, "first_start": None, "last_event_s": None}
        self.time_left: TimeLeft | None = None
        self._pending: list[dict] = []           # events read before session.json was

    # -- reading ------------------------------------------------------------------------
    def poll(self) -> None:
        problems = []
        if not self.folder.is_dir():
            self.problem = (f"{self.folder}: expected a session folder, got a file" if
                            self.folder.exists() else
                            f"{self.folder}: no such session folder (yet): waiting for it; a "
                            f"session folder holds session.json and events.jsonl")
            return
        if self.meta is None:
            problems += self._read_meta()
        problems += self._read_events()
        if self.live is not None:
            try:
                self.live.poll()
            except OSError as exc:
                problems.append(f"{self.live.tail.path}: cannot be read ({exc.strerror or exc})")
            if self.live.data.bad:
                problems.append(f"{self.live.tail.path}: {self.live.data.bad} line(s) that are "
                                f"not trace lines were left out")
        self.problem = "; ".join(problems) or None

    def _read_meta(self) -> list[str]:
        path = self.folder / "session.json"
        if not path.exists():
            if not (self.folder / "events.jsonl").exists():
                return [f"{self.folder}: not a session folder (yet): no session.json or "
                        f"events.jsonl; waiting for them"]
            return [f"{path}: not written yet (a session being created writes it next)"]
        try:
            meta = json.loads(read_regular_bytes(path).decode("utf-8-sig"))
            schedule = meta["schedule"]
            modes = {int(s["trial_index"]): str(s["mode"]) for s in schedule}
        except (OSError, ValueError, UnicodeDecodeError, KeyError, TypeError) as exc:
            why = exc.strerror if isinstance(exc, OSError) and exc.strerror else exc
            return [f"{path}: cannot be read as a session's record ({why}); the page shows "
                    f"what events.jsonl says"]
        self.meta = meta
        self.meta_version += 1
        protocol = meta.get("protocol") or {}
        rewarm = 0.0 if meta.get("clock") == "virtual" else \
            float((protocol.get("contact") or {}).get("rewarm_s") or 0.0)
        self.time_left = TimeLeft(modes, rewarm)
        for e in self._pending:
            self.time_left.feed(e)
        self._pending = []
        return []

    def _read_events(self) -> list[str]:
        path = self.events.path
        if self.damaged_at is not None:
            return [f"{path}: line {self.damaged_at} is damaged (not a JSON event); the page "
                    f"shows the session up to the line before it"]
        try:
            lines = self.events.read()
        except Restarted:                  # cut (a resume's repair) or replaced: start afresh
            folder, generation = self.folder, self.generation
            self.__init__(folder)
            self.generation = generation + 1       # the pages start afresh too (stream.py)
            return self._read_meta() + self._read_events()
        except OSError as exc:
            return [f"{path}: cannot be read ({exc.strerror or exc})"]
        first = self.events.lines_read - len(lines) + 1
        for n, raw in enumerate(lines, start=first):
            try:
                event = json.loads(raw.decode("utf-8"))
                if not isinstance(event, dict) or not isinstance(event.get("event"), str):
                    raise ValueError("not an event")
            except (ValueError, UnicodeDecodeError):
                if not raw.strip(b"\x00 \t\r"):
                    continue                        # blank or NUL padding (a power cut)
                self.damaged_at = n
                return self._read_events()
            self._take(event)
        return []

    # -- events -------------------------------------------------------------------------
    def _take(self, e: dict) -> None:
        self.version += 1
        if self.time_left is not None:
            self.time_left.feed(e)
        else:
            self._pending.append(e)
        kind, s = e["event"], self._s
        at = event_seconds(e)
        s["last_event_s"] = at
        if kind == "session_started" and s["first_start"] is None:
            s["first_start"] = at
        if kind in ("session_started", "session_resumed"):
            s["end"], s["ended_s"] = None, None
        elif kind == "state":
            s["machine"] = e.get("to")
            if e.get("to") in ("idle", "prompt"):
                s["armed"], s["device"] = False, None
        elif kind == "trial_started":
            s.update(trial=e.get("trial_index"), attempt=e.get("attempt"), block=e.get("block"),
                     started_s=at, armed=False, device=None)
            self._start_live(e.get("trial_index"), e.get("attempt"))
        elif kind == "armed":
            s["armed"] = True
        elif kind == "display_fault":
            key = (e.get("trial_index"), e.get("attempt"))
            self._faults[key] = (e.get("fault_code"), e.get("message"))
            s["last_fault"] = {"trial": key[0], "attempt": key[1], "code": e.get("fault_code"),
                               "message": e.get("message"), "words": explain(e.get("fault_code"))}
        elif kind in ("trial_completed", "trial_aborted"):
            self._end_attempt(e)
        elif kind in ("session_finished", "session_interrupted", "session_stopped", "session_error"):
            s["end"] = {"session_finished": "finished", "session_interrupted": "interrupted",
                        "session_stopped": "stopped", "session_error": "stopped by an error"}[kind]
            s["end_reason"] = e.get("reason") or e.get("message")
            s["ended_s"] = at

    def _start_live(self, trial, attempt) -> None:
        if self.live is not None and not self.live.done:
            self.live.finish()
        if isinstance(trial, int):
            self.live = LiveTrace(self.folder / "traces" / f"trial-{trial:03d}.csv", (trial, attempt))

    def _end_attempt(self, e: dict) -> None:
        key = (e.get("trial_index"), e.get("attempt"))
        completed = e["event"] == "trial_completed"
        row = dict(e.get("row") or {}) if completed else {}
        status = row.get("status", "ok") if completed else "aborted"
        code = row.get("fault_code") if completed else (e.get("fault_code") or e.get("reason"))
        message = self._faults.get(key, (None, None))[1]
        block = row.get("block") or self._s["block"]
        shown = self._answer_shown(block)
        out = {"trial": key[0], "attempt": key[1], "block": block, "mode": row.get("mode"),
               "status": status, "fault_code": code if status != "ok" else None,
               "words": explain(code) if status != "ok" else "", "message": message or "",
               "tracking_rms_C": row.get("tracking_rms_C"), "tracking_max_C": row.get("tracking_max_C"),
               "contact_s": row.get("contact_duration_s"), "frames": row.get("frames"),
               "frames_lost": row.get("frames_lost"),
               "trace_file": row.get("trace_file") if completed else e.get("trace_file"),
               "answer": row.get("response_id") if shown else None,
               "correct": row.get("correct") if shown else None}
        self.rows.append(out)
        live = self.live
        if live is not None and live.key == key and not live.done:
            try:
                live.finish()
            except OSError:
                live.done = True
            if status != "ok":
                live.fault = fault_marker(live.data, code, message)

    def _answer_shown(self, block) -> bool:
        """The answer appears only where the protocol shows it anyway: blocks with feedback."""
        for b in (self.meta or {}).get("blocks") or ():
            if b.get("name") == block:
                return bool(b.get("feedback")) and bool(b.get("response"))
        return False

    # -- what the page gets -------------------------------------------------------------
    def meta_public(self) -> dict:
        m = self.meta or {}
        protocol = m.get("protocol") or {}
        contact, display = protocol.get("contact") or {}, protocol.get("display") or {}
        blocks = [b.get("name") for b in m.get("blocks") or ()]
        per_block = {}
        for sp in m.get("schedule") or ():
            per_block[sp.get("block")] = per_block.get(sp.get("block"), 0) + 1
        return {"folder": str(self.folder), "participant": m.get("participant_id"),
                "session": m.get("session"), "protocol": m.get("protocol_name"),
                "n_trials": len(m.get("schedule") or ()), "blocks": blocks,
                "block_sizes": per_block, "clock": m.get("clock"),
                "force_threshold_N": contact.get("force_threshold_N"),
                "rewarm_s": contact.get("rewarm_s"), "min_C": display.get("min_C"),
                "max_C": display.get("max_C"), "neutral_C": display.get("neutral_C"),
                "display_url": m.get("display_url")}

    def status(self, now_s: float | None = None) -> dict:
        now_s = time.time() if now_s is None else now_s
        s = self._s
        device = None
        if self.live is not None and not self.live.done and self.live.data.cols["state"]:
            device = self.live.data.cols["state"][-1]
        end_s = s["ended_s"] if s["end"] else now_s
        left = None if self.time_left is None else self.time_left.seconds_left(now_s)
        if s["end"] == "finished":
            left = 0.0
        elif s["end"] is not None:
            left = None
        words = _MACHINE_WORDS.get(s["machine"], s["machine"])
        if s["machine"] == "wait_contact" and device in ("PLAYING", "RECORDING"):
            words = "touch in progress"     # the engine logs playback/record once it ends
        return {"state": "neutral" if s["end"] else page_state(s["machine"], device, s["armed"]),
                "machine": s["machine"], "machine_words": words,
                "trial": s["trial"], "attempt": s["attempt"], "block": s["block"],
                "block_position": self._block_position(s["trial"], s["block"]),
                "elapsed_s": None if s["first_start"] is None else max(0.0, end_s - s["first_start"]),
                "time_left_s": left, "end": s["end"], "end_reason": s.get("end_reason"),
                "last_fault": s["last_fault"], "done": sum(1 for r in self.rows if r["status"] == "ok")}

    def _block_position(self, trial, block):
        if self.meta is None or not isinstance(trial, int):
            return None
        same = [sp.get("trial_index") for sp in self.meta.get("schedule") or ()
                if sp.get("block") == block]
        return same.index(trial) + 1 if trial in same else None

    def trial_trace(self, trace_file: str) -> dict | None:
        """A finished attempt's trace and its fault marker; None unless a row names the file."""
        row = next((r for r in self.rows if r["trace_file"] == trace_file and trace_file), None)
        parts = Path(trace_file).parts
        if row is None or len(parts) != 2 or parts[0] != "traces" or not parts[1].endswith(".csv"):
            return None                     # (a log naming a file outside traces/ is not followed)
        data = read_trace(self.folder / trace_file)
        fault = None
        if row["status"] != "ok":
            fault = fault_marker(data, row["fault_code"], row["message"])
        return {"row": row, "trace": data.slice(0), "fault": fault, "bad_lines": data.bad}
