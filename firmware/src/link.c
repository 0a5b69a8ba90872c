#include "link.h"

#include <string.h>

#include "crc16.h"

enum {
    ST_HUNT = 0, /* outside frames: v1 bytes (v1 mode) or junk (v2 mode) */
    ST_SYNC1,    /* one F5 seen */
    ST_SYNCED,   /* F5 F5 seen; more F5 are tolerated as preamble */
    ST_BODY,     /* collecting LEN TYPE SEQ PAYLOAD CRC */
    ST_END       /* body complete, the next raw byte must be V2_END */
};

void link_init(link_t *l)
{
    memset(l, 0, sizeof *l);
    l->mode = LINK_MODE_V1;
    l->state = ST_HUNT;
}

static uint8_t is_v1_selector(uint8_t b)
{
    return (uint8_t)(b >= V1_SELECT_FIRST && b <= V1_SELECT_LAST);
}

static uint8_t is_escape_code(uint8_t b)
{
    uint8_t raw = (uint8_t)(b ^ V2_ESC_XOR);
    return v2_needs_escape(raw);
}

/* A frame attempt failed; the byte that showed it is consumed with it. */
static link_event_t reject(link_t *l, uint8_t next_state)
{
    l->bad_frames++;
    l->state = next_state;
    return LINK_NONE;
}

static link_event_t hunt(link_t *l, uint8_t b, link_out_t *out)
{
    if (b == V2_SYNC) {
        /* Clearing the selection is what makes a corrupted first sync byte harmless:
         * if F5 F5 arrives as FB F5, the second F5 undoes the bogus selection before
         * any body byte can be read as an angle. */
        l->v1_joint = 0;
        l->state = ST_SYNC1;
        return LINK_NONE;
    }
    if (l->mode == LINK_MODE_V1) {
        if (is_v1_selector(b)) {
            l->v1_joint = (uint8_t)(b - V1_SELECT_FIRST + 1u);
            return LINK_NONE;
        }
        if (b <= V1_ANGLE_MAX && l->v1_joint != 0u) {
            out->v1_joint = (uint8_t)(l->v1_joint - 1u);
            out->v1_angle_deg = b;
            return LINK_V1_ANGLE;
        }
    }
    l->dropped_bytes++;
    return LINK_NONE;
}

static link_event_t finish(link_t *l, link_out_t *out)
{
    uint8_t len = l->body[0];
    uint16_t crc = crc16_ccitt(l->body, (uint16_t)(len + 3u));
    uint16_t sent = v2_get_u16(&l->body[len + 3u]);

    l->state = ST_HUNT;
    if (crc != sent || !v2_board_accepts(l->body[1], &l->body[3], len)) {
        l->bad_frames++;
        return LINK_NONE;
    }
    l->good_frames++;
    l->mode = LINK_MODE_V2;
    l->v1_joint = 0;
    out->type = l->body[1];
    out->seq = l->body[2];
    out->len = len;
    out->payload = &l->body[3];
    return LINK_V2_FRAME;
}

static link_event_t body(link_t *l, uint8_t b)
{
    if (b == V2_SYNC) {
        return reject(l, ST_SYNC1); /* cut short; this F5 may start the next frame */
    }
    if (is_v1_selector(b) || b == V2_END) {
        return reject(l, ST_HUNT); /* never raw inside a body: corruption or truncation */
    }
    if (l->escaped) {
        l->escaped = 0;
        if (!is_escape_code(b)) {
            return reject(l, ST_HUNT);
        }
        b = (uint8_t)(b ^ V2_ESC_XOR);
    } else if (b == V2_ESC) {
        l->escaped = 1;
        return LINK_NONE;
    }
    l->body[l->n++] = b;
    if (l->n == 1u && b > V2_MAX_PAYLOAD) {
        return reject(l, ST_HUNT);
    }
    if (l->n == (uint8_t)(l->body[0] + 5u)) {
        l->state = ST_END;
    }
    return LINK_NONE;
}

link_event_t link_feed(link_t *l, uint8_t b, link_out_t *out)
{
    switch (l->state) {
    case ST_SYNC1:
        if (b == V2_SYNC) {
            l->state = ST_SYNCED;
        } else {
            /* a lone F5: it and this byte are dropped, this byte is NOT read as v1 */
            l->dropped_bytes = (uint16_t)(l->dropped_bytes + 2u);
            l->state = ST_HUNT;
        }
        return LINK_NONE;
    case ST_SYNCED:
        if (b == V2_SYNC) {
            l->dropped_bytes++;
            return LINK_NONE;
        }
        l->state = ST_BODY;
        l->n = 0;
        l->escaped = 0;
        return body(l, b);
    case ST_BODY:
        return body(l, b);
    case ST_END:
        if (b == V2_END) {
            return finish(l, out);
        }
        return reject(l, b == V2_SYNC ? ST_SYNC1 : ST_HUNT);
    default:
        return hunt(l, b, out);
    }
}
