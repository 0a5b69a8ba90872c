/* The thin hardware layer between fw.c and the microcontroller's registers: hal_msp430.c
 * (MSP430FR5969, the pins and clocks named below) or hal_avr.c (ATmega328P: servo pins D9,
 * D10, D11, USART0; no range sensor). Everything here is register plumbing; every decision
 * lives in src/fw.c. */
#ifndef DESKARM_HAL_H
#define DESKARM_HAL_H

#include <stdint.h>

#define HAL_JOINTS 3u /* PWM outputs on the board: P1.3 (TA1.2), P1.4 (TB0.1), P1.5 (TB0.2) */

/* 1 when an HC-SR04 range sensor is fitted (make msp430 RANGE_SENSOR=1): TRIG on P3.0,
 * ECHO on P1.2 through a divider (the sensor's echo is 5 V, the MSP430's pins 3.6 V max:
 * e.g. 1 kOhm in series, 2 kOhm to ground). */
#ifndef HAL_RANGE_SENSOR
#define HAL_RANGE_SENSOR 0
#endif

/* Clocks (DCO 8 MHz), UART 9600 8N1 on eUSCI_A0 (P2.0 TXD, P2.1 RXD: the LaunchPad's
 * back-channel UART), 50 Hz PWM with 1 us resolution, all outputs off. Enables interrupts. */
void hal_init(void);

/* Next received byte: 1 and *byte set, or 0 when none is waiting. */
uint8_t hal_uart_getc(uint8_t *byte);

/* Queue bytes for interrupt-driven transmission; returns how many fitted. */
uint8_t hal_uart_write(const uint8_t *data, uint8_t len);

/* Free space in the transmit queue. */
uint8_t hal_uart_tx_free(void);

/* 20 ms servo periods elapsed since the last call. */
uint8_t hal_take_ticks(void);

/* Pulse widths in microseconds (0 = output held low) for the first HAL_JOINTS joints;
 * loaded into the timers at the start of the next PWM period. */
void hal_set_pulses(const uint16_t *pulse_us);

/* HC-SR04: send the >= 10 us trigger pulse on P3.0 and time the echo on P1.2 (port
 * interrupts on both edges against Timer_A0, free-running at 1 MHz). Forgets any earlier
 * measurement. */
void hal_range_start(void);

/* 1 and *echo_us set when the echo of the last hal_range_start() has ended; 0 while there
 * has been no complete echo (none came, or it is still high: call this >= 40 ms after the
 * start and a 0 means no echo). */
uint8_t hal_range_take(uint16_t *echo_us);

/* Sleep (LPM0) until an interrupt, unless a byte or a tick is already waiting. */
void hal_wait_for_event(void);

#endif
