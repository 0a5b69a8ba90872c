/* MSP430FR5969 LaunchPad (MSP-EXP430FR5969) hardware layer.
 *
 * Pins, as on the seed firmware's boards:
 *   P1.3 = TA1.2  joint 1 PWM   (P1SEL1 = 0, P1SEL0 = 1: primary function)
 *   P1.4 = TB0.1  joint 2 PWM
 *   P1.5 = TB0.2  joint 3 PWM
 *   P2.0 = UCA0TXD, P2.1 = UCA0RXD (P2SEL1 = 1, P2SEL0 = 0), wired to the eZ-FET back-channel
 *   P3.0 = HC-SR04 TRIG (GPIO output), P1.2 = HC-SR04 ECHO (GPIO input, port interrupt; 5 V
 *          from the sensor: through a divider), used when a range sensor is fitted
 * Clocks: DCO 8 MHz -> MCLK = SMCLK = 8 MHz. UART from SMCLK (TI's 9600-baud settings for
 * 8 MHz). Timers from SMCLK / 8 = 1 MHz, up mode to 19999: a 20 ms (50 Hz) period with
 * 1 us steps, so a CCR value is the pulse width in microseconds. Timer_A0 runs free
 * (continuous mode) at the same 1 MHz: the range sensor's echo edges are stamped with TA0R.
 *
 * Built with TI's MSP430-GCC (msp430-elf-gcc). For host checks, test/msp430_stub/msp430.h
 * stands in for the real header and HAL_HOST_STUB turns the interrupt attributes off. */
#include <msp430.h>
#include <stdint.h>

#include "hal.h"

#if defined(HAL_HOST_STUB)
#define HAL_ISR(vector, name) void name(void)
#elif defined(__GNUC__)
#define HAL_ISR(vector, name) void __attribute__((interrupt(vector))) name(void)
#else
#error "hal_msp430.c is written for msp430-elf-gcc (TI's MSP430-GCC)"
#endif

#if defined(USCI_A0_VECTOR)
#define HAL_UART_VECTOR USCI_A0_VECTOR
#else
#define HAL_UART_VECTOR EUSCI_A0_VECTOR
#endif

#define PWM_PERIOD_US 20000u
#define PWM_PINS (BIT3 | BIT4 | BIT5)
#define RANGE_TRIG_PIN BIT0 /* P3.0 */
#define RANGE_ECHO_PIN BIT2 /* P1.2 */
#define RANGE_ECHO_P1IV 0x06u /* P1IV value for P1.2 (P1IV_P1IFG2 in TI's header) */
#define RANGE_TRIG_CYCLES 96u /* 12 us at 8 MHz: the HC-SR04 wants >= 10 us */

/* echo timing, written by the port 1 interrupt */
enum { RANGE_IDLE, RANGE_WAIT_RISE, RANGE_WAIT_FALL, RANGE_DONE };

/* Ring buffers: one producer and one consumer each, 8-bit indices (atomic on the MSP430),
 * power-of-two sizes so wrap-around is a mask. */
#define RX_SIZE 64u
#define TX_SIZE 128u

static volatile uint8_t rx_buf[RX_SIZE];
static volatile uint8_t rx_head; /* written by the RX interrupt */
static volatile uint8_t rx_tail; /* written by the main loop */
static volatile uint8_t tx_buf[TX_SIZE];
static volatile uint8_t tx_head; /* written by the main loop */
static volatile uint8_t tx_tail; /* written by the TX interrupt */
static volatile uint8_t ticks;   /* periods not yet taken by the main loop */
/* The main loop writes these; the period-start interrupt copies them into the timers. */
static volatile uint16_t next_pulse_us[HAL_JOINTS];
static volatile uint8_t range_state;
static volatile uint16_t range_rise_t; /* TA0R at the echo's rising edge */
static volatile uint16_t range_echo_us;

static void clock_init(void)
{
    CSCTL0_H = CSKEY >> 8; /* unlock CS registers */
    CSCTL1 = DCOFSEL_3 | DCORSEL; /* DCO 8 MHz */
    CSCTL2 = SELA__VLOCLK | SELS__DCOCLK | SELM__DCOCLK;
    CSCTL3 = DIVA__1 | DIVS__1 | DIVM__1;
    CSCTL0_H = 0; /* lock CS registers */
}

