/* ATmega328P @ 16 MHz (Arduino Uno, Nano) hardware layer.
 *
 * Pins (Arduino names):
 *   D9  = PB1  joint 1 servo pulse
 *   D10 = PB2  joint 2 servo pulse
 *   D11 = PB3  joint 3 servo pulse
 *   D0  = PD0 RXD, D1 = PD1 TXD: USART0, wired to the board's USB-serial chip
 *
 * Servo pulses: one timer multiplexing three pins. Timer1 runs free (normal mode) at
 * 16 MHz / 8 = 2 MHz (0.5 us steps, wraps every 32.768 ms); its compare-A interrupt
 * schedules every edge against absolute Timer1 counts. A 20 ms frame (40000 counts, 50 Hz)
 * has one slot per joint: joint j's pulse starts 4 ms * j after the frame start and lasts
 * its width (<= 3 ms, so pulses never overlap and every edge is >= 400 us from the next).
 * The compare fires EDGE_EARLY_COUNTS before each edge (FRAME_EARLY_COUNTS before a frame's
 * start, which also builds the frame's edge list); the interrupt then spins on TCNT1
 * until the edge's count and writes PORTB. So an edge lands on its count within one spin
 * (a few cycles, < 1 us) even when the UART interrupt or a short cli() in the main loop
 * delayed the timer interrupt: a pulse is as exact as the crystal, not the interrupt load.
 * New widths are taken at the frame start (the MSP430 layer does the same): a width that
 * changes mid-frame never cuts a pulse short.
 *
 * UART: 9600 8N1 (U2X, UBRR 207: 9615 baud, +0.2 %), receive and transmit interrupts into
 * ring buffers, as on the MSP430.
 *
 * Range sensor: not ported to this board (HAL_RANGE_SENSOR must be 0; main_avr.c then never
 * calls hal_range_start/hal_range_take, so they are not defined here). */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <stdint.h>

#include "hal.h"

#if HAL_RANGE_SENSOR
#error "hal_avr.c: the HC-SR04 range sensor is only wired up on the MSP430 (build with RANGE_SENSOR=0)"
#endif

#if F_CPU != 16000000UL
#error "hal_avr.c is timed for a 16 MHz ATmega328P (Arduino Uno/Nano): build with -DF_CPU=16000000UL"
#endif

