#include "range.h"

uint16_t range_echo_to_mm(uint16_t echo_us)
{
    uint32_t mm;
    if (echo_us == 0u || echo_us > RANGE_ECHO_TIMEOUT_US) {
        return RANGE_NO_ECHO;
    }
    /* distance = echo * speed / 2 (there and back): echo_us * 343 mm/ms / 2000, rounded.
     * 32-bit: 25000 * 343 does not fit the MSP430's 16-bit int. */
    mm = ((uint32_t)echo_us * RANGE_SOUND_MM_PER_MS + 1000u) / 2000u;
    if (mm < RANGE_MIN_MM || mm > RANGE_MAX_MM) {
        return RANGE_NO_ECHO;
    }
    return (uint16_t)mm;
}