static void uart_init(void)
{
    P2SEL1 |= BIT0 | BIT1;
    P2SEL0 &= (uint8_t)~(BIT0 | BIT1);
    UCA0CTLW0 = UCSWRST;
    UCA0CTLW0 |= UCSSEL__SMCLK;
    /* 8 MHz / (16 * 9600) = 52.083: UCBRx = 52, UCBRFx = 1, UCBRSx = 0x49 (SLAU367 table) */
    UCA0BRW = 52;
    UCA0MCTLW = UCOS16 | UCBRF_1 | 0x4900u;
    UCA0CTLW0 &= (uint16_t)~UCSWRST;
    UCA0IE |= UCRXIE;
}

static void pwm_init(void)
{
    P1OUT &= (uint8_t)~PWM_PINS;
    P1DIR |= PWM_PINS;
    P1SEL1 &= (uint8_t)~PWM_PINS;
    P1SEL0 |= PWM_PINS;

    /* Outputs start in OUTMOD_0 with OUT = 0: held low, no pulse, servos limp. */
    TA1CCR0 = PWM_PERIOD_US - 1u;
    TA1CCTL2 = OUTMOD_0;
    TA1CCR2 = 0;
    TA1CCTL0 = CCIE; /* period start: tick and load the next pulses */
    TB0CCR0 = PWM_PERIOD_US - 1u;
    TB0CCTL1 = OUTMOD_0;
    TB0CCTL2 = OUTMOD_0;
    TB0CCR1 = 0;
    TB0CCR2 = 0;
    /* started back to back so both timers' periods begin within a few cycles */
    TA1CTL = TASSEL__SMCLK | ID__8 | MC__UP | TACLR;
    TB0CTL = TBSSEL__SMCLK | ID__8 | MC__UP | TBCLR;
}

static void range_init(void)
{
    P3OUT &= (uint8_t)~RANGE_TRIG_PIN;
    P3DIR |= RANGE_TRIG_PIN;
    P1DIR &= (uint8_t)~RANGE_ECHO_PIN;
    P1IE &= (uint8_t)~RANGE_ECHO_PIN;
    range_state = RANGE_IDLE;
    TA0CTL = TASSEL__SMCLK | ID__8 | MC__CONTINUOUS | TACLR; /* 1 MHz, wraps every 65.5 ms */
}

void hal_init(void)
{
    uint8_t j;
    WDTCTL = WDTPW | WDTHOLD;
    for (j = 0; j < HAL_JOINTS; j++) {
        next_pulse_us[j] = 0;
    }
    rx_head = rx_tail = 0;
    tx_head = tx_tail = 0;
    ticks = 0;
    clock_init();
    uart_init();
    pwm_init();
    range_init();
    PM5CTL0 &= (uint16_t)~LOCKLPM5; /* FRAM parts start with pins locked: apply the above */
    __enable_interrupt();
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
    return (uint8_t)((TX_SIZE - 1u) - (uint8_t)((tx_head - tx_tail) & (TX_SIZE - 1u)));
}

uint8_t hal_uart_write(const uint8_t *data, uint8_t len)
{
    uint8_t n = 0;
    while (n < len && hal_uart_tx_free() > 0u) {
        tx_buf[tx_head] = data[n++];
        tx_head = (uint8_t)((tx_head + 1u) & (TX_SIZE - 1u));
    }
    if (n > 0u) {
        UCA0IE |= UCTXIE; /* UCTXIFG is set while the TX buffer is empty: this fires at once */
    }
    return n;
}

uint8_t hal_take_ticks(void)
{
    uint8_t n;
    __disable_interrupt();
    __no_operation(); /* MSP430X: DINT takes effect one instruction late */
    n = ticks;
    ticks = 0;
    __enable_interrupt();
    return n;
}

void hal_set_pulses(const uint16_t *pulse_us)
{
    uint8_t j;
    for (j = 0; j < HAL_JOINTS; j++) {
        /* a 16-bit store is atomic here; a torn set mixes two joints' periods at worst */
        next_pulse_us[j] = pulse_us[j];
    }
}

