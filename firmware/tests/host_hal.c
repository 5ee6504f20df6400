/* HAL of the host test runner (see host_hal.h). */
#include "host_hal.h"

#include <string.h>

#include "hal.h"

uint64_t host_now_us;
plant_t host_plant;
int host_reboots;
static uint8_t rx[65536], tx[1 << 20];
static size_t rx_head, rx_tail, tx_n;

void host_send(const uint8_t *data, size_t n)
{
    if (rx_head == rx_tail) rx_head = rx_tail = 0;
    memcpy(rx + rx_head, data, n);
    rx_head += n;
}

size_t host_take(uint8_t *out, size_t cap)
{
    size_t n = tx_n < cap ? tx_n : cap;
    memcpy(out, tx, n);
    memmove(tx, tx + n, tx_n - n);
    tx_n -= n;
    return n;
}

void hal_init(void) { plant_init(&host_plant, 1u); }
uint64_t hal_time_us(void) { return host_now_us; }
int hal_uart_read(void) { return rx_tail < rx_head ? rx[rx_tail++] : -1; }
bool hal_uart_tx_ready(void) { return tx_n < sizeof tx; }
void hal_uart_write(uint8_t b) { tx[tx_n++] = b; }
void hal_read_sensors(hal_sensors_t *out)
{
    if (plant_reboot_due(&host_plant, host_now_us)) host_reboots++;
    plant_read(&host_plant, host_now_us, out);
}
void hal_set_peltier(float drive) { host_plant.drive = drive; }
void hal_set_relay(bool closed) { host_plant.relay = closed; }
void hal_set_fan(bool on) { (void)on; }
void hal_iwdg_start(void) { }
void hal_iwdg_feed(void) { }
uint32_t hal_boot_entropy(void) { static uint32_t k = 7; return k += 0x9E3779B9u; }
void hal_reset(void) { }
int hal_board_command(uint8_t type, const uint8_t *payload, size_t len, uint8_t *reply,
                      size_t cap, int core_state, bool ready)
{
    return plant_command(&host_plant, host_now_us, type, payload, len, reply, cap, core_state, ready);
}
const char *hal_capabilities(void) { return ",sim"; }
const char *hal_device_id(void) { return "THERMOCUE-HOST-TEST"; }
const char *hal_image_id(void) { return "host-test"; }
void hal_on_ready(void) { plant_on_ready(&host_plant, host_now_us); }
void hal_on_arm(int mode) { plant_on_arm(&host_plant, mode); }
