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
#include "range.h"
#include "servo.h"
#include "v2.h"

#define FW_MAX_JOINTS V2_MAX_JOINTS
#define FW_DEFAULT_JOINTS 3u
#define FW_WATCHDOG_TICKS 25u /* 500 ms at 50 Hz */
#define FW_TX_SIZE 96u        /* room for one worst-case STATUS frame (8 + 16 bytes, escaped) */
#define FW_RANGE_PERIOD_TICKS 5u /* one range measurement per 100 ms (10 Hz): the HC-SR04
                                  * wants >= 60 ms between triggers so old echoes die out */

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
    uint16_t tick_count;      /* 50 Hz ticks since init, wrapping */
    /* range sensor (HC-SR04), when one is configured: see fw_range_* below */
    uint8_t range_enabled;    /* a sensor is fitted: measure and report */
    uint8_t range_countdown;  /* ticks until the next measurement is due */
    uint8_t range_due;        /* set by fw_tick, cleared by fw_range_due() */
    uint8_t range_measuring;  /* a trigger went out and its result is not reported yet */
    uint16_t range_trigger_tick; /* tick_count when that trigger went out */
    uint16_t range_mm;        /* the last reading, RANGE_NO_ECHO until there is one */
    uint8_t range_seq;        /* SEQ of the next RANGE frame (the board's own count) */
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

/* Range sensor. The hardware layer, when a sensor is fitted, calls fw_range_enable(fw, 1) once,
 * then after the ticks of each main-loop pass:
 *     if (fw_range_due(fw)) {
 *         if (fw->range_measuring) fw_range_result(fw, <echo width in us, 0 = none>);
 *         <send a 10 us trigger pulse>; fw_range_started(fw);
 *     }
 * so every FW_RANGE_PERIOD_TICKS the previous measurement is read and the next one starts.
 * Each result is converted (range_echo_to_mm) and, in v2 mode only (a v1 host expects no
 * bytes from the board), queued as a RANGE frame. */
void fw_range_enable(fw_t *fw, uint8_t enabled);

/* 1 once per FW_RANGE_PERIOD_TICKS while enabled (clears the request). */
uint8_t fw_range_due(fw_t *fw);

/* A trigger pulse went out now. */
void fw_range_started(fw_t *fw);

/* The echo of the last trigger lasted echo_us (0 = no echo came back); ignored when no
 * measurement is running. */
void fw_range_result(fw_t *fw, uint16_t echo_us);

/* Write the RANGE payload (V2_RANGE_LEN bytes) for a reading; returns its length. */
uint8_t fw_range_payload(uint16_t distance_mm, uint16_t trigger_tick, uint8_t *out);

/* Move up to max queued reply bytes into dst; returns how many. */
uint8_t fw_take_tx(fw_t *fw, uint8_t *dst, uint8_t max);

#endif
