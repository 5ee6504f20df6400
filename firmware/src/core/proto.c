/* Frames: CRC-8/SMBUS header check, CRC-16/CCITT-FALSE frame check, CRC-32 for profile data,
 * and the resynchronising parser of docs/display-protocol.md §1. */
#include "proto.h"

#include <string.h>

uint8_t proto_crc8(const uint8_t *data, size_t n)
{
    uint8_t c = 0;
    for (size_t i = 0; i < n; i++) {
        c ^= data[i];
        for (int k = 0; k < 8; k++)
            c = (c & 0x80u) ? (uint8_t)((c << 1) ^ 0x07u) : (uint8_t)(c << 1);
    }
    return c;
}

uint16_t proto_crc16(const uint8_t *data, size_t n, uint16_t crc)
{
    for (size_t i = 0; i < n; i++) {
        crc ^= (uint16_t)(data[i] << 8);
        for (int k = 0; k < 8; k++)
            crc = (crc & 0x8000u) ? (uint16_t)((crc << 1) ^ 0x1021u) : (uint16_t)(crc << 1);
    }
    return crc;
}

static uint32_t crc32_table[256];
static bool crc32_ready;

uint32_t proto_crc32(const uint8_t *data, size_t n, uint32_t crc)
{
    if (!crc32_ready) {
        for (uint32_t i = 0; i < 256; i++) {
            uint32_t c = i;
            for (int k = 0; k < 8; k++)
                c = (c & 1u) ? (c >> 1) ^ 0xEDB88320u : c >> 1;
            crc32_table[i] = c;
        }
        crc32_ready = true;
    }
    crc = ~crc;
    for (size_t i = 0; i < n; i++)
        crc = crc32_table[(crc ^ data[i]) & 0xFFu] ^ (crc >> 8);
    return ~crc;
}

void proto_parser_init(proto_parser_t *p)
{
    memset(p, 0, sizeof *p);
}

bool proto_parser_buffered(const proto_parser_t *p)
{
    return p->n > 0;
}

static void drop(proto_parser_t *p, size_t k)
{
    memmove(p->buf, p->buf + k, p->n - k);
    p->n -= k;
}

/* Examine the buffer: drop what cannot start a frame (one byte at a time), return true when a
 * whole, checked frame sits at its start. */
static bool examine(proto_parser_t *p)
{
    for (;;) {
        if (p->n >= 1 && p->buf[0] != PROTO_SOF0) { drop(p, 1); p->skipped++; continue; }
        if (p->n >= 2 && p->buf[1] != PROTO_SOF1) { drop(p, 1); p->skipped++; continue; }
        if (p->n < PROTO_HEADER)
            return false;
        size_t len = get_u16(p->buf + 2);
        if (len > FW_MAX_PAYLOAD || proto_crc8(p->buf + 2, 4) != p->buf[6]) {
            drop(p, 1); p->skipped++; continue;
        }
        size_t total = len + PROTO_OVERHEAD;
        if (p->n < total)
            return false;
        uint16_t crc = get_u16(p->buf + total - 2);
        if (proto_crc16(p->buf + 2, total - 4, 0xFFFFu) != crc) {
            drop(p, 1); p->skipped++; continue;
        }
        p->seq = p->buf[4];
        p->type = p->buf[5];
        p->payload = p->buf + PROTO_HEADER;
        p->len = len;
        p->frames++;
        return true;
    }
}

/* A frame delivered last call is consumed before anything else happens. */
static size_t consume_delivered(proto_parser_t *p)
{
    if (p->payload == NULL)
        return 0;
    size_t total = p->len + PROTO_OVERHEAD;
    p->payload = NULL;
    drop(p, total);
    return total;
}

bool proto_parser_byte(proto_parser_t *p, uint8_t byte)
{
    consume_delivered(p);
    if (p->n >= sizeof p->buf) {          /* cannot happen: a frame is complete by then */
        drop(p, 1); p->skipped++;
    }
    p->buf[p->n++] = byte;
    return examine(p);
}

bool proto_parser_next(proto_parser_t *p)
{
    if (consume_delivered(p) == 0)
        return false;
    return examine(p);
}

bool proto_parser_skip(proto_parser_t *p)
{
    consume_delivered(p);
    if (p->n == 0)
        return false;
    drop(p, 1);
    p->skipped++;
    return examine(p);
}

size_t proto_encode(uint8_t *out, size_t cap, uint8_t seq, uint8_t type, const uint8_t *payload,
                    size_t len)
{
    if (len > FW_MAX_PAYLOAD || cap < len + PROTO_OVERHEAD)
        return 0;
    out[0] = PROTO_SOF0;
    out[1] = PROTO_SOF1;
    put_u16(out + 2, (uint16_t)len);
    out[4] = seq;
    out[5] = type;
    out[6] = proto_crc8(out + 2, 4);
    if (len)
        memmove(out + PROTO_HEADER, payload, len);
    put_u16(out + PROTO_HEADER + len, proto_crc16(out + 2, len + 5, 0xFFFFu));
    return len + PROTO_OVERHEAD;
}
