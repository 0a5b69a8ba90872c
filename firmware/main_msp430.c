/* MSP430 entry point: drain the UART into fw, tick it at 50 Hz, drive the PWM, time the range
 * sensor (when fitted), sleep. */
#include "hal.h"
#include "src/fw.h"

static fw_t fw;

int main(void)
{
    uint8_t out[16];
    hal_init();
    fw_init(&fw, HAL_JOINTS);
    fw_range_enable(&fw, HAL_RANGE_SENSOR);
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
        if (fw_range_due(&fw)) {
            if (fw.range_measuring) {
                uint16_t echo_us = 0; /* stays 0 when no echo ended: "no echo" */
                (void)hal_range_take(&echo_us);
                fw_range_result(&fw, echo_us);
            }
            hal_range_start();
            fw_range_started(&fw);
        }
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
