/* The firmware core (see fw.h). One main loop, no interrupts of its own, no heap. */
#include "fw.h"

#include <string.h>

#include "control.h"
#include "proto.h"

/* ------------------------------------------------------------------ output */
#define TX_SIZE 4096u                      /* a power of two */
static uint8_t tx_buf[TX_SIZE];
static uint32_t tx_head, tx_tail;          /* written, sent (free-running counters) */
static uint32_t tx_dropped;

static uint32_t tx_free(void) { return TX_SIZE - (tx_head - tx_tail); }

/* Queue a whole frame (never a part of one). */
static bool tx_bytes(const uint8_t *data, size_t n)
{
    if (n > tx_free()) {
        tx_dropped++;
        return false;
    }
    for (size_t i = 0; i < n; i++)
        tx_buf[(tx_head + i) & (TX_SIZE - 1)] = data[i];
    tx_head += (uint32_t)n;
    return true;
}

static void tx_drain(void)
{
    while (tx_tail != tx_head && hal_uart_tx_ready()) {
        hal_uart_write(tx_buf[tx_tail & (TX_SIZE - 1)]);
        tx_tail++;
    }
}

/* ------------------------------------------------------------------ state */
#define STORE_PAYLOAD 176u
typedef struct {
    bool valid;
    uint8_t type, seq;
    uint16_t n;
    uint8_t frame[STORE_PAYLOAD + PROTO_OVERHEAD];
} stored_reply_t;

static struct {
    int state;
    uint8_t last_fault, end_reason, arm_mode, tx_seq, pending_fault;
    bool hello, relay, ready, fresh, uploading, have_profile;
    int32_t neutral_cC, lim_min_cC, lim_max_cC;
    int32_t trip_cC;                         /* over-temperature trip; lowered by SET_TRIP */
    uint32_t lim_rate_cC_per_s;
    float sp_C, sp_prev_C;
    float window[FW_RATE_WINDOW_TICKS];
    uint32_t win_n, win_pos;
    uint64_t now_us, last_rx_us, last_byte_us, contact_us, next_control_us;
    uint32_t counter, trials, boot_id, threshold_cN, max_duration_us, ready_count, release_count;
    uint32_t up_n, up_dt_us, prof_n, prof_dt_us;
    uint32_t same_count, last_raw;
    bool raw_valid;
    unsigned control_phase;
    hal_sensors_t s;
    controller_t ctl;
    char fault_text[64];
} F;

static int16_t profile[FW_MAX_POINTS];
static uint32_t got[FW_MAX_POINTS / 32u];
static stored_reply_t store[16];
static proto_parser_t parser;
static fw_timing_t timing;
static uint8_t reply[PROTO_FRAME_MAX];    /* the reply being built */
static size_t reply_n;

static const uint8_t CLEAR_MAGIC[14] = {'O', 'P', 'E', 'R', 'A', 'T', 'O', 'R', '-', 'R', 'E',
                                        'S', 'E', 'T'};

static bool active(int st) { return st == ST_ARMED || st == ST_PLAYING || st == ST_RECORDING; }
static bool latched(uint8_t code)
{
    return code == FAULT_OVER_TEMPERATURE || code == FAULT_SENSOR_FAILURE ||
           code == FAULT_SENSOR_STUCK;
}

static int16_t centi(float v)
{
    float x = v * 100.0f;
    x = x >= 0.0f ? x + 0.5f : x - 0.5f;
    if (x > 32767.0f) return 32767;
    if (x < -32768.0f) return -32768;
    return (int16_t)x;
}

static size_t text_len(const char *s, size_t cap)
{
    size_t n = 0;
    while (n < cap && s[n]) n++;
    return n;
}

/* ------------------------------------------------------------------ frames out */
static void send_frame(uint8_t seq, uint8_t type, const uint8_t *payload, size_t len)
{
    uint8_t f[PROTO_FRAME_MAX];
    size_t n = proto_encode(f, sizeof f, seq, type, payload, len);
    if (n) tx_bytes(f, n);
}

static void event(uint8_t kind, int16_t arg, const char *text)
{
    uint8_t p[11 + 64], *q = p;
    size_t n = text_len(text, 64);
    F.tx_seq++;
    q = put_u8(q, kind);
    q = put_u64(q, F.now_us);
    q = put_i16(q, arg);
    memcpy(q, text, n);
    send_frame(F.tx_seq, MSG_EVENT, p, (size_t)(q - p) + n);
}

static void ack(uint8_t seq, uint8_t cmd, const uint8_t *payload, size_t len)
{
    reply_n = proto_encode(reply, sizeof reply, seq, (uint8_t)(cmd | 0x80u), payload, len);
}

