/* Unit checks of the firmware core on the host (system cc): firmware/build --host-test, run
 * from tests/firmware/test_firmware_host.py. Expected values come from the protocol's text
 * (check values, layouts, the spec's numbers), never from the code under test. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "fw.h"
#include "host_hal.h"
#include "proto.h"

static int failures, checks;
#define CHECK(cond, ...) do { checks++; if (!(cond)) { failures++; \
    printf("FAIL %s:%d: ", __FILE__, __LINE__); printf(__VA_ARGS__); printf("\n"); } } while (0)

typedef struct { uint8_t seq, type; uint8_t payload[1200]; size_t len; } frame_t;
static frame_t frames[4096];
static size_t n_frames;
static proto_parser_t rxp;

static void run_us(uint64_t us)
{
    uint64_t end = host_now_us + us;
    while (host_now_us < end) {
        host_now_us += 250;
        fw_poll();
    }
    uint8_t buf[65536];
    size_t n;
    while ((n = host_take(buf, sizeof buf)) > 0) {
        for (size_t i = 0; i < n; i++) {
            bool ok = proto_parser_byte(&rxp, buf[i]);
            while (ok) {
                if (n_frames < 4096) {
                    frame_t *f = &frames[n_frames++];
                    f->seq = rxp.seq; f->type = rxp.type; f->len = rxp.len;
                    memcpy(f->payload, rxp.payload, rxp.len);
                }
                ok = proto_parser_next(&rxp);
            }
        }
    }
}

static void send(uint8_t seq, uint8_t type, const void *payload, size_t len)
{
    uint8_t f[1200];
    size_t n = proto_encode(f, sizeof f, seq, type, payload, len);
    host_send(f, n);
}

/* the reply with this seq and type (or NAK), after running 5 ms */
static frame_t *reply_to(uint8_t seq, uint8_t type)
{
    run_us(5000);
    for (size_t i = n_frames; i-- > 0;)
        if (frames[i].seq == seq && (frames[i].type == (type | 0x80) || frames[i].type == 0xFF))
            return &frames[i];
    return NULL;
}

static size_t count_type(uint8_t type, size_t from)
{
    size_t c = 0;
    for (size_t i = from; i < n_frames; i++) c += frames[i].type == type;
    return c;
}

static void heartbeat_for(uint64_t us)
{
    for (uint64_t t = 0; t < us; t += 10000) {
        uint8_t z = 0;
        send(0, 0x02, &z, 1);
        run_us(10000);
    }
}

