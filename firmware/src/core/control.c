#include "control.h"

#include <math.h>

void controller_init(controller_t *c)
{
    c->capacity_J_per_K = 0.8f;
    c->conductance_W_per_K = 0.4f;
    c->seebeck_V_per_K = 0.025f;
    c->resistance_ohm = 1.5f;
    c->i_max_A = 3.0f;
    c->kp_W_per_K = 40.0f;
    c->ki_W_per_K_s = 200.0f;
    c->kd_J_per_K = 0.0f;
    controller_reset(c);
}

void controller_reset(controller_t *c)
{
    c->integral_W = 0.0f;
    c->last_error_K = 0.0f;
    c->last_sp_C = 0.0f;
    c->primed = false;
}

float controller_step(controller_t *c, float sp_C, float contact_C, float heatsink_C, float dt_s)
{
    if (!c->primed) {
        c->last_sp_C = sp_C;
        c->last_error_K = sp_C - contact_C;
        c->primed = true;
    }
    float slope = (sp_C - c->last_sp_C) / dt_s;
    float e = sp_C - contact_C;
    float de = (e - c->last_error_K) / dt_s;
    c->last_sp_C = sp_C;
    c->last_error_K = e;
    /* heat the pad needs: its capacity times the setpoint's slope, the leak through the module
     * at the setpoint, and the PI(D) correction */
    float q = c->capacity_J_per_K * slope + c->conductance_W_per_K * (sp_C - heatsink_C)
              + c->kp_W_per_K * e + c->integral_W + c->kd_J_per_K * de;
    /* Peltier inversion: q = a I + R I^2 / 2 with a = Seebeck x T_pad (K) */
    float a = c->seebeck_V_per_K * (contact_C + 273.15f);
    float r = c->resistance_ohm;
    float disc = a * a + 2.0f * r * q;
    float i = disc > 0.0f ? (-a + sqrtf(disc)) / r : -a / r;
    float drive = i / c->i_max_A;
    bool saturated = false;
    if (drive > 1.0f) { drive = 1.0f; saturated = true; }
    if (drive < -1.0f) { drive = -1.0f; saturated = true; }
    /* anti-windup: integrate only while the drive is not saturated, or when it unwinds */
    float di = c->ki_W_per_K_s * e * dt_s;
    if (!saturated || (drive > 0.0f) != (di > 0.0f))
        c->integral_W += di;
    if (c->integral_W > 20.0f) c->integral_W = 20.0f;
    if (c->integral_W < -20.0f) c->integral_W = -20.0f;
    return drive;
}
