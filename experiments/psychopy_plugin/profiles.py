"""Where a thermal cue's target profile comes from: a protocol sample for a participant, or a file.

No PsychoPy here: the Builder component and the Coder example both call these, and the same
profile would be uploaded by ``thermocue run`` for that participant and sample
(:func:`experiments.session.setup.simulated_target_profile`).
"""
from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from experiments.errors import UserInputError

__all__ = ["CueProfile", "protocol_profile", "file_profile", "load_protocol_for_cue"]


@dataclass(frozen=True)
class CueProfile:
    """A target profile ready to upload.

    Attributes
    ----------
    times_s : ndarray, s
        Uniform from 0.
    target_C : ndarray, °C
    source : str
        How it was made (``"protocol:<name> sample <id> participant <id>"`` or ``"file:<path>"``).
    parameters : dict
        The model parameters (protocol profiles) or ``{}``.
    """

    times_s: np.ndarray
    target_C: np.ndarray
    source: str
    parameters: dict = field(default_factory=dict)

    @property
    def duration_s(self) -> float:
        return float(self.times_s[-1])


def load_protocol_for_cue(protocol):
    """A :class:`~experiments.protocol.Protocol` from a name, a path or a Protocol (unchanged)."""
    if hasattr(protocol, "display") and hasattr(protocol, "contact"):
        return protocol
    from experiments.protocol import load_protocol
    return load_protocol(str(protocol))


def protocol_profile(protocol, participant_file, sample_id) -> CueProfile:
    """The simulated-trial profile of ``sample_id`` for the participant, as a session makes it.

    Parameters
    ----------
    protocol : str, Path or Protocol
        Packaged protocol name (``"roughness_recognition"``) or TOML file.
    participant_file : str or Path
        The participant's JSON record (group and skin thickness come from it).
    sample_id : int
        A ``[[samples]] id`` of the protocol.

    Raises
    ------
    UserInputError
        An unknown sample (names the protocol and the field), a bad participant file.
    """
    from experiments.session.setup import simulated_target_profile
    from participants_schema import Participant, assign_group

    proto = load_protocol_for_cue(protocol)
    where = proto.path.name if getattr(proto, "path", None) is not None else proto.name
    try:
        sid = int(sample_id)
        sample = proto.sample(sid)
    except (KeyError, TypeError, ValueError):
        ids = ", ".join(str(s.id) for s in proto.samples)
        raise UserInputError(f"{where}: samples.id: expected one of {ids}, got {sample_id!r}") from None
    participant = Participant.read(participant_file)
    group = assign_group(participant, proto.grouping).group
    prof = simulated_target_profile(proto, participant, group, None, sample.id,
                                    sample.roughness_um)
    return CueProfile(np.asarray(prof.times, float), np.asarray(prof.temperature, float),
                      f"protocol:{proto.name} sample {sample.id} participant {participant.id}",
                      dict(prof.parameters, group=group))


def file_profile(path) -> CueProfile:
    """A profile from a CSV file with columns ``time_s`` and ``target_C`` (others ignored).

    Times must be uniform (the display's upload check says so otherwise); rows with an empty
    ``target_C`` are skipped.

    Raises
    ------
    UserInputError
        A missing column or a value that is not a number (names the file, the row and the column);
        a file that is not UTF-8 text (UTF-16, Latin-1: names the file and the byte offset) or
        not a regular file (:mod:`sessionfiles.session_reader`).
    OSError
        The file cannot be read (the message names the path).
    """
    import io

    from sessionfiles.session_reader import read_text_file
    p = Path(path)
    try:            # a regular UTF-8 file (a byte-order mark allowed): UTF-16, Latin-1, a FIFO
        text = read_text_file(p)        # or a device are refused naming the file (and byte)
    except FileNotFoundError as exc:
        raise OSError(f"{p}: cannot read the profile file: {exc.strerror or exc}") from None
    except UserInputError:
        raise
    except OSError as exc:
        raise OSError(f"{p}: cannot read the profile file: {exc.strerror or exc}") from None
    with io.StringIO(text, newline="") as fh:
        reader = csv.DictReader(fh)
        cols = reader.fieldnames or []
        for col in ("time_s", "target_C"):
            if col not in cols:
                raise UserInputError(f"{p}: {col}: expected a column named {col!r}, got columns "
                                     f"{', '.join(cols) or 'none'}")
        times, temps = [], []
        for i, row in enumerate(reader, start=2):
            if row.get("target_C") in ("", None):
                continue
            for col, out in (("time_s", times), ("target_C", temps)):
                try:
                    out.append(float(row[col]))
                except (TypeError, ValueError):
                    raise UserInputError(f"{p}: row {i}: {col}: expected a number, got "
                                         f"{row[col]!r}") from None
    if len(times) < 2:
        raise UserInputError(f"{p}: target_C: expected at least 2 samples, got {len(times)}")
    t = np.asarray(times) - times[0]
    return CueProfile(t, np.asarray(temps), f"file:{p}")
