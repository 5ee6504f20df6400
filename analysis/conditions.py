"""Conditions are data: the display and contact model each session ran on (one concept).

A session's *condition* is what its trials were played on: the display backend (the scheme
of ``session.json``'s ``display_url``: ``serial``, ``emulator``, ``qemu-firmware``, ``tcs2``,
...) and the protocol's contact model (``[simulation] contact_model``: ``press`` on the
paper's display, ``resting`` on a TCS II probe). Trials from different displays or contact
models are different experiments (docs/tcs2.md): :func:`choose_condition` never lets them into
one test. The device id and the firmware (image) hash, when ``session.json`` records them, and
the protocol's name and hash are carried as columns too (:data:`CONDITION_COLUMNS`), not as
part of the condition: two units of one display model run one condition.
"""
from __future__ import annotations

import pandas as pd

from .errors import LogError

__all__ = ["CONDITION_COLUMNS", "session_condition", "condition_label", "choose_condition"]

#: Columns every session row (``sessions.csv``) and every trial row carry.
CONDITION_COLUMNS = ["display_backend", "device_id", "firmware_image_id", "contact_model",
                     "protocol_name", "protocol_hash"]

#: pyserial's URL schemes: the thermocue protocol on a serial port (backend ``serial``).
_PYSERIAL = ("loop", "socket", "rfc2217", "spy", "hwgrep", "alt", "cp2110")

def _backend(url) -> str:
    """The backend scheme of a display URL; ``""`` when the session did not record one."""
    if not isinstance(url, str) or not url.strip():
        return ""
    if "://" not in url:
        return "serial"                          # a port path
    scheme = url.split("://", 1)[0].strip().lower()
    return "serial" if scheme in _PYSERIAL else scheme


def _opened(meta: dict, key: str) -> str:
    """``key`` (``device_id``, ``image_id``) of every display the session opened, in order,
    each once (``session.json``'s ``displays``: one entry per opening, at the start, a resume or
    a reconnection), joined by `` + ``; ``""`` when none is recorded."""
    displays = meta.get("displays")
    seen: list[str] = []
    for entry in displays if isinstance(displays, list) else ():
        value = entry.get(key) if isinstance(entry, dict) else None
        if isinstance(value, str) and value and value not in seen:
            seen.append(value)
    return " + ".join(seen)


def session_condition(meta: dict) -> dict:
    """The :data:`CONDITION_COLUMNS` of one session from its ``session.json`` (as read).

    Unrecorded values are ``""``. The contact model is the stored protocol's
    ``[simulation] contact_model``, ``press`` (the protocol's default) when the protocol is
    stored without one.
    """
    meta = meta if isinstance(meta, dict) else {}
    protocol = meta.get("protocol") if isinstance(meta.get("protocol"), dict) else None
    contact = ""
    if protocol is not None:
        simulation = protocol.get("simulation")
        value = simulation.get("contact_model") if isinstance(simulation, dict) else None
        contact = str(value) if isinstance(value, str) and value else "press"
    name = meta.get("protocol_name")
    if not isinstance(name, str) and protocol is not None:
        head = protocol.get("protocol")
        name = head.get("name") if isinstance(head, dict) else None
    digest = meta.get("protocol_hash")
    return {"display_backend": _backend(meta.get("display_url")),
            "device_id": _opened(meta, "device_id"),
            "firmware_image_id": _opened(meta, "image_id"),
            "contact_model": contact,
            "protocol_name": name if isinstance(name, str) else "",
            "protocol_hash": digest if isinstance(digest, str) else ""}


def condition_label(backend: str, contact: str) -> str:
    """``BACKEND/CONTACT`` (``tcs2/resting``); ``unrecorded`` for a value a session lacks.

    The same text is the value of ``thermocue analyze --condition``.
    """
    return f"{backend or 'unrecorded'}/{contact or 'unrecorded'}"


def _agrees(row, backend: str, contact: str) -> bool:
    """A session's recorded backend and contact model agree with ``backend``/``contact``
    (an unrecorded value, ``""``, agrees with any: a hand-written or old session folder)."""
    return (row["display_backend"] in ("", backend)) and (row["contact_model"] in ("", contact))


def choose_condition(sessions: pd.DataFrame, choice: str | None) -> tuple[pd.DataFrame, str]:
    """Keep the sessions of one condition; refuse to pool two.

    Parameters
    ----------
    sessions : pandas.DataFrame
        :class:`analysis.load.TrialLog`'s sessions before the inclusion policy, with
        :data:`CONDITION_COLUMNS` and ``skipped``.
    choice : str or None
        ``BACKEND/CONTACT`` (:func:`condition_label`), from ``--condition``.

    Returns
    -------
    sessions : pandas.DataFrame
        With ``condition`` added; sessions of another condition get a ``skipped`` reason.
    label : str
        The condition analysed: the recorded backend and contact model (``unrecorded`` for a
        value no session records).

    Raises
    ------
    LogError
        Sessions that record two different backends or contact models and no ``choice`` (the
        message names each condition, its sessions and ``--condition``), or a ``choice`` no
        session ran.

    Notes
    -----
    A value a session does not record (``""``: a folder written by hand or by an old version)
    is compatible with any: such sessions join the one recorded condition.
    """
    sessions = sessions.copy()
    sessions["condition"] = [condition_label(b, c) for b, c in
                             zip(sessions["display_backend"], sessions["contact_model"])]
    usable = sessions[sessions["skipped"] == ""]
    backends = list(dict.fromkeys(b for b in usable["display_backend"] if b))
    contacts = list(dict.fromkeys(c for c in usable["contact_model"] if c))
    found = list(dict.fromkeys(usable["condition"]))
    if choice is None:
        if len(backends) > 1 or len(contacts) > 1:
            parts = []
            for label in found:
                paths = usable.loc[usable["condition"] == label, "path"].tolist()
                more = f" and {len(paths) - 2} more" if len(paths) > 2 else ""
                parts.append(f"{label} ({', '.join(paths[:2])}{more})")
            named = [f for f in found if "unrecorded" not in f] or found
            raise LogError(f"{usable['path'].iloc[0]}: condition: expected one display and "
                           f"contact model per analysis, got {len(found)}: {'; '.join(parts)}; "
                           f"choose one with --condition {named[0]} (trials of different "
                           f"displays or contact models are never pooled)")
        return sessions, condition_label(backends[0] if backends else "",
                                         contacts[0] if contacts else "")
    backend, _, contact = choice.partition("/")
    agree = usable.apply(lambda row: _agrees(row, backend, contact), axis=1) \
        if not usable.empty else pd.Series(dtype=bool)
    def known(part: str, column: str) -> bool:
        return part == "unrecorded" or bool((usable[column] == part).any())

    if not (agree.any() and known(backend, "display_backend") and known(contact, "contact_model")):
        raise LogError(f"--condition: expected one of {', '.join(found)} (the conditions of the "
                       f"sessions found), got {choice!r}")
    other = (sessions["skipped"] == "") & ~sessions.apply(
        lambda row: _agrees(row, backend, contact), axis=1)
    sessions.loc[other, "skipped"] = [f"condition {c}, not the chosen {choice} (--condition)"
                                      for c in sessions.loc[other, "condition"]]
    return sessions, choice
