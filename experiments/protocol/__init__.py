"""Experiment protocols: TOML files validated into typed, frozen objects.

A protocol says everything a session needs that is not about the participant: the samples,
the room and skin temperatures, the display's safe range, the contact settings, the group
rule, how simulated profiles are computed and the blocks of trials.  The paper's two
experiments ship in ``experiments/protocols/`` (``interface_temperature``,
``roughness_recognition``); ``load_protocol("roughness_recognition")`` finds them by name.

Validation is strict: a wrong type, an out-of-range value, a missing key or an unknown key
raises :class:`experiments.errors.ProtocolError` with one line naming the file and the
field, e.g. ``"roughness_recognition.toml: blocks[1].repetitions: expected an integer ≥ 1,
got 'three'"``.  Block indices are 0-based, as in the TOML array.

The protocol's :attr:`Protocol.hash` is the SHA-256 of the parsed content in canonical JSON
(sorted keys, no whitespace), so comments and layout do not change it, and
``parse_protocol(protocol.data)`` (e.g. from ``session.json``) gives the same hash.

One concept, the protocol, in four modules and a schema: its typed parts (:mod:`.model`), the
ranges it is checked against (:mod:`.limits`), its keys, types, units and bounds
(``protocol.schema.json``, checked by the one validation stack,
:mod:`participants_schema.schema_check`, shared with ``session.json`` and participant records),
how checked content becomes a :class:`Protocol` (:mod:`.build`) and its hash (:mod:`.hashing`);
this module finds and reads the files and re-exports every public name.
"""
from __future__ import annotations

import sys
from pathlib import Path
from typing import Any, Mapping

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

from experiments.errors import ProtocolError
from experiments.protocol.build import build_protocol
from experiments.protocol.hashing import canonical_json, canonical_hash  # noqa: F401 (re-exported)
from experiments.protocol.limits import (MAX_ID, MAX_REPETITIONS, MAX_TRIALS,  # noqa: F401 (re-exported)
                                         MAX_WAIT_S, SKIN_SAFE_MAX_C, SKIN_SAFE_MIN_C)
from experiments.protocol.model import (BLOCK_ORDERS, DEFAULT_PAD_MATERIAL,  # noqa: F401 (re-exported)
                                        DEFAULT_EQUIVALENCE_MARGIN_PP, AnalysisSettings,
                                        DEFAULT_PAD_ROUGHNESS_UM, MODES, ORDERS, SIM_METHODS,
                                        SIM_CONTACT_MODELS, SIM_RATE_LIMITS, SIM_TARGET_SIDES, SIM_THICKNESS, Block,
                                        ContactSettings, DisplaySettings, Environment, Presentation,
                                        Protocol, Sample, SampleMaterial, Simulation)

__all__ = [
    "PROTOCOLS_DIR",
    "Protocol",
    "Sample",
    "Environment",
    "SampleMaterial",
    "DisplaySettings",
    "ContactSettings",
    "Simulation",
    "Block",
    "Presentation",
    "AnalysisSettings",
    "load_protocol",
    "parse_protocol",
    "protocol_names",
    "canonical_hash",
    "SKIN_SAFE_MIN_C",
    "SKIN_SAFE_MAX_C",
]

#: Folder of the packaged protocols (``experiments/protocols/``).
PROTOCOLS_DIR = Path(__file__).parent.with_name("protocols")


# --------------------------------------------------------------------------- entry points
def protocol_names() -> list[str]:
    """Names of the packaged protocols (``experiments/protocols/*.toml``)."""
    return sorted(p.stem for p in PROTOCOLS_DIR.glob("*.toml"))


def _resolve(path_or_name: str | Path) -> tuple[Path, str]:
    p = Path(path_or_name)
    if p.is_file():
        return p, str(path_or_name)
    text = str(path_or_name)
    if isinstance(path_or_name, str) and "/" not in text and "\\" not in text and not text.endswith(".toml"):
        packaged = PROTOCOLS_DIR / f"{text}.toml"
        if packaged.is_file():
            return packaged, packaged.name
    raise ProtocolError(f"{text}: expected a protocol file or one of the packaged protocols "
                        f"({', '.join(protocol_names())}), got no such file")


def load_protocol(path_or_name: str | Path) -> Protocol:
    """Read and validate a protocol.

    Parameters
    ----------
    path_or_name : str or Path
        A TOML file, or the bare name of a packaged protocol
        (``"roughness_recognition"``, ``"interface_temperature"``).

    Returns
    -------
    Protocol

    Raises
    ------
    ProtocolError
        One line naming the file and the field, for a missing file, a TOML syntax error,
        a missing, unknown, mistyped or out-of-range key.

    Examples
    --------
    >>> p = load_protocol("roughness_recognition")
    >>> [s.label for s in p.samples], [b.name for b in p.blocks]
    (['1#', '2#', '3#', '4#'], ['familiarise', 'real', 'simulated'])
    >>> p.simulation.skin_thickness_for("A"), p.grouping.threshold_um
    (650.0, 800.0)
    """
    path, source = _resolve(path_or_name)
    try:
        with open(path, "rb") as fh:
            raw = fh.read()
        text = raw.decode("utf-8")
        data = tomllib.loads(text)
    except UnicodeDecodeError as exc:
        raise ProtocolError(f"{source}: expected UTF-8 text, got byte 0x{raw[exc.start]:02x} at "
                            f"offset {exc.start}") from None
    except tomllib.TOMLDecodeError as exc:
        raise ProtocolError(f"{source}: expected valid TOML, got {exc}") from None
    except OSError as exc:
        raise ProtocolError(f"{source}: expected a readable file, got {exc.strerror}") from None
    return build_protocol(source, data, path)


def parse_protocol(data: Mapping[str, Any], source: str = "<protocol>", path: Path | None = None) -> Protocol:
    """Validate an already-parsed protocol (e.g. ``session.json``'s copy).

    Parameters
    ----------
    data : dict
        The content of a protocol file, as :attr:`Protocol.data`.
    source : str
        Name used in error messages.
    path : Path, optional
        Recorded as :attr:`Protocol.path`.

    Returns
    -------
    Protocol
        With the same :attr:`~Protocol.hash` as the file ``data`` came from.
    """
    return build_protocol(source, data, path)
