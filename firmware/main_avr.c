/* ATmega328P (Arduino Uno/Nano) entry point: the MSP430's main loop without the range
 * sensor: drain the UART into fw, tick it at 50 Hz, hand the pulses to the timer, send
 * replies, sleep. */
#include "hal.h"
#include "src/fw.h"

#if HAL_RANGE_SENSOR
#error "main_avr.c: no range sensor on the ATmega328P build (RANGE_SENSOR=0)"
#endif

static fw_t fw;

int main(void)
{
    uint8_t out[16];
    hal_init();
    fw_init(&fw, HAL_JOINTS);
    hal_set_pulses(fw.pulse_us);
    for (;;) {
        uint8_t byte;
        uint8_t n;
        while (hal_uart_getc(&byte)) {
            fw_feed(&fw, byte);
        }
        for (n = hal_take_ticks(); n > 0u; n--) {
            fw_tick(&fw);
        }
        hal_set_pulses(fw.pulse_us);
        for (;;) {
            uint8_t room = hal_uart_tx_free();
            n = fw_take_tx(&fw, out, room < sizeof out ? room : (uint8_t)sizeof out);
            if (n == 0u) {
                break;
            }
            (void)hal_uart_write(out, n);
        }
        hal_wait_for_event();
    }
}