static void nak(uint8_t seq, uint8_t cmd, uint8_t code, const char *text)
{
    uint8_t p[2 + 100];
    size_t n = text_len(text, 100);
    p[0] = cmd;
    p[1] = code;
    memcpy(p + 2, text, n);
    reply_n = proto_encode(reply, sizeof reply, seq, MSG_NAK, p, 2 + n);
}

/* Format an unsigned decimal into s (for texts). */
static char *fmt_u(char *s, uint32_t v)
{
    char t[11];
    int n = 0;
    do { t[n++] = (char)('0' + v % 10u); v /= 10u; } while (v);
    while (n) *s++ = t[--n];
    *s = 0;
    return s;
}

/* "12.34" from hundredths */
static char *fmt_centi(char *s, int32_t v)
{
    if (v < 0) { *s++ = '-'; v = -v; }
    s = fmt_u(s, (uint32_t)v / 100u);
    *s++ = '.';
    *s++ = (char)('0' + (v / 10) % 10);
    *s++ = (char)('0' + v % 10);
    *s = 0;
    return s;
}

static char *fmt_str(char *s, const char *t)
{
    while (*t) *s++ = *t++;
    *s = 0;
    return s;
}

/* ------------------------------------------------------------------ state changes */
static void set_relay(bool closed)
{
    F.relay = closed;
    if (!closed) hal_set_peltier(0.0f);
    hal_set_relay(closed);
}

static void window_reset(float sp)
{
    for (uint32_t i = 0; i < FW_RATE_WINDOW_TICKS; i++) F.window[i] = sp;
    F.win_n = 1;
    F.win_pos = 0;
    F.window[0] = sp;
}

static void window_push(float sp)
{
    F.win_pos = (F.win_pos + 1u) % FW_RATE_WINDOW_TICKS;
    F.window[F.win_pos] = sp;
    if (F.win_n < FW_RATE_WINDOW_TICKS) F.win_n++;
}

static void trip(uint8_t code, const char *text)
{
    if (active(F.state)) F.end_reason = END_FAULT;
    F.last_fault = code;
    set_relay(false);
    F.sp_C = (float)F.neutral_cC / 100.0f;
    F.sp_prev_C = F.sp_C;
    window_reset(F.sp_C);
    F.state = ST_FAULT;
    event(EV_FAULT, (int16_t)code, text);
}

static void power_up_state(void)
{
    memset(&F, 0, sizeof F);
    memset(store, 0, sizeof store);
    proto_parser_init(&parser);
    F.state = ST_IDLE;
    F.neutral_cC = FW_DEFAULT_NEUTRAL_cC;
    F.trip_cC = FW_OVERTEMP_cC;
    F.lim_min_cC = FW_HARD_MIN_cC;
    F.lim_max_cC = FW_SETPOINT_MAX_cC;
    F.lim_rate_cC_per_s = FW_DEFAULT_RATE_cC_per_s;
    F.sp_C = F.sp_prev_C = (float)F.neutral_cC / 100.0f;
    window_reset(F.sp_C);
    F.threshold_cN = 200;
    F.max_duration_us = 20000000u;
    controller_init(&F.ctl);
}

/* ------------------------------------------------------------------ boot */
bool fw_self_check(void)
{
    static const uint8_t check[9] = {'1', '2', '3', '4', '5', '6', '7', '8', '9'};
    bool ok = true;
    /* the limits, again at run time (a build with other numbers must fail here too) */
    ok = ok && FW_HARD_MIN_cC >= 1000 && FW_SETPOINT_MAX_cC <= 4450;
    ok = ok && FW_SETPOINT_MAX_cC < FW_OVERTEMP_cC && FW_OVERTEMP_cC <= FW_HARD_MAX_cC;
    ok = ok && FW_WATCHDOG_MS >= 50 && FW_WATCHDOG_MS <= 90;
    ok = ok && FW_TELEMETRY_HZ >= 50 && FW_TELEMETRY_HZ <= 250;
    ok = ok && FW_HARD_RATE_cC_per_s > 0 && FW_HARD_RATE_cC_per_s <= 10000;
    ok = ok && FW_MIN_DT_US >= 1000 && FW_MAX_POINTS >= 2;
    /* the checks that guard every frame and every profile */
    ok = ok && proto_crc8(check, 9) == 0xF4u;
    ok = ok && proto_crc16(check, 9, 0xFFFFu) == 0x29B1u;
    ok = ok && proto_crc32(check, 9, 0) == 0xCBF43926u;
    return ok;
}

