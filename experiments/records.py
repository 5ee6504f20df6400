"""One reader for the records thermocue reads back: typed, bounded, one line per problem.

:class:`TableReader` reads one table (a mapping) field by field: typed getters
(:meth:`~TableReader.number`, :meth:`~TableReader.integer`, :meth:`~TableReader.string`,
:meth:`~TableReader.boolean`, nested :meth:`~TableReader.table` / :meth:`~TableReader.tables`),
then :meth:`~TableReader.done` rejects unknown keys. Every problem raises the reader's error
class with one line naming the source (the file) and the field, e.g. ``"roughness_recognition.toml:
blocks[1].repetitions: expected an integer ≥ 1, got 'three'"``.

It reads the protocol (:mod:`experiments.protocol`, :class:`~experiments.errors.ProtocolError`),
``session.json`` (:mod:`experiments.session.store`, :class:`~experiments.errors.SessionError`)
and the planned trials in it (:meth:`experiments.schedule.TrialSpec.from_dict`, ``ValueError``).
Standard library only.
"""
from __future__ import annotations

import difflib
import math
from typing import Any, Mapping

from experiments.errors import ProtocolError

__all__ = ["TableReader", "Verbatim", "number_text"]

_MISSING = object()


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def number_text(x: float) -> str:
    """A bound as messages write it (``%g``)."""
    return f"{x:g}"


_fmt = number_text


class Verbatim(str):
    """A ``got`` written as is in the message (not repr'd): a type name, a count."""

    def __repr__(self):
        return str(self)


class _Unknown(str):
    def __repr__(self):
        return f"an unknown key {str.__repr__(self)}"


