#include "plant.h"

#include <math.h>
#include <string.h>

/* The longest time a sim command takes (a finger's hold, a fault's @AT_s or +FOR_s): a day. */
#define SIM_MAX_S 86400.0f

/* the plant's true numbers (the controller's model is 5 % off on purpose) */
#define CAP_J_PER_K     0.84f
#define K_W_PER_K       0.38f
#define SEEBECK         0.025f
#define R_OHM           1.5f
#define I_MAX_A         3.0f
#define HS_CAP_J_PER_K  60.0f
#define HS_G_W_PER_K    2.0f
#define TAU_SENSOR_S    0.003f
#define G_FINGER_W_PER_K 0.05f
#define NOISE_SENSOR_C  0.003f
#define NOISE_FORCE_N   0.005f
#define NOISE_AMBIENT_C 0.01f

#define PLANT_MAX_STEP_US 6000u

static const float SHARES[4] = {0.27f, 0.24f, 0.26f, 0.23f};

static float uniform(plant_t *p)
{
    uint32_t x = p->rng;            /* xorshift32 */
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    p->rng = x;
    return (float)(x >> 8) * (1.0f / 16777216.0f);
}

static float gauss(plant_t *p)
{
    return (uniform(p) + uniform(p) + uniform(p) + uniform(p) - 2.0f) * 1.7320508f;
}

void plant_init(plant_t *p, uint32_t seed)
{
    memset(p, 0, sizeof *p);
    p->room_C = 20.0f;
    p->pad_C = p->sensor_C = 32.0f;     /* the pad sits at neutral when the firmware starts */
    p->hs_C = 22.0f;
    p->finger_surface_C = 35.5f;
    p->skin_C = 35.5f;
    p->sample_temp_C = 20.0f;
    p->rng = seed ? seed : 0x12345678u;
}

static bool fault_active(const plant_t *p, uint8_t kind, uint64_t now)
{
    for (int i = 0; i < p->n_faults; i++) {
        const sim_fault_t *f = &p->faults[i];
        if (f->kind == kind && now >= f->at_us && (f->for_us == 0 || now < f->at_us + f->for_us))
            return true;
    }
    return false;
}

static float finger_force(const plant_t *p, uint64_t now)
{
    if (!p->finger_set || p->finger_waits || now < p->finger_start_us)
        return 0.0f;
    float tau = (float)(now - p->finger_start_us) * 1e-6f - p->press_after_s;
    float F = p->force_N;
    if (tau <= 0.0f) return 0.0f;
    if (tau < 0.15f) return 1.15f * F * tau / 0.15f;
    if (tau < p->hold_s) return F * (1.0f + 0.15f * expf(-(tau - 0.15f) / 0.2f));
    if (tau < p->hold_s + 0.1f) return F * (1.0f - (tau - p->hold_s) / 0.1f);
    return 0.0f;
}

void plant_advance(plant_t *p, uint64_t now)
{
    if (now < p->t_us) return;
    /* The plant advances with the firmware's control steps, at most one period (5 ms) and a
     * millisecond per reading. On a board the steps are 5 ms apart; under QEMU the host may hold
     * the emulator's thread off for tens of milliseconds, and the simulated world pauses with
     * it instead of heating the pad for 30 ms between two control steps, which no board does. */
    if (now - p->t_us > PLANT_MAX_STEP_US)
        p->t_us = now - PLANT_MAX_STEP_US;
    uint64_t steps = (now - p->t_us) / 1000u;
    const float dt = 0.001f;
    for (uint64_t k = 0; k < steps; k++) {
        p->t_us += 1000u;
        bool stuck_heater = fault_active(p, SIMF_OVERTEMP, p->t_us);
        float i = !p->relay ? 0.0f : stuck_heater ? I_MAX_A : p->drive * I_MAX_A;
        float force = finger_force(p, p->t_us);
        bool touching = force > 0.1f;
        float load = 0.0f;
        if (touching && p->mode == 0) {
            load = G_FINGER_W_PER_K * (p->finger_surface_C - p->pad_C);
            p->finger_surface_C += dt / 0.1f * (0.5f * (p->skin_C + p->pad_C) - p->finger_surface_C);
        } else {
            p->finger_surface_C += dt / 0.5f * (p->skin_C - p->finger_surface_C);
        }
        if (touching && !p->touched) {
            p->touched = true;
            p->touch_us = p->t_us;
        }
        float tp = p->pad_C + 273.15f, th = p->hs_C + 273.15f;
        float q_pad = SEEBECK * i * tp + 0.5f * i * i * R_OHM - K_W_PER_K * (p->pad_C - p->hs_C) + load;
        float q_hs = -SEEBECK * i * th + 0.5f * i * i * R_OHM + K_W_PER_K * (p->pad_C - p->hs_C)
                     - HS_G_W_PER_K * (p->hs_C - p->room_C);
        p->pad_C += dt * q_pad / CAP_J_PER_K;
        p->hs_C += dt * q_hs / HS_CAP_J_PER_K;
        p->sensor_C += dt / TAU_SENSOR_S * (p->pad_C - p->sensor_C);
        for (int s = 0; s < 4; s++) p->forces_N[s] = force * SHARES[s];
    }
}

