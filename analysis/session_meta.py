"""What a session's ``session.json`` says about its protocol's blocks (one concept).

Which blocks are scored and answered, and whether the protocol asks for answers at all
(:func:`not_recognition_reason`): :func:`analysis.load.load_trials` skips a session whose
protocol asks none and scores only the blocks :func:`block_roles` says are scored.
"""
from __future__ import annotations

import json
from pathlib import Path

from sessionfiles.session_reader import read_text_file

__all__ = ["read_session_meta", "not_recognition_reason", "block_roles"]


def read_session_meta(folder: Path) -> dict:
    """``session.json`` as a dict, or ``{}`` when missing or unreadable (reported elsewhere)."""
    try:
        data = json.loads(read_text_file(folder / "session.json"))   # the session reader's rules
    except (OSError, ValueError, UnicodeDecodeError):
        return {}
    return data if isinstance(data, dict) else {}


def not_recognition_reason(meta: dict) -> str:
    """Why a session's protocol is not a roughness-recognition protocol (``""`` if it is).

    Parameters
    ----------
    meta : dict
        The session's ``session.json``; its ``protocol`` member is the protocol's TOML as
        parsed (``[protocol]`` table, ``[[blocks]]`` list).

    Returns
    -------
    str
        ``""`` when any block asks for an answer (``response`` true, the default) or when the
        protocol cannot be judged (no stored protocol or blocks: loaded as before); otherwise
        a reason naming the protocol, e.g. Exp. 1's ``interface_temperature``, whose single
        block records contact traces and asks for no answer.

    Notes
    -----
    A block's ``response`` decides rather than ``[protocol] experiment``: the experiment
    number is informative (0 when a custom protocol leaves it out), whereas a protocol
    without a block asking for an answer has no recognition trial to analyse.
    """
    protocol = meta.get("protocol")
    if not isinstance(protocol, dict):
        return ""
    blocks = protocol.get("blocks")
    if not isinstance(blocks, list) or not blocks or not all(isinstance(b, dict) for b in blocks):
        return ""
    if any(b.get("response", True) is not False for b in blocks):
        return ""
    head = protocol.get("protocol") if isinstance(protocol.get("protocol"), dict) else {}
    name = head.get("name", meta.get("protocol_name", "unnamed"))
    experiment = f" (experiment {head['experiment']})" if "experiment" in head else ""
    names = ", ".join(repr(str(b.get("name", "?"))) for b in blocks)
    which = f"block {names} has" if len(blocks) == 1 else f"blocks {names} have"
    return (f"expected a roughness-recognition protocol (a block asking for an answer), got "
            f"{name!r}{experiment}, whose {which} response = false")


def block_roles(meta: dict) -> dict:
    """Block name -> ``{"scored": bool, "response": bool}`` from a session's ``session.json``.

    ``blocks`` (written by the session) first, else the stored protocol's ``[[blocks]]`` with
    their defaults (``response`` true, ``scored`` = ``response``); ``{}`` when neither is there.
    """
    listed = meta.get("blocks")
    if not isinstance(listed, list):
        protocol = meta.get("protocol")
        listed = protocol.get("blocks") if isinstance(protocol, dict) else None
    if not isinstance(listed, list):
        return {}
    roles = {}
    for b in listed:
        if not isinstance(b, dict) or not isinstance(b.get("name"), str):
            continue
        response = b.get("response", True) is not False
        roles[b["name"]] = {"scored": b.get("scored", response) is not False, "response": response}
    return roles