int main(void)
{
    static const uint8_t digits[9] = {'1', '2', '3', '4', '5', '6', '7', '8', '9'};
    /* CRC check values of the catalogue (CRC-8/SMBUS, CRC-16/CCITT-FALSE, CRC-32) */
    CHECK(proto_crc8(digits, 9) == 0xF4, "crc8");
    CHECK(proto_crc16(digits, 9, 0xFFFF) == 0x29B1, "crc16");
    CHECK(proto_crc32(digits, 9, 0) == 0xCBF43926u, "crc32");
    /* a heartbeat frame written out by hand from §1: A5 5A | 00 00 | 00 | 02 | crc8 | crc16 */
    {
        uint8_t f[16];
        size_t n = proto_encode(f, sizeof f, 0, 2, NULL, 0);
        uint8_t h[4] = {0, 0, 0, 2};
        CHECK(n == 9 && f[0] == 0xA5 && f[1] == 0x5A && f[6] == proto_crc8(h, 4), "frame layout");
    }
    hal_init();
    CHECK(fw_init(), "self-check");
    proto_parser_init(&rxp);
    run_us(20000);
    /* requirement 2: NO_HELLO before a HELLO */
    {
        int16_t v = 3000;
        send(1, 0x03, &v, 2);
        frame_t *r = reply_to(1, 0x03);
        CHECK(r && r->type == 0xFF && r->payload[1] == 9, "SET_NEUTRAL before HELLO: NAK NO_HELLO");
        send(2, 0x22, NULL, 0);
        r = reply_to(2, 0x22);
        CHECK(r && r->type == 0xA2 && r->len == 55, "STATUS before HELLO: 55-byte ACK");
    }
    /* HELLO */
    uint32_t boot = 0;
    {
        uint8_t v = 2;
        send(3, 0x01, &v, 1);
        frame_t *r = reply_to(3, 0x01);
        CHECK(r && r->type == 0x81, "HELLO ACK");
        if (r) {
            CHECK(r->payload[0] == 2 && get_u16(r->payload + 1) == 100, "version, 100 Hz");
            CHECK(get_i16(r->payload + 3) == 1000 && get_i16(r->payload + 5) == 4450, "range 10..44.5");
            CHECK(get_u16(r->payload + 9) == 3200 && get_u16(r->payload + 11) == 90, "neutral, watchdog");
            boot = get_u32(r->payload + 21);
            CHECK(boot != 0, "boot id");
        }
        v = 1;
        send(4, 0x01, &v, 1);
        r = reply_to(4, 0x01);
        CHECK(r && r->type == 0xFF && r->payload[1] == 8, "HELLO version 1: NOT_SUPPORTED");
    }
    /* SET_NEUTRAL twice in a row with the same seq: the second is answered from the store */
    {
        int16_t v = 3100;
        send(10, 0x03, &v, 2);
        frame_t *r = reply_to(10, 0x03);
        CHECK(r && r->type == 0x83 && get_i16(r->payload) == 3100, "SET_NEUTRAL 31 °C");
        v = 3300;
        send(10, 0x03, &v, 2);           /* a retry (same seq): answered, not carried out */
        r = reply_to(10, 0x03);
        CHECK(r && r->type == 0x83 && get_i16(r->payload) == 3100, "retry answered from the store");
        v = 5000;
        send(11, 0x03, &v, 2);
        r = reply_to(11, 0x03);
        CHECK(r && get_i16(r->payload) == 4450, "neutral clamped to 44.5");
        v = 3200;
        send(12, 0x03, &v, 2);
        reply_to(12, 0x03);
    }
    /* a bad frame followed by a good one: resynchronisation */
    {
        uint8_t junk[5] = {0xA5, 0x5A, 0x40, 0x00, 0x01};
        host_send(junk, 5);
        send(13, 0x22, NULL, 0);
        frame_t *r = reply_to(13, 0x22);
        CHECK(r && r->type == 0xA2, "resync after garbage");
    }
    /* upload: a 2 s ramp 32 -> 36 °C at 10 ms */
    {
        enum { N = 201 };
        int16_t prof[N];
        for (int i = 0; i < N; i++) prof[i] = (int16_t)(3200 + 2 * i);
        uint8_t p[8];
        put_u32(p, N);
        put_u32(p + 4, 10000);
        send(20, 0x10, p, 8);
        CHECK(reply_to(20, 0x10)->type == 0x90, "UPLOAD_BEGIN");
        uint8_t c[6 + 2 * N];
        put_u32(c, 0);
        put_u16(c + 4, N);
        for (int i = 0; i < N; i++) put_i16(c + 6 + 2 * i, prof[i]);
        send(21, 0x11, c, sizeof c);
        frame_t *r = reply_to(21, 0x11);
        CHECK(r && r->type == 0x91 && get_u32(r->payload + 6) == proto_crc32(c + 6, 2 * N, 0), "chunk crc");
        uint8_t k[4];
        put_u32(k, 0x12345678u);
        send(22, 0x12, k, 4);
        r = reply_to(22, 0x12);
        CHECK(r && r->type == 0xFF && r->payload[1] == 7, "commit with a wrong CRC: PROFILE_CRC");
        put_u32(k, proto_crc32(c + 6, 2 * N, 0));
        send(23, 0x12, k, 4);
        r = reply_to(23, 0x12);
        CHECK(r && r->type == 0x92 && get_u32(r->payload) == N && get_u16(r->payload + 8) == 0, "commit");
    }
    /* a trial: arm, finger presses after 0.3 s, the profile plays, END complete */
    size_t mark = n_frames;
    {
        const char *finger = "{\"press_after_s\":0.3,\"force_N\":2.0,\"hold_s\":5.0}";
        uint8_t a[7] = {0, 200, 0, 0x10, 0x27, 0, 0};   /* playback, 2 N, 10 s */
        send(30, 0x20, a, 7);
        frame_t *r = reply_to(30, 0x20);
        CHECK(r && r->type == 0xA0 && r->len == 4, "ARM ACK (4 bytes)");
        send(31, 0x31, finger, strlen(finger));
        r = reply_to(31, 0x31);
        CHECK(r && r->type == 0xB1, "SIM_FINGER");
        heartbeat_for(4000000);
        size_t tel = count_type(0xA0, mark);
        CHECK(tel > 200, "telemetry while armed and playing (%zu)", tel);
        int ready = 0, contact = 0, end = -1;
        float max_err = 0;
        for (size_t i = mark; i < n_frames; i++) {
            frame_t *f = &frames[i];
            if (f->type == 0xA1 && f->len >= 11) {
                if (f->payload[0] == 1) ready++;
                if (f->payload[0] == 2) contact++;
                if (f->payload[0] == 3) end = get_i16(f->payload + 9);
            }
            if (f->type == 0xA0 && f->len == 30 && f->payload[28] == 2) {
                float e = fabsf((get_i16(f->payload + 12) - get_i16(f->payload + 14)) / 100.0f);
                if (e > max_err) max_err = e;
            }
        }
        CHECK(ready == 1 && contact == 1 && end == 0, "READY, CONTACT, END complete (%d %d %d)", ready, contact, end);
        CHECK(max_err < 0.5f, "contact within 0.5 °C of the setpoint while playing (%.3f)", max_err);
        send(32, 0x22, NULL, 0);
        r = reply_to(32, 0x22);
        CHECK(r && r->payload[0] == 0 && get_u64(r->payload + 34) != 0 && r->payload[42] == 0,
              "STATUS: idle, contact time, end complete");
    }
    /* the longest host silence while armed is kept (the sim image reports it: the watchdog's
     * margin under QEMU); silence while idle does not count */
    {
        uint32_t before = fw_timing()->host_gap_max_us;
        run_us(200000);                                  /* idle: not a gap of an armed device */
        uint8_t a[7] = {0, 200, 0, 0x10, 0x27, 0, 0};
        send(41, 0x20, a, 7);
        reply_to(41, 0x20);
        run_us(60000);
        uint8_t silent = 0;
        send(0, 0x02, &silent, 1);
        run_us(1000);
        uint32_t gap = fw_timing()->host_gap_max_us;
        CHECK(gap >= 60000 && gap <= 70000 && gap > before,   /* + the frames' own time */
              "longest host silence while armed: %u us (60 ms sent)", (unsigned)gap);
        send(42, 0x21, NULL, 0);
        reply_to(42, 0x21);
        CHECK(fw_state() == 0, "IDLE after ABORT");
    }
    /* requirement 1: watchdog, armed, host silent -> IDLE within 100 ms of the last frame */
    {
        uint8_t a[7] = {0, 200, 0, 0x10, 0x27, 0, 0};
        send(40, 0x20, a, 7);
        reply_to(40, 0x20);
        mark = n_frames;
        uint64_t last = host_now_us;
        run_us(150000);
        int wd = 0;
        uint64_t at = 0;
        for (size_t i = mark; i < n_frames; i++)
            if (frames[i].type == 0xA1 && frames[i].payload[0] == 5) { wd++; at = get_u64(frames[i].payload + 1); }
        CHECK(wd == 1, "WATCHDOG event");
        CHECK(at > last && at - last <= 100000 + 250, "watchdog %llu us after the last frame",
              (unsigned long long)(at - last));
        CHECK(fw_state() == 0, "IDLE after the watchdog");
        CHECK(fw_timing()->host_gap_max_us >= 90000 && fw_timing()->host_gap_max_us <= 100250,
              "the trip's silence is the longest: %u us", (unsigned)fw_timing()->host_gap_max_us);
    }
    /* requirement 3/4: over-temperature trips below 45 °C, latched through ABORT */
    {
        const char *spec = "{\"spec\":\"overtemp\"}";
        send(50, 0x32, spec, strlen(spec));
        CHECK(reply_to(50, 0x32)->type == 0xB2, "SIM_FAULT overtemp");
        float pad_max = 0;
        for (int i = 0; i < 3000 && fw_state() != 4; i++) {
            run_us(1000);
            if (host_plant.pad_C > pad_max) pad_max = host_plant.pad_C;
        }
        for (int i = 0; i < 50; i++) { run_us(1000); if (host_plant.pad_C > pad_max) pad_max = host_plant.pad_C; }
        CHECK(fw_state() == 4, "FAULT after the heater stuck on");
        CHECK(pad_max < 45.0f, "pad stayed below 45 °C (%.3f)", pad_max);
        CHECK(!host_plant.relay, "relay open");
        send(51, 0x21, NULL, 0);
        reply_to(51, 0x21);
        CHECK(fw_state() == 4, "ABORT keeps the latch");
        uint8_t a[7] = {0, 200, 0, 0x10, 0x27, 0, 0};
        send(52, 0x20, a, 7);
        frame_t *r = reply_to(52, 0x20);
        CHECK(r && r->type == 0xFF && r->payload[1] == 10, "ARM refused FAULT_LATCHED");
        send(53, 0x23, "OPERATOR-RESET", 14);
        reply_to(53, 0x23);
        CHECK(fw_state() == 0 && host_plant.relay, "CLEAR_FAULT: IDLE, relay closed");
    }
    /* random bytes (with false markers) between valid commands: every command is answered,
     * nothing is read or written out of bounds (run under the sanitizers by firmware/build) */
    {
        uint32_t x = 12345u;
        int answered = 0;
        for (int round = 0; round < 200; round++) {
            uint8_t junk[300];
            size_t n = 1 + (x % 299u);
            for (size_t i = 0; i < n; i++) {
                x ^= x << 13; x ^= x >> 17; x ^= x << 5;
                junk[i] = (uint8_t)(i % 37 == 0 ? 0xA5 : i % 37 == 1 ? 0x5A : x);
            }
            host_send(junk, n);
            send((uint8_t)(60 + round % 100), 0x02, NULL, 0);
            run_us(250000);                      /* the stale-frame rule (0.2 s) may be needed */
            frame_t *r = reply_to((uint8_t)(60 + round % 100), 0x02);
            answered += r != NULL && r->type == 0x82;
        }
        CHECK(answered >= 190, "commands after garbage answered (%d of 200)", answered);
    }
    /* SET_TRIP: clamped to 20..44.8 °C (never raised); restoring is allowed in FAULT */
    {
        n_frames = 0;                        /* room for this block's replies */
        uint8_t hello = 2;
        send(199, 0x01, &hello, 1);
        reply_to(199, 0x01);
        send(198, 0x21, NULL, 0);
        reply_to(198, 0x21);
        send(197, 0x23, "OPERATOR-RESET", 14);
        reply_to(197, 0x23);
        CHECK(fw_state() == 0, "IDLE before SET_TRIP (state %d)", fw_state());
        int16_t v = 6000;
        send(200, 0x24, &v, 2);
        frame_t *r = reply_to(200, 0x24);
        CHECK(r && r->type == 0xA4 && get_i16(r->payload) == 4480, "SET_TRIP never above 44.8");
        v = 3400;
        send(202, 0x24, &v, 2);
        r = reply_to(202, 0x24);
        CHECK(r && r->type == 0xA4 && get_i16(r->payload) == 3400, "SET_TRIP 34 °C");
        v = 500;
        send(201, 0x24, &v, 2);
        r = reply_to(201, 0x24);
        CHECK(r && r->type == 0xA4 && get_i16(r->payload) == 2000, "SET_TRIP never below 20");
        v = 4500;                            /* restoring: allowed in any state */
        send(206, 0x24, &v, 2);
        r = reply_to(206, 0x24);
        CHECK(r && r->type == 0xA4 && get_i16(r->payload) == 4480, "SET_TRIP restored");
        send(196, 0x23, "OPERATOR-RESET", 14);
        reply_to(196, 0x23);
    }
    CHECK(fw_boot_id() == boot, "boot id unchanged without a power-up");
    printf("%d checks, %d failures\n", checks, failures);
    return failures != 0;
}
