/* CRC-16/CCITT-FALSE: poly 0x1021, init 0xFFFF, no reflection, no final XOR.
 * Check value: crc16_ccitt("123456789") == 0x29B1 (the catalogue's "check"). */
#ifndef DESKARM_CRC16_H
#define DESKARM_CRC16_H

#include <stdint.h>

#define CRC16_CCITT_INIT 0xFFFFu

/* Fold one byte into a running CRC (start from CRC16_CCITT_INIT). */
uint16_t crc16_ccitt_update(uint16_t crc, uint8_t byte);

/* CRC of a whole buffer. */
uint16_t crc16_ccitt(const uint8_t *data, uint16_t len);

#endif
