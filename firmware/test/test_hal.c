/* hal_msp430.c against the register stub: init values, interrupts and ring buffers. */
#include <stdint.h>
#include <string.h>

#include "../hal.h"
#include "msp430.h"
#include "unit.h"

#define STUB_DEF16(name) volatile uint16_t name
#define STUB_DEF8(name) volatile uint8_t name
STUB_DEF16(WDTCTL);
STUB_DEF8(CSCTL0_H);
STUB_DEF16(CSCTL1);
STUB_DEF16(CSCTL2);
STUB_DEF16(CSCTL3);
STUB_DEF16(PM5CTL0);
STUB_DEF8(P1OUT);
STUB_DEF8(P1DIR);
STUB_DEF8(P1SEL0);
STUB_DEF8(P1SEL1);
STUB_DEF8(P1IN);
STUB_DEF8(P1IES);
STUB_DEF8(P1IE);
STUB_DEF8(P1IFG);
STUB_DEF16(P1IV);
STUB_DEF8(P3OUT);
STUB_DEF8(P3DIR);
STUB_DEF8(P2SEL0);
STUB_DEF8(P2SEL1);
STUB_DEF16(UCA0CTLW0);
STUB_DEF16(UCA0BRW);
STUB_DEF16(UCA0MCTLW);
STUB_DEF16(UCA0IE);
STUB_DEF16(UCA0IV);
STUB_DEF16(UCA0RXBUF);
STUB_DEF16(UCA0TXBUF);
STUB_DEF16(TA0CTL);
STUB_DEF16(TA0R);
STUB_DEF16(TA1CTL);
STUB_DEF16(TA1CCTL0);
STUB_DEF16(TA1CCTL2);
STUB_DEF16(TA1CCR0);
STUB_DEF16(TA1CCR2);
STUB_DEF16(TB0CTL);
STUB_DEF16(TB0CCTL1);
STUB_DEF16(TB0CCTL2);
STUB_DEF16(TB0CCR0);
STUB_DEF16(TB0CCR1);
STUB_DEF16(TB0CCR2);

int stub_gie;
int stub_sleeps;
int stub_wakeups;

void __enable_interrupt(void) { stub_gie = 1; }
void __disable_interrupt(void) { stub_gie = 0; }
void __no_operation(void) {}
void __bis_SR_register(unsigned int bits)
{
    if (bits & GIE) {
        stub_gie = 1;
    }
    if (bits & LPM0_bits) {
        stub_sleeps++;
    }
}
void __bic_SR_register_on_exit(unsigned int bits)
{
    if (bits & LPM0_bits) {
        stub_wakeups++;
    }
}

/* __delay_cycles is where the trigger pulse is high: record the pin and the length */
static unsigned long stub_delay_cycles;
static int stub_trig_high_during_delay;
void __delay_cycles(unsigned long cycles)
{
    stub_delay_cycles += cycles;
    stub_trig_high_during_delay = (P3OUT & BIT0) != 0;
}

/* the interrupt handlers, plain functions in the stub build */
void hal_timer1_a0_isr(void);
void hal_uart_isr(void);
void hal_port1_isr(void);

static void reset_stub(void)
{
    /* power-on values that matter: PM5 locked, pins as GPIO inputs */
    PM5CTL0 = LOCKLPM5;
    P1OUT = 0xFF;
    P1DIR = 0;
    P1SEL0 = 0;
    P1SEL1 = 0xFF;
    P2SEL0 = 0xFF;
    P2SEL1 = 0;
    UCA0IE = 0;
    stub_gie = 0;
    stub_sleeps = 0;
    stub_wakeups = 0;
    P3OUT = 0xFF;
    P3DIR = 0;
    P1IE = 0;
    P1IES = 0;
    P1IFG = 0;
    stub_delay_cycles = 0;
    stub_trig_high_during_delay = 0;
    hal_init();
}

/* an edge on the echo pin (P1.2) when the free-running timer reads t */
static void echo_edge(uint16_t t)
{
    TA0R = t;
    P1IV = 0x06u; /* P1IFG2 */
    hal_port1_isr();
}

