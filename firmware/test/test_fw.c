/* Host unit tests of the firmware's pure logic (src/) and, through test_hal.c, of the
 * register layer against a stub <msp430.h>. Vectors come from vectors.json through the
 * generated build/vectors.h. Prints one line per test; the last line is "N passed, N failed". */
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "../src/crc16.h"
#include "../src/fw.h"
#include "../src/link.h"
#include "../src/range.h"
#include "../src/servo.h"
#include "../src/v2.h"
#include "unit.h"
#include "vectors.h"

int unit_failed;

extern const unit_test_t HAL_TESTS[];
extern const unsigned HAL_TEST_COUNT;

/* ---- helpers ---------------------------------------------------------------------- */

static uint32_t rng_state;

static void rng_seed(uint32_t seed)
{
    rng_state = seed ? seed : 1u;
}

/* xorshift32: deterministic across platforms, so a failure reproduces */
static uint32_t rng(void)
{
    uint32_t x = rng_state;
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    rng_state = x;
    return x;
}

static uint32_t rng_below(uint32_t n)
{
    return rng() % n;
}

static void feed(fw_t *fw, const uint8_t *data, uint16_t len)
{
    uint16_t i;
    for (i = 0; i < len; i++) {
        fw_feed(fw, data[i]);
    }
}

static void ticks(fw_t *fw, unsigned n)
{
    while (n-- > 0u) {
        fw_tick(fw);
    }
}

/* Encode a frame into a fresh fw; returns wire length. */
static uint16_t encode(uint8_t type, uint8_t seq, const uint8_t *payload, uint8_t len,
                       uint8_t *wire)
{
    return v2_encode_frame(type, seq, payload, len, wire, V2_MAX_WIRE);
}

static void send_frame(fw_t *fw, uint8_t type, uint8_t seq, const uint8_t *payload, uint8_t len)
{
    uint8_t wire[V2_MAX_WIRE];
    uint16_t n = encode(type, seq, payload, len, wire);
    feed(fw, wire, n);
}

static void send_set_joints(fw_t *fw, uint8_t seq, const uint16_t *cdeg, uint8_t n)
{
    uint8_t payload[2u * V2_MAX_JOINTS];
    uint8_t j;
    for (j = 0; j < n; j++) {
        v2_put_u16(&payload[2u * j], cdeg[j]);
    }
    send_frame(fw, V2_TYPE_SET_JOINTS, seq, payload, (uint8_t)(2u * n));
}

static void send_config(fw_t *fw, uint8_t seq, uint8_t joint, uint16_t min_us, uint16_t max_us,
                        uint16_t speed)
{
    uint8_t p[V2_CONFIG_LEN];
    p[0] = joint;
    v2_put_u16(&p[1], min_us);
    v2_put_u16(&p[3], max_us);
    v2_put_u16(&p[5], speed);
    send_frame(fw, V2_TYPE_CONFIG, seq, p, V2_CONFIG_LEN);
}

static void check_pulses_in_range(const fw_t *fw, const char *ctx)
{
    uint8_t j;
    for (j = 0; j < fw->n_joints; j++) {
        uint16_t p = fw->pulse_us[j];
        if (p != 0u) {
            CHECK_EQ_CTX(ctx, p >= fw->joint[j].cfg.min_pulse_us, 1);
            CHECK_EQ_CTX(ctx, p <= fw->joint[j].cfg.max_pulse_us, 1);
        }
    }
}

/* ---- CRC ------------------------------------------------------------------------- */

static void test_crc16_matches_every_vector_in_vectors_json(void)
{
    unsigned i;
    for (i = 0; i < VEC_CRC_COUNT; i++) {
        CHECK_EQ_CTX(VEC_CRC[i].name, crc16_ccitt(VEC_CRC[i].data, VEC_CRC[i].len), VEC_CRC[i].crc);
    }
}

static void test_crc16_of_123456789_is_the_ccitt_false_check_value_0x29b1(void)
{
    CHECK_EQ(crc16_ccitt((const uint8_t *)"123456789", 9), 0x29B1u);
}

static void test_crc16_bytewise_update_equals_the_whole_buffer_crc(void)
{
    uint8_t data[40];
    unsigned round;
    rng_seed(7);
    for (round = 0; round < 200u; round++) {
        uint16_t len = (uint16_t)rng_below(sizeof data + 1u);
        uint16_t crc = CRC16_CCITT_INIT;
        uint16_t i;
        for (i = 0; i < len; i++) {
            data[i] = (uint8_t)rng();
            crc = crc16_ccitt_update(crc, data[i]);
        }
        CHECK_EQ(crc, crc16_ccitt(data, len));
    }
}

/* ---- mapping --------------------------------------------------------------------- */

static void test_mapping_defaults_to_the_seed_firmware_900_plus_10_us_per_degree(void)
{
    servo_config_t c;
    uint16_t deg;
    servo_config_default(&c);
    for (deg = 0; deg <= 180u; deg++) {
        CHECK_EQ(servo_pulse_us(&c, (uint16_t)(deg * 100u)), 900u + 10u * deg);
    }
}

static void test_mapping_rounds_centidegrees_to_the_nearest_microsecond(void)
{
    servo_config_t c;
    servo_config_default(&c);
    CHECK_EQ(servo_pulse_us(&c, 4550), 1355u);
    CHECK_EQ(servo_pulse_us(&c, 4), 900u);
    CHECK_EQ(servo_pulse_us(&c, 5), 901u); /* half a microsecond rounds up */
    CHECK_EQ(servo_pulse_us(&c, 17999), 2700u);
}

static void test_mapping_uses_the_per_joint_min_and_max_pulse(void)
{
    servo_config_t c = {1000, 2000, 0};
    CHECK_EQ(servo_pulse_us(&c, 0), 1000u);
    CHECK_EQ(servo_pulse_us(&c, 9000), 1500u);
    CHECK_EQ(servo_pulse_us(&c, 18000), 2000u);
    c.min_pulse_us = 400;
    c.max_pulse_us = 3000;
    CHECK_EQ(servo_pulse_us(&c, 9000), 1700u);
}

static void test_mapping_clamps_angles_above_180_degrees(void)
{
    servo_config_t c;
    servo_config_default(&c);
    CHECK_EQ(servo_pulse_us(&c, 18001), 2700u);
    CHECK_EQ(servo_pulse_us(&c, 0xFFFE), 2700u);
}

static void test_mapping_never_leaves_the_configured_range_for_any_angle_and_config(void)
{
    static const uint16_t ranges[][2] = {{900, 2700}, {400, 3000}, {400, 401}, {1499, 1501},
                                         {2999, 3000}, {1000, 2000}};
    unsigned r;
    uint32_t a;
    for (r = 0; r < sizeof ranges / sizeof ranges[0]; r++) {
        servo_config_t c = {ranges[r][0], ranges[r][1], 0};
        uint16_t prev = 0;
        for (a = 0; a <= 0xFFFFu; a++) {
            uint16_t p = servo_pulse_us(&c, (uint16_t)a);
            CHECK(p >= c.min_pulse_us && p <= c.max_pulse_us);
            CHECK(p >= prev); /* monotonic */
            prev = p;
        }
    }
}

static void test_config_validation_accepts_the_documented_ranges_only(void)
{
    CHECK_EQ(servo_config_valid(400, 3000, 0), 1);
    CHECK_EQ(servo_config_valid(900, 2700, 1000), 1);
    CHECK_EQ(servo_config_valid(399, 2700, 0), 0);
    CHECK_EQ(servo_config_valid(900, 3001, 0), 0);
    CHECK_EQ(servo_config_valid(1500, 1500, 0), 0);
    CHECK_EQ(servo_config_valid(2000, 1000, 0), 0);
    CHECK_EQ(servo_config_valid(900, 2700, 1001), 0);
}

/* ---- rate limiter ---------------------------------------------------------------- */

static void test_limiter_moves_at_most_max_speed_over_50_per_tick(void)
{
    /* 180 deg/s = 3.6 deg = 360 cdeg per 20 ms tick */
    CHECK_EQ(servo_step_cdeg(9000, 12000, 180), 9360u);
    CHECK_EQ(servo_step_cdeg(9000, 0, 180), 8640u);
    CHECK_EQ(servo_step_cdeg(0, 18000, 1), 2u);
    CHECK_EQ(servo_step_cdeg(0, 18000, 1000), 2000u);
}

