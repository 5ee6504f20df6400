"""Seeded trial schedules: a pure function of (protocol hash, participant id, seed).

:func:`build_schedule` lays out a whole session: the blocks in protocol order (or
counterbalanced, or shuffled, among the scored blocks; unscored blocks such as
``familiarise`` keep their place), and within each block every sample ``repetitions`` times
in the block's order.  The random numbers come from ``numpy.random.default_rng`` seeded
with a SHA-256 of ``(ALGORITHM, protocol.hash, participant_id, seed, block name)``, so

* the same inputs give the same schedule on any machine and after a resume;
* a different participant, seed or protocol content gives an independent schedule;
* editing one block does not reshuffle the others.

The session stores the schedule in ``session.json`` and resumes from the stored copy; this
module is the way to make (and to check) it.

Within-block orders
-------------------
``random``
    All ``len(samples) * repetitions`` presentations are shuffled together (the paper:
    "presented randomly with three repetitions of each sample").  ``repetition`` is the
    occurrence number of that sample within the block (1, 2, 3 in time order).
``by_repetition``
    Each repetition is a separately shuffled pass over the samples.
``fixed``
    Samples in listed order, the list repeated (familiarisation, Exp. 1).

With ``no_immediate_repeats = true`` a shuffled block is redrawn (from the same stream,
so still reproducible) until no sample follows itself.  The paper states no such
constraint, so the shipped protocols do not ask for it.

Block order (``[schedule] block_order``)
----------------------------------------
``fixed``: as listed.  ``random``: the scored blocks shuffled (seeded as above).
``counterbalanced``: with k scored blocks, the participant's number n (the last run of
digits in the id, ``"P07"`` -> 7; an id without digits uses the first 8 bytes of its
SHA-256) selects permutation ``n mod k!`` in lexicographic order of the listed blocks
(permutation 0 is the listed order).  Consecutive participant numbers therefore cycle
through all orders: P01, P03, ... run one order and P02, P04, ... the other when k = 2.
"""
from __future__ import annotations

import hashlib
import itertools
import re
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from experiments.errors import UserInputError
from participants_schema.schema_check import check_against_schema

__all__ = ["TrialSpec", "build_schedule", "derive_seed", "participant_number", "ALGORITHM",
           "block_sequence"]

#: Part of every derived seed; change it when the algorithm changes.
ALGORITHM = "thermocue-schedule-v1"
_MAX_REDRAWS = 10_000
#: The schema of a planned trial (also ``session.json``'s ``schedule`` items).
TRIAL_SCHEMA = Path(__file__).parent / "session" / "trial.schema.json"


@dataclass(frozen=True)
class TrialSpec:
    """One planned trial.

    Attributes
    ----------
    trial_index : int
        1-based position in the whole session (``traces/trial-NNN.csv``).
    block : str
        Block name (``"familiarise"``, ``"real"``, ``"simulated"``).
    mode : {"real", "simulated"}
    roughness_id : int
        The sample's id (1..4 for 1#-4#).
    roughness_um : float, µm
        The sample's Ra.
    repetition : int
        1-based occurrence of this sample within the block.
    """

    trial_index: int
    block: str
    mode: str
    roughness_id: int
    roughness_um: float
    repetition: int

    def to_dict(self) -> dict:
        """JSON-ready dict of the six fields."""
        return asdict(self)

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], source: str = "TrialSpec") -> "TrialSpec":
        """Rebuild from :meth:`to_dict` output, or a row of ``trials.csv`` (extra keys are ignored;
        text holding a number is read as one).

        Checked against ``trial.schema.json`` (``experiments/session/``), the schema of
        ``session.json``'s planned trials.

        Raises
        ------
        ValueError
            ``"<source>: <field>: expected ..., got ..."`` if a field is missing or of the wrong type.
        """
        if not isinstance(d, Mapping):
            raise ValueError(f"{source}: expected an object, got {d!r}")
        values = {f.name: _from_text(f.name, d[f.name]) for f in fields(cls) if f.name in d}
        check_against_schema(values, TRIAL_SCHEMA, source)
        return cls.from_checked(values)

    @classmethod
    def from_checked(cls, values: Mapping[str, Any]) -> "TrialSpec":
        """From values ``trial.schema.json`` accepted (exactly its six keys; an integral
        roughness is stored as a float)."""
        return cls(**dict(values, roughness_um=float(values["roughness_um"])))


def _from_text(key: str, value: Any) -> Any:
    """A CSV cell as the value it holds: digits an int, a number's text a float, an integral
    float an int (for the integer fields); anything else unchanged, for the schema to refuse."""
    if key in ("block", "mode") or isinstance(value, bool):
        return value
    integer = key != "roughness_um"
    if isinstance(value, str):
        if integer:
            return int(value) if value.strip().lstrip("-").isdigit() else value
        try:
            return float(value)
        except ValueError:
            return value
    if integer and isinstance(value, float) and value.is_integer():
        return int(value)
    return value