bool fw_init(void)
{
    hal_set_relay(false);
    hal_set_peltier(0.0f);
    power_up_state();
    if (!fw_self_check())
        return false;
    uint8_t e[8];
    uint32_t a = hal_boot_entropy(), b = hal_boot_entropy();
    put_u32(e, a);
    put_u32(e + 4, b);
    F.boot_id = proto_crc32(e, sizeof e, 0);
    if (F.boot_id == 0) F.boot_id = 1;
    F.now_us = hal_time_us();
    F.last_rx_us = F.now_us;
    F.next_control_us = F.now_us + FW_CONTROL_US;
    hal_set_fan(true);
    set_relay(true);
    return true;
}

int fw_state(void) { return F.state; }
uint32_t fw_boot_id(void) { return F.boot_id; }
const fw_timing_t *fw_timing(void) { return &timing; }

/* ------------------------------------------------------------------ commands */
static size_t status_payload(uint8_t *p)
{
    uint8_t *q = p;
    q = put_u8(q, (uint8_t)F.state);
    q = put_u8(q, F.last_fault);
    q = put_u64(q, F.now_us);
    q = put_i16(q, centi(F.sp_C));
    q = put_i16(q, centi(F.s.contact_C));
    q = put_i16(q, centi(F.s.ambient_C));
    q = put_i16(q, centi(F.s.finger_C));
    q = put_i16(q, centi(F.s.heatsink_C));
    for (int i = 0; i < 4; i++) q = put_i16(q, centi(F.s.force_N[i]));
    q = put_i16(q, (int16_t)F.neutral_cC);
    q = put_u32(q, F.have_profile ? F.prof_n : 0u);
    q = put_u64(q, F.contact_us);
    q = put_u8(q, F.end_reason);
    q = put_u32(q, F.counter);
    q = put_u32(q, F.trials);
    q = put_u32(q, F.boot_id);
    return (size_t)(q - p);
}

static int32_t clamp32(int32_t v, int32_t lo, int32_t hi) { return v < lo ? lo : v > hi ? hi : v; }