static void test_limiter_reaches_the_target_exactly_without_overshoot(void)
{
    uint16_t pos = 9000;
    unsigned n = 0;
    while (pos != 12000u && n < 100u) {
        uint16_t next = servo_step_cdeg(pos, 12000, 180);
        CHECK(next > pos && next <= 12000u);
        pos = next;
        n++;
    }
    CHECK_EQ(pos, 12000u);
    CHECK_EQ(n, 9u); /* 3000 / 360 = 8.3 -> 9 ticks */
    CHECK_EQ(servo_step_cdeg(12000, 12000, 180), 12000u);
}

static void test_limiter_with_zero_speed_jumps_to_the_target(void)
{
    CHECK_EQ(servo_step_cdeg(0, 18000, 0), 18000u);
    CHECK_EQ(servo_step_cdeg(18000, 0, 0), 0u);
}

static void test_limiter_moves_down_as_well_as_up_and_stops_at_zero(void)
{
    uint16_t pos = 300;
    pos = servo_step_cdeg(pos, 0, 100);
    CHECK_EQ(pos, 100u);
    pos = servo_step_cdeg(pos, 0, 100);
    CHECK_EQ(pos, 0u);
}

/* ---- v1 -------------------------------------------------------------------------- */

static void test_v1_streams_from_vectors_json_give_the_expected_pulses(void)
{
    unsigned i;
    for (i = 0; i < VEC_V1_COUNT; i++) {
        const vec_v1_t *v = &VEC_V1[i];
        fw_t fw;
        uint8_t j;
        fw_init(&fw, v->joints);
        feed(&fw, v->bytes, v->len);
        for (j = 0; j < v->joints; j++) {
            CHECK_EQ_CTX(v->name, fw.pulse_us[j], v->pulses_us[j]);
        }
        CHECK_EQ_CTX(v->name, fw.link.mode, LINK_MODE_V1);
    }
}

static void test_parser_ignores_angle_bytes_before_any_selector(void)
{
    fw_t fw;
    unsigned b;
    fw_init(&fw, 3);
    for (b = 0; b <= V1_ANGLE_MAX; b++) {
        fw_feed(&fw, (uint8_t)b);
    }
    CHECK_EQ(fw.pulse_us[0], 0u);
    CHECK_EQ(fw.pulse_us[1], 0u);
    CHECK_EQ(fw.pulse_us[2], 0u);
    CHECK_EQ(fw.link.dropped_bytes, 181u);
}

static void test_parser_keeps_the_selection_sticky_across_angle_bytes(void)
{
    fw_t fw;
    fw_init(&fw, 3);
    fw_feed(&fw, 0xFC);
    fw_feed(&fw, 10);
    CHECK_EQ(fw.pulse_us[1], 1000u);
    fw_feed(&fw, 170);
    CHECK_EQ(fw.pulse_us[1], 2600u);
    fw_tick(&fw);
    fw_feed(&fw, 0);
    CHECK_EQ(fw.pulse_us[1], 900u);
    CHECK_EQ(fw.pulse_us[0], 0u);
}

static void test_parser_ignores_every_byte_that_is_neither_selector_nor_angle_nor_sync(void)
{
    unsigned b;
    for (b = V1_ANGLE_MAX + 1u; b <= 0xFFu; b++) {
        fw_t fw;
        if (b == V2_SYNC || (b >= V1_SELECT_FIRST && b <= V1_SELECT_LAST)) {
            continue;
        }
        fw_init(&fw, 3);
        fw_feed(&fw, 0xFB);
        fw_feed(&fw, (uint8_t)b);
        fw_feed(&fw, 45);
        CHECK_EQ(fw.pulse_us[0], 1350u); /* still selected */
        CHECK_EQ(fw.link.dropped_bytes, 1u);
    }
}

static void test_v1_every_angle_byte_on_every_joint_gives_900_plus_10_us_per_degree(void)
{
    fw_t fw;
    unsigned j;
    unsigned a;
    fw_init(&fw, 3);
    for (j = 0; j < 3u; j++) {
        fw_feed(&fw, (uint8_t)(V1_SELECT_FIRST + j));
        for (a = 0; a <= 180u; a++) {
            fw_feed(&fw, (uint8_t)a);
            CHECK_EQ(fw.pulse_us[j], 900u + 10u * a);
        }
    }
}

static void test_v1_moves_are_applied_at_once_and_not_rate_limited(void)
{
    fw_t fw;
    fw_init(&fw, 3);
    fw_feed(&fw, 0xFB);
    fw_feed(&fw, 0);
    fw_feed(&fw, 180);
    CHECK_EQ(fw.pulse_us[0], 2700u);
    fw_tick(&fw);
    CHECK_EQ(fw.pulse_us[0], 2700u);
    CHECK_EQ(fw_flags(&fw) & V2_FLAG_MOVING, 0u);
}

static void test_v1_mode_has_no_watchdog(void)
{
    fw_t fw;
    fw_init(&fw, 3);
    fw_feed(&fw, 0xFD);
    fw_feed(&fw, 90);
    ticks(&fw, 10000);
    CHECK_EQ(fw.pulse_us[2], 1800u);
    CHECK_EQ(fw_flags(&fw), 0u);
}

/* ---- v2 framing ------------------------------------------------------------------ */

static void test_v2_frames_from_vectors_json_encode_to_their_wire_bytes(void)
{
    unsigned i;
    for (i = 0; i < VEC_FRAMES_COUNT; i++) {
        const vec_frame_t *v = &VEC_FRAMES[i];
        uint8_t wire[V2_MAX_WIRE];
        uint16_t n = encode(v->type, v->seq, v->payload, v->payload_len, wire);
        CHECK_EQ_CTX(v->name, n, v->wire_len);
        CHECK_EQ_CTX(v->name, memcmp(wire, v->wire, n), 0);
    }
}

static void test_v2_frames_from_vectors_json_decode_to_their_fields(void)
{
    unsigned i;
    for (i = 0; i < VEC_FRAMES_COUNT; i++) {
        const vec_frame_t *v = &VEC_FRAMES[i];
        link_t l;
        link_out_t out;
        unsigned events = 0;
        uint16_t k;
        link_init(&l);
        memset(&out, 0, sizeof out);
        for (k = 0; k < v->wire_len; k++) {
            link_event_t ev = link_feed(&l, v->wire[k], &out);
            CHECK_EQ_CTX(v->name, ev != LINK_V1_ANGLE, 1);
            if (ev == LINK_V2_FRAME) {
                events++;
                CHECK_EQ_CTX(v->name, k, v->wire_len - 1u); /* only the end byte completes */
                CHECK_EQ_CTX(v->name, out.type, v->type);
                CHECK_EQ_CTX(v->name, out.seq, v->seq);
                CHECK_EQ_CTX(v->name, out.len, v->payload_len);
                CHECK_EQ_CTX(v->name, memcmp(out.payload, v->payload, v->payload_len), 0);
                if (v->type == V2_TYPE_SET_JOINTS) {
                    unsigned j;
                    CHECK_EQ_CTX(v->name, out.len, 2u * v->n_angles);
                    for (j = 0; j < v->n_angles; j++) {
                        CHECK_EQ_CTX(v->name, v2_get_u16(&out.payload[2u * j]), v->angles_cdeg[j]);
                    }
                } else if (v->type == V2_TYPE_CONFIG) {
                    CHECK_EQ_CTX(v->name, out.payload[0], v->cfg_joint);
                    CHECK_EQ_CTX(v->name, v2_get_u16(&out.payload[1]), v->cfg_min_pulse_us);
                    CHECK_EQ_CTX(v->name, v2_get_u16(&out.payload[3]), v->cfg_max_pulse_us);
                    CHECK_EQ_CTX(v->name, v2_get_u16(&out.payload[5]), v->cfg_max_speed_dps);
                }
            }
        }
        if (v->to_board) {
            CHECK_EQ_CTX(v->name, events, 1u);
            CHECK_EQ_CTX(v->name, l.good_frames, 1u);
            CHECK_EQ_CTX(v->name, l.mode, LINK_MODE_V2);
        } else {
            /* a board-to-host frame arriving at the board is well formed but not for it */
            CHECK_EQ_CTX(v->name, events, 0u);
            CHECK_EQ_CTX(v->name, l.bad_frames, 1u);
            CHECK_EQ_CTX(v->name, l.mode, LINK_MODE_V1);
        }
        CHECK_EQ_CTX(v->name, l.dropped_bytes, 0u);
    }
}

