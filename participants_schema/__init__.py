"""Participant records: schema, validation, group assignment (filled by issue 4)."""