class TableReader:
    """One table being read: typed getters, then :meth:`done` rejects unknown keys.

    Parameters
    ----------
    source : str
        How messages name the file (``roughness_recognition.toml``, ``.../session.json``).
    data : mapping
        The table.
    field : str
        Its path inside the file (``""`` for the top level, ``blocks[1]``).
    error : type of Exception
        Raised with the one-line message (default :class:`~experiments.errors.ProtocolError`);
        nested tables inherit it.
    """

    def __init__(self, source: str, data: Any, field: str, *, error: type = ProtocolError):
        self.source, self.field, self.error = source, field, error
        if not isinstance(data, Mapping):
            self._fail(field, "a table", data)
        self.data = data
        self.used: list[str] = []

    def _name(self, key: str) -> str:
        return f"{self.field}.{key}" if self.field else key

    def _fail(self, field: str, what: str, value: Any = _MISSING):
        got = "nothing (the key is required)" if value is _MISSING else repr(value)
        where = f"{self.source}: {field}" if field else self.source
        raise self.error(f"{where}: expected {what}, got {got}")

    def fail(self, key: str, what: str, value: Any = _MISSING):
        """Raise the reader's error for ``key``: expected ``what``, got ``value``."""
        self._fail(self._name(key), what, value)

    def require(self, *keys: str) -> None:
        """Each of ``keys`` present, else ``<key>: expected a value, got nothing``."""
        for key in keys:
            if key not in self.data:
                self._fail(self._name(key), "a value", Verbatim("nothing"))

    def _get(self, key: str, default: Any, what: str) -> Any:
        self.used.append(key)
        if key in self.data:
            return self.data[key]
        if default is _MISSING:
            self._missing(key, what)
        return default

    def _missing(self, key: str, what: str):
        near = difflib.get_close_matches(key, [k for k in self.data if isinstance(k, str)], n=1, cutoff=0.75)
        if near:
            self._fail(self._name(key), what, Verbatim(f"nothing (the key is required; is {near[0]!r} a misspelling?)"))
        self.fail(key, what)

    def number(self, key, default=_MISSING, *, gt=None, ge=None, le=None, lt=None,
               why: str = "", from_text: bool = False) -> float | None:
        """A finite number within the bounds; ``le`` with ``why`` states the reason when broken.

        ``from_text``: also a string holding a number (a CSV cell)."""
        bounds = []
        if gt is not None:
            bounds.append(f"> {_fmt(gt)}")
        if ge is not None:
            bounds.append(f"≥ {_fmt(ge)}")
        if lt is not None:
            bounds.append(f"< {_fmt(lt)}")
        # an upper bound given with its reason is stated when it is the one broken
        upper = f"≤ {_fmt(le)}" if le is not None else None
        if upper and not why:
            bounds.append(upper)
        what = "a number" + (" " + " and ".join(bounds) if bounds else "")
        v = self._get(key, default, what)
        if v is None and default is None and key not in self.data:
            return None
        if from_text and isinstance(v, str):
            try:
                v = float(v)
            except ValueError:
                self.fail(key, what, v)
        if not _is_number(v) or (gt is not None and not v > gt) or (ge is not None and not v >= ge) \
                or (lt is not None and not v < lt) or (le is not None and not why and not v <= le):
            self.fail(key, what, v)
        if le is not None and not v <= le:
            self.fail(key, f"{what} and {upper} ({why})", v)
        return float(v)

    def integer(self, key, default=_MISSING, *, ge=None, le=None, why: str = "",
                from_text: bool = False) -> int:
        """An integer (not a bool) ≥ ``ge``; ``le`` with ``why`` states the reason when broken.

        ``from_text``: also a string of digits or an integral float (a CSV cell)."""
        what = "an integer" + (f" ≥ {ge}" if ge is not None else "")
        v = self._get(key, default, what)
        if from_text and not isinstance(v, bool):
            if isinstance(v, str) and v.strip().lstrip("-").isdigit():
                v = int(v)
            elif isinstance(v, float) and v.is_integer():
                v = int(v)
        if isinstance(v, bool) or not isinstance(v, int) or (ge is not None and v < ge):
            self.fail(key, what, v)
        if le is not None and v > le:     # the upper bound and its reason, when broken
            self.fail(key, f"{what} and ≤ {le}" + (f" ({why})" if why else ""), v)
        return v

    def string(self, key, default=_MISSING, *, choices=None, nonempty=True) -> str:
        """A string (non-empty unless ``nonempty=False``), one of ``choices`` if given."""
        what = ("one of " + ", ".join(repr(c) for c in choices)) if choices else \
            ("a non-empty string" if nonempty else "a string")
        v = self._get(key, default, what)
        if not isinstance(v, str) or (choices and v not in choices) or (nonempty and not v.strip()):
            self.fail(key, what, v)
        return v

    def boolean(self, key, default=_MISSING) -> bool:
        """``true`` or ``false``."""
        v = self._get(key, default, "true or false")
        if not isinstance(v, bool):
            self.fail(key, "true or false", v)
        return v

    def table(self, key, required=True) -> "TableReader | None":
        """The nested table ``key`` (None if absent and not required)."""
        self.used.append(key)
        if key not in self.data:
            if required:
                self._missing(key, "a table")
            return None
        return TableReader(self.source, self.data[key], self._name(key), error=self.error)

    def tables(self, key) -> list["TableReader"]:
        """The non-empty array of tables ``key`` (``[[key]]``)."""
        self.used.append(key)
        v = self.data.get(key, _MISSING)
        if v is _MISSING:
            self._missing(key, "an array of tables ([[" + key + "]])")
        if not isinstance(v, list) or not v:
            self.fail(key, "a non-empty array of tables ([[" + key + "]])", v)
        return [TableReader(self.source, item, f"{self._name(key)}[{i}]", error=self.error)
                for i, item in enumerate(v)]

    def done(self):
        """Reject the first key no getter asked for (naming the known ones)."""
        unknown = [k for k in self.data if k not in self.used]
        if unknown:
            known = ", ".join(sorted(set(self.used)))
            self._fail(self._name(unknown[0]), f"one of the known keys ({known})",
                       _Unknown(unknown[0]))
