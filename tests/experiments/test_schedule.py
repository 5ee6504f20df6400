"""Schedules: reproducible from (protocol hash, participant, seed), balanced, counterbalanced."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from collections import Counter

import numpy as np
import pytest
from scipy import stats

from experiments.errors import UserInputError
from experiments.protocol import PROTOCOLS_DIR, load_protocol
from experiments.schedule import TrialSpec, build_schedule, participant_number

RR = PROTOCOLS_DIR / "roughness_recognition.toml"


@pytest.fixture(scope="module")
def rr():
    return load_protocol("roughness_recognition")


def variant(tmp_path, *pairs, name="variant.toml"):
    text = RR.read_text(encoding="utf-8")
    for old, new in pairs:
        assert old in text, f"test setup: {old!r} not in {RR.name}"
        text = text.replace(old, new)
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return load_protocol(path)


def ids(schedule, block):
    return [t.roughness_id for t in schedule if t.block == block]


def test_layout_of_a_session(rr):
    s = build_schedule(rr, "P07", 20261122)
    assert [t.trial_index for t in s] == list(range(1, 29))
    assert [t.block for t in s] == ["familiarise"] * 4 + ["real"] * 12 + ["simulated"] * 12
    assert [t.mode for t in s] == ["real"] * 16 + ["simulated"] * 12
    # familiarisation: each sample once, in listed order
    assert ids(s, "familiarise") == [1, 2, 3, 4]
    um = {1: 1.6, 2: 12.5, 3: 50.0, 4: 100.0}
    assert all(t.roughness_um == um[t.roughness_id] for t in s)
    for block in ("real", "simulated"):
        assert Counter(ids(s, block)) == {1: 3, 2: 3, 3: 3, 4: 3}
        # repetition counts occurrences of the sample in time order
        seen = Counter()
        for t in (t for t in s if t.block == block):
            seen[t.roughness_id] += 1
            assert t.repetition == seen[t.roughness_id]


def test_same_inputs_same_schedule(rr):
    assert build_schedule(rr, "P07", 5) == build_schedule(load_protocol(RR), "P07", 5)


def test_other_seed_participant_or_content_gives_another_schedule(rr, tmp_path):
    base = build_schedule(rr, "P07", 5)
    assert build_schedule(rr, "P07", 6) != base
    assert build_schedule(rr, "P08", 5) != base
    retitled = variant(tmp_path, ('title = "', 'title = "(copy) '))
    assert retitled.hash != rr.hash
    assert build_schedule(retitled, "P07", 5) != base
    # blocks are drawn from separate streams: the real and simulated orders differ
    assert ids(base, "real") != ids(base, "simulated")


def test_schedule_does_not_depend_on_the_process(rr):
    """Another interpreter with another PYTHONHASHSEED gives the same schedule (no hash())."""
    code = ("import json; from experiments.protocol import load_protocol; "
            "from experiments.schedule import build_schedule; "
            "print(json.dumps([t.to_dict() for t in build_schedule(load_protocol('roughness_recognition'), 'P07', 5)]))")
    env = dict(os.environ, PYTHONHASHSEED="12345")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         check=True, timeout=60).stdout
    theirs = [TrialSpec.from_dict(d) for d in json.loads(out)]
    assert theirs == build_schedule(rr, "P07", 5)


def test_positions_are_balanced_over_sessions(rr):
    """Each sample is equally likely at each of the 12 positions of a random block."""
    counts = np.zeros((12, 4))
    for seed in range(400):
        for pos, sid in enumerate(ids(build_schedule(rr, "P01", seed), "real")):
            counts[pos, sid - 1] += 1
    # every position holds each sample 100 times in expectation (400 sessions / 4)
    chi2 = ((counts - 100.0) ** 2 / 100.0).sum()
    dof = 12 * 3
    assert stats.chi2.sf(chi2, dof) > 1e-3


def test_random_block_allows_repeats_unless_asked(rr, tmp_path):
    def has_repeat(seq):
        return any(a == b for a, b in zip(seq, seq[1:]))

    plain = [ids(build_schedule(rr, "P01", seed), "real") for seed in range(50)]
    assert any(has_repeat(s) for s in plain)      # the paper's plain shuffle has some
    strict = variant(tmp_path, ('repetitions = 3\norder = "random"',
                                'repetitions = 3\norder = "random"\nno_immediate_repeats = true'))
    for seed in range(50):
        s = build_schedule(strict, "P01", seed)
        for block in ("real", "simulated"):
            assert not has_repeat(ids(s, block))
            assert Counter(ids(s, block)) == {1: 3, 2: 3, 3: 3, 4: 3}


def test_by_repetition_order(tmp_path):
    p = variant(tmp_path, ('order = "random"', 'order = "by_repetition"'))
    s = build_schedule(p, "P03", 1)
    real = [t for t in s if t.block == "real"]
    for k in range(3):
        part = real[4 * k: 4 * k + 4]
        assert sorted(t.roughness_id for t in part) == [1, 2, 3, 4]
        assert all(t.repetition == k + 1 for t in part)


def test_fixed_block_order_is_the_papers(rr):
    for pid in ("P01", "P02", "X"):
        s = build_schedule(rr, pid, 3)
        assert [t.block for t in s][::4] == ["familiarise", "real", "real", "real", "simulated", "simulated", "simulated"]


def test_counterbalanced_block_order(tmp_path):
    p = variant(tmp_path, ('block_order = "fixed"', 'block_order = "counterbalanced"'))
    firsts = {}
    for n in range(1, 21):
        s = build_schedule(p, f"P{n:02d}", 7)
        assert s[0].block == "familiarise" and [t.block for t in s[:4]] == ["familiarise"] * 4
        firsts[n] = s[4].block
        assert s[16].block == ("simulated" if firsts[n] == "real" else "real")
    assert Counter(firsts.values()) == {"real": 10, "simulated": 10}
    # consecutive participant numbers alternate; even numbers run the listed order
    assert all(firsts[n] == ("real" if n % 2 == 0 else "simulated") for n in firsts)
    # the order depends on the participant, not on the seed
    assert build_schedule(p, "P03", 1)[4].block == build_schedule(p, "P03", 99)[4].block


def test_random_block_order(tmp_path):
    p = variant(tmp_path, ('block_order = "fixed"', 'block_order = "random"'))
    firsts = Counter(build_schedule(p, "P01", seed)[4].block for seed in range(40))
    assert set(firsts) == {"real", "simulated"}


def test_participant_number():
    assert participant_number("P07") == 7
    assert participant_number("S12-b") == 12
    assert participant_number("anna") == participant_number("anna")


def test_trialspec_round_trip(rr):
    s = build_schedule(rr, "P07", 1)
    again = [TrialSpec.from_dict(d) for d in json.loads(json.dumps([t.to_dict() for t in s]))]
    assert again == s
    row = dict(s[5].to_dict(), response_id=2, rt_s=1.5)       # extra keys of a trial row
    assert TrialSpec.from_dict(row) == s[5]
    csv_like = {k: str(v) for k, v in s[5].to_dict().items()}  # as read back from trials.csv
    assert TrialSpec.from_dict(csv_like) == s[5]
    with pytest.raises(ValueError, match=r"TrialSpec: repetition: expected an integer, got nothing \(the key is required\)"):
        TrialSpec.from_dict({k: v for k, v in s[5].to_dict().items() if k != "repetition"})
    with pytest.raises(ValueError, match="TrialSpec: trial_index: expected an integer, got 'x'"):
        TrialSpec.from_dict(dict(s[5].to_dict(), trial_index="x"))
    with pytest.raises(AttributeError):
        s[0].block = "real"


@pytest.mark.parametrize("pid, seed, message", [
    ("P07", -1, "schedule: seed: expected an integer ≥ 0, got -1"),
    ("P07", "1", "schedule: seed: expected an integer ≥ 0, got '1'"),
    ("P07", True, "schedule: seed: expected an integer ≥ 0, got True"),
    ("", 1, "schedule: participant id: expected a non-empty string, got ''"),
])
def test_bad_inputs(rr, pid, seed, message):
    with pytest.raises(UserInputError) as ei:
        build_schedule(rr, pid, seed)
    assert str(ei.value) == message


def test_unscored_blocks_keep_their_place_when_counterbalanced(tmp_path):
    review = ("# [[blocks]]\n# name = \"review\"\n# mode = \"real\"\n# repetitions = 1\n# order = \"fixed\"\n"
              "# scored = false\n# feedback = true\n# response = false\n")
    p = variant(tmp_path, (review, review.replace("# ", "")),
                ('block_order = "fixed"', 'block_order = "counterbalanced"'))
    assert [b.name for b in p.blocks] == ["familiarise", "real", "review", "simulated"]
    for pid, middle_first in (("P01", "simulated"), ("P02", "real")):
        s = build_schedule(p, pid, 1)
        assert len(s) == 32
        assert [t.block for t in s][::4] == (["familiarise"] + [middle_first] * 3 + ["review"]
                                             + [{"real": "simulated", "simulated": "real"}[middle_first]] * 3)
        assert [t.roughness_id for t in s if t.block == "review"] == [1, 2, 3, 4]
