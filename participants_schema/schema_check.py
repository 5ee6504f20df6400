"""The one validation stack for what users write: a mapping checked against a JSON Schema
(Draft 2020-12), every problem one line naming the field.

The participant record (``participant.schema.json`` beside this module), the protocol (its TOML
parsed to a dict first; ``experiments/protocol/protocol.schema.json``) and ``session.json``
(``experiments/session/session.schema.json``) are all checked here: types, bounds, required and
unknown keys are declared in the schema files, and only the cross-field rules a schema cannot say
are left to the code that builds the typed objects.

Stricter than plain JSON Schema where a value becomes a number: ``integer`` is an ``int`` (not
``3.0``, not ``true``), ``number`` is finite (NaN passes every bound in JSON Schema).

Messages read ``<field>: expected <what>, got <value>`` (:func:`schema_problems`);
:func:`check_against_schema` prefixes the source and raises the caller's error class. What a
schema expects is said from its keywords (:func:`describe`), or verbatim from an ``x-expected``
annotation; ``x-why`` gives the reason of an upper bound (stated only when that bound is broken);
the root's ``x-vocabulary`` names what a key and an object are called (``"key"`` and ``"a table"``
for TOML; default ``"field"`` and ``"an object"``).
"""
from __future__ import annotations

import difflib
import json
import math
import re
from functools import lru_cache
from pathlib import Path
from typing import Any, Mapping

from jsonschema import Draft202012Validator, validators

__all__ = ["StrictValidator", "load_schema_file", "schema_problems", "check_against_schema",
           "describe", "field_path"]


