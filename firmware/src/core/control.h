/* The Peltier controller: feed-forward of the setpoint's slope and of the module's leak, a PI
 * term on the contact error (D gain 0 by default: the sensor's noise would feed it), and an
 * inversion of the Peltier module's heat equation to an H-bridge drive (-1..1). */
#ifndef THERMOCUE_CONTROL_H
#define THERMOCUE_CONTROL_H

#include <stdbool.h>

typedef struct {
    /* the firmware's model of the pad and the module (SI) */
    float capacity_J_per_K;       /* pad + half the module */
    float conductance_W_per_K;    /* module, pad to heat sink */
    float seebeck_V_per_K;
    float resistance_ohm;
    float i_max_A;
    /* gains */
    float kp_W_per_K;
    float ki_W_per_K_s;
    float kd_J_per_K;
    /* state */
    float integral_W;
    float last_error_K;
    float last_sp_C;
    bool primed;
} controller_t;

void controller_init(controller_t *c);
void controller_reset(controller_t *c);
/* One control step of dt_s: the drive (-1..1) that moves the contact reading to sp_C. */
float controller_step(controller_t *c, float sp_C, float contact_C, float heatsink_C, float dt_s);

#endif
