/* HC-SR04 ultrasonic range sensor: echo pulse width -> distance (pure, no registers).
 *
 * The sensor answers a 10 us trigger pulse with an echo pulse as long as the sound's round
 * trip. At 343 m/s (dry air at 20 degC; no temperature correction: the sensor's own spread is
 * larger than the ~0.18 %/degC it would fix) 1 us of echo is 0.1715 mm of distance.
 * Anything the sensor cannot measure reliably becomes RANGE_NO_ECHO: no echo pulse at all
 * (0 us), closer than 20 mm, farther than 4000 mm, or an echo longer than the timeout (the
 * HC-SR04 holds its echo line high for ~38 ms when nothing comes back). */
#ifndef DESKARM_RANGE_H
#define DESKARM_RANGE_H

#include <stdint.h>

#define RANGE_NO_ECHO 0xFFFFu          /* no valid reading: no echo, too near or too far */
#define RANGE_MIN_MM 20u               /* the HC-SR04's near limit */
#define RANGE_MAX_MM 4000u             /* the HC-SR04's far limit */
#define RANGE_SOUND_MM_PER_MS 343u     /* speed of sound, 343 m/s = 343 mm/ms */
#define RANGE_ECHO_TIMEOUT_US 25000u   /* > 23324 us, the echo of RANGE_MAX_MM */

/* Distance in mm (rounded to the nearest mm) for an echo of echo_us microseconds,
 * or RANGE_NO_ECHO when the reading is outside RANGE_MIN_MM..RANGE_MAX_MM or timed out. */
uint16_t range_echo_to_mm(uint16_t echo_us);

#endif