void hal_range_start(void)
{
    P1IE &= (uint8_t)~RANGE_ECHO_PIN;
    range_state = RANGE_WAIT_RISE;
    P1IES &= (uint8_t)~RANGE_ECHO_PIN; /* rising edge first */
    P1IFG &= (uint8_t)~RANGE_ECHO_PIN;
    P1IE |= RANGE_ECHO_PIN;
    P3OUT |= RANGE_TRIG_PIN;
    __delay_cycles(RANGE_TRIG_CYCLES);
    P3OUT &= (uint8_t)~RANGE_TRIG_PIN;
}

uint8_t hal_range_take(uint16_t *echo_us)
{
    uint8_t done;
    P1IE &= (uint8_t)~RANGE_ECHO_PIN; /* a late edge must not rewrite the result */
    done = (uint8_t)(range_state == RANGE_DONE);
    if (done) {
        *echo_us = range_echo_us;
    }
    range_state = RANGE_IDLE;
    return done;
}

void hal_wait_for_event(void)
{
    __disable_interrupt();
    __no_operation();
    if (rx_head == rx_tail && ticks == 0u) {
        /* sets GIE and LPM0 in one instruction: no interrupt can slip in between */
        __bis_SR_register(LPM0_bits | GIE);
    } else {
        __enable_interrupt();
    }
}

/* Pulse 0 = OUTMOD_0 with OUT clear (held low); else reset/set, high from the period start
 * to CCRn. Loading at the period start matters: lowering CCRn below a running TA1R/TB0R
 * would skip this period's reset and hold the line high for a whole 20 ms. */
static uint16_t outmod_for(uint16_t pulse_us)
{
    return pulse_us == 0u ? (uint16_t)OUTMOD_0 : (uint16_t)OUTMOD_7;
}

HAL_ISR(TIMER1_A0_VECTOR, hal_timer1_a0_isr)
{
    TA1CCR2 = next_pulse_us[0];
    TA1CCTL2 = outmod_for(next_pulse_us[0]);
    TB0CCR1 = next_pulse_us[1];
    TB0CCTL1 = outmod_for(next_pulse_us[1]);
    TB0CCR2 = next_pulse_us[2];
    TB0CCTL2 = outmod_for(next_pulse_us[2]);
    if (ticks < 255u) {
        ticks++;
    }
    __bic_SR_register_on_exit(LPM0_bits);
}

HAL_ISR(HAL_UART_VECTOR, hal_uart_isr)
{
    switch (UCA0IV) {
    case USCI_UART_UCRXIFG: {
        uint8_t byte = (uint8_t)UCA0RXBUF;
        uint8_t next = (uint8_t)((rx_head + 1u) & (RX_SIZE - 1u));
        if (next != rx_tail) { /* full: drop the byte; the v2 CRC will catch the gap */
            rx_buf[rx_head] = byte;
            rx_head = next;
        }
        __bic_SR_register_on_exit(LPM0_bits);
        break;
    }
    case USCI_UART_UCTXIFG:
        if (tx_tail != tx_head) {
            UCA0TXBUF = tx_buf[tx_tail];
            tx_tail = (uint8_t)((tx_tail + 1u) & (TX_SIZE - 1u));
        } else {
            UCA0IE &= (uint16_t)~UCTXIE;
        }
        break;
    default:
        break;
    }
}

HAL_ISR(PORT1_VECTOR, hal_port1_isr)
{
    if (P1IV != RANGE_ECHO_P1IV) {
        return; /* reading P1IV cleared the highest pending flag; only P1.2 is enabled */
    }
    if (range_state == RANGE_WAIT_RISE) {
        range_rise_t = TA0R;
        range_state = RANGE_WAIT_FALL;
        P1IES |= RANGE_ECHO_PIN;
        /* changing the edge while the pin is high may set the flag by itself */
        P1IFG &= (uint8_t)~RANGE_ECHO_PIN;
    } else if (range_state == RANGE_WAIT_FALL) {
        /* 16-bit difference: right across a TA0R wrap, and echoes last < 40 ms < 65.5 ms */
        range_echo_us = (uint16_t)(TA0R - range_rise_t);
        range_state = RANGE_DONE;
        P1IE &= (uint8_t)~RANGE_ECHO_PIN;
    }
}
