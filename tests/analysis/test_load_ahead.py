"""analysis.load_ahead: the sessions read by a forked child while the caller imports the rest.

The fork is tried in a fresh interpreter: the test process may hold other threads (a dask
cluster's, from earlier tests), where :func:`analysis.worker.can_fork` refuses to fork.
"""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).parent

SCRIPT = r"""
import json, os, sys, warnings
from pathlib import Path
sys.path.insert(0, sys.argv[1])
from _study_writer import paper_like_cells, write_study
from analysis import load_ahead

root = Path(sys.argv[2])
data = root / "data"
write_study(data, paper_like_cells(), n_per_group=2, write_events=False, seed=1)
path = sorted(data.rglob("trials.csv"))[0]
lines = path.read_text().splitlines(keepends=True)
path.write_text("".join(lines[:10]) + lines[10][:12])          # a torn last line: a warning

def read(how):
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        log = how()
    return log, [(type(w.message).__name__, str(w.message)) for w in seen]

out = {}
pending = load_ahead.start(data)
out["forked"] = pending.forked
log, seen = read(pending.result)
from analysis.load import load_trials
here, seen_here = read(lambda: load_trials(data))
out["same_trials"] = log.trials.equals(here.trials)
out["same_sessions"] = log.sessions.equals(here.sessions)
out["same_messages"] = log.warnings == here.warnings
out["warnings"] = seen
out["warnings_here"] = seen_here
out["policy"] = log.policy

try:
    load_ahead.start(root / "nope").result()
except Exception as exc:
    out["error"] = [type(exc).__name__, str(exc)]

load_ahead._child = lambda *args: os._exit(9)                 # the child dies, no answer
pending = load_ahead.start(data, sessions="all")
out["died_forked"] = pending.forked
log, _ = read(pending.result)
out["died_same"] = log.trials.equals(load_trials(data, sessions="all").trials)
out["died_policy"] = log.policy
print(json.dumps(out))
"""


@pytest.fixture(scope="module")
def outcome(tmp_path_factory):
    root = tmp_path_factory.mktemp("load_ahead")
    done = subprocess.run([sys.executable, "-c", SCRIPT, str(HERE), str(root)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1]), root


def test_a_forked_child_reads_the_sessions_as_this_process_does(outcome):
    out, _ = outcome
    assert out["forked"] is True
    assert out["same_trials"] and out["same_sessions"] and out["same_messages"]
    assert out["policy"] == "first"


def test_the_childs_warnings_are_issued_in_the_caller(outcome):
    out, root = outcome
    torn = [w for w in out["warnings"] if "torn last line" in w[1]]
    assert torn and torn[0][0] == "LogWarning" and str(root / "data") in torn[0][1]
    assert out["warnings"] == out["warnings_here"]


def test_the_childs_log_error_is_raised_in_the_caller(outcome):
    out, root = outcome
    assert out["error"][0] == "LogError"
    assert str(root / "nope") in out["error"][1]
    assert "expected an existing directory" in out["error"][1]


def test_a_child_that_dies_leaves_the_read_to_the_caller(outcome):
    out, _ = outcome
    assert out["died_forked"] is True
    assert out["died_same"] and out["died_policy"] == "all"


def test_the_loader_imports_neither_scipy_nor_statsmodels_nor_matplotlib():
    # what lets the child start reading before the caller's heavy imports
    script = ("import sys; import analysis.load, analysis.load_ahead; "
              "print(sorted(m for m in ('scipy', 'statsmodels', 'matplotlib') if m in sys.modules))")
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          check=True, timeout=120)
    assert done.stdout.strip() == "[]"
