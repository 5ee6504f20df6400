/* The native HAL: the firmware core built for this machine as a shared library (as Zephyr's
 * native_sim builds an application for the host), driven by the Python emulator through ctypes
 * (experiments/emulators/thermocue/native_core.py).
 *
 * Python owns the world -- the pad's and the finger's physics, the sensors, the fault
 * injection, the clock. Each 5 ms control step it computes the sensor readings and calls
 * native_control(), which sets the firmware's time, hands it the readings and runs fw_poll()
 * once; the Peltier drive and relay the core commanded come back in native_drive and the
 * returned flags. Host bytes go in with native_send(), the device's bytes come out with
 * native_take(). The board's sim commands (0x30..0x3F) are answered by a Python callback.
 *
 * One device per loaded copy of the library (the core keeps its state in statics): the
 * loader copies the file once per device and loads each copy on its own. */
#include <string.h>

#include "fw.h"
#include "hal.h"

#define EXPORT __attribute__((visibility("default")))

/* flags returned by native_control / native_poll */
enum {
    NATIVE_RELAY = 1,        /* the Peltier relay is closed */
    NATIVE_READY = 2,        /* the core declared READY during the call */
    NATIVE_ARMED = 4,        /* the core was ARMed during the call */
    NATIVE_RECORD = 8,       /* ... in record mode */
};

typedef int (*native_board_fn)(int type, const uint8_t *payload, int len, uint8_t *reply,
                               int cap, int core_state, int ready);

static uint64_t now_us;
static hal_sensors_t sensors;
static bool relay;
static int flags;
static uint32_t entropy = 1u;
static char device_id[64] = "THERMOCUE-NATIVE";
static char image_id[80] = "native";
static const char *caps = ",sim";
static native_board_fn board_fn;
static uint8_t rx[1 << 17], tx[1 << 17];
static size_t rx_head, rx_tail, tx_n;

EXPORT float native_drive;

/* ------------------------------------------------------------------ the HAL */
void hal_init(void) { }
uint64_t hal_time_us(void) { return now_us; }
int hal_uart_read(void) { return rx_tail < rx_head ? rx[rx_tail++] : -1; }
bool hal_uart_tx_ready(void) { return tx_n < sizeof tx; }
void hal_uart_write(uint8_t b) { tx[tx_n++] = b; }
void hal_read_sensors(hal_sensors_t *out) { *out = sensors; }
void hal_set_peltier(float drive) { native_drive = drive; }
void hal_set_relay(bool closed) { relay = closed; }
void hal_set_fan(bool on) { (void)on; }
void hal_iwdg_start(void) { }
void hal_iwdg_feed(void) { }
/* two draws per power-up (fw_init): the boot id is their CRC */
uint32_t hal_boot_entropy(void) { return entropy = entropy * 1664525u + 1013904223u; }
void hal_reset(void) { }

int hal_board_command(uint8_t type, const uint8_t *payload, size_t len, uint8_t *reply,
                      size_t cap, int core_state, bool ready)
{
    if (board_fn == NULL) {
        static const char text[] = "not an emulator";
        memcpy(reply, text, sizeof text < cap ? sizeof text : cap);
        return -ERR_NOT_SUPPORTED;
    }
    return board_fn(type, payload, (int)len, reply, (int)cap, core_state, ready ? 1 : 0);
}

const char *hal_capabilities(void) { return caps; }
const char *hal_device_id(void) { return device_id; }
const char *hal_image_id(void) { return image_id; }
void hal_on_ready(void) { flags |= NATIVE_READY; }
void hal_on_arm(int mode) { flags |= NATIVE_ARMED | (mode == 1 ? NATIVE_RECORD : 0); }

/* ------------------------------------------------------------------ the Python side */
static void copy_text(char *dst, size_t cap, const char *src)
{
    size_t n = strlen(src);
    if (n >= cap) n = cap - 1;
    memcpy(dst, src, n);
    dst[n] = 0;
}

/* Power-up (also a reboot): the core's state afresh, a new boot id from seed, time now_us. */
EXPORT int native_power_up(uint32_t seed, uint64_t t_us, const char *id, const char *image,
                           int sim, native_board_fn fn)
{
    entropy = seed * 2654435761u + 12345u;
    copy_text(device_id, sizeof device_id, id);
    copy_text(image_id, sizeof image_id, image);
    caps = sim ? ",sim" : "";
    board_fn = fn;
    now_us = t_us;
    rx_head = rx_tail = tx_n = 0;
    memset(&sensors, 0, sizeof sensors);
    return fw_init() ? 1 : 0;
}

static int run_poll(void)
{
    flags = 0;
    fw_poll();
    while (rx_tail < rx_head)              /* fw_poll takes at most 512 bytes at a time */
        fw_poll();
    if (rx_head == rx_tail) rx_head = rx_tail = 0;
    return flags | (relay ? NATIVE_RELAY : 0);
}

/* One control step at t_us with these readings (SI, degrees Celsius, N). */
EXPORT int native_control(uint64_t t_us, float contact_C, float ambient_C, float finger_C,
                          float heatsink_C, float f0, float f1, float f2, float f3,
                          float sample_C, uint32_t contact_raw)
{
    now_us = t_us;
    sensors.contact_C = contact_C;
    sensors.ambient_C = ambient_C;
    sensors.finger_C = finger_C;
    sensors.heatsink_C = heatsink_C;
    sensors.force_N[0] = f0;
    sensors.force_N[1] = f1;
    sensors.force_N[2] = f2;
    sensors.force_N[3] = f3;
    sensors.sample_C = sample_C;
    sensors.contact_raw = contact_raw;
    return run_poll();
}

/* Host bytes into the UART, handled at once (the time stays where it is). */
EXPORT int native_send(const uint8_t *data, size_t n)
{
    if (n > sizeof rx - rx_head) n = sizeof rx - rx_head;   /* a full UART loses the rest */
    memcpy(rx + rx_head, data, n);
    rx_head += n;
    return run_poll();
}

/* The device's bytes since the last call (at most cap). */
EXPORT size_t native_take(uint8_t *out, size_t cap)
{
    size_t n = tx_n < cap ? tx_n : cap;
    memcpy(out, tx, n);
    memmove(tx, tx + n, tx_n - n);
    tx_n -= n;
    return n;
}

EXPORT size_t native_pending(void) { return tx_n; }
EXPORT int native_state(void) { return fw_state(); }
EXPORT uint32_t native_boot_id(void) { return fw_boot_id(); }
