"""Load and validate participant records (JSON Schema 2020-12 plus semantic checks).

The schema (``participant.schema.json`` beside this module, checked by the one validation
stack, :mod:`participants_schema.schema_check`) fixes the fields and their
types; :func:`validate_participant` adds what a schema cannot say well: consent must be
given, each skin layer is thinner than the whole skin, the thickness is in a range a
fingertip can have (which catches millimetres typed as micrometres).  Milder oddities
(layers that do not quite add up, an unusual but possible thickness) are not errors:
:func:`participant_warnings` lists them, and :func:`participants_schema.assign_group`
reports them with the group.
"""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, Mapping

from participants_schema.errors import ParticipantError
from participants_schema.schema_check import field_path as _field
from participants_schema.schema_check import load_schema_file, schema_problems

__all__ = [
    "SCHEMA_PATH",
    "load_schema",
    "load_participant",
    "validate_participant",
    "participant_warnings",
    "HARD_THICKNESS_RANGE_UM",
    "PLAUSIBLE_THICKNESS_RANGE_UM",
    "LAYER_TOLERANCE_UM",
    "LAYER_TOLERANCE_REL",
    "LAYER_ERROR_REL",
]

#: The JSON Schema file shipped with the package.
SCHEMA_PATH = Path(__file__).with_name("participant.schema.json")

#: Fingertip skin thickness outside this range (µm) is an error (a unit mistake, most likely).
HARD_THICKNESS_RANGE_UM = (100.0, 5000.0)
#: Outside this range (µm) a thickness is possible but unusual: a warning.  The paper's
#: participants were 600-1200 µm; its reference [22] gives epidermis 31-637 µm and dermis
#: 469-1942 µm.
PLAUSIBLE_THICKNESS_RANGE_UM = (400.0, 2600.0)
#: Layers must sum to the total within max(LAYER_TOLERANCE_UM, LAYER_TOLERANCE_REL * total)
#: or a warning is given ...
LAYER_TOLERANCE_UM = 10.0
LAYER_TOLERANCE_REL = 0.02
#: ... and beyond LAYER_ERROR_REL * total it is an error.
LAYER_ERROR_REL = 0.25


def load_schema() -> dict:
    """Return the participant JSON Schema (a dict, parsed once, by the stack that checks it)."""
    return load_schema_file(str(SCHEMA_PATH))


def _semantic_errors(record: Mapping[str, Any]) -> list[tuple[str, str]]:
    out: list[tuple[str, str]] = []
    consent = record.get("consent", {})
    if consent.get("given") is not True:
        out.append(("consent.given",
                    f"expected true (no session without consent), got {consent.get('given')!r}"))
    st = record.get("skin_thickness", {})
    total = st.get("total_um")
    lo, hi = HARD_THICKNESS_RANGE_UM
    if not lo <= total <= hi:
        out.append(("skin_thickness.total_um",
                    f"expected a fingertip skin thickness from {lo:g} to {hi:g} µm, got {total!r}"))
        return out
    for layer in ("epidermis_um", "dermis_um"):
        if layer in st and st[layer] >= total:
            out.append((f"skin_thickness.{layer}",
                        f"expected less than total_um ({total:g}), got {st[layer]!r}"))
    if not out and "epidermis_um" in st and "dermis_um" in st:
        s = st["epidermis_um"] + st["dermis_um"]
        if abs(s - total) > LAYER_ERROR_REL * total:
            out.append(("skin_thickness",
                        f"expected epidermis_um + dermis_um to equal total_um ({total:g}) "
                        f"within {LAYER_ERROR_REL:.0%}, got {s:g}"))
    cal = record.get("calibration", {})
    if "skin_thickness_um" in cal and not lo <= cal["skin_thickness_um"] <= hi:
        out.append(("calibration.skin_thickness_um",
                    f"expected a fingertip skin thickness from {lo:g} to {hi:g} µm, "
                    f"got {cal['skin_thickness_um']!r}"))
    return out


