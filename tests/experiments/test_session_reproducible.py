"""No hidden state: a fixed-seed session's log does not depend on where it was written or on what
the profile cache held, and durability is a setting of each session, not of the process.

One seed-0 simulated participant (the default protocol, emulator on a virtual clock) is written to
two data folders: the first with an empty profile cache (every simulated profile computed), the
second with the cache the first one filled (every profile read back). Their ``events.jsonl`` must
be byte for byte equal once timestamps and wall-clock durations are blanked.
"""
from __future__ import annotations

import io
import json
import os
import re
from pathlib import Path

import pytest

#: Wall-clock values: ISO timestamps (events' ``time``, rows' ``started_at``) and the
#: ``session_started`` event's PsychoPy-style ``date`` (2026-11-26_19h24.33.838) and ``expStart``
#: (2026-11-26 19h24.33.838123 +0000).
_VOLATILE = re.compile(rb'\d{4}-\d{2}-\d{2}(T[0-9:.]+Z|_\d{2}h\d{2}\.\d{2}\.\d{3}'
                       rb'| \d{2}h\d{2}\.\d{2}\.\d{6} [+-]\d{4})')
#: Keys whose values are wall-clock durations (none today on a virtual clock; blanked if added).
_DURATION_KEYS = re.compile(rb'"(seconds|wall_s|elapsed_s|t_wall|duration_s_wall)":\s*[0-9.e+-]+')


def _blank(data: bytes) -> bytes:
    return _DURATION_KEYS.sub(rb'"\1":0', _VOLATILE.sub(b"T", data))


def _run(participant: Path, data_dir: Path, *, durable: bool) -> Path:
    from experiments.responders import get_responder
    from experiments.session import create_session
    session = create_session("roughness_recognition", participant, data_dir,
                             "emulator://?clock=virtual&seed=0", seed=0, responder_name="simulated",
                             clock="virtual", out=io.StringIO(), durable=durable)
    assert session.run(get_responder("simulated", seed=0)) == 0
    return session.directory


@pytest.fixture(scope="module")
def two_sessions(tmp_path_factory):
    """The same participant and seed in two data folders, cold and then warm profile cache."""
    from experiments.participant_model.cohort import write_cohort
    import stimuli._cache as cache
    tmp = tmp_path_factory.mktemp("two")
    participant = {p.stem: p for p in write_cohort(tmp / "participants", seed=0)}["P01"]
    hits = []
    real_load = cache.load

    def counting_load(kind, key, directory=None):
        entry = real_load(kind, key, directory)
        hits.append(entry is not None)
        return entry

    mp = pytest.MonkeyPatch()
    mp.setenv("THERMOCUE_CACHE", str(tmp / "cache"))
    mp.setattr(cache, "load", counting_load)
    try:
        first = _run(participant, tmp / "first" / "data", durable=False)
        cold = list(hits)
        entries = sorted(p.name for p in (tmp / "cache").iterdir())
        hits.clear()
        second = _run(participant, tmp / "elsewhere" / "deeper" / "data", durable=False)
        warm = list(hits)
        assert sorted(p.name for p in (tmp / "cache").iterdir()) == entries   # nothing recomputed
    finally:
        mp.undo()
    return first, second, cold, warm


def test_the_two_runs_differ_in_cache_and_folder(two_sessions):
    first, second, cold, warm = two_sessions
    # the first run computed its profiles (cache misses), the second read every one back
    assert cold and not any(cold)
    assert warm and all(warm) and len(warm) == len(cold)
    assert first.parent.parent != second.parent.parent


def test_a_session_log_is_the_same_wherever_it_was_written_and_whatever_the_cache(two_sessions):
    first, second, _, _ = two_sessions
    a = (first / "events.jsonl").read_bytes()
    b = (second / "events.jsonl").read_bytes()
    assert a != b                                    # the timestamps differ ...
    a_lines, b_lines = _blank(a).splitlines(), _blank(b).splitlines()
    assert len(a_lines) > 300
    for n, (x, y) in enumerate(zip(a_lines, b_lines), 1):
        assert x == y, f"events.jsonl line {n} differs:\n{x[:300]!r}\n{y[:300]!r}"
    assert len(a_lines) == len(b_lines)


def test_the_log_records_no_absolute_path(two_sessions):
    first, second, _, _ = two_sessions
    for session in (first, second):
        text = (session / "events.jsonl").read_text(encoding="utf-8")
        assert str(session.parent.parent) not in text and os.sep + "tmp" not in text
        exported = [json.loads(line) for line in text.splitlines() if '"bids_exported"' in line]
        assert len(exported) == 1
        path = exported[0]["path"]
        # relative to the session folder, and it names the file the export wrote
        assert not os.path.isabs(path) and path.startswith("../../bids/")
        assert (session / path).is_file()


def test_the_trials_table_traces_and_session_record_match_too(two_sessions):
    first, second, _, _ = two_sessions
    a, b = ((s / "session.json").read_bytes() for s in (first, second))
    assert _blank(a) == _blank(b)
    assert json.loads(a)["protocol_file"] == "roughness_recognition.toml"   # not the code's folder
    assert _blank((first / "trials.csv").read_bytes()) == _blank((second / "trials.csv").read_bytes())
    names = sorted(p.name for p in (first / "traces").iterdir())
    assert names and names == sorted(p.name for p in (second / "traces").iterdir())
    for name in names:
        assert (first / "traces" / name).read_bytes() == (second / "traces" / name).read_bytes()