#define SERVO_PINS ((uint8_t)((1u << PB1) | (1u << PB2) | (1u << PB3)))
#define COUNTS_PER_US 2u                 /* Timer1 at F_CPU / 8 */
#define FRAME_COUNTS 40000u              /* 20 ms: 50 Hz */
#define SLOT_COUNTS 8000u                /* 4 ms per joint */
#define EDGE_EARLY_COUNTS 40u            /* 20 us: longer than any interrupt or cli() here */
#define FRAME_EARLY_COUNTS 200u          /* 100 us: also room to build the frame's edge list
                                          * (with 20 us, a UART interrupt just before it made
                                          * the frame's first edge up to ~1 us late) */
#define PULSE_MIN_US 100u                /* fw never asks for less than 400 (V2_PULSE_MIN_US) */
#define PULSE_MAX_US 3000u               /* = V2_PULSE_MAX_US: fits the 4 ms slot */
#define EVENTS_MAX (1u + 2u * HAL_JOINTS) /* frame start + a rise and a fall per joint */

#define RX_SIZE 64u
#define TX_SIZE 128u

static const uint8_t servo_pin[HAL_JOINTS] = {1u << PB1, 1u << PB2, 1u << PB3};

static volatile uint8_t rx_buf[RX_SIZE];
static volatile uint8_t rx_head; /* written by the RX interrupt */
static volatile uint8_t rx_tail; /* written by the main loop */
static volatile uint8_t tx_buf[TX_SIZE];
static volatile uint8_t tx_head; /* written by the main loop */
static volatile uint8_t tx_tail; /* written by the UDRE interrupt */
static volatile uint8_t ticks;   /* frames not yet taken by the main loop */
/* written by the main loop (interrupts off), read by the timer interrupt at a frame start */
static volatile uint16_t next_pulse_us[HAL_JOINTS];

/* The current frame's edges, built at its start; only the timer interrupt touches these. */
static uint16_t frame_start;              /* Timer1 count of this frame's first edge */
static uint16_t event_at[EVENTS_MAX];     /* Timer1 count of each edge */
static uint8_t event_port[EVENTS_MAX];    /* PORTB from that edge on */
static uint8_t event_count;
static uint8_t event_next;

static void uart_init(void)
{
    UBRR0H = 0;
    UBRR0L = 207; /* 16 MHz / (8 * (207 + 1)) = 9615 baud with U2X */
    UCSR0A = (uint8_t)(1u << U2X0);
    UCSR0C = (uint8_t)((1u << UCSZ01) | (1u << UCSZ00)); /* 8N1 */
    UCSR0B = (uint8_t)((1u << RXEN0) | (1u << TXEN0) | (1u << RXCIE0));
}

static void servo_init(void)
{
    PORTB &= (uint8_t)~SERVO_PINS; /* held low: no pulse, servos limp */
    DDRB |= SERVO_PINS;
    TCCR1A = 0;                        /* normal mode, OC1A/OC1B pins not driven by the timer */
    TCCR1B = (uint8_t)(1u << CS11);    /* clk / 8: 2 MHz */
    TCNT1 = 0;
    event_count = 0;
    event_next = 0;
    frame_start = FRAME_COUNTS;        /* first frame 20 ms after start-up */
    OCR1A = (uint16_t)(frame_start - FRAME_EARLY_COUNTS);
    TIFR1 = (uint8_t)(1u << OCF1A);
    TIMSK1 = (uint8_t)(1u << OCIE1A);
}

void hal_init(void)
{
    uint8_t j;
    cli();
    for (j = 0; j < HAL_JOINTS; j++) {
        next_pulse_us[j] = 0;
    }
    rx_head = rx_tail = 0;
    tx_head = tx_tail = 0;
    ticks = 0;
    uart_init();
    servo_init();
    SMCR = 0; /* sleep mode idle (SM2..0 = 0): Timer1 and the USART keep running */
    sei();
}

uint8_t hal_uart_getc(uint8_t *byte)
{
    uint8_t tail = rx_tail;
    if (tail == rx_head) {
        return 0;
    }
    *byte = rx_buf[tail];
    rx_tail = (uint8_t)((tail + 1u) & (RX_SIZE - 1u));
    return 1;
}

uint8_t hal_uart_tx_free(void)
{
    unsigned used = ((unsigned)tx_head - (unsigned)tx_tail) & (TX_SIZE - 1u);
    return (uint8_t)((TX_SIZE - 1u) - used);
}

uint8_t hal_uart_write(const uint8_t *data, uint8_t len)
{
    uint8_t n = 0;
    while (n < len && hal_uart_tx_free() > 0u) {
        tx_buf[tx_head] = data[n++];
        tx_head = (uint8_t)((tx_head + 1u) & (TX_SIZE - 1u));
    }
    if (n > 0u) {
        UCSR0B |= (uint8_t)(1u << UDRIE0); /* fires at once while the data register is empty */
    }
    return n;
}

uint8_t hal_take_ticks(void)
{
    uint8_t n;
    cli();
    n = ticks;
    ticks = 0;
    sei();
    return n;
}

void hal_set_pulses(const uint16_t *pulse_us)
{
    uint8_t j;
    uint16_t p[HAL_JOINTS];
    for (j = 0; j < HAL_JOINTS; j++) {
        p[j] = pulse_us[j];
        if (p[j] != 0u && p[j] < PULSE_MIN_US) {
            p[j] = PULSE_MIN_US;
        } else if (p[j] > PULSE_MAX_US) {
            p[j] = PULSE_MAX_US;
        }
    }
    cli(); /* 16-bit stores are not atomic here: no torn width at a frame start */
    for (j = 0; j < HAL_JOINTS; j++) {
        next_pulse_us[j] = p[j];
    }
    sei();
}

void hal_wait_for_event(void)
{
    cli();
    if (rx_head == rx_tail && ticks == 0u) {
        sleep_enable();
        sei(); /* the instruction after sei runs before any interrupt: no wake-up is lost */
        sleep_cpu();
        sleep_disable();
    } else {
        sei();
    }
}

/* The frame's edges in time order from the widths the main loop left in next_pulse_us. */
static void build_frame(void)
{
    uint8_t j;
    uint8_t port = 0;
    uint8_t n = 1;
    uint16_t w0 = next_pulse_us[0];
    event_at[0] = frame_start;
    event_port[0] = w0 != 0u ? servo_pin[0] : 0u;
    port = event_port[0];
    for (j = 0; j < HAL_JOINTS; j++) {
        uint16_t w = next_pulse_us[j];
        uint16_t rise = (uint16_t)(frame_start + (uint16_t)(j * SLOT_COUNTS));
        if (w == 0u) {
            continue;
        }
        if (j > 0u) {
            port = (uint8_t)(port | servo_pin[j]);
            event_at[n] = rise;
            event_port[n] = port;
            n++;
        }
        port = (uint8_t)(port & (uint8_t)~servo_pin[j]);
        event_at[n] = (uint16_t)(rise + (uint16_t)(w * COUNTS_PER_US));
        event_port[n] = port;
        n++;
    }
    event_count = n;
}

ISR(TIMER1_COMPA_vect)
{
    uint16_t at;
    if (event_next == 0u) {
        build_frame(); /* FRAME_EARLY_COUNTS ahead of the frame start: time to spare */
        if (ticks < 255u) {
            ticks++; /* every 20 ms exactly; the widths fw computes now start next frame */
        }
    }
    at = event_at[event_next];
    while ((int16_t)(TCNT1 - at) < 0) {
        /* spin to the exact count: the edge does not depend on how late this interrupt ran */
    }
    PORTB = (uint8_t)((PORTB & (uint8_t)~SERVO_PINS) | event_port[event_next]);
    event_next++;
    if (event_next >= event_count) {
        event_next = 0;
        frame_start = (uint16_t)(frame_start + FRAME_COUNTS);
        OCR1A = (uint16_t)(frame_start - FRAME_EARLY_COUNTS);
    } else {
        OCR1A = (uint16_t)(event_at[event_next] - EDGE_EARLY_COUNTS);
    }
}

ISR(USART_RX_vect)
{
    uint8_t status = UCSR0A;
    uint8_t byte = UDR0;
    uint8_t next = (uint8_t)((rx_head + 1u) & (RX_SIZE - 1u));
    if ((status & (uint8_t)(1u << FE0)) != 0u) {
        return; /* framing error: drop it; a v2 frame's CRC and end byte catch the gap */
    }
    if (next != rx_tail) { /* full: drop the byte, as on the MSP430 */
        rx_buf[rx_head] = byte;
        rx_head = next;
    }
}

ISR(USART_UDRE_vect)
{
    if (tx_tail != tx_head) {
        UDR0 = tx_buf[tx_tail];
        tx_tail = (uint8_t)((tx_tail + 1u) & (TX_SIZE - 1u));
    } else {
        UCSR0B &= (uint8_t)~(1u << UDRIE0);
    }
}