static void handle(uint8_t seq, uint8_t cmd, const uint8_t *p, size_t len)
{
    uint8_t out[STORE_PAYLOAD], *q = out;
    char text[100];
    bool before_hello_ok = cmd == CMD_HELLO || cmd == CMD_HEARTBEAT || cmd == CMD_STATUS ||
                           cmd == CMD_ABORT || cmd == CMD_CLEAR_FAULT;   /* requirement 2:
                           no sim command either (the bench is driven within a session) */
    if (!F.hello && !before_hello_ok) {
        nak(seq, cmd, ERR_NO_HELLO, "no HELLO since power-up");
        return;
    }
    switch (cmd) {
    case CMD_HEARTBEAT:
        q = put_u64(q, F.now_us);
        ack(seq, cmd, out, 8);
        return;
    case CMD_HELLO: {
        if (len != 1) { nak(seq, cmd, ERR_BAD_LENGTH, "malformed payload"); return; }
        if (p[0] != FW_PROTOCOL_VERSION) {
            nak(seq, cmd, ERR_NOT_SUPPORTED, "protocol not supported (device speaks 2)");
            return;
        }
        /* a new session: forget the stored replies and any unfinished upload */
        memset(store, 0, sizeof store);
        F.uploading = false;
        F.hello = true;
        F.trip_cC = FW_OVERTEMP_cC;          /* a lowered test trip never outlives its host */
        uint8_t h[23 + 4 * 64], *r = h;
        r = put_u8(r, FW_PROTOCOL_VERSION);
        r = put_u16(r, FW_TELEMETRY_HZ);
        r = put_i16(r, FW_HARD_MIN_cC);
        r = put_i16(r, FW_SETPOINT_MAX_cC);
        r = put_u16(r, FW_HARD_RATE_cC_per_s);
        r = put_i16(r, (int16_t)F.neutral_cC);
        r = put_u16(r, FW_WATCHDOG_MS);
        r = put_u32(r, FW_MAX_POINTS);
        r = put_u32(r, FW_MIN_DT_US);
        r = put_u32(r, F.boot_id);
        char caps[64];
        char *c = fmt_str(caps, "playback,record,force4,ir,ambient");
        fmt_str(c, hal_capabilities());
        const char *strs[4] = {hal_device_id(), FW_VERSION_STRING, caps, hal_image_id()};
        for (int i = 0; i < 4; i++) {
            size_t n = text_len(strs[i], 63);
            *r++ = (uint8_t)n;
            memcpy(r, strs[i], n);
            r += n;
        }
        ack(seq, cmd, h, (size_t)(r - h));
        return;
    }
    case CMD_STATUS:
        ack(seq, cmd, out, status_payload(out));
        return;
    case CMD_ABORT:
        if (active(F.state)) {
            F.end_reason = END_ABORTED;
            event(EV_END, END_ABORTED, "aborted by host");
        }
        if (F.state == ST_FAULT && latched(F.last_fault)) {
            ack(seq, cmd, NULL, 0);          /* stopped already; the latch stays (relay open) */
            return;
        }
        F.state = ST_IDLE;
        set_relay(true);
        ack(seq, cmd, NULL, 0);
        return;
    case CMD_CLEAR_FAULT:
        if (len != sizeof CLEAR_MAGIC || memcmp(p, CLEAR_MAGIC, sizeof CLEAR_MAGIC) != 0) {
            nak(seq, cmd, ERR_BAD_ARGUMENT, "CLEAR_FAULT needs the operator's payload");
            return;
        }
        if (F.state == ST_FAULT) {
            F.state = ST_IDLE;
            F.same_count = 0;
            controller_reset(&F.ctl);
            set_relay(true);
        }
        ack(seq, cmd, NULL, 0);
        return;
    case CMD_SET_TRIP: {
        /* a qualification test lowers the trip; it can never be raised above FW_OVERTEMP_cC */
        if (len != 2) { nak(seq, cmd, ERR_BAD_LENGTH, "malformed payload"); return; }
        if (F.state != ST_IDLE && get_i16(p) < FW_OVERTEMP_cC) {   /* restoring: any state */
            nak(seq, cmd, ERR_BAD_STATE, "SET_TRIP lowers the trip in IDLE only");
            return;
        }
        F.trip_cC = clamp32(get_i16(p), FW_TRIP_TEST_MIN_cC, FW_OVERTEMP_cC);
        put_i16(out, (int16_t)F.trip_cC);
        ack(seq, cmd, out, 2);
        return;
    }
    case CMD_SET_NEUTRAL: {
        if (len != 2) { nak(seq, cmd, ERR_BAD_LENGTH, "malformed payload"); return; }
        if (F.state != ST_IDLE && F.state != ST_FAULT) {
            nak(seq, cmd, ERR_BAD_STATE, "SET_NEUTRAL outside IDLE and FAULT");
            return;
        }
        F.neutral_cC = clamp32(get_i16(p), F.lim_min_cC, F.lim_max_cC);
        put_i16(out, (int16_t)F.neutral_cC);
        ack(seq, cmd, out, 2);
        return;
    }
    case CMD_SET_LIMITS: {
        if (len != 6) { nak(seq, cmd, ERR_BAD_LENGTH, "malformed payload"); return; }
        int32_t lo = get_i16(p), hi = get_i16(p + 2);
        uint32_t rate = get_u16(p + 4);
        if (lo < FW_HARD_MIN_cC) lo = FW_HARD_MIN_cC;
        if (hi > FW_SETPOINT_MAX_cC) hi = FW_SETPOINT_MAX_cC;
        if (F.state != ST_IDLE) { nak(seq, cmd, ERR_BAD_STATE, "SET_LIMITS outside IDLE"); return; }
        if (!(lo < hi) || rate == 0) {
            nak(seq, cmd, ERR_BAD_ARGUMENT, "empty range or zero rate");
            return;
        }
        F.lim_min_cC = lo;
        F.lim_max_cC = hi;
        F.lim_rate_cC_per_s = rate < FW_HARD_RATE_cC_per_s ? rate : FW_HARD_RATE_cC_per_s;
        F.neutral_cC = clamp32(F.neutral_cC, lo, hi);
        q = put_i16(q, (int16_t)lo);
        q = put_i16(q, (int16_t)hi);
        q = put_u16(q, (uint16_t)F.lim_rate_cC_per_s);
        ack(seq, cmd, out, 6);
        return;
    }
    case CMD_UPLOAD_BEGIN: {
        if (len != 8) { nak(seq, cmd, ERR_BAD_LENGTH, "malformed payload"); return; }
        uint32_t n = get_u32(p), dt = get_u32(p + 4);
        if (F.state != ST_IDLE) { nak(seq, cmd, ERR_BAD_STATE, "UPLOAD outside IDLE"); return; }
        /* in IDLE any UPLOAD_BEGIN discards the committed profile and any upload, also one it
         * refuses: a host that refused a profile is never left with it playable (§3) */
        F.uploading = false;
        F.have_profile = false;
        if (n < 2 || n > FW_MAX_POINTS || dt < FW_MIN_DT_US) {
            char *t = fmt_str(text, "n=");
            t = fmt_u(t, n);
            t = fmt_str(t, " (2..");
            t = fmt_u(t, FW_MAX_POINTS);
            t = fmt_str(t, "), dt=");
            t = fmt_u(t, dt);
            fmt_str(t, " us (>= 1000)");
            nak(seq, cmd, ERR_OUT_OF_RANGE, text);
            return;
        }
        F.uploading = true;
        F.have_profile = false;
        F.up_n = n;
        F.up_dt_us = dt;
        memset(got, 0, sizeof got);
        ack(seq, cmd, NULL, 0);
        return;
    }
    case CMD_UPLOAD_CHUNK: {
        if (len < 6) { nak(seq, cmd, ERR_BAD_LENGTH, "malformed payload"); return; }
        uint32_t off = get_u32(p), count = get_u16(p + 4);
        if (!F.uploading) { nak(seq, cmd, ERR_BAD_STATE, "no UPLOAD_BEGIN"); return; }
        if (len - 6 != 2u * count) {
            nak(seq, cmd, ERR_BAD_LENGTH, "count does not match the samples");
            return;
        }
        if ((uint64_t)off + count > F.up_n) {
            nak(seq, cmd, ERR_OUT_OF_RANGE, "chunk beyond the profile");
            return;
        }
        for (uint32_t i = 0; i < count; i++) {
            profile[off + i] = get_i16(p + 6 + 2 * i);
            got[(off + i) >> 5] |= 1u << ((off + i) & 31u);
        }
        q = put_u32(q, off);
        q = put_u16(q, (uint16_t)count);
        q = put_u32(q, proto_crc32(p + 6, 2u * count, 0));
        ack(seq, cmd, out, 10);
        return;
    }
    case CMD_UPLOAD_COMMIT: {
        if (len != 4) { nak(seq, cmd, ERR_BAD_LENGTH, "malformed payload"); return; }
        uint32_t want = get_u32(p);
        bool complete = F.uploading;
        for (uint32_t i = 0; complete && i < F.up_n; i++)
            complete = (got[i >> 5] >> (i & 31u)) & 1u;
        if (!complete) { nak(seq, cmd, ERR_PROFILE_INCOMPLETE, "missing samples"); return; }
        uint32_t crc = 0;
        for (uint32_t i = 0; i < F.up_n; i++) {
            uint8_t b[2];
            put_i16(b, profile[i]);
            crc = proto_crc32(b, 2, crc);
        }
        if (crc != want) { nak(seq, cmd, ERR_PROFILE_CRC, "crc32 differs"); return; }
        uint32_t clamped = 0;
        for (uint32_t i = 0; i < F.up_n; i++) {
            int32_t v = clamp32(profile[i], F.lim_min_cC, F.lim_max_cC);
            if (v != profile[i]) { profile[i] = (int16_t)v; clamped++; }
        }
        F.prof_n = F.up_n;
        F.prof_dt_us = F.up_dt_us;
        F.have_profile = true;
        F.uploading = false;
        q = put_u32(q, F.prof_n);
        q = put_u32(q, crc);
        q = put_u16(q, (uint16_t)(clamped > 65535u ? 65535u : clamped));
        ack(seq, cmd, out, 10);
        return;
    }
    case CMD_ARM: {
        if (len != 7) { nak(seq, cmd, ERR_BAD_LENGTH, "malformed payload"); return; }
        uint8_t mode = p[0];
        uint32_t thr = get_u16(p + 1), maxdur = get_u32(p + 3);
        if (F.state == ST_FAULT) {
            char *t = fmt_str(text, "fault ");
            fmt_u(t, F.last_fault);
            nak(seq, cmd, ERR_FAULT_LATCHED, text);
            return;
        }
        if (F.state != ST_IDLE) { nak(seq, cmd, ERR_BAD_STATE, "ARM outside IDLE"); return; }
        if (mode > 1 || thr == 0 || maxdur == 0) {
            nak(seq, cmd, ERR_BAD_ARGUMENT, "mode, threshold or duration");
            return;
        }
        if (mode == 0 && !F.have_profile) {
            nak(seq, cmd, ERR_PROFILE_INCOMPLETE, "no profile committed");
            return;
        }
        F.arm_mode = mode;
        F.threshold_cN = thr;
        F.max_duration_us = maxdur > 4000000u ? 4000000000u : maxdur * 1000u;
        F.ready = false;
        F.ready_count = 0;
        F.fresh = false;
        F.contact_us = 0;
        F.end_reason = END_COMPLETE;
        F.state = ST_ARMED;
        hal_on_arm(mode);
        q = put_u32(q, F.counter);
        ack(seq, cmd, out, 4);
        return;
    }
    default:
        break;
    }
    if (cmd >= CMD_SIM_FIRST && cmd <= CMD_SIM_LAST) {
        uint8_t r[160];
        int n = hal_board_command(cmd, p, len, r, sizeof r - 1, F.state, F.ready);
        if (n >= 0) {
            ack(seq, cmd, r, (size_t)n);
        } else {
            r[sizeof r - 1] = 0;
            nak(seq, cmd, (uint8_t)(-n), (const char *)r);
        }
        return;
    }
    nak(seq, cmd, ERR_UNKNOWN_COMMAND, "unknown command type");
}