static void rx_interrupt(uint8_t byte)
{
    UCA0RXBUF = byte;
    UCA0IV = USCI_UART_UCRXIFG;
    hal_uart_isr();
}

static void test_hal_init_sets_up_50_hz_pwm_with_1_us_steps_on_p1_3_p1_4_p1_5(void)
{
    reset_stub();
    CHECK_EQ(WDTCTL, WDTPW | WDTHOLD);
    CHECK_EQ(TA1CCR0, 19999u);
    CHECK_EQ(TB0CCR0, 19999u);
    CHECK_EQ(TA1CTL, TASSEL__SMCLK | ID__8 | MC__UP | TACLR); /* 8 MHz / 8 = 1 MHz */
    CHECK_EQ(TB0CTL, TBSSEL__SMCLK | ID__8 | MC__UP | TBCLR);
    CHECK_EQ(CSCTL1, DCOFSEL_3 | DCORSEL);
    CHECK_EQ(TA1CCTL0 & CCIE, CCIE);
    CHECK_EQ(P1DIR & (BIT3 | BIT4 | BIT5), BIT3 | BIT4 | BIT5);
    CHECK_EQ(P1SEL0 & (BIT3 | BIT4 | BIT5), BIT3 | BIT4 | BIT5);
    CHECK_EQ(P1SEL1 & (BIT3 | BIT4 | BIT5), 0u);
    CHECK_EQ(P1OUT & (BIT3 | BIT4 | BIT5), 0u);
    CHECK_EQ(PM5CTL0 & LOCKLPM5, 0u);
    CHECK_EQ(stub_gie, 1);
}

static void test_hal_init_starts_with_every_output_held_low(void)
{
    reset_stub();
    CHECK_EQ(TA1CCTL2, OUTMOD_0);
    CHECK_EQ(TB0CCTL1, OUTMOD_0);
    CHECK_EQ(TB0CCTL2, OUTMOD_0);
}

static void test_hal_init_sets_the_uart_to_9600_baud_from_8_mhz_on_p2_0_p2_1(void)
{
    reset_stub();
    CHECK_EQ(UCA0BRW, 52u);
    CHECK_EQ(UCA0MCTLW, UCOS16 | UCBRF_1 | 0x4900u);
    CHECK_EQ(UCA0CTLW0 & UCSWRST, 0u);
    CHECK_EQ(UCA0CTLW0 & UCSSEL__SMCLK, UCSSEL__SMCLK);
    CHECK_EQ(UCA0IE & UCRXIE, UCRXIE);
    CHECK_EQ(P2SEL1 & (BIT0 | BIT1), BIT0 | BIT1);
    CHECK_EQ(P2SEL0 & (BIT0 | BIT1), 0u);
}

static void test_hal_uart_rx_interrupt_queues_bytes_in_order_and_wakes_the_cpu(void)
{
    uint8_t b = 0;
    unsigned i;
    reset_stub();
    CHECK_EQ(hal_uart_getc(&b), 0u);
    for (i = 0; i < 10u; i++) {
        rx_interrupt((uint8_t)(0xF0u + i));
    }
    CHECK_EQ(stub_wakeups, 10);
    for (i = 0; i < 10u; i++) {
        CHECK_EQ(hal_uart_getc(&b), 1u);
        CHECK_EQ(b, 0xF0u + i);
    }
    CHECK_EQ(hal_uart_getc(&b), 0u);
}

static void test_hal_uart_rx_drops_bytes_when_the_ring_is_full(void)
{
    uint8_t b = 0;
    unsigned i;
    unsigned got = 0;
    reset_stub();
    for (i = 0; i < 200u; i++) {
        rx_interrupt((uint8_t)i);
    }
    while (hal_uart_getc(&b)) {
        CHECK_EQ(b, got);
        got++;
    }
    CHECK_EQ(got, 63u); /* 64-byte ring, one slot kept empty */
}

