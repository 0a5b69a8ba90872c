/* The firmware's pure core: everything except registers.
 *
 * The hardware layer (hal_msp430.c, or host/host_firmware.c on a pseudo-terminal) calls
 *   fw_feed()  for every received byte,
 *   fw_tick()  every 20 ms (the 50 Hz servo period),
 * then writes fw->pulse_us[] to the PWM outputs and sends what fw_take_tx() returns. */
#ifndef DESKARM_FW_H
#define DESKARM_FW_H

#include <stdint.h>

#include "link.h"
#include "servo.h"
#include "v2.h"

#define FW_MAX_JOINTS V2_MAX_JOINTS
#define FW_DEFAULT_JOINTS 3u
#define FW_WATCHDOG_TICKS 25u /* 500 ms at 50 Hz */
#define FW_TX_SIZE 96u        /* room for one worst-case STATUS frame (8 + 16 bytes, escaped) */

typedef struct {
    servo_config_t cfg;
    uint16_t pos_cdeg;    /* where the servo is being driven now */
    uint16_t target_cdeg; /* where the rate limiter is heading */
    uint8_t known;        /* 0 until the first command: no pulse, and the first command jumps */
} fw_joint_t;

typedef struct {
    link_t link;
    fw_joint_t joint[FW_MAX_JOINTS];
    uint16_t pulse_us[FW_MAX_JOINTS]; /* what the PWM outputs must produce; 0 = off */
    uint8_t n_joints;
    uint8_t estop;            /* pulses off until ARM */
    uint8_t watchdog;         /* latched until the next SET_JOINTS */
    uint8_t config_rejected;  /* last CONFIG out of range */
    uint8_t clamped;          /* last SET_JOINTS clamped an angle */
    uint8_t ticks_since_frame; /* saturates at 255 */
    uint8_t tx_len;
    uint8_t tx[FW_TX_SIZE];
} fw_t;

/* n_joints is clamped to 1..FW_MAX_JOINTS. Starts in v1 mode, armed, every pulse off. */
void fw_init(fw_t *fw, uint8_t n_joints);

/* One received byte. May change pulse_us[] (v1 angle, first v2 target, e-stop, config). */
void fw_feed(fw_t *fw, uint8_t byte);

/* One 50 Hz tick: watchdog, then the rate limiter. */
void fw_tick(fw_t *fw);

/* STATUS flags (V2_FLAG_*) as they would be reported now. */
uint8_t fw_flags(const fw_t *fw);

/* Write the STATUS payload (V2_STATUS_HEADER_LEN + 2 * n_joints bytes); returns its length. */
uint8_t fw_status_payload(const fw_t *fw, uint8_t *out);

/* Move up to max queued reply bytes into dst; returns how many. */
uint8_t fw_take_tx(fw_t *fw, uint8_t *dst, uint8_t max);

#endif