void plant_read(plant_t *p, uint64_t now, hal_sensors_t *out)
{
    plant_advance(p, now);
    float y = p->sensor_C + NOISE_SENSOR_C * gauss(p);
    float q = y * 1000.0f;
    int32_t raw = (int32_t)(q >= 0.0f ? q + 0.5f : q - 0.5f);   /* 1 mK steps */
    y = (float)raw / 1000.0f;
    if (fault_active(p, SIMF_STUCK, now)) {
        if (!p->frozen) {
            p->frozen = true;
            p->frozen_C = y;
            p->frozen_raw = (uint32_t)raw;
        }
        y = p->frozen_C;
        raw = (int32_t)p->frozen_raw;
    } else {
        p->frozen = false;
    }
    if (fault_active(p, SIMF_RANGE, now)) {
        y = 150.0f;
        raw = 150000;
    }
    out->contact_C = y;
    out->contact_raw = (uint32_t)raw;
    out->ambient_C = p->room_C + NOISE_AMBIENT_C * gauss(p);
    out->heatsink_C = p->hs_C;
    out->finger_C = p->finger_set ? p->finger_surface_C : p->room_C + NOISE_AMBIENT_C * gauss(p);
    for (int s = 0; s < 4; s++) out->force_N[s] = p->forces_N[s] + NOISE_FORCE_N * gauss(p);
    /* the thermometer glued on the sample: its temperature, then towards the interface
     * temperature of skin on steel once touched (crude: 12 % of the way, 50 ms) */
    float ts = p->sample_temp_C;
    if (p->touched) {
        float t = (float)(now - p->touch_us) * 1e-6f;
        ts += 0.12f * (p->skin_C - ts) * (1.0f - expf(-t / 0.05f));
    }
    out->sample_C = ts + NOISE_SENSOR_C * gauss(p);
}

bool plant_reboot_due(plant_t *p, uint64_t now)
{
    for (int i = 0; i < p->n_faults; i++) {
        sim_fault_t *f = &p->faults[i];
        if (f->kind == SIMF_REBOOT && !f->done && now >= f->at_us) {
            f->done = true;
            return true;
        }
    }
    return false;
}

void plant_on_ready(plant_t *p, uint64_t now)
{
    if (p->finger_set && p->finger_waits) {
        p->finger_waits = false;
        p->finger_start_us = now;
    }
}

void plant_on_arm(plant_t *p, int mode)
{
    p->mode = mode;
    p->touched = false;
}

/* ------------------------------------------------------------------ a minimal JSON reader */
static const char *find_key(const char *s, size_t n, const char *key)
{
    size_t k = strlen(key);
    for (size_t i = 0; i + k + 2 <= n; i++) {
        if (s[i] == '"' && memcmp(s + i + 1, key, k) == 0 && s[i + 1 + k] == '"') {
            size_t j = i + k + 2;
            while (j < n && (s[j] == ' ' || s[j] == ':')) j++;
            return j < n ? s + j : NULL;
        }
    }
    return NULL;
}

/* A JSON number at s (no heap, no locale); false if there is none. The exponent is bounded:
 * beyond 400 (past a double's range either way) it adds nothing, so "1e999999999" costs 400
 * steps and gives inf (refused by the caller's range check), not 10^9 steps of a silent bench. */
