/* Host stand-in for TI's <msp430.h>, enough for hal_msp430.c: every register the HAL
 * touches is a plain variable (defined in test/test_hal.c), the bit names carry the values
 * of msp430fr5969.h, and the intrinsics record what they did. Used only with HAL_HOST_STUB. */
#ifndef DESKARM_MSP430_STUB_H
#define DESKARM_MSP430_STUB_H

#include <stdint.h>

#define STUB_REG16(name) extern volatile uint16_t name
#define STUB_REG8(name) extern volatile uint8_t name

STUB_REG16(WDTCTL);
STUB_REG8(CSCTL0_H);
STUB_REG16(CSCTL1);
STUB_REG16(CSCTL2);
STUB_REG16(CSCTL3);
STUB_REG16(PM5CTL0);
STUB_REG8(P1OUT);
STUB_REG8(P1DIR);
STUB_REG8(P1SEL0);
STUB_REG8(P1SEL1);
STUB_REG8(P1IN);
STUB_REG8(P1IES);
STUB_REG8(P1IE);
STUB_REG8(P1IFG);
STUB_REG16(P1IV);
STUB_REG8(P3OUT);
STUB_REG8(P3DIR);
STUB_REG8(P2SEL0);
STUB_REG8(P2SEL1);
STUB_REG16(UCA0CTLW0);
STUB_REG16(UCA0BRW);
STUB_REG16(UCA0MCTLW);
STUB_REG16(UCA0IE);
STUB_REG16(UCA0IV);
STUB_REG16(UCA0RXBUF);
STUB_REG16(UCA0TXBUF);
STUB_REG16(TA0CTL);
STUB_REG16(TA0R);
STUB_REG16(TA1CTL);
STUB_REG16(TA1CCTL0);
STUB_REG16(TA1CCTL2);
STUB_REG16(TA1CCR0);
STUB_REG16(TA1CCR2);
STUB_REG16(TB0CTL);
STUB_REG16(TB0CCTL1);
STUB_REG16(TB0CCTL2);
STUB_REG16(TB0CCR0);
STUB_REG16(TB0CCR1);
STUB_REG16(TB0CCR2);

#define BIT0 0x01u
#define BIT1 0x02u
#define BIT2 0x04u
#define BIT3 0x08u
#define BIT4 0x10u
#define BIT5 0x20u
#define BIT6 0x40u
#define BIT7 0x80u

#define WDTPW 0x5A00u
#define WDTHOLD 0x0080u
#define CSKEY 0xA500u
#define DCORSEL 0x0040u
#define DCOFSEL_3 0x0006u
#define SELA__VLOCLK 0x0100u
#define SELS__DCOCLK 0x0030u
#define SELM__DCOCLK 0x0003u
#define DIVA__1 0x0000u
#define DIVS__1 0x0000u
#define DIVM__1 0x0000u
#define LOCKLPM5 0x0001u

#define UCSWRST 0x0001u
#define UCSSEL__SMCLK 0x0080u
#define UCOS16 0x0001u
#define UCBRF_1 0x0010u
#define UCRXIE 0x0001u
#define UCTXIE 0x0002u
#define USCI_UART_UCRXIFG 0x0002u
#define USCI_UART_UCTXIFG 0x0004u

#define OUTMOD_0 0x0000u
#define OUTMOD_7 0x00E0u
#define CCIE 0x0010u
#define TASSEL__SMCLK 0x0200u
#define TBSSEL__SMCLK 0x0200u
#define ID__8 0x00C0u
#define MC__UP 0x0010u
#define MC__CONTINUOUS 0x0020u
#define TACLR 0x0004u
#define TBCLR 0x0004u

#define GIE 0x0008u
#define LPM0_bits 0x0010u

#define TIMER1_A0_VECTOR 40
#define USCI_A0_VECTOR 41
#define PORT1_VECTOR 39

extern int stub_gie;        /* 1 while interrupts are enabled */
extern int stub_sleeps;     /* times the CPU entered LPM0 */
extern int stub_wakeups;    /* times an interrupt cleared LPM0 on exit */
void __enable_interrupt(void);
void __disable_interrupt(void);
void __no_operation(void);
void __bis_SR_register(unsigned int bits);
void __bic_SR_register_on_exit(unsigned int bits);
void __delay_cycles(unsigned long cycles); /* the stub records the trigger pin's pulse */

#endif
