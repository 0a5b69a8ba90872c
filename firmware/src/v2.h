/* deskarm serial protocol v2: constants, frame encoder and payload checks.
 *
 * Wire format (PROTOCOL.md has every byte):
 *     F5 F5 | stuffed( LEN TYPE SEQ PAYLOAD[LEN] CRC_HI CRC_LO ) | F7
 * CRC-16/CCITT-FALSE over LEN TYPE SEQ PAYLOAD (unstuffed). Inside the stuffed part the
 * bytes F5 F6 F7 FB FC FD never appear raw: each is sent as F6, byte ^ 0x20. So a v2
 * frame never carries a v1 selector byte, and a raw F5 always means "a frame starts". */
#ifndef DESKARM_V2_H
#define DESKARM_V2_H

#include <stdint.h>

/* v1 (the seed protocol) byte classes */
#define V1_SELECT_FIRST 0xFBu /* 0xFB, 0xFC, 0xFD select joint 1, 2, 3 */
#define V1_SELECT_LAST 0xFDu
#define V1_ANGLE_MAX 0xB4u /* 0x00..0xB4 = 0..180 degrees */

/* v2 framing bytes */
#define V2_SYNC 0xF5u
#define V2_ESC 0xF6u
#define V2_END 0xF7u
#define V2_ESC_XOR 0x20u

#define V2_MAX_PAYLOAD 32u
#define V2_MAX_JOINTS 8u
/* LEN TYPE SEQ + payload + CRC */
#define V2_MAX_BODY (V2_MAX_PAYLOAD + 5u)
/* two syncs + every body byte escaped + end */
#define V2_MAX_WIRE (2u + 2u * V2_MAX_BODY + 1u)

/* message types; bit 7 set = board to host */
#define V2_TYPE_SET_JOINTS 0x01u
#define V2_TYPE_CONFIG 0x02u
#define V2_TYPE_ESTOP 0x03u
#define V2_TYPE_ARM 0x04u
#define V2_TYPE_PING 0x05u
#define V2_TYPE_STATUS 0x81u
#define V2_TYPE_RANGE 0x82u /* HC-SR04 reading, sent unasked at a fixed rate */

/* SET_JOINTS: one big-endian uint16 per joint, centidegrees 0..18000; this value = keep */
#define V2_ANGLE_KEEP 0xFFFFu
#define V2_ANGLE_MAX_CDEG 18000u

/* CONFIG: joint index, or this value for every joint */
#define V2_CONFIG_ALL_JOINTS 0xFFu
#define V2_CONFIG_LEN 7u
#define V2_PULSE_MIN_US 400u  /* lowest min_pulse_us a CONFIG may set */
#define V2_PULSE_MAX_US 3000u /* highest max_pulse_us a CONFIG may set */
#define V2_SPEED_MAX_DPS 1000u /* highest max_speed_dps; 0 means unlimited */

/* STATUS payload: flags, n_joints, good u16, bad u16, dropped u16, then pulses u16 each */
#define V2_STATUS_HEADER_LEN 8u

/* RANGE payload: distance_mm u16 (0xFFFF = no valid reading), tick u16 (the board's 50 Hz
 * tick count when the measurement was triggered, wrapping) */
#define V2_RANGE_LEN 4u

/* STATUS flags */
#define V2_FLAG_V2_MODE 0x01u         /* locked into v2: v1 bytes are ignored until reset */
#define V2_FLAG_ESTOP 0x02u           /* pulses off until an ARM frame */
#define V2_FLAG_WATCHDOG 0x04u        /* no valid frame for 500 ms: holding (latched) */
#define V2_FLAG_MOVING 0x08u          /* a joint is still ramping to its target */
#define V2_FLAG_CONFIG_REJECTED 0x10u /* the last CONFIG was out of range and ignored */
#define V2_FLAG_CLAMPED 0x20u         /* the last SET_JOINTS had an angle above 180.00 deg */

/* 1 when the byte must be escaped inside a frame body. */
uint8_t v2_needs_escape(uint8_t byte);

/* Encode one frame onto the wire. Returns the number of bytes written into out, or 0 when
 * len > V2_MAX_PAYLOAD or out_max is too small (nothing useful is written then). */
uint16_t v2_encode_frame(uint8_t type, uint8_t seq, const uint8_t *payload, uint8_t len,
                         uint8_t *out, uint16_t out_max);

/* 1 when a frame of this type and payload is one the board accepts (type known, length
 * right for the type). Range checks on values are the core's business, not framing's. */
uint8_t v2_board_accepts(uint8_t type, const uint8_t *payload, uint8_t len);

uint16_t v2_get_u16(const uint8_t *p);
void v2_put_u16(uint8_t *p, uint16_t value);

#endif