def _non_finite(value: Any, path: tuple = ()) -> list[tuple[str, str]]:
    """Every NaN or infinity in a record, as (field, message): no field may hold one."""
    if isinstance(value, float) and not math.isfinite(value):
        return [(_field(path) or "(record)", f"expected a finite number, got {value!r}")]
    if isinstance(value, Mapping):
        return [p for k, v in value.items() for p in _non_finite(v, path + (k,))]
    if isinstance(value, (list, tuple)):
        return [p for i, v in enumerate(value) for p in _non_finite(v, path + (i,))]
    return []


def validate_participant(record: Any, source: str = "<participant>") -> dict:
    """Validate a participant record against the schema and the semantic checks.

    Parameters
    ----------
    record : dict
        The record, as parsed from JSON.
    source : str
        Name used in error messages (usually the file name).

    Returns
    -------
    dict
        ``record`` itself, unchanged.

    Raises
    ------
    ParticipantError
        With a one-line message ``"<source>: <field>: expected ..., got ..."`` for the
        first problem; ``.errors`` holds all of them.

    See Also
    --------
    participant_warnings : the milder problems, which do not raise.

    Examples
    --------
    >>> validate_participant({"id": "P01"}, source="P01.json")
    Traceback (most recent call last):
    ...
    participants_schema.errors.ParticipantError: P01.json: skin_thickness: expected an object, got nothing (the field is required)
    """
    problems = _non_finite(record)   # JSON Schema's bounds let NaN through (NaN > 0 is False)
    if not problems:
        problems = schema_problems(record, SCHEMA_PATH)
    if not problems:
        problems = _semantic_errors(record)
    if problems:
        lines = tuple(f"{source}: {f}: {m}" for f, m in problems)
        raise ParticipantError(lines[0], source=source, field=problems[0][0], errors=lines)
    return record


def participant_warnings(record: Mapping[str, Any]) -> list[str]:
    """Problems in a valid record that deserve the experimenter's attention.

    Parameters
    ----------
    record : dict
        A record that passed :func:`validate_participant`.

    Returns
    -------
    list of str
        One sentence each: skin layers not summing to the total within
        ``max(LAYER_TOLERANCE_UM, LAYER_TOLERANCE_REL * total)``, a thickness outside
        :data:`PLAUSIBLE_THICKNESS_RANGE_UM`, handedness contradicting the dominant hand.
    """
    out = []
    st = record["skin_thickness"]
    total = st["total_um"]
    if "epidermis_um" in st and "dermis_um" in st:
        s = st["epidermis_um"] + st["dermis_um"]
        tol = max(LAYER_TOLERANCE_UM, LAYER_TOLERANCE_REL * total)
        if abs(s - total) > tol:
            out.append(f"skin_thickness: epidermis_um + dermis_um = {s:g} µm differs from "
                       f"total_um = {total:g} µm by {abs(s - total):g} µm (tolerance {tol:g} µm); "
                       f"the group uses total_um")
    lo, hi = PLAUSIBLE_THICKNESS_RANGE_UM
    if not lo <= total <= hi:
        out.append(f"skin_thickness.total_um: {total:g} µm is outside the usual fingertip "
                   f"range {lo:g}-{hi:g} µm; check the measurement")
    hand, dom = record.get("handedness"), record.get("dominant_hand")
    if hand in ("right", "left") and dom in ("right", "left") and hand != dom:
        out.append(f"handedness {hand!r} contradicts dominant_hand {dom!r}")
    return out


def load_participant(path: str | Path) -> dict:
    """Read and validate a participant file.

    Parameters
    ----------
    path : str or Path
        A JSON file holding one record.

    Returns
    -------
    dict
        The validated record.

    Raises
    ------
    ParticipantError
        If the file is missing, is not JSON, or does not validate; the message names
        the file (as given) and the field.
    """
    source = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ParticipantError(f"{source}: expected a participant file, got no such file",
                               source=source) from None
    except UnicodeDecodeError as exc:
        raise ParticipantError(f"{source}: expected UTF-8 text, got byte "
                               f"0x{exc.object[exc.start]:02x} at offset {exc.start}",
                               source=source) from None
    except OSError as exc:
        raise ParticipantError(f"{source}: expected a readable UTF-8 file, got {exc}",
                               source=source) from None
    try:
        record = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ParticipantError(
            f"{source}: line {exc.lineno} column {exc.colno}: expected valid JSON, got {exc.msg}",
            source=source) from None
    return validate_participant(record, source=source)
