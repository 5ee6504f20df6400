"""The emulated firmware's fixed numbers: its range, rate, timing budget and power-up identity.

Shared by the firmware's tick (:mod:`.device`) and its command handling (:mod:`.device_commands`);
``docs/display-protocol.md`` gives the same numbers to the host.
"""
from __future__ import annotations

import zlib

from experiments.display.thermocue.messages import Cmd, Err
# why a trial ended: the wire format's codes
from experiments.display.thermocue.messages import (END_ABORTED, END_COMPLETE, END_FAULT,  # noqa: F401
                                                    END_MAX_DURATION, END_RELEASED)

FIRMWARE = "thermocue-emu 1.0.0"
IMAGE_ID = "emulator-1.0.0"   # HELLO's image id: the emulator has no firmware image, it states its version
HARD_MIN_C = 10.0          # the firmware's own range: setpoints are clamped to it, always
HARD_MAX_C = 45.0          # the skin-safe maximum: the pad is never above it for a tick
SETPOINT_MAX_C = 44.5      # highest setpoint (HELLO's hard_max): a margin below the trip
HARD_RATE_C_PER_S = 100.0  # largest setpoint step per second the firmware ever makes
DEFAULT_NEUTRAL_C = 32.0
WATCHDOG_MS = 90           # host silence that trips the watchdog, checked every 10 ms tick:
                           # the setpoint goes to neutral ≤ WATCHDOG_MS + one tick = 100 ms
                           # after the last host frame (docs/display-protocol.md, timing budget)
RATE_WINDOW_TICKS = 10     # the rate limit is also held over any 10 ticks (0.1 s), the host's
                           # window (SafetyLimits.rate_window_s): playback may step faster for a
                           # tick (a sqrt(t) profile's first samples), never faster over 0.1 s
RATE_SLACK_C = 0.01        # one setpoint resolution step, as the host's check allows
MAX_POINTS = 65536         # 65.5 s at 1 ms, 655 s at 10 ms
MIN_DT_US = 1000
TICK_US = 10_000
READY_BAND_C = 0.1         # |contact - first sample| to declare READY
RELEASE_MS = 50            # force below half the threshold this long ends a trial
OVERTEMP_C = HARD_MAX_C - 0.2   # contact sensor reading that cuts the Peltier current within
                                # the same 5 ms control step (PadPlant.trip_C): the sensor's lag
                                # and one step of a stuck full-current heater stay below 45 °C
TRIP_TEST_MIN_C = 20.0     # the lowest trip SET_TRIP accepts (thermocue check's test)
HEATSINK_MAX_C = 70.0
STUCK_SAMPLES = 20         # identical raw readings in a row (100 ms at 200 Hz)

#: Faults that stay latched through ABORT until an operator reset (CLEAR_FAULT).
LATCHED_FAULTS = (Err.OVER_TEMPERATURE, Err.SENSOR_FAILURE, Err.SENSOR_STUCK)
#: Commands a device carries out before any HELLO (everything else, the sim bench's commands
#: too: NAK NO_HELLO; requirement 2 of docs/display-protocol.md §6).
BEFORE_HELLO = (Cmd.HELLO, Cmd.HEARTBEAT, Cmd.STATUS, Cmd.ABORT, Cmd.CLEAR_FAULT)
#: A partial frame waits this long (device time, no byte arriving) before the parser skips a
#: byte and searches again (§1; the firmware does the same).
STALE_US = 200_000
#: The longest time a sim command takes (a finger's hold or wait, a fault's @AT_s or +FOR_s), s.
SIM_MAX_S = 86400.0


def make_boot_id(seed: int, boots: int) -> int:
    """A power-up's boot id (non-zero, different at every power-up of one device)."""
    return (zlib.crc32(f"{seed}:{boots}".encode()) or 1) & 0xFFFFFFFF