static unsigned store_slot(uint8_t type)
{
    switch (type) {
    case CMD_HEARTBEAT: return 0;
    case CMD_SET_NEUTRAL: return 1;
    case CMD_SET_LIMITS: return 2;
    case CMD_UPLOAD_BEGIN: return 3;
    case CMD_UPLOAD_CHUNK: return 4;
    case CMD_UPLOAD_COMMIT: return 5;
    case CMD_ARM: return 6;
    case CMD_ABORT: return 7;
    case CMD_STATUS: return 8;
    case CMD_CLEAR_FAULT: return 9;
    case CMD_SET_TRIP: return 13;
    case 0x30: return 10;
    case 0x31: return 11;
    case 0x32: return 12;
    default: return 15;                     /* any other type shares the last slot */
    }
}

static void on_frame(uint8_t seq, uint8_t type, const uint8_t *p, size_t len)
{
    if (active(F.state) && F.now_us - F.last_rx_us > timing.host_gap_max_us)
        timing.host_gap_max_us = (uint32_t)(F.now_us - F.last_rx_us > 0xFFFFFFFFu
                                            ? 0xFFFFFFFFu : F.now_us - F.last_rx_us);
    F.last_rx_us = F.now_us;                 /* any valid host frame feeds the watchdog */
    if (type == CMD_HEARTBEAT && len == 1 && p[0] == 0)
        return;                              /* silent: no reply, nothing stored */
    bool hello = type == CMD_HELLO;          /* always carried out (a new session) */
    stored_reply_t *st = &store[store_slot(type)];
    if (!hello && st->valid && st->type == type && st->seq == seq) {
        tx_bytes(st->frame, st->n);          /* a retry: the same answer, not a second action */
        return;
    }
    reply_n = 0;
    handle(seq, type, p, len);
    if (reply_n) tx_bytes(reply, reply_n);
    if (!hello) {
        st->valid = reply_n > 0 && reply_n <= sizeof st->frame;
        st->type = type;
        st->seq = seq;
        st->n = (uint16_t)reply_n;
        if (st->valid) memcpy(st->frame, reply, reply_n);
    }
}

