"""Participant records: schema, validation, group assignment.

>>> from participants_schema import validate_participant, assign_group, GroupRule
>>> rec = validate_participant({"id": "P01", "consent": {"given": True, "date": "2026-11-20"},
...                             "skin_thickness": {"total_um": 680, "method": "bio-speckle"}})
>>> assign_group(rec, GroupRule(threshold_um=800.0)).describe()
'group A: 680 µm, 120 µm below the 800 µm threshold'

``load_participant(path)`` does the same for a JSON file; ``participants/examples/`` holds
valid records.
"""
from participants_schema.errors import ParticipantError
from participants_schema.groups import GroupAssignment, GroupRule, assign_group
from participants_schema.validate import (
    SCHEMA_PATH,
    load_participant,
    load_schema,
    participant_warnings,
    validate_participant,
)

__all__ = [
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
