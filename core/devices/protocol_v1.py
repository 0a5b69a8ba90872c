"""The seed serial protocol (v1), byte for byte.

9600 8N1. Selector bytes 0xFB, 0xFC, 0xFD choose joint 1, 2, 3 and stay selected; an angle byte
0x00–0xB4 (0–180°) sets the selected joint; every other byte is ignored by the seed firmware,
which maps an angle to a pulse of 900 + 10·angle µs every 20 ms.
"""
from __future__ import annotations

from typing import Sequence

V1_BAUD = 9600
V1_SELECTORS = (0xFB, 0xFC, 0xFD)
V1_MAX_ANGLE_DEG = 180


def encode_v1(angles_deg: Sequence[int]) -> bytes:
    """``FB a1 FC a2 FD a3`` for up to three whole-degree servo angles in 0–180.

    Raises ValueError for anything else: callers clamp first (core.motion.safety), and an angle byte
    above 0xB4 would be read by the firmware as a selector or ignored.
    """
    if not 1 <= len(angles_deg) <= len(V1_SELECTORS):
        raise ValueError(f"v1 carries 1–3 joints, got {len(angles_deg)}")
    out = bytearray()
    for selector, angle in zip(V1_SELECTORS, angles_deg):
        if isinstance(angle, bool) or not isinstance(angle, int) or not 0 <= angle <= V1_MAX_ANGLE_DEG:
            raise ValueError(f"v1 angle {angle!r} is not a whole degree in 0…{V1_MAX_ANGLE_DEG}")
        out += bytes((selector, angle))
    return bytes(out)


def v1_pulse_us(angle_deg: int) -> int:
    """The seed firmware's pulse width for an angle byte."""
    return 900 + 10 * int(angle_deg)