static void test_status_payload_layout_matches_the_to_host_vectors(void)
{
    unsigned i;
    unsigned seen = 0;
    for (i = 0; i < VEC_FRAMES_COUNT; i++) {
        const vec_frame_t *v = &VEC_FRAMES[i];
        fw_t fw;
        uint8_t payload[V2_STATUS_HEADER_LEN + 2u * FW_MAX_JOINTS];
        uint8_t j;
        if (v->type != V2_TYPE_STATUS) {
            continue;
        }
        seen++;
        /* put a board in exactly the reported state, then let fw_status_payload speak */
        fw_init(&fw, v->st_n);
        fw.link.mode = (v->st_flags & V2_FLAG_V2_MODE) ? LINK_MODE_V2 : LINK_MODE_V1;
        fw.estop = (uint8_t)((v->st_flags & V2_FLAG_ESTOP) != 0u);
        fw.watchdog = (uint8_t)((v->st_flags & V2_FLAG_WATCHDOG) != 0u);
        fw.config_rejected = (uint8_t)((v->st_flags & V2_FLAG_CONFIG_REJECTED) != 0u);
        fw.clamped = (uint8_t)((v->st_flags & V2_FLAG_CLAMPED) != 0u);
        if (v->st_flags & V2_FLAG_MOVING) {
            fw.joint[0].known = 1;
            fw.joint[0].target_cdeg = 1;
        }
        fw.link.good_frames = v->st_good;
        fw.link.bad_frames = v->st_bad;
        fw.link.dropped_bytes = v->st_dropped;
        for (j = 0; j < v->st_n; j++) {
            fw.pulse_us[j] = v->st_pulses_us[j];
        }
        CHECK_EQ_CTX(v->name, fw_status_payload(&fw, payload), v->payload_len);
        CHECK_EQ_CTX(v->name, memcmp(payload, v->payload, v->payload_len), 0);
    }
    CHECK(seen >= 1u);
}

static void test_v2_rejected_vectors_are_not_accepted_and_are_counted(void)
{
    unsigned i;
    for (i = 0; i < VEC_REJECTED_COUNT; i++) {
        const vec_reject_t *v = &VEC_REJECTED[i];
        fw_t fw;
        fw_init(&fw, 3);
        feed(&fw, v->wire, v->len);
        CHECK_EQ_CTX(v->name, fw.link.good_frames, 0u);
        CHECK_EQ_CTX(v->name, fw.link.bad_frames, v->bad_frames);
        CHECK_EQ_CTX(v->name, fw.link.dropped_bytes, v->dropped_bytes);
        CHECK_EQ_CTX(v->name, fw.link.mode, LINK_MODE_V1);
        CHECK_EQ_CTX(v->name, fw.link.v1_joint, 0u);
        CHECK_EQ_CTX(v->name, fw.pulse_us[0] | fw.pulse_us[1] | fw.pulse_us[2], 0u);
        CHECK_EQ_CTX(v->name, fw.tx_len, 0u);
    }
}

static void test_v2_receiver_resyncs_when_a_new_sync_cuts_a_frame_short(void)
{
    fw_t fw;
    uint8_t wire[V2_MAX_WIRE];
    static const uint16_t cdeg[3] = {9000, 4550, 12000};
    uint8_t payload[6];
    uint16_t n;
    unsigned cut;
    v2_put_u16(&payload[0], cdeg[0]);
    v2_put_u16(&payload[2], cdeg[1]);
    v2_put_u16(&payload[4], cdeg[2]);
    n = encode(V2_TYPE_SET_JOINTS, 1, payload, 6, wire);
    for (cut = 2; cut < n; cut++) {
        fw_init(&fw, 3);
        feed(&fw, wire, (uint16_t)cut); /* a partial frame... */
        feed(&fw, wire, n);             /* ...then a whole one */
        CHECK_EQ(fw.link.good_frames, 1u);
        /* a cut right after F5 F5 leaves only surplus preamble, not a frame attempt */
        CHECK_EQ(fw.link.bad_frames, cut == 2u ? 0u : 1u);
        CHECK_EQ(fw.pulse_us[1], 1355u);
    }
}

static void test_v2_extra_sync_bytes_before_a_frame_are_tolerated(void)
{
    fw_t fw;
    static const uint8_t pre[] = {V2_SYNC, V2_SYNC, V2_SYNC};
    fw_init(&fw, 3);
    feed(&fw, pre, sizeof pre);
    send_frame(&fw, V2_TYPE_PING, 0, NULL, 0);
    CHECK_EQ(fw.link.good_frames, 1u);
    CHECK_EQ(fw.link.bad_frames, 0u);
    CHECK_EQ(fw.link.dropped_bytes, 3u);
}

static void test_v2_payload_lengths_are_checked_per_type(void)
{
    uint8_t p[V2_MAX_PAYLOAD] = {0};
    CHECK_EQ(v2_board_accepts(V2_TYPE_SET_JOINTS, p, 2), 1);
    CHECK_EQ(v2_board_accepts(V2_TYPE_SET_JOINTS, p, 16), 1);
    CHECK_EQ(v2_board_accepts(V2_TYPE_SET_JOINTS, p, 0), 0);
    CHECK_EQ(v2_board_accepts(V2_TYPE_SET_JOINTS, p, 3), 0);
    CHECK_EQ(v2_board_accepts(V2_TYPE_SET_JOINTS, p, 18), 0);
    CHECK_EQ(v2_board_accepts(V2_TYPE_CONFIG, p, 7), 1);
    CHECK_EQ(v2_board_accepts(V2_TYPE_CONFIG, p, 8), 0);
    CHECK_EQ(v2_board_accepts(V2_TYPE_PING, p, 0), 1);
    CHECK_EQ(v2_board_accepts(V2_TYPE_ESTOP, p, 1), 0);
    CHECK_EQ(v2_board_accepts(V2_TYPE_STATUS, p, 14), 0);
    CHECK_EQ(v2_board_accepts(0x00, p, 0), 0);
}

static void test_v2_encoder_refuses_payloads_longer_than_32_bytes_or_a_short_buffer(void)
{
    uint8_t p[V2_MAX_PAYLOAD + 1u] = {0};
    uint8_t wire[V2_MAX_WIRE];
    CHECK_EQ(v2_encode_frame(V2_TYPE_SET_JOINTS, 0, p, V2_MAX_PAYLOAD + 1u, wire, sizeof wire), 0u);
    CHECK_EQ(v2_encode_frame(V2_TYPE_PING, 0, p, 0, wire, 7), 0u); /* needs 8 */
    CHECK_EQ(v2_encode_frame(V2_TYPE_PING, 0, p, 0, wire, 8), 8u);
}

/* ---- v1/v2 coexistence: corrupted v2 is never v1 ------------------------------------ */

/* Feed bytes to a fresh link; fail if any byte is taken as a v1 angle. Returns the number of
 * valid frames. */
static unsigned feed_link_expecting_no_v1(link_t *l, const uint8_t *data, uint16_t len,
                                          const char *ctx)
{
    uint16_t i;
    unsigned frames = 0;
    link_out_t out;
    for (i = 0; i < len; i++) {
        link_event_t ev = link_feed(l, data[i], &out);
        if (ev == LINK_V1_ANGLE) {
            printf("    [%s] byte %u (0x%02X) was read as a v1 angle for joint %u\n", ctx,
                   (unsigned)i, data[i], (unsigned)out.v1_joint + 1u);
            unit_failed = 1;
            return frames;
        }
        if (ev == LINK_V2_FRAME) {
            frames++;
        }
    }
    return frames;
}

static void test_every_single_byte_corruption_of_every_frame_vector_is_rejected(void)
{
    unsigned i;
    for (i = 0; i < VEC_FRAMES_COUNT; i++) {
        const vec_frame_t *v = &VEC_FRAMES[i];
        uint8_t wire[V2_MAX_WIRE];
        uint16_t pos;
        unsigned value;
        if (!v->to_board) {
            continue;
        }
        for (pos = 0; pos < v->wire_len; pos++) {
            for (value = 0; value <= 0xFFu; value++) {
                link_t l;
                if (value == v->wire[pos]) {
                    continue;
                }
                memcpy(wire, v->wire, v->wire_len);
                wire[pos] = (uint8_t)value;
                link_init(&l);
                CHECK_EQ_CTX(v->name, feed_link_expecting_no_v1(&l, wire, v->wire_len, v->name), 0u);
                CHECK_HELPER();
                CHECK_EQ_CTX(v->name, l.v1_joint, 0u);
                CHECK_EQ_CTX(v->name, l.mode, LINK_MODE_V1);
            }
        }
    }
}

