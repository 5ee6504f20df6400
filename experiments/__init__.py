"""Protocols, schedules, sessions, the thermal display and responders."""
