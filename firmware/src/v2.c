#include "v2.h"

#include "crc16.h"

uint8_t v2_needs_escape(uint8_t byte)
{
    return (uint8_t)(byte == V2_SYNC || byte == V2_ESC || byte == V2_END ||
                     (byte >= V1_SELECT_FIRST && byte <= V1_SELECT_LAST));
}

uint16_t v2_get_u16(const uint8_t *p)
{
    return (uint16_t)(((uint16_t)p[0] << 8) | (uint16_t)p[1]);
}

void v2_put_u16(uint8_t *p, uint16_t value)
{
    p[0] = (uint8_t)(value >> 8);
    p[1] = (uint8_t)(value & 0xFFu);
}

/* Append one body byte, escaped when needed; returns the new position or 0 on overflow. */
static uint16_t put_body(uint8_t *out, uint16_t pos, uint16_t out_max, uint8_t byte)
{
    if (v2_needs_escape(byte)) {
        if ((uint16_t)(pos + 2u) > out_max) {
            return 0;
        }
        out[pos++] = V2_ESC;
        out[pos++] = (uint8_t)(byte ^ V2_ESC_XOR);
    } else {
        if ((uint16_t)(pos + 1u) > out_max) {
            return 0;
        }
        out[pos++] = byte;
    }
    return pos;
}

uint16_t v2_encode_frame(uint8_t type, uint8_t seq, const uint8_t *payload, uint8_t len,
                         uint8_t *out, uint16_t out_max)
{
    uint8_t head[3];
    uint16_t crc = CRC16_CCITT_INIT;
    uint16_t pos = 2;
    uint8_t i;

    if (len > V2_MAX_PAYLOAD || out_max < 2u) {
        return 0;
    }
    out[0] = V2_SYNC;
    out[1] = V2_SYNC;
    head[0] = len;
    head[1] = type;
    head[2] = seq;
    for (i = 0; i < 3u; i++) {
        crc = crc16_ccitt_update(crc, head[i]);
        pos = put_body(out, pos, out_max, head[i]);
        if (pos == 0u) {
            return 0;
        }
    }
    for (i = 0; i < len; i++) {
        crc = crc16_ccitt_update(crc, payload[i]);
        pos = put_body(out, pos, out_max, payload[i]);
        if (pos == 0u) {
            return 0;
        }
    }
    pos = put_body(out, pos, out_max, (uint8_t)(crc >> 8));
    if (pos == 0u) {
        return 0;
    }
    pos = put_body(out, pos, out_max, (uint8_t)(crc & 0xFFu));
    if (pos == 0u || pos >= out_max) {
        return 0;
    }
    out[pos++] = V2_END;
    return pos;
}

uint8_t v2_board_accepts(uint8_t type, const uint8_t *payload, uint8_t len)
{
    (void)payload;
    switch (type) {
    case V2_TYPE_SET_JOINTS:
        return (uint8_t)(len >= 2u && len <= 2u * V2_MAX_JOINTS && (len & 1u) == 0u);
    case V2_TYPE_CONFIG:
        return (uint8_t)(len == V2_CONFIG_LEN);
    case V2_TYPE_ESTOP:
    case V2_TYPE_ARM:
    case V2_TYPE_PING:
        return (uint8_t)(len == 0u);
    default:
        return 0; /* unknown, or a board-to-host type such as STATUS */
    }
}