static void test_hal_uart_tx_drains_through_the_tx_interrupt(void)
{
    static const uint8_t msg[] = {0xF5, 0xF5, 0x00, 0x05, 0x09, 0xA2, 0x40, 0xF7};
    unsigned i;
    reset_stub();
    CHECK_EQ(hal_uart_tx_free(), 127u);
    CHECK_EQ(hal_uart_write(msg, sizeof msg), sizeof msg);
    CHECK_EQ(UCA0IE & UCTXIE, UCTXIE);
    for (i = 0; i < sizeof msg; i++) {
        UCA0IV = USCI_UART_UCTXIFG;
        hal_uart_isr();
        CHECK_EQ(UCA0TXBUF, msg[i]);
    }
    UCA0IV = USCI_UART_UCTXIFG;
    hal_uart_isr();
    CHECK_EQ(UCA0IE & UCTXIE, 0u); /* empty: TX interrupt off */
    CHECK_EQ(hal_uart_tx_free(), 127u);
}

static void test_hal_timer_interrupt_counts_ticks_and_loads_pulses_at_the_period_start(void)
{
    static const uint16_t p[3] = {900, 1800, 2700};
    reset_stub();
    hal_set_pulses(p);
    CHECK_EQ(TA1CCR2, 0u); /* not before the period starts */
    hal_timer1_a0_isr();
    CHECK_EQ(TA1CCR2, 900u);
    CHECK_EQ(TB0CCR1, 1800u);
    CHECK_EQ(TB0CCR2, 2700u);
    CHECK_EQ(TA1CCTL2, OUTMOD_7);
    CHECK_EQ(TB0CCTL1, OUTMOD_7);
    CHECK_EQ(TB0CCTL2, OUTMOD_7);
    hal_timer1_a0_isr();
    CHECK_EQ(hal_take_ticks(), 2u);
    CHECK_EQ(hal_take_ticks(), 0u);
    CHECK_EQ(stub_gie, 1);
}

static void test_hal_zero_pulse_holds_the_output_low_instead_of_a_glitch(void)
{
    static const uint16_t on[3] = {1500, 1500, 1500};
    static const uint16_t off[3] = {0, 1500, 0};
    reset_stub();
    hal_set_pulses(on);
    hal_timer1_a0_isr();
    hal_set_pulses(off);
    hal_timer1_a0_isr();
    CHECK_EQ(TA1CCTL2, OUTMOD_0);
    CHECK_EQ(TB0CCTL1, OUTMOD_7);
    CHECK_EQ(TB0CCTL2, OUTMOD_0);
}

static void test_hal_sleeps_only_when_no_byte_or_tick_is_waiting(void)
{
    uint8_t b;
    reset_stub();
    hal_wait_for_event();
    CHECK_EQ(stub_sleeps, 1);
    rx_interrupt(0x42);
    hal_wait_for_event();
    CHECK_EQ(stub_sleeps, 1); /* a byte is waiting: no sleep */
    CHECK_EQ(stub_gie, 1);
    (void)hal_uart_getc(&b);
    hal_timer1_a0_isr();
    hal_wait_for_event();
    CHECK_EQ(stub_sleeps, 1); /* a tick is waiting */
    (void)hal_take_ticks();
    hal_wait_for_event();
    CHECK_EQ(stub_sleeps, 2);
}

static void test_hal_init_sets_up_the_range_sensor_pins_and_a_free_running_1_mhz_timer(void)
{
    reset_stub();
    CHECK_EQ(P3DIR & BIT0, BIT0);  /* TRIG: output */
    CHECK_EQ(P3OUT & BIT0, 0u);    /* ... held low */
    CHECK_EQ(P1DIR & BIT2, 0u);    /* ECHO: input */
    CHECK_EQ(P1IE & BIT2, 0u);     /* no edge interrupts before a measurement */
    CHECK_EQ(TA0CTL, TASSEL__SMCLK | ID__8 | MC__CONTINUOUS | TACLR);
}

static void test_hal_range_start_sends_a_trigger_pulse_of_at_least_10_us(void)
{
    reset_stub();
    hal_range_start();
    CHECK_EQ(stub_trig_high_during_delay, 1);
    CHECK(stub_delay_cycles >= 80u); /* 10 us at 8 MHz */
    CHECK_EQ(P3OUT & BIT0, 0u);      /* and low again */
    CHECK_EQ(P1IE & BIT2, BIT2);     /* echo edges armed ... */
    CHECK_EQ(P1IES & BIT2, 0u);      /* ... rising first */
}

