#include "fw.h"

#include <string.h>

void fw_init(fw_t *fw, uint8_t n_joints)
{
    uint8_t j;
    memset(fw, 0, sizeof *fw);
    if (n_joints < 1u) {
        n_joints = 1u;
    }
    if (n_joints > FW_MAX_JOINTS) {
        n_joints = FW_MAX_JOINTS;
    }
    fw->n_joints = n_joints;
    link_init(&fw->link);
    for (j = 0; j < FW_MAX_JOINTS; j++) {
        servo_config_default(&fw->joint[j].cfg);
    }
    fw->range_mm = RANGE_NO_ECHO;
}

static void update_outputs(fw_t *fw)
{
    uint8_t j;
    for (j = 0; j < fw->n_joints; j++) {
        const fw_joint_t *jt = &fw->joint[j];
        fw->pulse_us[j] = (fw->estop || !jt->known) ? 0u : servo_pulse_us(&jt->cfg, jt->pos_cdeg);
    }
}

static void hold_all(fw_t *fw)
{
    uint8_t j;
    for (j = 0; j < fw->n_joints; j++) {
        fw->joint[j].target_cdeg = fw->joint[j].pos_cdeg;
    }
}

static void set_joints(fw_t *fw, const uint8_t *payload, uint8_t len)
{
    uint8_t n = (uint8_t)(len / 2u);
    uint8_t j;
    if (fw->estop) {
        return; /* only ARM ends an e-stop; a late SET_JOINTS must not */
    }
    fw->clamped = 0;
    for (j = 0; j < n && j < fw->n_joints; j++) {
        fw_joint_t *jt = &fw->joint[j];
        uint16_t cdeg = v2_get_u16(&payload[2u * j]);
        if (cdeg == V2_ANGLE_KEEP) {
            continue;
        }
        if (cdeg > V2_ANGLE_MAX_CDEG) {
            cdeg = V2_ANGLE_MAX_CDEG;
            fw->clamped = 1;
        }
        jt->target_cdeg = cdeg;
        if (!jt->known) {
            /* no idea where an unpowered servo is, so there is nothing to ramp from */
            jt->pos_cdeg = cdeg;
            jt->known = 1;
        }
    }
    fw->watchdog = 0;
}

static void config(fw_t *fw, const uint8_t *p)
{
    uint8_t joint = p[0];
    uint16_t min_us = v2_get_u16(&p[1]);
    uint16_t max_us = v2_get_u16(&p[3]);
    uint16_t speed = v2_get_u16(&p[5]);
    uint8_t j;
    if ((joint != V2_CONFIG_ALL_JOINTS && joint >= fw->n_joints) ||
        !servo_config_valid(min_us, max_us, speed)) {
        fw->config_rejected = 1;
        return;
    }
    fw->config_rejected = 0;
    for (j = 0; j < fw->n_joints; j++) {
        if (joint == V2_CONFIG_ALL_JOINTS || joint == j) {
            fw->joint[j].cfg.min_pulse_us = min_us;
            fw->joint[j].cfg.max_pulse_us = max_us;
            fw->joint[j].cfg.max_speed_dps = speed;
        }
    }
}

/* Queue one whole frame for the host, or nothing when it does not fit: the host is asking
 * faster than 9600 baud drains replies, and a skipped frame is better than a torn one. */
static void queue_frame(fw_t *fw, uint8_t type, uint8_t seq, const uint8_t *payload, uint8_t len)
{
    uint8_t wire[V2_MAX_WIRE];
    uint16_t n = v2_encode_frame(type, seq, payload, len, wire, sizeof wire);
    if (n == 0u || (uint16_t)(fw->tx_len + n) > FW_TX_SIZE) {
        return;
    }
    memcpy(&fw->tx[fw->tx_len], wire, n);
    fw->tx_len = (uint8_t)(fw->tx_len + n);
}

static void queue_status(fw_t *fw, uint8_t seq)
{
    uint8_t payload[V2_STATUS_HEADER_LEN + 2u * FW_MAX_JOINTS];
    uint8_t len = fw_status_payload(fw, payload);
    queue_frame(fw, V2_TYPE_STATUS, seq, payload, len);
}

static void frame(fw_t *fw, const link_out_t *f)
{
    fw->ticks_since_frame = 0;
    switch (f->type) {
    case V2_TYPE_SET_JOINTS:
        set_joints(fw, f->payload, f->len);
        break;
    case V2_TYPE_CONFIG:
        config(fw, f->payload);
        break;
    case V2_TYPE_ESTOP:
        fw->estop = 1;
        hold_all(fw);
        break;
    case V2_TYPE_ARM:
        /* resume at the position held when the e-stop hit; move only on a new SET_JOINTS */
        fw->estop = 0;
        hold_all(fw);
        break;
    case V2_TYPE_PING:
        queue_status(fw, f->seq);
        break;
    default:
        break; /* link_feed only passes types the board accepts */
    }
}

