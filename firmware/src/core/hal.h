/* The thin hardware layer between the firmware core (src/core) and a board.
 *
 * Implemented by the STM32F405 board (src/board + src/stm32), by the simulation HAL
 * (src/sim + src/stm32: the same MCU, a pad plant and a scripted finger instead of the
 * sensors) and by the host test runner (tests/). The core calls nothing else. */
#ifndef THERMOCUE_HAL_H
#define THERMOCUE_HAL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/* Readings of one control step, SI units at the sensors' resolution. */
typedef struct {
    float contact_C;        /* pad (contact) thermometer */
    float ambient_C;
    float finger_C;         /* IR thermometer aimed at the fingertip */
    float heatsink_C;
    float force_N[4];       /* the four force sensors under the pad */
    float sample_C;         /* the thermometer glued on a real sample (record mode) */
    uint32_t contact_raw;   /* the contact channel's raw ADC code (stuck-sensor check) */
} hal_sensors_t;

void hal_init(void);
/* Microseconds since power-up (monotonic, starts near 0). */
uint64_t hal_time_us(void);
/* One received byte, or -1 when none is waiting (never blocks). */
int hal_uart_read(void);
/* Whether one byte can be written now without blocking, and writing it. */
bool hal_uart_tx_ready(void);
void hal_uart_write(uint8_t byte);
/* Read every sensor once (called each 5 ms control step). */
void hal_read_sensors(hal_sensors_t *out);
/* Peltier drive through the H-bridge: -1 (full cooling) .. +1 (full heating) of the current
 * limit; PWM duty = |drive|, direction = sign. */
void hal_set_peltier(float drive);
/* Peltier relay: closed = current may flow; open = the module is disconnected (safe state). */
void hal_set_relay(bool closed);
void hal_set_fan(bool on);
/* Independent hardware watchdog: started once at boot, fed from the main loop. */
void hal_iwdg_start(void);
void hal_iwdg_feed(void);
/* A 32-bit value that differs at every power-up (entropy for the boot id). */
uint32_t hal_boot_entropy(void);
/* Restart the MCU (a power-up); does not return. */
void hal_reset(void);

/* Board-specific commands 0x30..0x3F (the simulation bench: SIM_SAMPLE, SIM_FINGER, SIM_FAULT).
 * Returns the reply's length (written to reply, at most cap bytes) for an ACK, or a negative
 * error code (-8 NOT_SUPPORTED, -3 BAD_ARGUMENT, ...) with a text in reply (NUL-terminated). */
int hal_board_command(uint8_t type, const uint8_t *payload, size_t len, uint8_t *reply,
                      size_t cap, int core_state, bool ready);
/* The board's capability string tail (",sim" or ""), its device id. */
const char *hal_capabilities(void);
const char *hal_device_id(void);
/* The running image's id (the linker's GNU build id in hex; build.json records the same). */
const char *hal_image_id(void);
/* Called by the core when READY is declared (the scripted finger waits for the cue). */
void hal_on_ready(void);
/* Called by the core at every ARM (mode 0 playback, 1 record). */
void hal_on_arm(int mode);

#endif
