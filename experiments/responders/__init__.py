"""Responders: who answers the trials (PsychoPy window, console, simulated participant).

PsychoPy is never imported here: :func:`get_responder` imports ``psychopy_window`` (or the
participant model's ``simulated``) only when that name is asked for.
"""
from experiments.responders.base import (
    RESPONSE_IDS,
    Responder,
    ResponderClosed,
    Response,
    TrialStimulus,
    get_responder,
    responder_names,
)
from experiments.responders.console import ConsoleResponder

__all__ = [
    "RESPONSE_IDS",
    "Responder",
    "ResponderClosed",
    "Response",
    "TrialStimulus",
    "get_responder",
    "responder_names",
    "ConsoleResponder",
]