/* ------------------------------------------------------------------ control and tick */
static void control_step(unsigned phase)
{
    hal_read_sensors(&F.s);
    float y = F.s.contact_C;
    if (F.raw_valid && F.s.contact_raw == F.last_raw) F.same_count++;
    else F.same_count = 0;
    F.last_raw = F.s.contact_raw;
    F.raw_valid = true;
    if (F.state != ST_FAULT && F.pending_fault == 0) {
        if (!(y > (float)FW_SENSOR_LO_cC / 100.0f && y < (float)FW_SENSOR_HI_cC / 100.0f))
            F.pending_fault = FAULT_SENSOR_FAILURE;
        else if (F.relay && F.same_count + 1u >= FW_STUCK_SAMPLES)
            F.pending_fault = FAULT_SENSOR_STUCK;
        else if (y > (float)F.trip_cC / 100.0f ||
                 F.s.heatsink_C > (float)FW_HEATSINK_MAX_cC / 100.0f)
            F.pending_fault = FAULT_OVER_TEMPERATURE;
    }
    if (F.pending_fault) {                   /* cut the heater in this same control step */
        set_relay(false);
        return;
    }
    if (!F.relay) {
        hal_set_peltier(0.0f);
        return;
    }
    /* the setpoint moves linearly across the tick's control steps */
    float frac = (float)(phase + 1u) / (float)(FW_TICK_US / FW_CONTROL_US);
    float target = F.sp_prev_C + frac * (F.sp_C - F.sp_prev_C);
    float drive = controller_step(&F.ctl, target, y, F.s.heatsink_C, (float)FW_CONTROL_US * 1e-6f);
    hal_set_peltier(drive);
}

static float sample_C(uint32_t i) { return (float)profile[i] / 100.0f; }

