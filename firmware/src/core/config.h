/* The firmware's fixed limits: compile-time constants, checked here (static asserts) and again
 * at boot (fw_self_check), reported in HELLO. Units are in the names: _cC hundredths of a
 * degree Celsius, _cC_per_s hundredths of a degree per second, _us microseconds, _ms ms. */
#ifndef THERMOCUE_CONFIG_H
#define THERMOCUE_CONFIG_H

#include <assert.h>
#include <stdint.h>

#define FW_PROTOCOL_VERSION     2u
#define FW_VERSION_STRING       "thermocue-fw 1.0.0"
#define FW_TELEMETRY_HZ         100u
#define FW_TICK_US              10000u      /* state machine, watchdog check, telemetry */
#define FW_CONTROL_US           5000u       /* control loop and over-temperature check (200 Hz) */
#define FW_HARD_MIN_cC          1000        /* coldest setpoint, 10.00 °C */
#define FW_HARD_MAX_cC          4500        /* skin-safe maximum, 45.00 °C: never exceeded */
#define FW_SETPOINT_MAX_cC      4450        /* highest setpoint (HELLO hard_max), below the trip */
#define FW_OVERTEMP_cC          4480        /* contact reading that cuts the heater (44.80 °C) */
#define FW_TRIP_TEST_MIN_cC     2000        /* lowest trip SET_TRIP accepts (a test's), 20.00 °C */
#define FW_HEATSINK_MAX_cC      7000        /* heat sink over-temperature, 70.00 °C */
#define FW_SENSOR_LO_cC         (-1000)     /* contact reading outside -10..90 °C: sensor failure */
#define FW_SENSOR_HI_cC         9000
#define FW_STUCK_SAMPLES        20u         /* identical raw readings in a row: stuck sensor */
#define FW_HARD_RATE_cC_per_s   10000u      /* largest setpoint change, 100 °C/s (1 °C a tick) */
#define FW_DEFAULT_RATE_cC_per_s 1000u      /* the host's rate limit until SET_LIMITS, 10 °C/s */
#define FW_DEFAULT_NEUTRAL_cC   3200        /* 32.00 °C */
#define FW_WATCHDOG_MS          90u         /* host silence that trips the watchdog */
#define FW_RATE_WINDOW_TICKS    10u         /* the host's 0.1 s rate window, in ticks */
#define FW_RATE_SLACK_cC        1           /* one resolution step */
#define FW_MAX_POINTS           32768u      /* profile samples (64 KiB; 32.7 s at 1 ms) */
#define FW_MIN_DT_US            1000u
#define FW_READY_BAND_cC        10          /* |contact - first sample| for READY, 0.1 °C */
#define FW_READY_TICKS          10u         /* ... for 100 ms */
#define FW_RELEASE_MS           50u         /* force < threshold/2 this long ends a trial */
#define FW_MAX_PAYLOAD          1100u       /* largest frame payload (a 512-sample chunk) */
#define FW_CHUNK_MAX            512u

/* The protocol's bounds (docs/display-protocol.md §3, §6): the host refuses a device whose
 * limits are wider, so a build with wider ones must not exist. */
static_assert(FW_HARD_MIN_cC >= 1000, "setpoint range starts below the protocol's 10 °C");
static_assert(FW_SETPOINT_MAX_cC <= 4450, "highest setpoint above the protocol's 44.5 °C");
static_assert(FW_SETPOINT_MAX_cC < FW_OVERTEMP_cC, "the trip must lie above every setpoint");
static_assert(FW_OVERTEMP_cC <= FW_HARD_MAX_cC, "the trip must act at or below 45 °C");
static_assert(FW_HARD_RATE_cC_per_s > 0 && FW_HARD_RATE_cC_per_s <= 10000, "rate 0 < r <= 100 °C/s");
static_assert(FW_WATCHDOG_MS >= 50 && FW_WATCHDOG_MS <= 90, "watchdog outside 50..90 ms");
static_assert(FW_WATCHDOG_MS * 1000u + FW_TICK_US <= 100000u, "neutral > 100 ms after host silence");
static_assert(FW_TELEMETRY_HZ >= 50 && FW_TELEMETRY_HZ <= 250, "telemetry outside 50..250 Hz");
static_assert(1000000u / FW_TICK_US == FW_TELEMETRY_HZ, "one telemetry frame a tick");
static_assert(FW_TICK_US % FW_CONTROL_US == 0, "whole control steps per tick");
static_assert(FW_MIN_DT_US >= 1000, "profile step below 1 ms");
static_assert(FW_MAX_POINTS >= 2 && FW_MAX_POINTS <= 65536, "profile length");
static_assert(FW_DEFAULT_NEUTRAL_cC >= FW_HARD_MIN_cC && FW_DEFAULT_NEUTRAL_cC <= FW_SETPOINT_MAX_cC,
              "neutral outside the range");
static_assert(FW_CHUNK_MAX * 2 + 6 <= FW_MAX_PAYLOAD, "a chunk must fit a frame");

#endif