def derive_seed(protocol_hash: str, participant_id: str, seed: int, *parts: str) -> int:
    """A 256-bit integer seed from the schedule's inputs (SHA-256, big-endian)."""
    msg = "\x1f".join([ALGORITHM, protocol_hash, participant_id, str(int(seed)), *parts])
    return int.from_bytes(hashlib.sha256(msg.encode("utf-8")).digest(), "big")


def participant_number(participant_id: str) -> int:
    """The last run of digits in the id (``"P07"`` -> 7), else a number from its SHA-256."""
    m = re.search(r"(\d+)\D*$", participant_id)
    if m:
        return int(m.group(1))
    return int.from_bytes(hashlib.sha256(participant_id.encode("utf-8")).digest()[:8], "big")


def block_sequence(protocol, participant_id: str, seed: int) -> list:
    """The protocol's blocks in the order this participant runs them."""
    blocks = list(protocol.blocks)
    slots = [i for i, b in enumerate(blocks) if b.scored]
    scored = [blocks[i] for i in slots]
    if protocol.block_order == "fixed" or len(scored) < 2:
        order = scored
    elif protocol.block_order == "random":
        rng = np.random.default_rng(derive_seed(protocol.hash, participant_id, seed, "block_order"))
        order = [scored[i] for i in rng.permutation(len(scored))]
    elif protocol.block_order == "counterbalanced":
        perms = list(itertools.permutations(range(len(scored))))
        order = [scored[i] for i in perms[participant_number(participant_id) % len(perms)]]
    else:  # pragma: no cover - rejected by the protocol loader
        raise ValueError(f"block_order: unknown {protocol.block_order!r}")
    for slot, b in zip(slots, order):
        blocks[slot] = b
    return blocks


def _has_immediate_repeat(seq) -> bool:
    return any(a == b for a, b in zip(seq, seq[1:]))


def _block_ids(block, rng) -> list[int]:
    ids = list(block.samples)
    if block.order == "fixed":
        return ids * block.repetitions
    if block.order == "random":
        pool = np.array(ids * block.repetitions)
        for _ in range(_MAX_REDRAWS):
            seq = [int(x) for x in rng.permutation(pool)]
            if not (block.no_immediate_repeats and _has_immediate_repeat(seq)):
                return seq
        raise _undrawable(block)
    seq: list[int] = []  # by_repetition
    for _ in range(block.repetitions):
        for _ in range(_MAX_REDRAWS):
            part = [int(x) for x in rng.permutation(ids)]
            if not (block.no_immediate_repeats and (_has_immediate_repeat(part)
                                                    or (seq and part[0] == seq[-1]))):
                seq.extend(part)
                break
        else:
            raise _undrawable(block)
    return seq


def _undrawable(block) -> UserInputError:
    return UserInputError(f"block {block.name!r}: no_immediate_repeats: expected an order that "
                          f"can be drawn, got none in {_MAX_REDRAWS} draws")


def build_schedule(protocol, participant_id: str, seed: int) -> list[TrialSpec]:
    """Plan every trial of a session.

    Parameters
    ----------
    protocol : experiments.protocol.Protocol
    participant_id : str
        The participant record's ``id``.
    seed : int
        Non-negative session seed (``--seed``), stored in ``session.json``.

    Returns
    -------
    list of TrialSpec
        In running order, ``trial_index`` 1..N.

    Raises
    ------
    UserInputError
        For an empty participant id or a seed that is not an integer ≥ 0.

    Notes
    -----
    A pure function of ``(protocol.hash, participant_id, seed)`` and the protocol's content
    (which the hash identifies); see the module docstring for the orders.

    Examples
    --------
    >>> from experiments.protocol import load_protocol
    >>> s = build_schedule(load_protocol("roughness_recognition"), "P07", 1)
    >>> len(s), s[0].block, s[4].block, s[-1].block
    (28, 'familiarise', 'real', 'simulated')
    >>> s == build_schedule(load_protocol("roughness_recognition"), "P07", 1)
    True
    """
    if not isinstance(participant_id, str) or not participant_id:
        raise UserInputError(f"schedule: participant id: expected a non-empty string, got {participant_id!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise UserInputError(f"schedule: seed: expected an integer ≥ 0, got {seed!r}")
    seed = int(seed)
    out: list[TrialSpec] = []
    for block in block_sequence(protocol, participant_id, seed):
        rng = np.random.default_rng(derive_seed(protocol.hash, participant_id, seed, "block", block.name))
        counts: dict[int, int] = {}
        for sid in _block_ids(block, rng):
            counts[sid] = counts.get(sid, 0) + 1
            out.append(TrialSpec(trial_index=len(out) + 1, block=block.name, mode=block.mode,
                                 roughness_id=sid, roughness_um=protocol.sample(sid).roughness_um,
                                 repetition=counts[sid]))
    return out
