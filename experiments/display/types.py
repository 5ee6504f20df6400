"""What a display reports, in types no wire format owns: :class:`DeviceInfo`, :class:`Status`,
:class:`Telemetry`, :class:`DeviceEvent`.

Every backend fills these (the thermocue backend converts its protocol's wire structs,
:mod:`experiments.display.thermocue.messages`; the TCS II backend fills them from its text
replies), and every caller (the session, the trial recording, the PsychoPy plugin, the command
line) reads only these. Each field carries its unit; a field a backend cannot know is ``None``
(in :class:`Telemetry`, a reading the device does not measure is NaN: frames are numbers
written to the trace, 100 a second).

Standard library only: the emulators, the session files and the plugin may import it freely.
"""
from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from typing import NamedTuple

__all__ = ["DeviceInfo", "Status", "Telemetry", "DeviceEvent", "STATES", "EVENT_KINDS",
           "END_REASONS"]

#: A display's states: holding neutral; armed (reaching the profile's start, then waiting for
#: contact); playing a profile since contact; recording a real sample since contact; faulted
#: (safe state: the display holds no temperature of its own).
STATES = ("IDLE", "ARMED", "PLAYING", "RECORDING", "FAULT")

#: Kinds of :class:`DeviceEvent`.
EVENT_KINDS = ("READY", "CONTACT", "END", "FAULT", "WATCHDOG")

#: Why a trial ended (:attr:`DeviceEvent.reason` of an END, :attr:`Status.end_reason`).
END_REASONS = ("complete", "released", "max_duration", "aborted", "fault")


class _Json:
    def to_json(self) -> str:
        """The record as a JSON object (field names as keys)."""
        return json.dumps(asdict(self), sort_keys=True)


@dataclass(frozen=True)
class DeviceInfo(_Json):
    """Who the opened device is and what it declared when the host shook hands with it.

    Parameters
    ----------
    device_id : str
        The device's own id (serial number, probe id).
    firmware : str
        Its firmware's name and version.
    capabilities : tuple of str
        ``"playback"``, ``"record"`` and ``"sim"`` (a scriptable bench: an emulator).
    telemetry_hz : float, Hz
        Temperature readings per second during a trial.
    hard_min_C, hard_max_C : float, °C
        The setpoint range the device itself holds to (its firmware clamps, or the maximum it
        was set to and read back), whatever the host sends.
    max_rate_C_per_s : float, °C/s
        The fastest setpoint change it plays.
    neutral_C : float, °C
        The temperature it holds between trials.
    max_points : int
        The longest profile it holds, in samples.
    min_dt_s : float, s
        The shortest step between profile samples.
    protocol : int or None
        The version of the wire protocol it speaks; None: its protocol has no version.
    watchdog_s : float or None, s
        How long the device tolerates host silence before it returns to neutral on its own;
        None: it has no watchdog (a host that dies leaves it playing the uploaded profile to
        its end).
    image_id : str
        The firmware image's id as the device reports it (the thermocue protocol: the build id
        HELLO carries, ``firmware/out/build.json`` names it; a TCS II: its firmware version);
        empty when the device reports none. ``session.json`` and ``check.md`` record it.
    """

    device_id: str
    firmware: str
    capabilities: tuple
    telemetry_hz: float
    hard_min_C: float
    hard_max_C: float
    max_rate_C_per_s: float
    neutral_C: float
    max_points: int
    min_dt_s: float
    protocol: int | None = None
    watchdog_s: float | None = None
    image_id: str = ""


@dataclass(frozen=True)
class Status(_Json):
    """The device's state now (one status query).

    Parameters
    ----------
    state : str
        One of :data:`STATES`.
    fault : str or None
        The latched or last fault's code (``OVER_TEMPERATURE``, ``SENSOR_FAILURE``, ...);
        None: none.
    device_time_s : float, s
        The device's clock; a device without one reports the host's monotonic clock.
    setpoint_C : float, °C
        What the device is commanded to hold now.
    contact_C : float, °C
        The contact (pad or probe) temperature.
    ambient_C : float or None, °C
        The ambient or reference sensor; None: the device has none.
    finger_C : float or None, °C
        The skin thermometer; None: the device has none.
    forces_N : tuple of float or None, N
        The force sensors; None: the device has no force sensing.
    neutral_C : float, °C
        The temperature held between trials.
    profile_points : int
        Samples of the uploaded profile (0: none).
    contact_time_s : float or None, s
        Device time of the last trial's contact; None: no contact since it was armed.
    end_reason : str or None
        How the last trial ended (one of :data:`END_REASONS`); None: no trial has ended.
    trials : int
        Trials armed since the device was opened or powered up.
    heatsink_C : float or None, °C
        The heat sink's thermometer; None: the device has none (or does not report it).
    """

    state: str
    fault: str | None
    device_time_s: float
    setpoint_C: float
    contact_C: float
    ambient_C: float | None
    finger_C: float | None
    forces_N: tuple | None
    neutral_C: float
    profile_points: int
    contact_time_s: float | None
    end_reason: str | None
    trials: int
    heatsink_C: float | None = None


class Telemetry(NamedTuple):
    """One reading during a trial (a named tuple: 100 of them a second must stay cheap).

    Fields: ``counter`` (frame number, increasing; a gap is a lost frame), ``device_time_s``
    (s, the device's clock), ``setpoint_C``, ``contact_C``, ``ambient_C``, ``finger_C`` (°C;
    NaN: not measured), ``forces_N`` (4 × N; NaN: no force sensing), ``state`` (one of
    :data:`STATES`), ``fault`` (a fault code, or None).
    """

    counter: int
    device_time_s: float
    setpoint_C: float
    contact_C: float
    ambient_C: float
    finger_C: float
    forces_N: tuple
    state: str
    fault: str | None

    @property
    def force_N(self) -> float:
        """Summed force, N (NaN without force sensing)."""
        return sum(self.forces_N)


@dataclass(frozen=True)
class DeviceEvent(_Json):
    """Something the device reports during a trial.

    Parameters
    ----------
    kind : str
        One of :data:`EVENT_KINDS`: READY (at the starting temperature, contact detection on),
        CONTACT (contact; its time), END (the trial is over), FAULT, WATCHDOG (the host fell
        silent).
    device_time_s : float, s
    reason : str or None
        END: one of :data:`END_REASONS`; FAULT: the fault's code; WATCHDOG: ``"WATCHDOG"``;
        otherwise None.
    text : str
        The device's words (CONTACT: the force, ``"2.10 N"``).
    """

    kind: str
    device_time_s: float
    reason: str | None = None
    text: str = ""
