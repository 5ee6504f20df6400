"""The protocol's hash: SHA-256 of its parsed content in canonical JSON.

Sorted keys, no whitespace, UTF-8, no NaN: comments and layout of the TOML file do not change it,
and ``parse_protocol(protocol.data)`` (e.g. from ``session.json``) gives the same hash.
"""
from __future__ import annotations

import hashlib
import json
from typing import Any, Mapping


def canonical_json(data: Any) -> bytes:
    return json.dumps(data, sort_keys=True, separators=(",", ":"), ensure_ascii=False,
                      allow_nan=False).encode("utf-8")


def canonical_hash(data: Mapping[str, Any]) -> str:
    """SHA-256 hex of ``data`` in canonical JSON (sorted keys, no whitespace, UTF-8)."""
    return hashlib.sha256(canonical_json(data)).hexdigest()