static void test_every_dropped_byte_of_every_frame_vector_is_rejected(void)
{
    unsigned i;
    for (i = 0; i < VEC_FRAMES_COUNT; i++) {
        const vec_frame_t *v = &VEC_FRAMES[i];
        uint8_t wire[V2_MAX_WIRE];
        uint16_t pos;
        if (!v->to_board) {
            continue;
        }
        for (pos = 0; pos < v->wire_len; pos++) {
            link_t l;
            memcpy(wire, v->wire, pos);
            memcpy(&wire[pos], &v->wire[pos + 1u], (size_t)(v->wire_len - pos - 1u));
            link_init(&l);
            CHECK_EQ_CTX(v->name, feed_link_expecting_no_v1(&l, wire, (uint16_t)(v->wire_len - 1u), v->name), 0u);
            CHECK_HELPER();
            CHECK_EQ_CTX(v->name, l.v1_joint, 0u);
        }
    }
}

static void test_every_inserted_byte_in_every_frame_vector_is_rejected_or_harmless(void)
{
    /* An inserted byte either breaks the frame, or leaves it intact and rightly accepted: a
     * surplus F5 in the preamble, or an F7 just before the end byte (the frame ends there and
     * the real end byte is dropped). Either way no byte is ever read as v1. */
    unsigned i;
    for (i = 0; i < VEC_FRAMES_COUNT; i++) {
        const vec_frame_t *v = &VEC_FRAMES[i];
        uint8_t wire[V2_MAX_WIRE + 1u];
        uint16_t pos;
        unsigned value;
        if (!v->to_board) {
            continue;
        }
        for (pos = 1; pos < v->wire_len; pos++) {
            for (value = 0; value <= 0xFFu; value++) {
                link_t l;
                unsigned frames;
                memcpy(wire, v->wire, pos);
                wire[pos] = (uint8_t)value;
                memcpy(&wire[pos + 1u], &v->wire[pos], (size_t)(v->wire_len - pos));
                link_init(&l);
                frames = feed_link_expecting_no_v1(&l, wire, (uint16_t)(v->wire_len + 1u), v->name);
                CHECK_HELPER();
                if (frames != 0u) {
                    CHECK_EQ_CTX(v->name, frames, 1u);
                    CHECK_EQ_CTX(v->name, (value == V2_SYNC && pos <= 2u) ||
                                              (value == V2_END && pos == v->wire_len - 1u), 1);
                }
                CHECK_EQ_CTX(v->name, l.v1_joint, 0u);
            }
        }
    }
}

static void test_corrupted_v2_frames_fed_to_a_fresh_board_never_change_a_pulse(void)
{
    /* Streams of 1..8 frames from the vectors, each with one byte replaced, dropped or
     * inserted inside the frame, fed back to back to a fresh v1-mode board. */
    unsigned round;
    rng_seed(20240611u);
    for (round = 0; round < 20000u; round++) {
        uint8_t stream[8u * (V2_MAX_WIRE + 1u)];
        uint16_t len = 0;
        unsigned frames = 1u + rng_below(8);
        unsigned f;
        fw_t fw;
        uint16_t i;
        for (f = 0; f < frames; f++) {
            const vec_frame_t *v;
            uint16_t pos;
            do {
                v = &VEC_FRAMES[rng_below(VEC_FRAMES_COUNT)];
            } while (!v->to_board);
            pos = (uint16_t)rng_below(v->wire_len);
            switch (rng_below(3)) {
            case 0: /* replace with a different value */
                memcpy(&stream[len], v->wire, v->wire_len);
                stream[len + pos] = (uint8_t)(v->wire[pos] ^ (uint8_t)(1u + rng_below(255)));
                len = (uint16_t)(len + v->wire_len);
                break;
            case 1: /* drop */
                memcpy(&stream[len], v->wire, pos);
                memcpy(&stream[len + pos], &v->wire[pos + 1u], (size_t)(v->wire_len - pos - 1u));
                len = (uint16_t)(len + v->wire_len - 1u);
                break;
            default: /* insert strictly inside the body, where even F5 breaks the frame */
                pos = (uint16_t)(3u + rng_below((uint32_t)(v->wire_len - 3u)));
                memcpy(&stream[len], v->wire, pos);
                stream[len + pos] = (uint8_t)rng();
                memcpy(&stream[len + pos + 1u], &v->wire[pos], (size_t)(v->wire_len - pos));
                len = (uint16_t)(len + v->wire_len + 1u);
                break;
            }
        }
        fw_init(&fw, 3);
        for (i = 0; i < len; i++) {
            fw_feed(&fw, stream[i]);
            if (fw.link.good_frames != 0u) {
                /* the insert was an F7 just before the end byte, leaving the frame intact:
                 * accepting it is right, and v1 is locked out from here on */
                break;
            }
            CHECK_EQ(fw.pulse_us[0] | fw.pulse_us[1] | fw.pulse_us[2], 0u);
            if ((i & 7u) == 0u) {
                fw_tick(&fw);
            }
        }
        CHECK_EQ(fw.tx_len == 0u || fw.link.good_frames != 0u, 1);
    }
}

static void test_the_first_valid_v2_frame_locks_out_v1_until_reset(void)
{
    fw_t fw;
    static const uint8_t v1[] = {0xFB, 90, 0xFC, 45, 0xFD, 0};
    fw_init(&fw, 3);
    send_frame(&fw, V2_TYPE_PING, 1, NULL, 0);
    CHECK_EQ(fw.link.mode, LINK_MODE_V2);
    feed(&fw, v1, sizeof v1);
    CHECK_EQ(fw.pulse_us[0] | fw.pulse_us[1] | fw.pulse_us[2], 0u);
    CHECK_EQ(fw.link.dropped_bytes, sizeof v1);
    fw_init(&fw, 3); /* reset */
    feed(&fw, v1, sizeof v1);
    CHECK_EQ(fw.pulse_us[0], 1800u);
}

static void test_a_sync_byte_in_v1_mode_clears_the_selection(void)
{
    fw_t fw;
    fw_init(&fw, 3);
    fw_feed(&fw, 0xFB);
    fw_feed(&fw, 10);
    fw_feed(&fw, V2_SYNC);
    fw_feed(&fw, 0x00); /* swallowed with the lone sync */
    fw_feed(&fw, 20);   /* no selection any more */
    CHECK_EQ(fw.pulse_us[0], 1000u);
    CHECK_EQ(fw.link.v1_joint, 0u);
    fw_feed(&fw, 0xFB);
    fw_feed(&fw, 20);
    CHECK_EQ(fw.pulse_us[0], 1100u); /* v1 still works afterwards */
}

/* ---- v2 behaviour -------------------------------------------------------------- */

static void test_v2_scenarios_from_vectors_json_hold_step_by_step(void)
{
    unsigned i;
    for (i = 0; i < VEC_SCENARIOS_COUNT; i++) {
        const vec_scenario_t *sc = &VEC_SCENARIOS[i];
        fw_t fw;
        uint16_t s;
        fw_init(&fw, sc->joints);
        for (s = 0; s < sc->n_steps; s++) {
            const vec_step_t *st = &sc->steps[s];
            char ctx[160];
            uint8_t j;
            snprintf(ctx, sizeof ctx, "%s, step %u", sc->name, (unsigned)s);
            switch (st->kind) {
            case STEP_FEED:
                feed(&fw, st->data, st->len);
                break;
            case STEP_TICKS:
                ticks(&fw, st->count);
                break;
            case STEP_FLAGS:
                CHECK_EQ_CTX(ctx, fw_flags(&fw), st->count);
                break;
            case STEP_PULSES:
                for (j = 0; j < sc->joints; j++) {
                    CHECK_EQ_CTX(ctx, fw.pulse_us[j], st->values[j]);
                }
                break;
            case STEP_TX: {
                uint8_t tx[FW_TX_SIZE];
                uint8_t n = fw_take_tx(&fw, tx, sizeof tx);
                CHECK_EQ_CTX(ctx, n, st->len);
                CHECK_EQ_CTX(ctx, memcmp(tx, st->data, n), 0);
                break;
            }
            default:
                CHECK(0);
            }
        }
    }
}

static void test_the_first_set_joints_jumps_because_an_unpowered_servo_position_is_unknown(void)
{
    fw_t fw;
    static const uint16_t a[3] = {18000, 0, 9000};
    fw_init(&fw, 3);
    send_set_joints(&fw, 1, a, 3);
    CHECK_EQ(fw.pulse_us[0], 2700u);
    CHECK_EQ(fw.pulse_us[1], 900u);
    CHECK_EQ(fw.pulse_us[2], 1800u);
    CHECK_EQ(fw_flags(&fw) & V2_FLAG_MOVING, 0u);
}