static void tick(void)
{
    uint64_t t = F.now_us;
    int prev = F.state;
    char text[64];
    /* host loss restores the normal trip, in any state */
    if (F.trip_cC != FW_OVERTEMP_cC && t - F.last_rx_us > (uint64_t)FW_WATCHDOG_MS * 1000u)
        F.trip_cC = FW_OVERTEMP_cC;
    /* watchdog: host silent while the pad is doing something, HELLO or not */
    if (active(F.state) && t - F.last_rx_us > (uint64_t)FW_WATCHDOG_MS * 1000u) {
        uint64_t ms = (t - F.last_rx_us) / 1000u;
        if (t - F.last_rx_us > timing.host_gap_max_us)
            timing.host_gap_max_us = (uint32_t)(t - F.last_rx_us);  /* < 1 h: a tick trips it */
        F.last_fault = FAULT_WATCHDOG;
        F.end_reason = END_FAULT;
        event(EV_WATCHDOG, (int16_t)(ms > 32767u ? 32767u : ms), "host heartbeat lost");
        F.state = ST_IDLE;
    }
    int state = F.state;
    float fsum = F.s.force_N[0] + F.s.force_N[1] + F.s.force_N[2] + F.s.force_N[3];
    float thr = (float)F.threshold_cN / 100.0f;
    /* setpoint: the goal, slewed at the host's rate (the hard rate during playback), held to
     * the host's rate over every 0.1 s window, clamped to the limits */
    float sp_prev = F.sp_C;
    float max_step = (float)F.lim_rate_cC_per_s / 100.0f * ((float)FW_TICK_US * 1e-6f);
    float goal;
    if (state == ST_PLAYING) {
        uint64_t el = t - F.contact_us;
        uint64_t i = el / F.prof_dt_us;
        if (i >= F.prof_n - 1u) {
            goal = sample_C(F.prof_n - 1u);
        } else {
            float x = (float)(el - i * F.prof_dt_us) / (float)F.prof_dt_us;
            goal = sample_C((uint32_t)i) + x * (sample_C((uint32_t)i + 1u) - sample_C((uint32_t)i));
        }
        max_step = (float)FW_HARD_RATE_cC_per_s / 100.0f * ((float)FW_TICK_US * 1e-6f);
    } else if (state == ST_ARMED && F.arm_mode == 0) {
        goal = sample_C(0);
    } else {
        goal = (float)F.neutral_cC / 100.0f;
    }
    float lo = (float)F.lim_min_cC / 100.0f, hi = (float)F.lim_max_cC / 100.0f;
    if (goal < lo) goal = lo;
    if (goal > hi) goal = hi;
    float d = goal - sp_prev;
    float sp = (d >= -max_step && d <= max_step) ? goal : sp_prev + (d > 0 ? max_step : -max_step);
    float span = (float)F.lim_rate_cC_per_s / 100.0f * ((float)FW_TICK_US * 1e-6f) *
                 (float)FW_RATE_WINDOW_TICKS + (float)FW_RATE_SLACK_cC / 100.0f;
    float wmax = F.window[0], wmin = F.window[0];
    for (uint32_t k = 0; k < F.win_n; k++) {
        uint32_t j = (F.win_pos + FW_RATE_WINDOW_TICKS - k) % FW_RATE_WINDOW_TICKS;
        if (F.window[j] > wmax) wmax = F.window[j];
        if (F.window[j] < wmin) wmin = F.window[j];
    }
    /* the window holds the last 9 setpoints and this one: 10 ticks */
    if (wmax - span > sp) sp = wmax - span;
    if (wmin + span < sp) sp = wmin + span;
    if (sp < (float)FW_HARD_MIN_cC / 100.0f) sp = (float)FW_HARD_MIN_cC / 100.0f;
    if (sp < lo) sp = lo;
    if (sp > (float)FW_SETPOINT_MAX_cC / 100.0f) sp = (float)FW_SETPOINT_MAX_cC / 100.0f;
    if (sp > hi) sp = hi;
    if (state != ST_FAULT) {
        F.sp_prev_C = sp_prev;
        F.sp_C = sp;
        window_push(sp);
    }
    /* safety monitors (found by the control steps, which already cut the heater) */
    if (F.state != ST_FAULT && F.pending_fault) {
        char *s = text;
        float y = F.s.contact_C;
        if (F.pending_fault == FAULT_SENSOR_FAILURE) s = fmt_str(s, "contact sensor reads ");
        else if (F.pending_fault == FAULT_SENSOR_STUCK) s = fmt_str(s, "contact sensor stuck at ");
        else s = fmt_str(s, "pad ");
        s = fmt_centi(s, centi(y > 300.0f ? 300.0f : y < -300.0f ? -300.0f : y));
        s = fmt_str(s, " C");
        if (F.pending_fault == FAULT_OVER_TEMPERATURE) {
            s = fmt_str(s, ", heat sink ");
            s = fmt_centi(s, centi(F.s.heatsink_C));
            fmt_str(s, " C");
        }
        trip(F.pending_fault, text);
    }
    F.pending_fault = 0;
    state = F.state;
    float y = F.s.contact_C;
    /* trial logic */
    if (state == ST_ARMED) {
        /* a finger still pressing from the last trial is not a new contact: contact only once
         * the force has dropped below half the threshold since ARM (a fresh touch) */
        if (!F.fresh && fsum < 0.5f * thr) F.fresh = true;
        if (!F.ready) {
            float e = y - sample_C(0);
            bool near = F.arm_mode == 1 ||
                        ((e < 0 ? -e : e) < (float)FW_READY_BAND_cC / 100.0f && sp == goal);
            F.ready_count = near ? F.ready_count + 1u : 0u;
            if (F.ready_count >= FW_READY_TICKS) {
                F.ready = true;
                event(EV_READY, 0, "ready for contact");
                hal_on_ready();
            }
        } else if (fsum >= thr && F.fresh) {
            F.contact_us = t;
            F.trials++;
            F.release_count = 0;
            char *s = fmt_centi(text, centi(fsum));
            fmt_str(s, " N");
            event(EV_CONTACT, 0, text);
            F.state = F.arm_mode == 0 ? ST_PLAYING : ST_RECORDING;
        }
    } else if (state == ST_PLAYING || state == ST_RECORDING) {
        uint64_t el = t - F.contact_us;
        F.release_count = fsum < 0.5f * thr ? F.release_count + 1u : 0u;
        int reason = -1;
        if ((uint64_t)F.release_count * FW_TICK_US >= (uint64_t)FW_RELEASE_MS * 1000u)
            reason = END_RELEASED;
        else if (el >= F.max_duration_us)
            reason = END_MAX_DURATION;
        else if (state == ST_PLAYING && el >= (uint64_t)(F.prof_n - 1u) * F.prof_dt_us)
            reason = END_COMPLETE;
        if (reason >= 0) {
            static const char *const names[3] = {"complete", "released", "max duration"};
            F.end_reason = (uint8_t)reason;
            event(EV_END, (int16_t)reason, names[reason]);
            F.state = ST_IDLE;
        }
    }
    /* telemetry: while a trial is on, in FAULT, and on the tick a trial ends */
    if (F.state != ST_IDLE || prev != ST_IDLE) {
        uint8_t p[30], *q = p;
        bool record_ch = F.arm_mode == 1 && (F.state == ST_ARMED || F.state == ST_RECORDING ||
                                             prev == ST_RECORDING);
        F.counter++;
        F.tx_seq++;
        q = put_u32(q, F.counter);
        q = put_u64(q, t);
        q = put_i16(q, centi(F.sp_C));
        q = put_i16(q, centi(record_ch ? F.s.sample_C : F.s.contact_C));
        q = put_i16(q, centi(F.s.ambient_C));
        q = put_i16(q, centi(F.s.finger_C));
        for (int i = 0; i < 4; i++) q = put_i16(q, centi(F.s.force_N[i]));
        q = put_u8(q, (uint8_t)F.state);
        q = put_u8(q, F.state == ST_FAULT ? F.last_fault : 0u);
        send_frame(F.tx_seq, MSG_TELEMETRY, p, sizeof p);
    }
}