#define JSON_MAX_EXP 400
static bool parse_number(const char *s, const char *end, float *out)
{
    double v = 0, frac = 0.1;
    int sign = 1, esign = 1, e = 0;
    bool digits = false;
    if (s < end && *s == '-') { sign = -1; s++; }
    while (s < end && *s >= '0' && *s <= '9') { v = v * 10 + (*s++ - '0'); digits = true; }
    if (s < end && *s == '.') {
        s++;
        while (s < end && *s >= '0' && *s <= '9') { v += (*s++ - '0') * frac; frac /= 10; digits = true; }
    }
    if (!digits) return false;
    if (s < end && (*s == 'e' || *s == 'E')) {
        s++;
        if (s < end && (*s == '+' || *s == '-')) { esign = *s == '-' ? -1 : 1; s++; }
        if (!(s < end && *s >= '0' && *s <= '9')) return false;
        while (s < end && *s >= '0' && *s <= '9') {
            if (e < JSON_MAX_EXP) e = e * 10 + (*s - '0');
            s++;
        }
        if (e > JSON_MAX_EXP) e = JSON_MAX_EXP;
    }
    while (e-- > 0) v = esign > 0 ? v * 10 : v / 10;
    if (v > 3.0e38) v = INFINITY;               /* beyond a float: inf, never an undefined cast */
    *out = (float)(sign * v);
    return true;
}

/* A key's number: 0 absent, 1 read into *out, -1 present but not a number. */
static int get_number(const char *s, size_t n, const char *key, float *out)
{
    const char *v = find_key(s, n, key);
    if (v == NULL) return 0;
    return parse_number(v, s + n, out) ? 1 : -1;
}

/* A JSON object: '{' first and '}' last, but for white space (the bench reads nothing else). */
static bool is_object(const char *s, size_t n)
{
    size_t a = 0, b = n;
    while (a < b && (s[a] == ' ' || s[a] == '\t' || s[a] == '\n' || s[a] == '\r')) a++;
    while (b > a && (s[b - 1] == ' ' || s[b - 1] == '\t' || s[b - 1] == '\n' || s[b - 1] == '\r')) b--;
    return b - a >= 2 && s[a] == '{' && s[b - 1] == '}';
}

/* An optional key within [lo, hi] (NaN and inf fail), or null if null_ok: false if present
 * and not so. */
static bool optional_in(const char *s, size_t n, const char *key, float lo, float hi, bool null_ok)
{
    float x;
    const char *v = find_key(s, n, key);
    if (null_ok && v != NULL && (size_t)(s + n - v) >= 4 && memcmp(v, "null", 4) == 0) return true;
    int got = get_number(s, n, key, &x);
    return got == 0 || (got == 1 && x >= lo && x <= hi);
}

/* ------------------------------------------------------------------ JSON writing */
static char *put_s(char *o, const char *t) { while (*t) *o++ = *t++; return o; }

static char *put_num(char *o, double v)
{
    if (v < 0) { *o++ = '-'; v = -v; }
    uint64_t whole = (uint64_t)v;
    uint32_t frac = (uint32_t)((v - (double)whole) * 1e6 + 0.5);
    if (frac >= 1000000u) { whole++; frac -= 1000000u; }
    char t[24];
    int n = 0;
    do { t[n++] = (char)('0' + whole % 10u); whole /= 10u; } while (whole);
    while (n) *o++ = t[--n];
    *o++ = '.';
    for (uint32_t d = 100000u; d; d /= 10u) *o++ = (char)('0' + (frac / d) % 10u);
    return o;
}

int plant_json_add_seconds(uint8_t *reply, size_t n, const char *key, uint64_t us)
{
    char *o = (char *)reply + n - 1;            /* over the closing brace */
    o = put_s(o, ",\"");
    o = put_s(o, key);
    o = put_s(o, "\":");
    o = put_num(o, (double)us * 1e-6);
    o = put_s(o, "}");
    return (int)(o - (char *)reply);
}

static int refuse(uint8_t *reply, size_t cap, int code, const char *text)
{
    size_t n = strlen(text);
    if (n >= cap) n = cap - 1;
    memcpy(reply, text, n);
    reply[n] = 0;
    return -code;
}

static int fault_kind(const char *name, size_t n)
{
    static const struct { const char *name; int kind; } names[] = {
        {"overtemp", SIMF_OVERTEMP}, {"stuck_sensor", SIMF_STUCK},
        {"sensor_range", SIMF_RANGE}, {"reboot", SIMF_REBOOT}};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        if (strlen(names[i].name) == n && memcmp(names[i].name, name, n) == 0)
            return names[i].kind;
    return 0;
}

