/* The simulation bench: a first-order pad on a Peltier module and a heat sink, a scripted
 * finger (press, hold, release on four force sensors), a passive sample for record mode, and
 * the emulator's sensor-fault injections. Portable C (used by the sim MCU image and by the
 * host tests). Not the Python emulator's physics: a simpler plant with the same numbers. */
#ifndef THERMOCUE_PLANT_H
#define THERMOCUE_PLANT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "hal.h"

enum { SIMF_OVERTEMP = 1, SIMF_STUCK = 2, SIMF_RANGE = 3, SIMF_REBOOT = 4 };
#define SIM_MAX_FAULTS 8

typedef struct {
    uint8_t kind;
    bool done;                  /* a reboot happens once */
    uint64_t at_us, for_us;     /* for_us 0: for ever */
} sim_fault_t;

typedef struct {
    /* physics, SI and °C */
    float pad_C, hs_C, sensor_C, finger_surface_C, room_C;
    float drive;
    bool relay;
    uint64_t t_us;
    uint32_t rng;
    /* finger */
    bool finger_set, finger_waits;
    uint64_t finger_start_us;
    float press_after_s, force_N, hold_s, skin_C;
    float forces_N[4];
    /* sample (record mode) */
    float sample_temp_C;
    int mode;
    bool touched;
    uint64_t touch_us;
    /* faults */
    sim_fault_t faults[SIM_MAX_FAULTS];
    int n_faults;
    bool frozen;
    float frozen_C;
    uint32_t frozen_raw;
} plant_t;

void plant_init(plant_t *p, uint32_t seed);
/* Integrate to now_us (1 ms steps). */
void plant_advance(plant_t *p, uint64_t now_us);
void plant_read(plant_t *p, uint64_t now_us, hal_sensors_t *out);
/* Whether a scheduled reboot is due now (then the glue restarts the firmware). */
bool plant_reboot_due(plant_t *p, uint64_t now_us);
/* SIM_SAMPLE / SIM_FINGER / SIM_FAULT (JSON payloads as the emulator's); see hal.h. */
int plant_command(plant_t *p, uint64_t now_us, uint8_t type, const uint8_t *payload, size_t len,
                  uint8_t *reply, size_t cap, int core_state, bool ready);
void plant_on_ready(plant_t *p, uint64_t now_us);
/* Append ,"key":seconds to the JSON object of n bytes in reply; returns the new length. */
int plant_json_add_seconds(uint8_t *reply, size_t n, const char *key, uint64_t us);
void plant_on_arm(plant_t *p, int mode);

#endif
