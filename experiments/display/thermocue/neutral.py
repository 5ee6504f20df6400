"""The thermocue protocol's wire structs as the display contract's neutral types.

The protocol's messages (:mod:`.messages`) stay its own; the host beyond this backend sees only
:mod:`experiments.display.types`. One function per struct.
"""
from __future__ import annotations

import functools

from ..types import DeviceEvent, DeviceInfo, Status, Telemetry
from . import messages as m

__all__ = ["device_info", "status", "event", "decode_telemetry"]



def device_info(w: m.DeviceInfo) -> DeviceInfo:
    """The HELLO reply as a :class:`~experiments.display.types.DeviceInfo`."""
    return DeviceInfo(device_id=w.device_id, firmware=w.firmware, capabilities=tuple(w.capabilities),
                      telemetry_hz=float(w.telemetry_hz), hard_min_C=w.hard_min_C,
                      hard_max_C=w.hard_max_C, max_rate_C_per_s=w.max_rate_C_per_s,
                      neutral_C=w.neutral_C, max_points=w.max_points, min_dt_s=w.min_dt_s,
                      protocol=w.protocol, watchdog_s=w.watchdog_ms * 1e-3,
                      image_id=w.image_id)


def status(w: m.Status) -> Status:
    """A STATUS reply as a :class:`~experiments.display.types.Status` (the last trial's end
    reason named; None while a trial runs)."""
    ended = w.state not in ("ARMED", "PLAYING", "RECORDING")
    return Status(state=w.state, fault=w.last_fault, device_time_s=w.device_time_s,
                  setpoint_C=w.setpoint_C, contact_C=w.contact_C, ambient_C=w.ambient_C,
                  finger_C=w.finger_C, forces_N=tuple(w.forces_N), neutral_C=w.neutral_C,
                  profile_points=w.profile_points, contact_time_s=w.contact_time_s,
                  end_reason=m.END_NAMES.get(w.end_reason, str(w.end_reason)) if ended else None,
                  trials=w.trials, heatsink_C=w.heatsink_C)


def event(w: m.DeviceEvent) -> DeviceEvent:
    """An EVENT message as a :class:`~experiments.display.types.DeviceEvent` (its argument
    named: END's end reason, FAULT's code)."""
    if w.kind == "END":
        reason = m.END_NAMES.get(w.arg, str(w.arg))
    elif w.kind == "FAULT":
        reason = m.error_name(w.arg)
    elif w.kind == "WATCHDOG":
        reason = "WATCHDOG"
    else:
        reason = None
    return DeviceEvent(w.kind, w.device_time_s, reason, w.text)


# A TELEMETRY frame's payload as a Telemetry: the wire's decoder (messages.Telemetry.decode)
# building the neutral tuple itself. The two named tuples have the same fields in the same
# order, so a frame (100 a second) costs one call and one tuple, not the wire's tuple copied.
assert m.Telemetry._fields == Telemetry._fields, "the wire's and the neutral Telemetry differ"
decode_telemetry = functools.partial(m.Telemetry.decode.__func__, Telemetry)
decode_telemetry.__doc__ = ("A TELEMETRY frame's payload as a "
                            ":class:`~experiments.display.types.Telemetry`.")
