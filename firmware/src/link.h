/* The byte-level receiver: v1 and v2 on one line.
 *
 * Coexistence rule (PROTOCOL.md, "v1 and v2 on one line"):
 *   - The board starts in v1 mode and applies v1 exactly as the seed firmware: 0xFB/0xFC/0xFD
 *     select joint 1/2/3 and stay selected, 0x00..0xB4 sets the selected joint, angle bytes
 *     before any selector and every other byte are ignored.
 *   - A v2 frame starts with two sync bytes F5 F5. In v1 mode every F5 also clears the v1
 *     selection. Every byte from an F5 up to the end of that frame attempt (valid or not) is
 *     consumed by the v2 receiver and is never read as v1.
 *   - Frame bodies never contain a raw F5 F6 F7 FB FC FD (they are escaped).
 *   - The first valid v2 frame locks the board into v2 mode until reset: from then on, bytes
 *     outside frames are dropped.
 * Consequence (tested exhaustively): a stream of v2 frames, each with any one byte
 * corrupted, dropped or inserted, never moves a joint on a fresh board. */
#ifndef DESKARM_LINK_H
#define DESKARM_LINK_H

#include <stdint.h>

#include "v2.h"

#define LINK_MODE_V1 0u
#define LINK_MODE_V2 1u

typedef enum {
    LINK_NONE = 0,  /* nothing to act on */
    LINK_V1_ANGLE,  /* v1: set joint out->v1_joint (0-based) to out->v1_angle_deg */
    LINK_V2_FRAME   /* v2: a valid frame the board accepts is in out->type/seq/payload/len */
} link_event_t;

typedef struct {
    uint8_t v1_joint;     /* 0-based joint index */
    uint8_t v1_angle_deg; /* 0..180 */
    uint8_t type;
    uint8_t seq;
    uint8_t len;
    const uint8_t *payload; /* points into the link's buffer; valid until the next byte */
} link_out_t;

typedef struct {
    uint8_t mode;     /* LINK_MODE_V1 until the first valid v2 frame */
    uint8_t v1_joint; /* v1 selection: 0 = none, 1..3 */
    uint8_t state;    /* receiver state, see link.c */
    uint8_t escaped;  /* the previous body byte was V2_ESC */
    uint8_t n;        /* unstuffed body bytes received */
    uint8_t body[V2_MAX_BODY]; /* LEN TYPE SEQ PAYLOAD CRC_HI CRC_LO */
    /* counters, wrapping modulo 65536 */
    uint16_t good_frames;   /* valid frames accepted */
    uint16_t bad_frames;    /* frame attempts rejected (CRC, length, escape, type, cut short) */
    uint16_t dropped_bytes; /* bytes outside frames that had no effect */
} link_t;

void link_init(link_t *l);

/* Feed one received byte. */
link_event_t link_feed(link_t *l, uint8_t byte, link_out_t *out);

#endif
