/* The simulation HAL of the STM32F405 sim image: the MCU's time base, UART, watchdog and
 * reset (src/stm32), the pad plant and scripted finger (plant.c) instead of the sensors and
 * the H-bridge. This image is what runs under QEMU (which has no Peltier). */
#include "hal.h"
#include "lowlevel.h"
#include "plant.h"
#include "fw.h"

static plant_t plant;

/* The sim image's clock: TIM2 less the time the MCU did not run. Consecutive readings of the
 * clock are microseconds apart while the main loop runs; a gap longer than STALL_US means QEMU's
 * thread was held off by its host (no board pauses its CPU: its independent watchdog would
 * restart it after 50 ms). The simulated world -- firmware clock, plant, finger, faults --
 * pauses for such a gap instead of jumping: otherwise heartbeats still queued in QEMU's serial
 * input would look late to the firmware's watchdog, and the pad would heat for the length of
 * the stall between two control steps. The paused total is reported by SIM_FAULT. Each stall
 * still counts STALL_US of device time in which no host byte can arrive (QEMU hands the USART
 * one byte at a time, and only a running guest takes it); on a host loaded so far that QEMU
 * ran in short slices, 2 ms a stall added up to spurious watchdog trips (1 to 4 in 100 trials
 * at a load average of 20-25 on 2 cores; 0 at 0.5 ms: benchmarks/README.md). */
#define STALL_US 500u
static uint64_t last_raw_us, paused_us;

static uint64_t sim_time_us(void)
{
    uint64_t raw = stm32_time_us();
    if (last_raw_us != 0 && raw - last_raw_us > STALL_US)
        paused_us += raw - last_raw_us - STALL_US;
    last_raw_us = raw;
    return raw - paused_us;
}

void hal_init(void)
{
    stm32_init();
    plant_init(&plant, stm32_boot_entropy());
}

uint64_t hal_time_us(void) { return sim_time_us(); }
int hal_uart_read(void) { return stm32_uart_read(); }
bool hal_uart_tx_ready(void) { return stm32_uart_tx_ready(); }
void hal_uart_write(uint8_t b) { stm32_uart_write(b); }

void hal_read_sensors(hal_sensors_t *out)
{
    uint64_t now = sim_time_us();
    if (plant_reboot_due(&plant, now))
        stm32_reset();                       /* the power cycle of the "reboot" fault */
    plant_read(&plant, now, out);
}

void hal_set_peltier(float drive) { plant.drive = drive; }
void hal_set_relay(bool closed) { plant.relay = closed; }
void hal_set_fan(bool on) { (void)on; }
void hal_iwdg_start(void) { stm32_iwdg_start(); }
void hal_iwdg_feed(void) { stm32_iwdg_feed(); }
uint32_t hal_boot_entropy(void) { return stm32_boot_entropy(); }
void hal_reset(void) { stm32_reset(); }

int hal_board_command(uint8_t type, const uint8_t *payload, size_t len, uint8_t *reply,
                      size_t cap, int core_state, bool ready)
{
    int n = plant_command(&plant, sim_time_us(), type, payload, len, reply, cap, core_state, ready);
    if (type == 0x32 && n > 1 && (size_t)n + 24 < cap)
        n = plant_json_add_seconds(reply, (size_t)n, "paused_s", paused_us);
    if (type == 0x32 && n > 1 && (size_t)n + 32 < cap)
        n = plant_json_add_seconds(reply, (size_t)n, "host_gap_max_s",
                                   fw_timing()->host_gap_max_us);
    return n;
}

const char *hal_capabilities(void) { return ",sim"; }
const char *hal_device_id(void) { return "THERMOCUE-SIM-F405"; }
const char *hal_image_id(void) { return stm32_image_id(); }
void hal_on_ready(void) { plant_on_ready(&plant, sim_time_us()); }
void hal_on_arm(int mode) { plant_on_arm(&plant, mode); }
