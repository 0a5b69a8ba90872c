#include "crc16.h"

/* Bitwise on purpose: a 512-byte table costs a quarter of the MSP430's RAM budget
 * if it lands in RAM, and frames are short (at most 37 CRC'd bytes). */
uint16_t crc16_ccitt_update(uint16_t crc, uint8_t byte)
{
    uint8_t bit;
    crc = (uint16_t)(crc ^ (uint16_t)((uint16_t)byte << 8));
    for (bit = 0; bit < 8u; bit++) {
        if ((crc & 0x8000u) != 0u) {
            crc = (uint16_t)((uint16_t)(crc << 1) ^ 0x1021u);
        } else {
            crc = (uint16_t)(crc << 1);
        }
    }
    return crc;
}

uint16_t crc16_ccitt(const uint8_t *data, uint16_t len)
{
    uint16_t crc = CRC16_CCITT_INIT;
    uint16_t i;
    for (i = 0; i < len; i++) {
        crc = crc16_ccitt_update(crc, data[i]);
    }
    return crc;
}
