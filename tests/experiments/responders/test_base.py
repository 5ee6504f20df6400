"""Tests of the responder base: registry, Response, lazy imports."""
from __future__ import annotations

import json
import subprocess
import sys

import pytest

from experiments.errors import UserInputError
from experiments.responders import ConsoleResponder, Responder, Response, get_responder, responder_names


def test_registry_by_subclassing_with_aliases():
    class Nod(Responder, name="nod-test", aliases=("nod-alias-test",)):
        def respond(self, trial, stimulus):
            return Response(2, 0.1, "nod")

    assert isinstance(get_responder("nod-test"), Nod)
    assert isinstance(get_responder("nod-alias-test"), Nod)
    assert "nod-test" in responder_names() and Nod.name == "nod-test"
    assert isinstance(get_responder("console"), ConsoleResponder)
    assert isinstance(get_responder("terminal"), ConsoleResponder)


def test_a_name_taken_by_another_class_is_refused():
    with pytest.raises(TypeError, match="'console' already registered"):
        class Other(Responder, name="console"):
            pass


def test_unknown_name_and_option_are_user_errors():
    with pytest.raises(UserInputError, match=r"--responder: expected one of .*'console'.*got 'telepathy'"):
        get_responder("telepathy")
    with pytest.raises(UserInputError, match=r"responder 'console': options \['colour'\]"):
        get_responder("console", colour="red")


def test_response_is_typed_frozen_and_json_ready():
    r = Response(3, 1.25, "keyboard:ptb")
    assert repr(r) == "Response(response_id=3, rt_s=1.2500, source='keyboard:ptb')"
    assert json.loads(json.dumps(r.to_dict())) == {"response_id": 3, "rt_s": 1.25, "source": "keyboard:ptb",
                                                   "answer_keyed_after_cue_s": None,
                                                   "answer_mode": "keyed"}
    spoken = Response(2, 0.75, "experimenter:keyboard:ptb", answer_mode="spoken")
    assert spoken.to_dict() == {"response_id": 2, "rt_s": None, "answer_keyed_after_cue_s": 0.75,
                                "source": "experimenter:keyboard:ptb", "answer_mode": "spoken"}
    with pytest.raises(ValueError, match="answer_mode"):
        Response(1, 1.0, answer_mode="typed")
    with pytest.raises(AttributeError):
        r.response_id = 2
    for bad in (0, 5, "2", True, 2.0):
        with pytest.raises(ValueError, match="response_id"):
            Response(bad, 1.0)
    for bad in (-0.1, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="rt_s"):
            Response(1, bad)


def test_importing_the_package_does_not_import_psychopy_or_the_model():
    code = ("import sys, experiments.responders as r, experiments.session; "
            "r.get_responder('console'); "
            "print(sorted(m for m in sys.modules if m.split('.')[0] == 'psychopy' "
            "or m.endswith('simulation.person') or m.endswith('responders.simulated')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_simulated_and_psychopy_are_imported_on_demand():
    code = ("import sys, experiments.responders as r; x = r.get_responder('simulated'); "
            "p = r.get_responder('psychopy'); "
            "print(type(x).__name__, type(p).__name__, 'psychopy' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["SimulatedResponder", "PsychopyResponder", "False"]
