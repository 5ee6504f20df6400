"""A synthetic-study generator for the analysis tests (parameter recovery, loader, report).

``write_study`` writes session folders in the documented layout
(``DATA/<participant>/<session>/`` with ``session.json``, ``events.jsonl`` and
``trials.csv``; docs/design.md "Session directory", docs/internal-contracts.md
"Trials table"; events as ``sessionfiles.logbook`` documents them:
``session_started`` with the session context, ``trial_started`` with the trial's
spec, ``trial_completed`` whose ``row`` holds only the outcome, ``session_finished``) from *known* per-cell probabilities of a correct answer. A
participant's probability in a cell is ``expit(logit(p_cell) + u)`` with a
random intercept ``u ~ N(0, sigma²)`` on the log-odds scale (``sigma = 0``: no
participant differences). A wrong answer is one of the three other samples,
uniformly. The generator is independent of the code under test: it uses only
numpy, json and csv.
"""
from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np

COLUMNS = ["participant", "group", "session", "block", "trial_index", "mode", "roughness_id",
           "roughness_um", "repetition", "response_id", "correct", "rt_s", "status",
           "tracking_rms_C", "skin_thickness_um", "sex", "attempt", "started_at", "fault_code",
           "answer_mode", "answer_keyed_after_cue_s"]
ROUGHNESS_UM = {1: 1.6, 2: 12.5, 3: 50.0, 4: 100.0}


def expit(x):
    return 1.0 / (1.0 + math.exp(-x))


def logit(p):
    return math.log(p / (1 - p))


def paper_like_cells():
    """Known per-cell probabilities: A above B in real mode, equal in simulated mode."""
    base = {1: 0.30, 2: 0.40, 3: 0.50, 4: 0.60}
    cells = {}
    for r, p in base.items():
        cells[("A", "real", r)] = min(p + 0.15, 0.95)
        cells[("B", "real", r)] = p
        cells[("A", "simulated", r)] = p + 0.05
        cells[("B", "simulated", r)] = p + 0.05
    return cells


def write_study(root, cells, *, n_per_group=15, reps=3, sigma=0.0, seed=0, familiarise=True,
                fault_rate=0.0, write_csv=True, write_events=True, session="S1"):
    """Write one session per participant; return the participants' random intercepts."""
    rng = np.random.default_rng(seed)
    root = Path(root)
    intercepts = {}
    for group in ("A", "B"):
        for i in range(n_per_group):
            pid = f"{group}{i:02d}"
            u = float(rng.normal(0.0, sigma)) if sigma > 0 else 0.0
            intercepts[pid] = u
            thickness = 650.0 if group == "A" else 1000.0
            rows, index = [], 0
            blocks = (["familiarise"] if familiarise else []) + ["real", "simulated"]
            for block in blocks:
                plan = [(r, k) for r in range(1, 5) for k in range(1 if block == "familiarise" else reps)]
                order = rng.permutation(len(plan))
                for j in order:
                    r, rep = plan[j]
                    index += 1
                    attempt = 1
                    base = {"participant": pid, "group": group, "session": session, "block": block,
                            "trial_index": index, "roughness_id": r,
                            "mode": "real" if block == "familiarise" else block,
                            "roughness_um": ROUGHNESS_UM[r], "repetition": rep + 1,
                            "skin_thickness_um": thickness, "sex": "F" if i % 2 else "M",
                            "started_at": f"2026-11-22T04:{index % 60:02d}:00Z",
                            "answer_mode": "keyed", "answer_keyed_after_cue_s": ""}
                    if block != "familiarise" and rng.random() < fault_rate:
                        rows.append({**base, "response_id": "", "correct": "", "rt_s": "",
                                     "status": "fault", "tracking_rms_C": "", "attempt": attempt,
                                     "fault_code": "E_TRACK"})
                        attempt += 1
                    if block == "familiarise":     # no answer asked (as experiments.session logs it)
                        rows.append({**base, "response_id": "", "correct": "", "rt_s": "",
                                     "status": "ok", "tracking_rms_C": "", "attempt": attempt,
                                     "fault_code": ""})
                        continue
                    p = expit(logit(cells[(group, block, r)]) + u)
                    correct = bool(rng.random() < p)
                    response = r if correct else int(rng.choice([s for s in range(1, 5) if s != r]))
                    rows.append({**base, "response_id": response, "correct": int(correct),
                                 "rt_s": round(float(rng.uniform(2, 8)), 3), "status": "ok",
                                 "tracking_rms_C": round(float(rng.uniform(0.01, 0.1)), 4),
                                 "attempt": attempt, "fault_code": ""})
            folder = root / pid / session
            folder.mkdir(parents=True, exist_ok=True)
            (folder / "session.json").write_text(json.dumps({
                "participant": {"id": pid, "sex": "F" if i % 2 else "M",
                                "skin_thickness_um": thickness},
                "group": group, "session": session, "seed": seed}))
            if write_events:     # as sessionfiles.logbook writes them
                # written from the documented format, not from sessionfiles.logformat's lists:
                # the generator stays independent of the code under test
                spec_keys = ("block", "mode", "roughness_id", "roughness_um", "repetition")
                context = ("participant", "group", "session", "skin_thickness_um", "sex")
                with open(folder / "events.jsonl", "w") as fh:
                    first = rows[0]
                    fh.write(json.dumps({"event": "session_started", "seq": 1, "seed": seed,
                                         **{k: first[k] for k in context}}) + "\n")
                    for row in rows:
                        key = {"trial_index": row["trial_index"], "attempt": row["attempt"]}
                        fh.write(json.dumps({"event": "trial_started", **key,
                                             "time": row["started_at"],
                                             **{k: row[k] for k in spec_keys}}) + "\n")
                        outcome = {k: (None if row[k] == "" else row[k]) for k in row
                                   if k not in spec_keys + context + ("trial_index", "attempt")}
                        fh.write(json.dumps({"event": "trial_completed", **key,
                                             "row": outcome}) + "\n")
                    fh.write(json.dumps({"event": "session_finished"}) + "\n")
            if write_csv:
                with open(folder / "trials.csv", "w", newline="") as fh:
                    writer = csv.DictWriter(fh, fieldnames=COLUMNS, lineterminator="\n")
                    writer.writeheader()
                    writer.writerows(rows)
    return intercepts
