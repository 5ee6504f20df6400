"""Scored blocks come from the session's data, not from block names.

The packaged roughness_recognition protocol with its commented-out ``review`` block enabled is run
through the session engine (in-process emulator, virtual clock); the loader must read from
``session.json`` that ``review`` is unscored and unanswered (on the old code it stopped with
``response_id: expected an integer ... got ''``).
"""
from __future__ import annotations

import json
import re
from importlib.resources import files
from pathlib import Path

import pytest

from analysis.load import block_roles, load_trials
from experiments.responders.base import Responder, Response

ROOT = Path(__file__).resolve().parents[2]
P01 = ROOT / "participants" / "examples" / "P01.json"


class RightAnswers(Responder, name="right-answers-test"):
    human = False

    def respond(self, trial, stimulus):
        return Response(trial.roughness_id, 0.4, source="test")


def review_protocol(folder: Path, block_name: str = "review") -> Path:
    text = (files("experiments") / "protocols" / "roughness_recognition.toml").read_text("utf-8")
    start = text.index("# [[blocks]]\n# name = \"review\"")
    end = text.index("\n\n", start)
    text = text[:start] + "\n".join(line[2:] for line in text[start:end].splitlines()) + text[end:]
    text = text.replace('name = "review"', f'name = "{block_name}"')
    for key in ("max_contact_s", "record_s", "duration_s"):
        text = re.sub(rf"^{key} = 20\.0", f"{key} = 1.0", text, flags=re.M)
    path = folder / "review.toml"
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.slow
@pytest.mark.parametrize("name", ["review", "look-again"])
def test_an_unscored_review_block_of_any_name_is_read_from_session_json(tmp_path, name):
    from experiments.session import create_session

    s = create_session(review_protocol(tmp_path, name), P01, tmp_path / "data",
                       "emulator://?clock=virtual&seed=4", seed=3, responder_name="right-answers-test",
                       clock="virtual")
    assert s.run(RightAnswers()) == 0
    meta = json.loads((s.directory / "session.json").read_text())
    assert block_roles(meta)[name] == {"scored": False, "response": False}
    log = load_trials(tmp_path / "data")
    t = log.trials
    assert sorted(t["block"].unique()) == sorted(["familiarise", "real", name, "simulated"])
    assert (t.loc[t["block"] == name, "exclusion"] == "unscored block").all()
    assert (t.loc[t["block"] == name].shape[0]) == 4
    assert (t.loc[t["block"] == "familiarise", "exclusion"] == "familiarisation").all()
    assert set(log.analysable["block"]) == {"real", "simulated"} and len(log.analysable) == 24


def test_block_roles_fall_back_to_the_stored_protocol_with_its_defaults():
    meta = {"protocol": {"blocks": [{"name": "a", "response": False}, {"name": "b"},
                                    {"name": "c", "scored": False}]}}
    assert block_roles(meta) == {"a": {"scored": False, "response": False},
                                 "b": {"scored": True, "response": True},
                                 "c": {"scored": False, "response": True}}
    assert block_roles({}) == {}