static void test_set_joints_keep_value_leaves_a_joint_heading_where_it_was(void)
{
    fw_t fw;
    static const uint16_t a[3] = {9000, 9000, 9000};
    static const uint16_t b[3] = {V2_ANGLE_KEEP, 0, V2_ANGLE_KEEP};
    static const uint16_t c[3] = {0, V2_ANGLE_KEEP, V2_ANGLE_KEEP};
    fw_init(&fw, 3);
    send_config(&fw, 0, V2_CONFIG_ALL_JOINTS, 900, 2700, 360);
    send_set_joints(&fw, 1, a, 3);
    send_set_joints(&fw, 2, b, 3);
    ticks(&fw, 20); /* 20 x 7.2 deg > 90 deg, and short of the watchdog */
    CHECK_EQ(fw.pulse_us[0], 1800u);
    CHECK_EQ(fw.pulse_us[1], 900u);
    CHECK_EQ(fw.pulse_us[2], 1800u);
    send_set_joints(&fw, 3, a, 3);
    send_set_joints(&fw, 4, c, 3); /* joint 2 keeps heading back to 90 */
    ticks(&fw, 20);
    CHECK_EQ(fw.pulse_us[0], 900u);
    CHECK_EQ(fw.pulse_us[1], 1800u);
    CHECK_EQ(fw.pulse_us[2], 1800u);
}

static void test_set_joints_beyond_the_board_joint_count_are_ignored(void)
{
    fw_t fw;
    static const uint16_t a[8] = {0, 1000, 2000, 3000, 4000, 5000, 6000, 7000};
    fw_init(&fw, 2);
    send_set_joints(&fw, 1, a, 8);
    CHECK_EQ(fw.link.good_frames, 1u);
    CHECK_EQ(fw.pulse_us[0], 900u);
    CHECK_EQ(fw.pulse_us[1], 1000u);
    CHECK_EQ(fw.pulse_us[2], 0u);
}

static void test_fw_init_clamps_the_joint_count_to_1_to_8(void)
{
    fw_t fw;
    fw_init(&fw, 0);
    CHECK_EQ(fw.n_joints, 1u);
    fw_init(&fw, 9);
    CHECK_EQ(fw.n_joints, 8u);
    fw_init(&fw, 8);
    CHECK_EQ(fw.n_joints, 8u);
}

static void test_config_for_all_joints_applies_to_every_joint(void)
{
    fw_t fw;
    static const uint16_t a[8] = {9000, 9000, 9000, 9000, 9000, 9000, 9000, 9000};
    uint8_t j;
    fw_init(&fw, 8);
    send_config(&fw, 1, V2_CONFIG_ALL_JOINTS, 1000, 2000, 0);
    send_set_joints(&fw, 2, a, 8);
    for (j = 0; j < 8u; j++) {
        CHECK_EQ(fw.pulse_us[j], 1500u);
        CHECK_EQ(fw.joint[j].cfg.max_speed_dps, 0u);
    }
}

static void test_config_speed_limit_paces_each_joint_separately(void)
{
    fw_t fw;
    static const uint16_t zero[2] = {0, 0};
    static const uint16_t far[2] = {18000, 18000};
    fw_init(&fw, 2);
    send_config(&fw, 1, 0, 900, 2700, 50);  /* 100 cdeg = 10 us per tick */
    send_config(&fw, 2, 1, 900, 2700, 500); /* 1000 cdeg = 100 us per tick */
    send_set_joints(&fw, 3, zero, 2);
    send_set_joints(&fw, 4, far, 2);
    fw_tick(&fw);
    CHECK_EQ(fw.pulse_us[0], 910u);
    CHECK_EQ(fw.pulse_us[1], 1000u);
}

static void test_watchdog_trips_on_the_25th_silent_tick_and_not_before(void)
{
    fw_t fw;
    static const uint16_t a[1] = {0};
    fw_init(&fw, 1);
    send_set_joints(&fw, 1, a, 1);
    ticks(&fw, FW_WATCHDOG_TICKS - 1u);
    CHECK_EQ(fw_flags(&fw) & V2_FLAG_WATCHDOG, 0u);
    fw_tick(&fw);
    CHECK_EQ(fw_flags(&fw) & V2_FLAG_WATCHDOG, V2_FLAG_WATCHDOG);
}

static void test_watchdog_is_fed_by_any_valid_frame_including_ping(void)
{
    fw_t fw;
    static const uint16_t a[1] = {0};
    uint8_t tx[FW_TX_SIZE];
    unsigned k;
    fw_init(&fw, 1);
    send_set_joints(&fw, 1, a, 1);
    for (k = 0; k < 20u; k++) {
        ticks(&fw, FW_WATCHDOG_TICKS - 1u);
        send_frame(&fw, V2_TYPE_PING, (uint8_t)k, NULL, 0);
        (void)fw_take_tx(&fw, tx, sizeof tx);
    }
    CHECK_EQ(fw_flags(&fw) & V2_FLAG_WATCHDOG, 0u);
}

static void test_watchdog_is_not_fed_by_corrupted_frames(void)
{
    fw_t fw;
    static const uint16_t a[1] = {0};
    uint8_t wire[V2_MAX_WIRE];
    uint16_t n;
    unsigned k;
    fw_init(&fw, 1);
    send_set_joints(&fw, 1, a, 1);
    n = encode(V2_TYPE_PING, 2, NULL, 0, wire);
    wire[n - 2u] ^= 0x01u; /* CRC */
    for (k = 0; k < FW_WATCHDOG_TICKS; k++) {
        feed(&fw, wire, n);
        fw_tick(&fw);
    }
    CHECK_EQ(fw_flags(&fw) & V2_FLAG_WATCHDOG, V2_FLAG_WATCHDOG);
    CHECK_EQ(fw.link.bad_frames, FW_WATCHDOG_TICKS);
}

static void test_watchdog_holds_mid_ramp_and_stays_latched_until_the_next_set_joints(void)
{
    fw_t fw;
    static const uint16_t from[1] = {0};
    static const uint16_t to[1] = {18000};
    uint16_t held;
    fw_init(&fw, 1);
    send_set_joints(&fw, 1, from, 1);
    send_set_joints(&fw, 2, to, 1);
    ticks(&fw, 100);
    held = fw.pulse_us[0];
    CHECK(held > 900u && held < 2700u);
    CHECK_EQ(fw.joint[0].target_cdeg, fw.joint[0].pos_cdeg);
    send_frame(&fw, V2_TYPE_PING, 3, NULL, 0);
    send_config(&fw, 4, 0, 900, 2700, 180);
    ticks(&fw, 10);
    CHECK_EQ(fw.pulse_us[0], held);
    CHECK_EQ(fw_flags(&fw) & V2_FLAG_WATCHDOG, V2_FLAG_WATCHDOG);
    send_set_joints(&fw, 5, to, 1);
    CHECK_EQ(fw_flags(&fw) & V2_FLAG_WATCHDOG, 0u);
    fw_tick(&fw);
    CHECK(fw.pulse_us[0] > held);
}

static void test_estop_turns_every_pulse_off_at_once(void)
{
    fw_t fw;
    static const uint16_t a[8] = {1, 2, 3, 4, 5, 6, 7, 8};
    uint8_t j;
    fw_init(&fw, 8);
    send_set_joints(&fw, 1, a, 8);
    send_frame(&fw, V2_TYPE_ESTOP, 2, NULL, 0);
    for (j = 0; j < 8u; j++) {
        CHECK_EQ(fw.pulse_us[j], 0u);
    }
    CHECK_EQ(fw_flags(&fw) & V2_FLAG_ESTOP, V2_FLAG_ESTOP);
}

static void test_estop_ignores_set_joints_and_config_keeps_pulses_off_until_arm(void)
{
    fw_t fw;
    static const uint16_t a[1] = {9000};
    static const uint16_t b[1] = {0};
    fw_init(&fw, 1);
    send_set_joints(&fw, 1, a, 1);
    send_frame(&fw, V2_TYPE_ESTOP, 2, NULL, 0);
    send_set_joints(&fw, 3, b, 1);
    send_config(&fw, 4, 0, 1000, 2000, 0);
    ticks(&fw, 100); /* the watchdog trips meanwhile: pulses stay off */
    CHECK_EQ(fw.pulse_us[0], 0u);
    CHECK_EQ(fw.joint[0].target_cdeg, 9000u);
    send_frame(&fw, V2_TYPE_ARM, 5, NULL, 0);
    CHECK_EQ(fw.pulse_us[0], 1500u); /* held angle, new pulse range */
    CHECK_EQ(fw_flags(&fw) & V2_FLAG_ESTOP, 0u);
}

