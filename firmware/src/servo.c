#include "servo.h"

#include "v2.h"

void servo_config_default(servo_config_t *c)
{
    c->min_pulse_us = SERVO_DEFAULT_MIN_US;
    c->max_pulse_us = SERVO_DEFAULT_MAX_US;
    c->max_speed_dps = SERVO_DEFAULT_SPEED_DPS;
}

uint8_t servo_config_valid(uint16_t min_pulse_us, uint16_t max_pulse_us, uint16_t max_speed_dps)
{
    return (uint8_t)(min_pulse_us >= V2_PULSE_MIN_US && max_pulse_us <= V2_PULSE_MAX_US &&
                     min_pulse_us < max_pulse_us && max_speed_dps <= V2_SPEED_MAX_DPS);
}

uint16_t servo_pulse_us(const servo_config_t *c, uint16_t angle_cdeg)
{
    uint32_t span;
    uint32_t offset;
    if (angle_cdeg > V2_ANGLE_MAX_CDEG) {
        angle_cdeg = V2_ANGLE_MAX_CDEG;
    }
    if (c->max_pulse_us <= c->min_pulse_us) {
        return c->min_pulse_us; /* never configured so (servo_config_valid), but stay in range */
    }
    /* 32-bit on purpose: span * angle reaches 4.7e7, and the MSP430's int is 16-bit */
    span = (uint32_t)c->max_pulse_us - (uint32_t)c->min_pulse_us;
    offset = (span * (uint32_t)angle_cdeg + V2_ANGLE_MAX_CDEG / 2u) / V2_ANGLE_MAX_CDEG;
    return (uint16_t)((uint32_t)c->min_pulse_us + offset);
}

uint16_t servo_step_cdeg(uint16_t pos_cdeg, uint16_t target_cdeg, uint16_t max_speed_dps)
{
    /* deg/s * 100 cdeg/deg / 50 ticks/s = 2 cdeg per tick per deg/s */
    uint32_t step = (uint32_t)max_speed_dps * (100u / SERVO_TICK_HZ);
    if (max_speed_dps == 0u) {
        return target_cdeg;
    }
    if (target_cdeg > pos_cdeg) {
        if ((uint32_t)(target_cdeg - pos_cdeg) <= step) {
            return target_cdeg;
        }
        return (uint16_t)((uint32_t)pos_cdeg + step);
    }
    if ((uint32_t)(pos_cdeg - target_cdeg) <= step) {
        return target_cdeg;
    }
    return (uint16_t)((uint32_t)pos_cdeg - step);
}
