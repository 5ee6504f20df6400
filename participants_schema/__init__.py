"""Participant records: schema, validation, group assignment.

>>> from participants_schema import validate_participant, assign_group, GroupRule
>>> rec = validate_participant({"id": "P01", "consent": {"given": True, "date": "2026-11-20"},
...                             "skin_thickness": {"total_um": 680, "method": "bio-speckle"}})
>>> assign_group(rec, GroupRule(threshold_um=800.0)).describe()
'group A: 680 µm, 120 µm below the 800 µm threshold'

``load_participant(path)`` does the same for a JSON file; ``participants/examples/`` holds
valid records.  The rest of the code gets a participant as a frozen :class:`Participant`
(SI units; one skin thickness per purpose), read once: ``Participant.read(path)``.
"""
from participants_schema.errors import ParticipantError
from participants_schema.record import Participant, skin_um
from participants_schema.groups import GroupAssignment, GroupRule, assign_group
from participants_schema.validate import (
    SCHEMA_PATH,
    load_participant,
    load_schema,
    participant_warnings,
    validate_participant,
)

__all__ = [
    "Participant",
    "skin_um",
    "ParticipantError",
    "load_participant",
    "validate_participant",
    "participant_warnings",
    "assign_group",
    "GroupRule",
    "GroupAssignment",
    "load_schema",
    "SCHEMA_PATH",
]