int plant_command(plant_t *p, uint64_t now, uint8_t type, const uint8_t *payload, size_t len,
                  uint8_t *reply, size_t cap, int core_state, bool ready)
{
    const char *s = (const char *)payload;
    char *o = (char *)reply;
    if (cap < 96) return refuse(reply, cap, 3, "reply buffer");
    if (type < 0x30 || type > 0x32) return refuse(reply, cap, 1, "unknown sim command");
    if (!is_object(s, len)) return refuse(reply, cap, 3, "a sim command's payload is a JSON object");
    if (type == 0x30) {                                         /* SIM_SAMPLE */
        float t;
        if (get_number(s, len, "temperature_C", &t) != 1 || !(t >= 0.0f && t <= 60.0f))
            return refuse(reply, cap, 3, "SIM_SAMPLE needs temperature_C (0..60)");
        /* not used by this bench, but never accepted out of range (as the emulator) */
        if (!optional_in(s, len, "roughness_m", 1e-9f, 1e-3f, false) ||
            !optional_in(s, len, "thickness_m", 1e-5f, 0.1f, true))
            return refuse(reply, cap, 3, "SIM_SAMPLE: roughness_m 1e-9..1e-3, thickness_m 1e-5..0.1");
        p->sample_temp_C = t;
        o = put_s(o, "{\"temperature_C\":");
        o = put_num(o, t);
        o = put_s(o, "}");
        return (int)(o - (char *)reply);
    }
    if (type == 0x31) {                                         /* SIM_FINGER */
        float after = 0.3f, force = 2.0f, hold = 20.0f, skin = 35.5f;
        float skin_m = 650e-6f;
        if (get_number(s, len, "press_after_s", &after) < 0 ||
            get_number(s, len, "force_N", &force) < 0 ||
            get_number(s, len, "hold_s", &hold) < 0 ||
            get_number(s, len, "skin_temperature_C", &skin) < 0 ||
            get_number(s, len, "skin_thickness_m", &skin_m) < 0)
            return refuse(reply, cap, 3, "finger: a value is not a number");
        if (!(force >= 0.05f && force <= 20.0f && hold > 0.0f && hold <= SIM_MAX_S &&
              after >= 0.0f && after <= SIM_MAX_S && skin >= 25.0f && skin <= 40.0f &&
              skin_m >= 100e-6f && skin_m <= 5e-3f))
            return refuse(reply, cap, 3, "finger out of range");
        p->finger_set = true;
        p->press_after_s = after;
        p->force_N = force;
        p->hold_s = hold;
        p->skin_C = skin;
        /* the finger waits for the cue: armed but not ready, its clock starts at READY */
        p->finger_waits = core_state == 1 && !ready;
        p->finger_start_us = now;
        o = put_s(o, "{\"start_s\":");
        if (p->finger_waits) o = put_s(o, "null");
        else o = put_num(o, (double)now * 1e-6);
        o = put_s(o, "}");
        return (int)(o - (char *)reply);
    }
    if (type == 0x32) {                                         /* SIM_FAULT */
        const char *v = find_key(s, len, "spec");
        if (v == NULL || *v != '"') return refuse(reply, cap, 3, "SIM_FAULT needs spec");
        const char *end = v + 1;
        while (end < s + len && *end != '"') end++;
        int added = 0;
        for (const char *a = v + 1; a < end;) {
            const char *b = a;
            while (b < end && *b != ',') b++;
            const char *nm = a;
            while (a < b && *a != '=' && *a != '@' && *a != '+') a++;
            int kind = fault_kind(nm, (size_t)(a - nm));
            if (kind == 0)
                return refuse(reply, cap, 8, "SIM_FAULT: the firmware's sim bench injects only "
                                             "overtemp, stuck_sensor, sensor_range, reboot");
            float at = 0.0f, dur = 0.0f;
            while (a < b) {
                char c = *a++;
                float x;
                if ((c != '@' && c != '+') || !parse_number(a, b, &x) ||
                    !(x >= 0.0f && x <= SIM_MAX_S))
                    return refuse(reply, cap, 3, "SIM_FAULT: @AT_s and +FOR_s are 0..86400 s");
                if (c == '@') at = x;
                else dur = x;
                while (a < b && *a != '@' && *a != '+') a++;
            }
            if (p->n_faults >= SIM_MAX_FAULTS) return refuse(reply, cap, 3, "too many faults");
            sim_fault_t *f = &p->faults[p->n_faults++];
            f->kind = (uint8_t)kind;
            f->done = false;
            f->at_us = now + (uint64_t)(at * 1e6f);
            f->for_us = (uint64_t)(dur * 1e6f);
            added++;
            a = b < end ? b + 1 : b;
        }
        o = put_s(o, "{\"faults\":");
        *o++ = (char)('0' + added % 10);
        o = put_s(o, ",\"now_s\":");
        o = put_num(o, (double)now * 1e-6);
        o = put_s(o, "}");
        return (int)(o - (char *)reply);
    }
    return refuse(reply, cap, 1, "unknown sim command");
}