void fw_feed(fw_t *fw, uint8_t byte)
{
    link_out_t out;
    link_event_t ev = link_feed(&fw->link, byte, &out);
    if (ev == LINK_V1_ANGLE) {
        if (out.v1_joint < fw->n_joints) {
            /* v1 is applied at once, like the seed firmware: the v1 host does its own pacing */
            fw_joint_t *jt = &fw->joint[out.v1_joint];
            jt->pos_cdeg = (uint16_t)((uint16_t)out.v1_angle_deg * 100u);
            jt->target_cdeg = jt->pos_cdeg;
            jt->known = 1;
        }
    } else if (ev == LINK_V2_FRAME) {
        frame(fw, &out);
    } else {
        return;
    }
    update_outputs(fw);
}

void fw_tick(fw_t *fw)
{
    uint8_t j;
    fw->tick_count++;
    if (fw->range_enabled) {
        if (fw->range_countdown <= 1u) {
            fw->range_countdown = FW_RANGE_PERIOD_TICKS;
            fw->range_due = 1;
        } else {
            fw->range_countdown--;
        }
    }
    if (fw->link.mode == LINK_MODE_V2) {
        if (fw->ticks_since_frame < 255u) {
            fw->ticks_since_frame++;
        }
        if (fw->ticks_since_frame >= FW_WATCHDOG_TICKS && !fw->watchdog) {
            fw->watchdog = 1;
            hold_all(fw);
        }
    }
    if (!fw->estop) {
        for (j = 0; j < fw->n_joints; j++) {
            fw_joint_t *jt = &fw->joint[j];
            if (jt->known) {
                jt->pos_cdeg = servo_step_cdeg(jt->pos_cdeg, jt->target_cdeg, jt->cfg.max_speed_dps);
            }
        }
    }
    update_outputs(fw);
}

uint8_t fw_flags(const fw_t *fw)
{
    uint8_t flags = 0;
    uint8_t j;
    if (fw->link.mode == LINK_MODE_V2) {
        flags |= V2_FLAG_V2_MODE;
    }
    if (fw->estop) {
        flags |= V2_FLAG_ESTOP;
    }
    if (fw->watchdog) {
        flags |= V2_FLAG_WATCHDOG;
    }
    if (fw->config_rejected) {
        flags |= V2_FLAG_CONFIG_REJECTED;
    }
    if (fw->clamped) {
        flags |= V2_FLAG_CLAMPED;
    }
    for (j = 0; j < fw->n_joints; j++) {
        if (fw->joint[j].known && fw->joint[j].pos_cdeg != fw->joint[j].target_cdeg) {
            flags |= V2_FLAG_MOVING;
        }
    }
    return flags;
}

uint8_t fw_status_payload(const fw_t *fw, uint8_t *out)
{
    uint8_t j;
    out[0] = fw_flags(fw);
    out[1] = fw->n_joints;
    v2_put_u16(&out[2], fw->link.good_frames);
    v2_put_u16(&out[4], fw->link.bad_frames);
    v2_put_u16(&out[6], fw->link.dropped_bytes);
    for (j = 0; j < fw->n_joints; j++) {
        v2_put_u16(&out[V2_STATUS_HEADER_LEN + 2u * j], fw->pulse_us[j]);
    }
    return (uint8_t)(V2_STATUS_HEADER_LEN + 2u * fw->n_joints);
}

void fw_range_enable(fw_t *fw, uint8_t enabled)
{
    fw->range_enabled = (uint8_t)(enabled != 0u);
    fw->range_countdown = 1u; /* the first measurement starts on the next tick */
    fw->range_due = 0;
    fw->range_measuring = 0;
}

uint8_t fw_range_due(fw_t *fw)
{
    uint8_t due = (uint8_t)(fw->range_due && fw->range_enabled);
    fw->range_due = 0;
    return due;
}

void fw_range_started(fw_t *fw)
{
    fw->range_measuring = 1;
    fw->range_trigger_tick = fw->tick_count;
}

uint8_t fw_range_payload(uint16_t distance_mm, uint16_t trigger_tick, uint8_t *out)
{
    v2_put_u16(&out[0], distance_mm);
    v2_put_u16(&out[2], trigger_tick);
    return V2_RANGE_LEN;
}

void fw_range_result(fw_t *fw, uint16_t echo_us)
{
    uint8_t payload[V2_RANGE_LEN];
    if (!fw->range_measuring) {
        return;
    }
    fw->range_measuring = 0;
    fw->range_mm = range_echo_to_mm(echo_us);
    if (fw->link.mode != LINK_MODE_V2) {
        return; /* a v1 host never reads the line: keep it quiet */
    }
    (void)fw_range_payload(fw->range_mm, fw->range_trigger_tick, payload);
    queue_frame(fw, V2_TYPE_RANGE, fw->range_seq, payload, V2_RANGE_LEN);
    fw->range_seq++;
}

uint8_t fw_take_tx(fw_t *fw, uint8_t *dst, uint8_t max)
{
    uint8_t n = fw->tx_len < max ? fw->tx_len : max;
    memcpy(dst, fw->tx, n);
    memmove(fw->tx, &fw->tx[n], (uint8_t)(fw->tx_len - n));
    fw->tx_len = (uint8_t)(fw->tx_len - n);
    return n;
}
