/* Frames of the display protocol (docs/display-protocol.md §1): CRCs, a resynchronising
 * byte-at-a-time parser and little-endian field helpers. No heap: fixed-size buffers. */
#ifndef THERMOCUE_PROTO_H
#define THERMOCUE_PROTO_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "config.h"

#define PROTO_SOF0 0xA5u
#define PROTO_SOF1 0x5Au
#define PROTO_HEADER 7u                      /* marker, length, seq, type, hcrc */
#define PROTO_OVERHEAD 9u                    /* header + CRC-16 */
#define PROTO_FRAME_MAX (FW_MAX_PAYLOAD + PROTO_OVERHEAD)

uint8_t proto_crc8(const uint8_t *data, size_t n);                  /* CRC-8/SMBUS */
uint16_t proto_crc16(const uint8_t *data, size_t n, uint16_t crc);  /* CRC-16/CCITT-FALSE */
uint32_t proto_crc32(const uint8_t *data, size_t n, uint32_t crc);  /* CRC-32 (zlib), start 0 */

/* Parser: feed bytes; proto_parser_byte returns true when a complete, checked frame is ready
 * (seq, type, payload, len), readable until the next call on the parser. */
typedef struct {
    uint8_t buf[PROTO_FRAME_MAX];
    size_t n;
    uint8_t seq, type;
    const uint8_t *payload;
    size_t len;
    uint32_t frames, skipped;               /* frames delivered, bytes skipped */
} proto_parser_t;

void proto_parser_init(proto_parser_t *p);
/* Feed one byte; returns true when a frame is complete (seq, type, payload, len valid). */
bool proto_parser_byte(proto_parser_t *p, uint8_t byte);
/* Consume the frame just delivered and look for another one already buffered (after a resync
 * the buffer may hold several): true when one is ready. Call until false. */
bool proto_parser_next(proto_parser_t *p);
/* A partial frame made no progress for too long: drop one byte and search again. Returns true
 * when a frame became complete while re-examining the remaining bytes. */
bool proto_parser_skip(proto_parser_t *p);
bool proto_parser_buffered(const proto_parser_t *p);

/* Encode a frame into out (cap bytes); returns its size, 0 if it does not fit. */
size_t proto_encode(uint8_t *out, size_t cap, uint8_t seq, uint8_t type, const uint8_t *payload,
                    size_t len);

/* Little-endian writers/readers. */
static inline uint8_t *put_u8(uint8_t *p, uint8_t v) { p[0] = v; return p + 1; }
static inline uint8_t *put_u16(uint8_t *p, uint16_t v) { p[0] = (uint8_t)v; p[1] = (uint8_t)(v >> 8); return p + 2; }
static inline uint8_t *put_i16(uint8_t *p, int16_t v) { return put_u16(p, (uint16_t)v); }
static inline uint8_t *put_u32(uint8_t *p, uint32_t v) { p = put_u16(p, (uint16_t)v); return put_u16(p, (uint16_t)(v >> 16)); }
static inline uint8_t *put_u64(uint8_t *p, uint64_t v) { p = put_u32(p, (uint32_t)v); return put_u32(p, (uint32_t)(v >> 32)); }
static inline uint16_t get_u16(const uint8_t *p) { return (uint16_t)(p[0] | (p[1] << 8)); }
static inline int16_t get_i16(const uint8_t *p) { return (int16_t)get_u16(p); }
static inline uint32_t get_u32(const uint8_t *p) { return (uint32_t)get_u16(p) | ((uint32_t)get_u16(p + 2) << 16); }
static inline uint64_t get_u64(const uint8_t *p) { return (uint64_t)get_u32(p) | ((uint64_t)get_u32(p + 4) << 32); }

#endif
