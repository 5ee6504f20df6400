/* The host test runner's HAL: virtual time, in-memory UART, the simulation bench's plant. */
#ifndef THERMOCUE_HOST_HAL_H
#define THERMOCUE_HOST_HAL_H

#include <stddef.h>
#include <stdint.h>

#include "plant.h"

extern uint64_t host_now_us;
extern plant_t host_plant;
extern int host_reboots;
/* bytes from the host to the device, and from the device */
void host_send(const uint8_t *data, size_t n);
size_t host_take(uint8_t *out, size_t cap);

#endif