/* ------------------------------------------------------------------ main loop */
void fw_poll(void)
{
    F.now_us = hal_time_us();
    for (int k = 0; k < 512; k++) {          /* bounded: the control step must not starve */
        int b = hal_uart_read();
        if (b < 0) break;
        F.last_byte_us = F.now_us;
        bool ready = proto_parser_byte(&parser, (uint8_t)b);
        while (ready) {
            on_frame(parser.seq, parser.type, parser.payload, parser.len);
            ready = proto_parser_next(&parser);
        }
    }
    if (proto_parser_buffered(&parser) && F.now_us - F.last_byte_us > 200000u) {
        /* a frame whose tail was lost: skip one byte and search again */
        F.last_byte_us = F.now_us;
        bool ready = proto_parser_skip(&parser);
        while (ready) {
            on_frame(parser.seq, parser.type, parser.payload, parser.len);
            ready = proto_parser_next(&parser);
        }
    }
    if (F.now_us >= F.next_control_us) {
        uint64_t late = F.now_us - F.next_control_us;
        if (late > timing.late_max_us) timing.late_max_us = late > 0xFFFFFFFFu ? 0xFFFFFFFFu : (uint32_t)late;
        if (late > 10u * FW_CONTROL_US) {    /* far behind (a debugger stop): start afresh */
            timing.skipped += (uint32_t)(late / FW_CONTROL_US);
            F.next_control_us = F.now_us;
        }
        F.next_control_us += FW_CONTROL_US;
        unsigned phase = F.control_phase;
        control_step(phase);
        F.control_phase = (phase + 1u) % (FW_TICK_US / FW_CONTROL_US);
        if (F.control_phase == 0) {
            timing.ticks++;
            tick();
        }
    }
    tx_drain();
    hal_iwdg_feed();
}

void fw_run(void)
{
    hal_init();
    if (!fw_init()) {
        /* the compiled-in limits or the checksums failed their check: never drive the pad */
        hal_set_relay(false);
        hal_set_peltier(0.0f);
        for (;;) hal_iwdg_feed();
    }
    hal_iwdg_start();
    for (;;) fw_poll();
}