def _is_integer(_checker, value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _is_number(_checker, value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


#: Draft 2020-12 with a strict ``integer`` (an int, not 3.0 or true) and a finite ``number``.
StrictValidator = validators.extend(
    Draft202012Validator,
    type_checker=Draft202012Validator.TYPE_CHECKER.redefine_many(
        {"integer": _is_integer, "number": _is_number}))


@lru_cache(maxsize=None)
def load_schema_file(path: str | Path) -> dict:
    """A schema file, parsed and checked against the 2020-12 meta-schema (once per path)."""
    with open(path, encoding="utf-8") as fh:
        schema = json.load(fh)
    StrictValidator.check_schema(schema)
    return schema


@lru_cache(maxsize=None)
def _validator_for(path: str) -> Draft202012Validator:
    return StrictValidator(load_schema_file(path), format_checker=Draft202012Validator.FORMAT_CHECKER)


_TYPE_WORDS = {"number": "a number", "integer": "an integer", "string": "a string",
               "boolean": "true or false", "object": "an object", "array": "a list", "null": "null"}


def _num(x: float) -> str:
    return f"{x:g}"


def describe(schema: Mapping[str, Any], broken: str = "", words: Mapping[str, str] | None = None) -> str:
    """Say in words what a (sub)schema expects, e.g. ``"a number > 0 and ≤ 600"``.

    ``broken`` is the keyword that failed: an upper bound with an ``x-why`` is stated (with the
    reason) only when it is the one broken."""
    if "x-expected" in schema:
        return schema["x-expected"]
    if "enum" in schema:
        return "one of " + ", ".join(repr(v) for v in schema["enum"])
    if "const" in schema:
        return json.dumps(schema["const"])
    names = dict(_TYPE_WORDS, **(words or {}))
    t = schema.get("type")
    out = (" or ".join(names.get(x, x) for x in t) if isinstance(t, list)
           else names.get(t, t) if t is not None else "a value")
    why = schema.get("x-why")
    bounds = []
    for key, sign in (("exclusiveMinimum", ">"), ("minimum", "≥"), ("exclusiveMaximum", "<"),
                      ("maximum", "≤")):
        if key in schema and not (key == "maximum" and why):
            bounds.append(f"{sign} {_num(schema[key])}")
    if why and "maximum" in schema and broken == "maximum":
        bounds.append(f"≤ {_num(schema['maximum'])} ({why})")
    if bounds:
        out += " " + " and ".join(bounds)
    if schema.get("format") == "date":
        out = "a date (YYYY-MM-DD)"
    if schema.get("minLength", 0) >= 1 or schema.get("pattern") == r"\S":
        out = "a non-empty string"
    if "maxLength" in schema:
        out += f" of at most {schema['maxLength']} characters"
    if "pattern" in schema and schema["pattern"] != r"\S":
        out += f" matching {schema['pattern']}"
    return out


def field_path(path) -> str:
    """``("blocks", 1, "repetitions")`` -> ``"blocks[1].repetitions"``."""
    out = ""
    for part in path:
        out += f"[{part}]" if isinstance(part, int) else ("." if out else "") + str(part)
    return out


def _join(prefix: str, name: str) -> str:
    return f"{prefix}.{name}" if prefix else name


def _translate(err, noun: str, words: Mapping[str, str]) -> list[tuple[str, str]]:
    """A jsonschema ValidationError -> [(field, "expected ..., got ...")]."""
    field = field_path(err.absolute_path)
    kind = err.validator
    if kind == "required":
        out = []
        for name in (n for n in err.validator_value if n not in err.instance):
            near = difflib.get_close_matches(name, [k for k in err.instance if isinstance(k, str)],
                                             n=1, cutoff=0.75)
            hint = f"; is {near[0]!r} a misspelling?" if near else ""
            want = describe(err.schema.get("properties", {}).get(name, {}), words=words)
            out.append((_join(field, name), f"expected {want}, got nothing (the {noun} is required{hint})"))
        return out
    if kind == "additionalProperties":
        known = set(err.schema.get("properties", {}))
        patterns = err.schema.get("patternProperties", {})
        extra = sorted(k for k in err.instance
                       if k not in known and not any(re.search(p, k) for p in patterns))
        name = extra[0] if extra else "?"
        allowed = ", ".join(sorted(k for k in known if not k.startswith("$")))
        hint = f" or an x_... {noun}" if patterns else ""
        return [(_join(field, name), f"expected one of the known {noun}s ({allowed}{hint}), "
                                     f"got an unknown {noun} {name!r}")]
    if "x-message" in err.schema:       # a schema's own words for a pattern it cannot explain
        return [(field, err.schema["x-message"].format(got=repr(err.instance)))]
    if kind == "type" and field == "":
        return [("(record)", f"expected {describe(err.schema, words=words)}, got {err.instance!r}")]
    return [(field or "(record)", f"expected {describe(err.schema, kind, words)}, got {err.instance!r}")]


_RANK = {"required": 0, "additionalProperties": 1, "type": 2}


def _order(err) -> tuple:
    path = tuple((0, p, "") if isinstance(p, int) else (1, 0, str(p)) for p in err.absolute_path)
    return (path, _RANK.get(err.validator, 3))


def schema_problems(data: Any, schema_path: str | Path) -> list[tuple[str, str]]:
    """Every problem of ``data`` against the schema file, as ``(field, "expected ..., got ...")``,
    in field order (a missing key before an unknown one, so a misspelling is named as such)."""
    schema = load_schema_file(str(schema_path))
    vocabulary = schema.get("x-vocabulary", {})
    noun, words = vocabulary.get("key", "field"), {"object": vocabulary.get("object", "an object")}
    out: list[tuple[str, str]] = []
    for e in sorted(_validator_for(str(schema_path)).iter_errors(data), key=_order):
        # "required" yields one error per missing key, each seeing all of them
        out.extend(item for item in _translate(e, noun, words) if item not in out)
    return out


def check_against_schema(data: Any, schema_path: str | Path, source: str, error: type = ValueError,
                         at: str = "") -> Any:
    """Raise ``error("<source>: <field>: expected ..., got ...")`` for the first problem of
    ``data`` against the schema file; return ``data`` unchanged when there is none.

    ``at``: where ``data`` sits in its file (``"schedule[3]"``), prefixed to the field."""
    problems = schema_problems(data, schema_path)
    if problems:
        field, message = problems[0]
        field = at if field == "(record)" else f"{at}{'' if field.startswith('[') else '.'}{field}" if at else field
        raise error(f"{source}: {field}: {message}" if field != "(record)" else f"{source}: {message}")
    return data
