/* Angle to pulse mapping and the per-tick rate limiter. Angles are in centidegrees. */
#ifndef DESKARM_SERVO_H
#define DESKARM_SERVO_H

#include <stdint.h>

#define SERVO_TICK_HZ 50u
/* the seed firmware's mapping: 900 + 10 * angle_deg microseconds */
#define SERVO_DEFAULT_MIN_US 900u
#define SERVO_DEFAULT_MAX_US 2700u
#define SERVO_DEFAULT_SPEED_DPS 180u

typedef struct {
    uint16_t min_pulse_us;  /* pulse at 0 degrees */
    uint16_t max_pulse_us;  /* pulse at 180 degrees */
    uint16_t max_speed_dps; /* degrees per second, 0 = no limit */
} servo_config_t;

void servo_config_default(servo_config_t *c);

/* 1 when a CONFIG may set these values (see V2_PULSE_MIN_US and friends in v2.h). */
uint8_t servo_config_valid(uint16_t min_pulse_us, uint16_t max_pulse_us, uint16_t max_speed_dps);

/* Pulse width for an angle, rounded to the nearest microsecond; angles above 180.00
 * degrees are clamped, so the result is always within [min_pulse_us, max_pulse_us]. */
uint16_t servo_pulse_us(const servo_config_t *c, uint16_t angle_cdeg);

/* One 50 Hz tick of the rate limiter: move pos toward target by at most
 * max_speed_dps / 50 degrees. */
uint16_t servo_step_cdeg(uint16_t pos_cdeg, uint16_t target_cdeg, uint16_t max_speed_dps);

#endif
