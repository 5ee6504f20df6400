"""Participant records: schema, validation, group assignment.

>>> from participants_schema import load_participant, assign_group, GroupRule
>>> rec = load_participant("participants/examples/P01.json")   # doctest: +SKIP
>>> assign_group(rec, GroupRule(threshold_um=800.0)).group     # doctest: +SKIP
'A'
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