static void test_a_second_estop_and_a_lone_arm_change_nothing_else(void)
{
    fw_t fw;
    fw_init(&fw, 1);
    send_frame(&fw, V2_TYPE_ARM, 1, NULL, 0); /* arming an armed board */
    CHECK_EQ(fw.pulse_us[0], 0u);
    CHECK_EQ(fw_flags(&fw), V2_FLAG_V2_MODE);
    send_frame(&fw, V2_TYPE_ESTOP, 2, NULL, 0);
    send_frame(&fw, V2_TYPE_ESTOP, 3, NULL, 0);
    CHECK_EQ(fw_flags(&fw), V2_FLAG_V2_MODE | V2_FLAG_ESTOP);
}

/* ---- status ---------------------------------------------------------------------- */

static void test_ping_is_answered_with_a_status_frame_echoing_its_seq(void)
{
    fw_t fw;
    uint8_t tx[FW_TX_SIZE];
    uint8_t n;
    link_t host; /* decode the reply with the board's own receiver, bypassing type checks */
    fw_init(&fw, 3);
    send_frame(&fw, V2_TYPE_PING, 0xFB, NULL, 0);
    n = fw_take_tx(&fw, tx, sizeof tx);
    CHECK(n > 0u);
    CHECK_EQ(tx[0], V2_SYNC);
    CHECK_EQ(tx[1], V2_SYNC);
    CHECK_EQ(tx[n - 1u], V2_END);
    link_init(&host);
    feed_link_expecting_no_v1(&host, tx, n, "status");
    CHECK_HELPER();
    CHECK_EQ(host.bad_frames, 1u); /* STATUS is not for a board: well formed, rejected */
    CHECK_EQ(host.body[1], V2_TYPE_STATUS);
    CHECK_EQ(host.body[2], 0xFBu);
    CHECK_EQ(host.body[0], V2_STATUS_HEADER_LEN + 6u);
    CHECK_EQ(fw_take_tx(&fw, tx, sizeof tx), 0u);
}

static void test_status_counts_good_and_bad_frames_and_dropped_bytes(void)
{
    fw_t fw;
    uint8_t payload[V2_STATUS_HEADER_LEN + 2u * FW_MAX_JOINTS];
    uint8_t wire[V2_MAX_WIRE];
    static const uint8_t junk[] = {0x01, 0x02, 0x03};
    uint16_t n;
    fw_init(&fw, 3);
    feed(&fw, junk, sizeof junk);
    n = encode(V2_TYPE_PING, 1, NULL, 0, wire);
    wire[n - 2u] ^= 0x80u;
    feed(&fw, wire, n);
    send_frame(&fw, V2_TYPE_PING, 2, NULL, 0);
    CHECK_EQ(fw_status_payload(&fw, payload), V2_STATUS_HEADER_LEN + 6u);
    CHECK_EQ(payload[0], V2_FLAG_V2_MODE);
    CHECK_EQ(payload[1], 3u);
    CHECK_EQ(v2_get_u16(&payload[2]), 1u);
    CHECK_EQ(v2_get_u16(&payload[4]), 1u);
    CHECK_EQ(v2_get_u16(&payload[6]), 3u);
}

static void test_status_reports_one_pulse_per_configured_joint(void)
{
    fw_t fw;
    uint8_t payload[V2_STATUS_HEADER_LEN + 2u * FW_MAX_JOINTS];
    static const uint16_t a[8] = {0, 1000, 2000, 3000, 4000, 5000, 6000, 18000};
    uint8_t j;
    fw_init(&fw, 8);
    send_set_joints(&fw, 1, a, 8);
    CHECK_EQ(fw_status_payload(&fw, payload), V2_STATUS_HEADER_LEN + 16u);
    for (j = 0; j < 8u; j++) {
        CHECK_EQ(v2_get_u16(&payload[V2_STATUS_HEADER_LEN + 2u * j]), 900u + a[j] / 10u);
    }
}

static void test_counters_wrap_modulo_65536(void)
{
    fw_t fw;
    fw_init(&fw, 1);
    fw.link.dropped_bytes = 0xFFFFu;
    fw_feed(&fw, 0x01);
    CHECK_EQ(fw.link.dropped_bytes, 0u);
}

static void test_tx_queue_skips_a_reply_that_does_not_fit_instead_of_truncating_it(void)
{
    fw_t fw;
    unsigned k;
    uint8_t first;
    fw_init(&fw, 8);
    send_frame(&fw, V2_TYPE_PING, 0, NULL, 0);
    first = fw.tx_len;
    CHECK(first > 0u);
    for (k = 0; k < 10u; k++) {
        send_frame(&fw, V2_TYPE_PING, (uint8_t)(k + 1u), NULL, 0);
    }
    CHECK(fw.tx_len <= FW_TX_SIZE);
    CHECK_EQ(fw.tx_len % first, 0u); /* whole frames only */
}


/* ---- range sensor ------------------------------------------------------------------ */

static void test_range_echo_widths_from_vectors_json_convert_to_their_distances(void)
{
    unsigned i;
    CHECK(VEC_RANGE_ECHO_COUNT >= 5u);
    for (i = 0; i < VEC_RANGE_ECHO_COUNT; i++) {
        const vec_range_echo_t *v = &VEC_RANGE_ECHO[i];
        CHECK_EQ_CTX(v->name, range_echo_to_mm(v->echo_us), v->distance_mm);
    }
}

static void test_range_every_echo_width_gives_no_reading_or_a_distance_within_20_to_4000_mm(void)
{
    uint32_t e;
    uint16_t last = 0;
    for (e = 0; e <= 0xFFFFu; e++) {
        uint16_t mm = range_echo_to_mm((uint16_t)e);
        if (mm == RANGE_NO_ECHO) {
            continue;
        }
        CHECK(mm >= RANGE_MIN_MM && mm <= RANGE_MAX_MM);
        CHECK(mm >= last); /* longer echoes are never nearer */
        /* 343 m/s there and back: 0.1715 mm per us, rounded to the nearest mm */
        CHECK(2000u * (uint32_t)mm + 1000u >= e * 343u);
        CHECK(2000u * (uint32_t)mm <= e * 343u + 1000u);
        CHECK(e <= RANGE_ECHO_TIMEOUT_US);
        last = mm;
    }
}

static void test_range_frame_vectors_encode_to_their_wire_bytes_and_a_board_refuses_them(void)
{
    unsigned i;
    CHECK(VEC_RANGE_FRAMES_COUNT >= 2u);
    for (i = 0; i < VEC_RANGE_FRAMES_COUNT; i++) {
        const vec_range_frame_t *v = &VEC_RANGE_FRAMES[i];
        uint8_t payload[V2_RANGE_LEN];
        uint8_t wire[V2_MAX_WIRE];
        uint16_t n;
        fw_t fw;
        CHECK_EQ_CTX(v->name, fw_range_payload(v->distance_mm, v->tick, payload), v->payload_len);
        CHECK_EQ_CTX(v->name, memcmp(payload, v->payload, v->payload_len), 0);
        {
            uint8_t body[3u + V2_RANGE_LEN];
            body[0] = V2_RANGE_LEN;
            body[1] = V2_TYPE_RANGE;
            body[2] = v->seq;
            memcpy(&body[3], payload, V2_RANGE_LEN);
            CHECK_EQ_CTX(v->name, crc16_ccitt(body, sizeof body), v->crc);
        }
        n = v2_encode_frame(V2_TYPE_RANGE, v->seq, payload, V2_RANGE_LEN, wire, sizeof wire);
        CHECK_EQ_CTX(v->name, n, v->wire_len);
        CHECK_EQ_CTX(v->name, memcmp(wire, v->wire, n), 0);
        CHECK_EQ_CTX(v->name, v2_board_accepts(V2_TYPE_RANGE, payload, V2_RANGE_LEN), 0u);
        fw_init(&fw, 3);
        feed(&fw, wire, n); /* board to host only: a board that hears one counts it as bad */
        CHECK_EQ_CTX(v->name, fw.link.bad_frames, 1u);
        CHECK_EQ_CTX(v->name, fw.link.good_frames, 0u);
    }
}