static void test_hal_range_measures_the_echo_between_its_rising_and_falling_edge(void)
{
    uint16_t echo = 0;
    reset_stub();
    hal_range_start();
    echo_edge(1000);
    CHECK_EQ(P1IES & BIT2, BIT2); /* now waiting for the falling edge */
    CHECK_EQ(hal_range_take(&echo), 0u); /* still high: no result yet */
    hal_range_start();
    echo_edge(1000);
    echo_edge(3041);
    CHECK_EQ(hal_range_take(&echo), 1u);
    CHECK_EQ(echo, 2041u);
    CHECK_EQ(hal_range_take(&echo), 0u); /* taken once */
}

static void test_hal_range_echo_across_a_timer_wrap_is_measured_right(void)
{
    uint16_t echo = 0;
    reset_stub();
    hal_range_start();
    echo_edge(65000u);
    echo_edge(1500u);
    CHECK_EQ(hal_range_take(&echo), 1u);
    CHECK_EQ(echo, 2036u);
}

static void test_hal_range_clears_the_flag_that_switching_the_edge_may_raise(void)
{
    reset_stub();
    hal_range_start();
    P1IFG |= BIT2; /* as the hardware may when IES changes while the pin is high */
    echo_edge(1000);
    CHECK_EQ(P1IFG & BIT2, 0u);
}

static void test_hal_range_without_an_echo_reports_nothing(void)
{
    uint16_t echo = 1234;
    reset_stub();
    hal_range_start();
    CHECK_EQ(hal_range_take(&echo), 0u);
    CHECK_EQ(echo, 1234u); /* untouched */
    CHECK_EQ(P1IE & BIT2, 0u); /* and no late edge can write a result any more */
}

static void test_hal_range_ignores_other_port_1_interrupts_and_edges_after_the_result(void)
{
    uint16_t echo = 0;
    reset_stub();
    hal_range_start();
    TA0R = 500;
    P1IV = 0x04u; /* P1.1, not ours */
    hal_port1_isr();
    echo_edge(1000);
    echo_edge(2000);
    echo_edge(9000); /* a stray edge after the fall */
    CHECK_EQ(hal_range_take(&echo), 1u);
    CHECK_EQ(echo, 1000u);
}

#define T(fn) {#fn, fn}
const unit_test_t HAL_TESTS[] = {
    T(test_hal_init_sets_up_50_hz_pwm_with_1_us_steps_on_p1_3_p1_4_p1_5),
    T(test_hal_init_starts_with_every_output_held_low),
    T(test_hal_init_sets_the_uart_to_9600_baud_from_8_mhz_on_p2_0_p2_1),
    T(test_hal_uart_rx_interrupt_queues_bytes_in_order_and_wakes_the_cpu),
    T(test_hal_uart_rx_drops_bytes_when_the_ring_is_full),
    T(test_hal_uart_tx_drains_through_the_tx_interrupt),
    T(test_hal_timer_interrupt_counts_ticks_and_loads_pulses_at_the_period_start),
    T(test_hal_zero_pulse_holds_the_output_low_instead_of_a_glitch),
    T(test_hal_sleeps_only_when_no_byte_or_tick_is_waiting),
    T(test_hal_init_sets_up_the_range_sensor_pins_and_a_free_running_1_mhz_timer),
    T(test_hal_range_start_sends_a_trigger_pulse_of_at_least_10_us),
    T(test_hal_range_measures_the_echo_between_its_rising_and_falling_edge),
    T(test_hal_range_echo_across_a_timer_wrap_is_measured_right),
    T(test_hal_range_clears_the_flag_that_switching_the_edge_may_raise),
    T(test_hal_range_without_an_echo_reports_nothing),
    T(test_hal_range_ignores_other_port_1_interrupts_and_edges_after_the_result),
};
const unsigned HAL_TEST_COUNT = sizeof HAL_TESTS / sizeof HAL_TESTS[0];
