"""The participant as the code passes it around: a frozen :class:`Participant`, read once.

A participant file is JSON with micrometres (``skin_thickness.total_um``); it is read and
validated at the edge (:meth:`Participant.read`, or :meth:`Participant.from_record` for a
record stored in a session's ``session.json``) and from there on the session, the responders,
the PsychoPy plugin and the calibration get this record, in SI units.

One participant has up to three skin thicknesses, each for its own purpose:

* :attr:`Participant.measured_skin_m` (``skin_thickness.total_um``): what the group is
  assigned by, the skin of the emulated finger and of the simulated participant;
* :attr:`Participant.fitted_skin_m` (``calibration.skin_thickness_um``, written by
  ``thermocue calibrate``): the skin a simulated trial's target profile is computed for, when
  the record has a calibration;
* the protocol's simulated skin (``[simulation] skin_thickness``: the group's mean or the
  measured one), which :meth:`experiments.protocol.Simulation.skin_thickness_for` gives when the
  record has no calibration.  It is not the participant's, so it is not here.

>>> p = Participant.from_record({"id": "P01", "consent": {"given": True, "date": "2026-11-20"},
...                              "skin_thickness": {"total_um": 680, "dermis_um": 408,
...                                                 "method": "bio-speckle"}})
>>> p.id, round(p.measured_skin_m * 1e6, 9), p.dermis_fraction, p.fitted_skin_m
('P01', 680.0, 0.6, None)
>>> skin_um(p.measured_skin_m)
680
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

from participants_schema.validate import load_participant, validate_participant

__all__ = ["Participant", "skin_um"]


def _number(value) -> float | None:
    if value is None or isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    return float(value)


def skin_um(thickness_m: float | None):
    """A thickness in m as the µm figure files carry: rounded to 1e-6 µm, an int when whole
    (a record's ``680`` stays ``680`` in ``trials.csv`` and ``events.jsonl``)."""
    if thickness_m is None:
        return None
    um = round(float(thickness_m) * 1e6, 6)
    return int(um) if um.is_integer() else um


@dataclass(frozen=True)
class Participant:
    """A validated participant record, in SI units.

    Attributes
    ----------
    id : str
        The record's ``id`` (the session folder's name).
    measured_skin_m : float, m
        ``skin_thickness.total_um``: assigns the group; the emulated finger's and the simulated
        participant's skin.
    dermis_fraction : float or None
        ``skin_thickness.dermis_um / total_um`` when both were measured.
    fitted_skin_m : float or None, m
        ``calibration.skin_thickness_um``: the skin ``thermocue calibrate`` fitted; simulated
        trials compute their target profile for it (see :attr:`calibration`).
    initial_skin_temperature_C : float or None, °C
    sex : str or None
    source : str
        Where the record came from (its file), for messages.
    """

    id: str
    measured_skin_m: float
    dermis_fraction: float | None = None
    fitted_skin_m: float | None = None
    initial_skin_temperature_C: float | None = None
    sex: str | None = None
    source: str = "<participant>"
    _json: str = field(default="{}", repr=False, compare=False)

    @classmethod
    def from_record(cls, record: Any, source: str = "<participant>") -> "Participant":
        """Validate a JSON record (:func:`validate_participant`) and read it.

        Raises
        ------
        ParticipantError
            One line naming ``source`` and the field.
        """
        validate_participant(record, source=source)
        st = record["skin_thickness"]
        total, dermis = _number(st.get("total_um")), _number(st.get("dermis_um"))
        cal = record.get("calibration") or {}
        fitted = _number(cal.get("skin_thickness_um"))
        return cls(id=str(record["id"]), measured_skin_m=total * 1e-6,
                   dermis_fraction=dermis / total if dermis and total else None,
                   fitted_skin_m=None if fitted is None else fitted * 1e-6,
                   # as written (an int stays an int in the events it is logged in)
                   initial_skin_temperature_C=record.get("initial_skin_temperature_C"),
                   sex=record.get("sex"), source=source,
                   _json=json.dumps(record, ensure_ascii=False))

    @classmethod
    def read(cls, path: str | Path) -> "Participant":
        """Read and validate a participant file (:func:`load_participant`).

        Raises
        ------
        ParticipantError
            One line naming the file (as given) and the field.
        """
        return cls.from_record(load_participant(path), source=str(path))

    def record(self) -> dict:
        """The JSON record as read (a new dict each call): what ``session.json`` stores."""
        return json.loads(self._json)

    @property
    def calibration(self) -> Mapping[str, Any] | None:
        """The record's ``calibration`` object (a copy), or None: the fitted contact resistances
        per sample and the fitted skin that :mod:`experiments.calibration` reads."""
        return self.record().get("calibration") or None
