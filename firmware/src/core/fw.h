/* The firmware core: commands, reply store, state machine, watchdog, safety monitors, trial
 * logic, telemetry (docs/display-protocol.md §2-§6). Board-independent: it reaches the
 * hardware only through hal.h. */
#ifndef THERMOCUE_FW_H
#define THERMOCUE_FW_H

#include <stdbool.h>
#include <stdint.h>

#include "config.h"
#include "hal.h"

enum { ST_IDLE = 0, ST_ARMED = 1, ST_PLAYING = 2, ST_RECORDING = 3, ST_FAULT = 4 };
enum {
    ERR_UNKNOWN_COMMAND = 1, ERR_BAD_LENGTH = 2, ERR_BAD_ARGUMENT = 3, ERR_BAD_STATE = 4,
    ERR_OUT_OF_RANGE = 5, ERR_PROFILE_INCOMPLETE = 6, ERR_PROFILE_CRC = 7, ERR_NOT_SUPPORTED = 8,
    ERR_NO_HELLO = 9, ERR_FAULT_LATCHED = 10, FAULT_WATCHDOG = 20, FAULT_OVER_TEMPERATURE = 21,
    FAULT_SENSOR_FAILURE = 22, FAULT_SENSOR_STUCK = 23
};
enum { END_COMPLETE = 0, END_RELEASED = 1, END_MAX_DURATION = 2, END_ABORTED = 3, END_FAULT = 4 };
enum {
    CMD_HELLO = 0x01, CMD_HEARTBEAT = 0x02, CMD_SET_NEUTRAL = 0x03, CMD_SET_LIMITS = 0x04,
    CMD_UPLOAD_BEGIN = 0x10, CMD_UPLOAD_CHUNK = 0x11, CMD_UPLOAD_COMMIT = 0x12, CMD_ARM = 0x20,
    CMD_ABORT = 0x21, CMD_STATUS = 0x22, CMD_CLEAR_FAULT = 0x23, CMD_SET_TRIP = 0x24, CMD_SIM_FIRST = 0x30,
    CMD_SIM_LAST = 0x3F, MSG_TELEMETRY = 0xA0, MSG_EVENT = 0xA1, MSG_NAK = 0xFF
};
enum { EV_READY = 1, EV_CONTACT = 2, EV_END = 3, EV_FAULT = 4, EV_WATCHDOG = 5 };

/* Loop timing, measured by the main loop (for the README's figures and the tests). */
typedef struct {
    uint32_t ticks;
    uint32_t late_max_us;      /* largest lateness of a control step behind its schedule */
    uint32_t skipped;          /* control steps skipped (more than 10 late) */
    uint32_t host_gap_max_us;  /* longest host silence (between valid frames) while ARMED,
                                * PLAYING or RECORDING, up to a watchdog trip: the margin */
} fw_timing_t;

/* Power-up: self-check of the compiled-in limits, firmware state, boot id. Returns false if
 * the self-check failed (the firmware then stays in FAULT with the relay open). */
bool fw_init(void);
/* The main loop's body: input, the 5 ms control steps and 10 ms ticks that are due, output.
 * Never blocks. */
void fw_poll(void);
/* The forever loop of an MCU image. */
void fw_run(void) __attribute__((noreturn));

/* For tests and the simulation HAL. */
int fw_state(void);
uint32_t fw_boot_id(void);
const fw_timing_t *fw_timing(void);
bool fw_self_check(void);

#endif
