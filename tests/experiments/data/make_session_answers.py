"""Regenerate ``session_answers_seed0.json`` (the reference answers of emulated sessions).

Run from the repository root:  .venv/bin/python tests/experiments/data/make_session_answers.py

It runs P01 (group A) and P16 (group B) of ``experiments.participant_model.cohort.paper_cohort(0)`` through
``roughness_recognition.toml`` on ``emulator://?clock=virtual&seed=0`` with the simulated
responder (default options) on the durable path (fsync per event) and stores, per trial, the
logged answer, response time and the percept. tests/experiments/test_session_answers.py checks
that a simulated study's fast path (no fsync) logs exactly these answers. Regenerate it only when
the model or what a trial logs changes on purpose, and say so in the commit.
"""
from __future__ import annotations

import csv
import json
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
PARTICIPANTS = ("P01", "P16")
SEED = 0


def session_answers(participants=PARTICIPANTS, seed: int = SEED, durable: bool = True) -> dict:
    """participant -> list of {block, trial_index, roughness_id, response_id, rt_s, percept}.

    ``durable=True`` is the slow path every real session takes (fsync per event); a simulated
    study runs with ``durable=False`` (no fsync, a simulated study's speed-up). The reference is made
    with the former and the test checks the latter against it.
    """
    from experiments.participant_model.cohort import write_cohort
    from experiments.simulation.figure9.study import run_participant
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        paths = {p.stem: p for p in write_cohort(Path(tmp) / "participants", seed=seed)}
        for pid in participants:
            res = run_participant(paths[pid], Path(tmp) / "data", seed=seed, durable=durable)
            session = Path(res["session_dir"])
            percepts = {}
            for line in (session / "events.jsonl").read_text(encoding="utf-8").splitlines():
                ev = json.loads(line)
                if ev.get("event", ev.get("type")) == "simulated_percept" or "percept" in ev and "features" in ev:
                    percepts[int(ev["trial_index"])] = ev["percept"]
            rows = []
            with open(session / "trials.csv", newline="", encoding="utf-8") as fh:
                for row in csv.DictReader(fh):
                    idx = int(row["trial_index"])
                    rows.append({"block": row["block"], "trial_index": idx,
                                 "roughness_id": int(row["roughness_id"]),
                                 "response_id": row["response_id"], "rt_s": row["rt_s"],
                                 "percept": percepts.get(idx)})
            out[pid] = rows
    return out


def git_commit() -> str:
    return subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                          cwd=HERE).stdout.strip()


if __name__ == "__main__":
    data = {"_comment": ("Reference answers of emulated sessions (P01, P16 of paper_cohort(0), "
                         "roughness_recognition, emulator://?clock=virtual&seed=0, simulated "
                         "responder with default options), produced by "
                         "tests/experiments/data/make_session_answers.py at commit "
                         f"{git_commit()} on the durable path (fsync per event, durable=True)."),
            "answers": session_answers(durable=True)}
    (HERE / "session_answers_seed0.json").write_text(json.dumps(data, indent=1) + "\n",
                                                      encoding="utf-8")
    sys.exit(0)