static void test_range_is_due_every_5_ticks_only_while_enabled(void)
{
    fw_t fw;
    unsigned k;
    unsigned due = 0;
    fw_init(&fw, 3);
    ticks(&fw, 20);
    CHECK_EQ(fw_range_due(&fw), 0u); /* no sensor configured: never */
    fw_range_enable(&fw, 1);
    fw_tick(&fw);
    CHECK_EQ(fw_range_due(&fw), 1u); /* the first measurement on the next tick */
    CHECK_EQ(fw_range_due(&fw), 0u); /* taken */
    for (k = 0; k < 50u; k++) {
        fw_tick(&fw);
        due += fw_range_due(&fw);
        if (k % FW_RANGE_PERIOD_TICKS != FW_RANGE_PERIOD_TICKS - 1u) {
            CHECK_EQ(fw.range_due, 0u);
        }
    }
    CHECK_EQ(due, 50u / FW_RANGE_PERIOD_TICKS); /* 10 Hz at 50 Hz ticks */
    fw_range_enable(&fw, 0);
    ticks(&fw, 20);
    CHECK_EQ(fw_range_due(&fw), 0u);
}

/* one full measurement as main_msp430.c runs it: due -> result of the last -> trigger */
static void range_cycle(fw_t *fw, uint16_t echo_us)
{
    unsigned k;
    for (k = 0; k < 2u * FW_RANGE_PERIOD_TICKS; k++) {
        fw_tick(fw);
        if (fw_range_due(fw)) {
            if (fw->range_measuring) {
                fw_range_result(fw, echo_us);
            }
            fw_range_started(fw);
            return;
        }
    }
}

static void test_range_results_in_v2_mode_are_sent_as_range_frames_with_the_trigger_tick(void)
{
    fw_t fw;
    uint8_t tx[FW_TX_SIZE];
    uint8_t n;
    uint16_t trigger_tick;
    link_t host;
    fw_init(&fw, 3);
    send_frame(&fw, V2_TYPE_PING, 1, NULL, 0); /* into v2 mode */
    (void)fw_take_tx(&fw, tx, sizeof tx);
    fw_range_enable(&fw, 1);
    range_cycle(&fw, 0); /* the first trigger: nothing to report yet */
    CHECK_EQ(fw.tx_len, 0u);
    trigger_tick = fw.range_trigger_tick;
    range_cycle(&fw, 2041); /* its echo: 350 mm */
    CHECK_EQ(fw.range_mm, 350u);
    n = fw_take_tx(&fw, tx, sizeof tx);
    CHECK(n > 0u);
    link_init(&host);
    feed_link_expecting_no_v1(&host, tx, n, "range");
    CHECK_HELPER();
    CHECK_EQ(host.bad_frames, 1u); /* well formed, but not for a board */
    CHECK_EQ(host.body[0], V2_RANGE_LEN);
    CHECK_EQ(host.body[1], V2_TYPE_RANGE);
    CHECK_EQ(host.body[2], 0u); /* the board's own RANGE count */
    CHECK_EQ(v2_get_u16(&host.body[3]), 350u);
    CHECK_EQ(v2_get_u16(&host.body[5]), trigger_tick);
    CHECK_EQ(fw.range_trigger_tick, (uint16_t)(trigger_tick + FW_RANGE_PERIOD_TICKS));
    range_cycle(&fw, 0); /* no echo */
    CHECK_EQ(fw.range_mm, RANGE_NO_ECHO);
    n = fw_take_tx(&fw, tx, sizeof tx);
    link_init(&host);
    feed_link_expecting_no_v1(&host, tx, n, "no echo");
    CHECK_HELPER();
    CHECK_EQ(host.body[2], 1u); /* seq counts up */
    CHECK_EQ(v2_get_u16(&host.body[3]), RANGE_NO_ECHO);
}

static void test_range_results_in_v1_mode_are_kept_but_never_sent(void)
{
    fw_t fw;
    static const uint8_t v1_home[] = {0xFB, 0x00, 0xFC, 0x5A, 0xFD, 0x5A};
    fw_init(&fw, 3);
    feed(&fw, v1_home, sizeof v1_home);
    fw_range_enable(&fw, 1);
    range_cycle(&fw, 0);
    range_cycle(&fw, 2041);
    range_cycle(&fw, 5831);
    CHECK_EQ(fw.range_mm, 1000u);
    CHECK_EQ(fw.tx_len, 0u); /* a v1 host expects no bytes from the board */
    CHECK_EQ(fw.pulse_us[0], 900u);
}

static void test_range_result_without_a_running_measurement_is_ignored(void)
{
    fw_t fw;
    fw_init(&fw, 3);
    send_frame(&fw, V2_TYPE_PING, 1, NULL, 0);
    fw.tx_len = 0;
    fw_range_enable(&fw, 1);
    fw_range_result(&fw, 2041);
    CHECK_EQ(fw.tx_len, 0u);
    CHECK_EQ(fw.range_mm, RANGE_NO_ECHO);
    CHECK_EQ(fw.range_seq, 0u);
}

static void test_range_frame_that_does_not_fit_is_skipped_whole_and_its_seq_still_counts(void)
{
    fw_t fw;
    unsigned k;
    uint8_t before;
    fw_init(&fw, 8);
    for (k = 0; k < 10u; k++) {
        send_frame(&fw, V2_TYPE_PING, (uint8_t)k, NULL, 0); /* fill the queue with STATUS */
    }
    before = fw.tx_len;
    fw_range_enable(&fw, 1);
    range_cycle(&fw, 0);
    range_cycle(&fw, 2041);
    CHECK(fw.tx_len <= FW_TX_SIZE);
    if (before + 12u > FW_TX_SIZE) {
        CHECK_EQ(fw.tx_len, before); /* nothing torn onto the end */
    }
    CHECK_EQ(fw.range_seq, 1u); /* the host sees the gap in the SEQ */
}

static void test_range_reporting_changes_no_pulse_and_feeds_no_watchdog(void)
{
    fw_t fw;
    static const uint16_t a[3] = {9000, 9000, 9000};
    unsigned k;
    fw_init(&fw, 3);
    send_set_joints(&fw, 1, a, 3);
    fw_range_enable(&fw, 1);
    for (k = 0; k < 6u; k++) {
        range_cycle(&fw, 2041);
    }
    CHECK_EQ(fw.pulse_us[0], 1800u);
    CHECK_EQ(fw_flags(&fw) & V2_FLAG_WATCHDOG, V2_FLAG_WATCHDOG); /* 30 silent ticks */
}

/* ---- fuzz ------------------------------------------------------------------------ */

static void test_one_million_random_bytes_never_crash_or_leave_the_pulse_range(void)
{
    fw_t fw;
    uint32_t i;
    uint8_t tx[FW_TX_SIZE];
    rng_seed(0xDE5CA12u);
    fw_init(&fw, 3);
    for (i = 0; i < 1000000u; i++) {
        /* a quarter of the bytes from the protocol's own alphabet, so the receiver's
         * states are all visited, not just "hunting" */
        static const uint8_t special[] = {V2_SYNC, V2_ESC, V2_END, 0xFB, 0xFC, 0xFD, 0xD5, 0x00};
        uint32_t r = rng();
        uint8_t b = (r & 3u) == 0u ? special[(r >> 2) & 7u] : (uint8_t)(r >> 8);
        fw_feed(&fw, b);
        if ((r >> 24) < 12u) {
            fw_tick(&fw);
        }
        check_pulses_in_range(&fw, "random bytes");
        CHECK_HELPER();
        (void)fw_take_tx(&fw, tx, sizeof tx);
    }
    CHECK(fw.link.dropped_bytes != 0u);
}

