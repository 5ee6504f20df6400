"""Load and validate participant records (JSON Schema 2020-12 plus semantic checks).

The schema (``participant.schema.json`` beside this module) fixes the fields and their
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
import re
from functools import lru_cache
from pathlib import Path
from typing import Any, Mapping

from jsonschema import Draft202012Validator

from participants_schema.errors import ParticipantError

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

_TYPE_WORDS = {
    "number": "a number",
    "integer": "an integer",
    "string": "a string",
    "boolean": "true or false",
    "object": "an object",
    "array": "a list",
    "null": "null",
}


@lru_cache(maxsize=1)
def load_schema() -> dict:
    """Return the participant JSON Schema (a dict, parsed once)."""
    with open(SCHEMA_PATH, encoding="utf-8") as fh:
        return json.load(fh)


@lru_cache(maxsize=1)
def _validator() -> Draft202012Validator:
    schema = load_schema()
    Draft202012Validator.check_schema(schema)
    return Draft202012Validator(schema, format_checker=Draft202012Validator.FORMAT_CHECKER)


def _fmt_num(x: float) -> str:
    return f"{x:g}"


def _describe(schema: Mapping[str, Any]) -> str:
    """Say in words what a (sub)schema expects, e.g. ``"a number > 0"``."""
    if "x-expected" in schema:
        return schema["x-expected"]
    if "enum" in schema:
        return "one of " + ", ".join(repr(v) for v in schema["enum"])
    if "const" in schema:
        return json.dumps(schema["const"])
    t = schema.get("type")
    if isinstance(t, list):
        words = " or ".join(_TYPE_WORDS.get(x, x) for x in t)
    elif t is not None:
        words = _TYPE_WORDS.get(t, t)
    else:
        words = "a value"
    bounds = []
    if "exclusiveMinimum" in schema:
        bounds.append(f"> {_fmt_num(schema['exclusiveMinimum'])}")
    if "minimum" in schema:
        bounds.append(f"≥ {_fmt_num(schema['minimum'])}")
    if "exclusiveMaximum" in schema:
        bounds.append(f"< {_fmt_num(schema['exclusiveMaximum'])}")
    if "maximum" in schema:
        bounds.append(f"≤ {_fmt_num(schema['maximum'])}")
    if bounds:
        words += " " + " and ".join(bounds)
    if schema.get("format") == "date":
        words = "a date (YYYY-MM-DD)"
    if "minLength" in schema and schema["minLength"] >= 1:
        words = "a non-empty string"
    if "maxLength" in schema:
        words += f" of at most {schema['maxLength']} characters"
    if "pattern" in schema:
        words += f" matching {schema['pattern']}"
    return words


def _field(path) -> str:
    out = ""
    for part in path:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += ("." if out else "") + str(part)
    return out


def _join(prefix: str, name: str) -> str:
    return f"{prefix}.{name}" if prefix else name


def _translate(err) -> list[tuple[str, str]]:
    """A jsonschema ValidationError -> [(field, "expected ..., got ...")]."""
    field = _field(err.absolute_path)
    kind = err.validator
    if kind == "required":
        missing = [n for n in err.validator_value if n not in err.instance]
        return [(_join(field, name),
                 f"expected {_describe(err.schema.get('properties', {}).get(name, {}))}, "
                 f"got nothing (the field is required)") for name in missing]
    if kind == "additionalProperties":
        known = set(err.schema.get("properties", {}))
        patterns = err.schema.get("patternProperties", {})
        extra = sorted(k for k in err.instance
                       if k not in known and not any(re.search(p, k) for p in patterns))
        name = extra[0] if extra else "?"
        allowed = ", ".join(sorted(k for k in known if not k.startswith("$")))
        hint = " or an x_... field" if patterns else ""
        return [(_join(field, name), f"expected a known field (one of {allowed}{hint}), got an unknown field {name!r}")]
    if kind == "pattern" and field.endswith("contact_resistance_m2K_W"):
        return [(field, f"expected keys naming samples by their roughness Ra in µm, as `thermocue "
                        f"calibrate` writes them (e.g. '1.6', '12.5', '50', '100'), got "
                        f"{err.instance!r}")]
    if kind == "type" and field == "":
        return [("(record)", f"expected a JSON object, got {err.instance!r}")]
    return [(field or "(record)", f"expected {_describe(err.schema)}, got {err.instance!r}")]


def _schema_errors(record: Any) -> list[tuple[str, str]]:
    errors = sorted(_validator().iter_errors(record),
                    key=lambda e: ([str(p) for p in e.absolute_path], e.validator))
    out: list[tuple[str, str]] = []
    for e in errors:  # "required" yields one error per missing field, each seeing all of them
        out.extend(item for item in _translate(e) if item not in out)
    return out


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
        problems = _schema_errors(record)
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
