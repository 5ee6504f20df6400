"""Parameter recovery through the real pipeline: session engine -> emulated display -> logs on
disk -> loader -> analysis.

``test_recovery.py`` checks interval coverage over many synthetic studies written directly to
disk; here one small study is *run*: a responder with known per-cell probabilities answers the
packaged ``roughness_recognition`` protocol through :mod:`experiments.session` against the
in-process emulator (virtual clock), and the analysis must report exactly the answers the
responder gave (its own tally, kept outside the logs) and recover the known probabilities.
"""
from __future__ import annotations

import numpy as np
import pytest

from experiments.responders.base import RESPONSE_IDS, Responder, Response

# Known probabilities of a correct answer: strong group difference with real samples, none with
# simulated ones (the pattern the paper reports, exaggerated so a small study resolves it).
CELLS = {("A", "real"): 0.9, ("B", "real"): 0.3, ("A", "simulated"): 0.6, ("B", "simulated"): 0.6}


class KnownProbabilityResponder(Responder, name="known-probability-test"):
    """Answers correctly with the cell's known probability, else one of the other samples."""

    human = False

    def __init__(self, seed=0):
        super().__init__()
        self.rng = np.random.default_rng(seed)
        self.tally = {}          # (group, mode, roughness_id) -> [n_trials, n_correct]

    def respond(self, trial, stimulus):
        group = self.session.group
        if trial.block == "familiarise":
            return Response(trial.roughness_id, 0.5, source="known-probability")
        correct = self.rng.random() < CELLS[(group, trial.mode)]
        others = [r for r in RESPONSE_IDS if r != trial.roughness_id]
        answer = trial.roughness_id if correct else int(self.rng.choice(others))
        n = self.tally.setdefault((group, trial.mode, trial.roughness_id), [0, 0])
        n[0] += 1
        n[1] += int(correct)
        return Response(answer, 0.5, source="known-probability")


@pytest.mark.slow
def test_analysis_recovers_what_a_known_responder_answered_through_the_session_engine(tmp_path):
    from analysis import analyze
    from experiments.participant_model.cohort import alternate_groups, paper_cohort
    import json
    import re
    from importlib.resources import files

    from experiments.session import create_session

    records = alternate_groups(paper_cohort(seed=11), 8)           # 4 per group
    # The packaged protocol with 2 s contacts (this responder ignores the stimulus): the same
    # blocks, samples, repetitions and randomisation, an eighth of the emulated device time.
    text = (files("experiments") / "protocols" / "roughness_recognition.toml").read_text("utf-8")
    for key in ("max_contact_s", "record_s", "duration_s"):
        text, n = re.subn(rf"^{key} = [0-9.]+", f"{key} = 2.0", text, flags=re.M)
        assert n == 1, key
    protocol = tmp_path / "recognition_2s.toml"
    protocol.write_text(text, encoding="utf-8")
    tally = {}
    for k, record in enumerate(records):
        path = tmp_path / "people" / f"{record['id']}.json"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(record), encoding="utf-8")
        session = create_session(protocol, path, tmp_path / "data",
                                 "emulator://?clock=virtual", seed=100 + k,
                                 responder_name="known-probability-test")
        responder = KnownProbabilityResponder(seed=200 + k)
        assert session.run(responder) == 0
        for key, (n, c) in responder.tally.items():
            t = tally.setdefault(key, [0, 0])
            t[0] += n
            t[1] += c

    result = analyze(tmp_path / "data", tmp_path / "out", progress=None, bayes=False)
    props = result.proportions.set_index(["group", "mode", "roughness_id"])
    # 1. Nothing lost, altered or duplicated between the responder and the analysis.
    assert len(props) == 16
    for (group, mode, r), (n, c) in tally.items():
        assert (props.loc[(group, mode, r), "n_trials"], props.loc[(group, mode, r), "n_correct"]) \
            == (n, c)
    # 2. Recovery: per group x mode (48 trials each) the known probability lies in the 95 %
    #    Wilson interval of the pooled answers, and the GEE sees the real-mode group difference
    #    (log odds ratio of the known cells: logit 0.9 - logit 0.3 = 3.04) and none in simulated.
    for (group, mode), p in CELLS.items():
        n = sum(tally[(group, mode, r)][0] for r in RESPONSE_IDS)
        c = sum(tally[(group, mode, r)][1] for r in RESPONSE_IDS)
        z = 1.959964
        centre = (c + z * z / 2) / (n + z * z)
        half = z * np.sqrt(c * (n - c) / n + z * z / 4) / (n + z * z)
        assert centre - half <= p <= centre + half, (group, mode, c, n)
    contrasts = result.contrasts[(result.contrasts["model"] == "gee")
                                 & (result.contrasts["roughness_id"] == 0)].set_index("mode")
    assert contrasts.loc["real", "ci_low"] > 0
    assert contrasts.loc["real", "ci_low"] < 3.04 < contrasts.loc["real", "ci_high"]
    assert contrasts.loc["simulated", "ci_low"] < 0 < contrasts.loc["simulated", "ci_high"]