static void test_random_valid_and_corrupted_frames_keep_pulses_in_range_and_speed_limited(void)
{
    fw_t fw;
    unsigned round;
    uint8_t tx[FW_TX_SIZE];
    unsigned accepted = 0;
    rng_seed(99u);
    fw_init(&fw, 4);
    for (round = 0; round < 50000u; round++) {
        uint8_t payload[V2_MAX_PAYLOAD];
        uint8_t wire[V2_MAX_WIRE];
        uint8_t type;
        uint8_t len = 0;
        uint16_t n;
        uint8_t j;
        uint16_t before[FW_MAX_JOINTS];
        uint8_t known_before[FW_MAX_JOINTS];
        uint16_t good_before = fw.link.good_frames;
        switch (rng_below(8)) {
        case 0:
        case 1:
        case 2:
            type = V2_TYPE_SET_JOINTS;
            len = (uint8_t)(2u * (1u + rng_below(8)));
            for (j = 0; j < len; j += 2u) {
                uint16_t a = (uint16_t)rng_below(20000);
                if (rng_below(10) == 0u) {
                    a = V2_ANGLE_KEEP;
                }
                v2_put_u16(&payload[j], a);
            }
            break;
        case 3:
            type = V2_TYPE_CONFIG;
            len = V2_CONFIG_LEN;
            payload[0] = rng_below(6) == 0u ? V2_CONFIG_ALL_JOINTS : (uint8_t)rng_below(6);
            v2_put_u16(&payload[1], (uint16_t)(300u + rng_below(1500)));
            v2_put_u16(&payload[3], (uint16_t)(1500u + rng_below(1600)));
            v2_put_u16(&payload[5], (uint16_t)rng_below(1100));
            break;
        case 4:
            type = rng_below(4) == 0u ? V2_TYPE_ESTOP : V2_TYPE_ARM;
            break;
        default:
            type = V2_TYPE_PING;
            break;
        }
        n = encode(type, (uint8_t)round, payload, len, wire);
        if (rng_below(5) == 0u) {
            wire[rng_below(n)] ^= (uint8_t)(1u + rng_below(255));
        }
        feed(&fw, wire, n);
        accepted += (unsigned)(fw.link.good_frames != good_before);
        check_pulses_in_range(&fw, "after a frame");
        CHECK_HELPER();
        for (j = 0; j < fw.n_joints; j++) {
            before[j] = fw.joint[j].pos_cdeg;
            known_before[j] = fw.joint[j].known;
        }
        fw_tick(&fw);
        check_pulses_in_range(&fw, "after a tick");
        CHECK_HELPER();
        for (j = 0; j < fw.n_joints; j++) {
            uint16_t speed = fw.joint[j].cfg.max_speed_dps;
            uint16_t now = fw.joint[j].pos_cdeg;
            uint16_t moved = (uint16_t)(now > before[j] ? now - before[j] : before[j] - now);
            if (known_before[j] && speed != 0u) {
                CHECK(moved <= 2u * speed);
            }
            CHECK(now <= V2_ANGLE_MAX_CDEG);
        }
        (void)fw_take_tx(&fw, tx, sizeof tx);
    }
    CHECK(accepted > 30000u);
}

/* ---- runner ---------------------------------------------------------------------- */

#define T(fn) {#fn, fn}
static const unit_test_t FW_TESTS[] = {
    T(test_crc16_matches_every_vector_in_vectors_json),
    T(test_crc16_of_123456789_is_the_ccitt_false_check_value_0x29b1),
    T(test_crc16_bytewise_update_equals_the_whole_buffer_crc),
    T(test_mapping_defaults_to_the_seed_firmware_900_plus_10_us_per_degree),
    T(test_mapping_rounds_centidegrees_to_the_nearest_microsecond),
    T(test_mapping_uses_the_per_joint_min_and_max_pulse),
    T(test_mapping_clamps_angles_above_180_degrees),
    T(test_mapping_never_leaves_the_configured_range_for_any_angle_and_config),
    T(test_config_validation_accepts_the_documented_ranges_only),
    T(test_limiter_moves_at_most_max_speed_over_50_per_tick),
    T(test_limiter_reaches_the_target_exactly_without_overshoot),
    T(test_limiter_with_zero_speed_jumps_to_the_target),
    T(test_limiter_moves_down_as_well_as_up_and_stops_at_zero),
    T(test_v1_streams_from_vectors_json_give_the_expected_pulses),
    T(test_parser_ignores_angle_bytes_before_any_selector),
    T(test_parser_keeps_the_selection_sticky_across_angle_bytes),
    T(test_parser_ignores_every_byte_that_is_neither_selector_nor_angle_nor_sync),
    T(test_v1_every_angle_byte_on_every_joint_gives_900_plus_10_us_per_degree),
    T(test_v1_moves_are_applied_at_once_and_not_rate_limited),
    T(test_v1_mode_has_no_watchdog),
    T(test_v2_frames_from_vectors_json_encode_to_their_wire_bytes),
    T(test_v2_frames_from_vectors_json_decode_to_their_fields),
    T(test_status_payload_layout_matches_the_to_host_vectors),
    T(test_v2_rejected_vectors_are_not_accepted_and_are_counted),
    T(test_v2_receiver_resyncs_when_a_new_sync_cuts_a_frame_short),
    T(test_v2_extra_sync_bytes_before_a_frame_are_tolerated),
    T(test_v2_payload_lengths_are_checked_per_type),
    T(test_v2_encoder_refuses_payloads_longer_than_32_bytes_or_a_short_buffer),
    T(test_every_single_byte_corruption_of_every_frame_vector_is_rejected),
    T(test_every_dropped_byte_of_every_frame_vector_is_rejected),
    T(test_every_inserted_byte_in_every_frame_vector_is_rejected_or_harmless),
    T(test_corrupted_v2_frames_fed_to_a_fresh_board_never_change_a_pulse),
    T(test_the_first_valid_v2_frame_locks_out_v1_until_reset),
    T(test_a_sync_byte_in_v1_mode_clears_the_selection),
    T(test_v2_scenarios_from_vectors_json_hold_step_by_step),
    T(test_the_first_set_joints_jumps_because_an_unpowered_servo_position_is_unknown),
    T(test_set_joints_keep_value_leaves_a_joint_heading_where_it_was),
    T(test_set_joints_beyond_the_board_joint_count_are_ignored),
    T(test_fw_init_clamps_the_joint_count_to_1_to_8),
    T(test_config_for_all_joints_applies_to_every_joint),
    T(test_config_speed_limit_paces_each_joint_separately),
    T(test_watchdog_trips_on_the_25th_silent_tick_and_not_before),
    T(test_watchdog_is_fed_by_any_valid_frame_including_ping),
    T(test_watchdog_is_not_fed_by_corrupted_frames),
    T(test_watchdog_holds_mid_ramp_and_stays_latched_until_the_next_set_joints),
    T(test_estop_turns_every_pulse_off_at_once),
    T(test_estop_ignores_set_joints_and_config_keeps_pulses_off_until_arm),
    T(test_a_second_estop_and_a_lone_arm_change_nothing_else),
    T(test_ping_is_answered_with_a_status_frame_echoing_its_seq),
    T(test_status_counts_good_and_bad_frames_and_dropped_bytes),
    T(test_status_reports_one_pulse_per_configured_joint),
    T(test_counters_wrap_modulo_65536),
    T(test_tx_queue_skips_a_reply_that_does_not_fit_instead_of_truncating_it),
    T(test_range_echo_widths_from_vectors_json_convert_to_their_distances),
    T(test_range_every_echo_width_gives_no_reading_or_a_distance_within_20_to_4000_mm),
    T(test_range_frame_vectors_encode_to_their_wire_bytes_and_a_board_refuses_them),
    T(test_range_is_due_every_5_ticks_only_while_enabled),
    T(test_range_results_in_v2_mode_are_sent_as_range_frames_with_the_trigger_tick),
    T(test_range_results_in_v1_mode_are_kept_but_never_sent),
    T(test_range_result_without_a_running_measurement_is_ignored),
    T(test_range_frame_that_does_not_fit_is_skipped_whole_and_its_seq_still_counts),
    T(test_range_reporting_changes_no_pulse_and_feeds_no_watchdog),
    T(test_one_million_random_bytes_never_crash_or_leave_the_pulse_range),
    T(test_random_valid_and_corrupted_frames_keep_pulses_in_range_and_speed_limited),
};

static void run(const unit_test_t *tests, unsigned count, unsigned *passed, unsigned *failed)
{
    unsigned i;
    for (i = 0; i < count; i++) {
        unit_failed = 0;
        tests[i].fn();
        if (unit_failed) {
            printf("FAIL %s\n", tests[i].name);
            (*failed)++;
        } else {
            printf("ok   %s\n", tests[i].name);
            (*passed)++;
        }
    }
}

int main(void)
{
    unsigned passed = 0;
    unsigned failed = 0;
    run(FW_TESTS, (unsigned)(sizeof FW_TESTS / sizeof FW_TESTS[0]), &passed, &failed);
    run(HAL_TESTS, HAL_TEST_COUNT, &passed, &failed);
    printf("%u passed, %u failed\n", passed, failed);
    return failed == 0u ? 0 : 1;
}
