"""deskarm serial protocol v2: framed, checksummed, sequenced (pure: no Qt, threads or serial).

The byte-by-byte specification is ``firmware/PROTOCOL.md``; the shared test vectors are
``firmware/vectors.json``. In short::

    F5 F5 | stuffed( LEN TYPE SEQ PAYLOAD[LEN] CRC_HI CRC_LO ) | F7

CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, no reflection, no final XOR) over
LEN TYPE SEQ PAYLOAD before stuffing, sent big-endian. Inside the stuffed part the bytes
F5 F6 F7 FB FC FD are sent as F6 followed by the byte XOR 0x20, so a frame never carries a
raw v1 selector (0xFB..0xFD) and a raw F5 always means "a frame starts". Multi-byte fields
are big-endian. Angles travel as centidegrees (0..18000) — the degrees live only here, at
the edge of the program.
"""
from __future__ import annotations

import binascii
from dataclasses import dataclass
from enum import IntEnum, IntFlag
from typing import Optional, Sequence, Union

SYNC = 0xF5
ESC = 0xF6
END = 0xF7
ESC_XOR = 0x20
V1_SELECTORS = (0xFB, 0xFC, 0xFD)
ESCAPED = frozenset((SYNC, ESC, END) + V1_SELECTORS)  # never raw inside a frame body

MAX_PAYLOAD = 32
MAX_JOINTS = 8
ANGLE_KEEP = 0xFFFF  # SET_JOINTS value meaning "leave this joint where it is heading"
ANGLE_MAX_CDEG = 18000
CONFIG_ALL_JOINTS = 0xFF
PULSE_MIN_US = 400  # lowest min_pulse_us a CONFIG may set
PULSE_MAX_US = 3000  # highest max_pulse_us a CONFIG may set
SPEED_MAX_DPS = 1000  # highest max_speed_dps a CONFIG may set; 0 = unlimited
STATUS_HEADER_LEN = 8
RANGE_LEN = 4  # RANGE payload: distance_mm u16, tick u16
RANGE_NO_READING = 0xFFFF  # RANGE distance meaning no echo, nearer than 20 mm or farther than 4 m
RANGE_MIN_MM = 20  # the HC-SR04's near limit: the board reports nothing nearer
RANGE_MAX_MM = 4000  # its far limit
RANGE_HZ = 10  # a board with a range sensor measures and sends RANGE this often
WATCHDOG_S = 0.5  # the board holds and flags after this long without a valid frame
TICK_HZ = 50  # the board's servo period and rate-limiter tick


class MsgType(IntEnum):
    """Frame TYPE byte; bit 7 set means board to host."""

    SET_JOINTS = 0x01
    CONFIG = 0x02
    ESTOP = 0x03
    ARM = 0x04
    PING = 0x05
    STATUS = 0x81
    RANGE = 0x82


class Flag(IntFlag):
    """STATUS flags."""

    V2_MODE = 0x01  # locked into v2: v1 bytes are ignored until the board resets
    ESTOP = 0x02  # pulses off until an ARM frame
    WATCHDOG = 0x04  # no valid frame for 500 ms, holding position (latched until SET_JOINTS)
    MOVING = 0x08  # a joint is still ramping to its target
    CONFIG_REJECTED = 0x10  # the last CONFIG was out of range and ignored
    CLAMPED = 0x20  # the last SET_JOINTS had an angle above 180.00 deg


def crc16_ccitt(data: bytes, crc: int = 0xFFFF) -> int:
    """CRC-16/CCITT-FALSE of ``data``; ``crc16_ccitt(b"123456789") == 0x29B1``.

    ``binascii.crc_hqx`` is exactly this CRC when started from 0xFFFF.
    """
    return binascii.crc_hqx(bytes(data), crc)


def _stuff(body: bytes) -> bytes:
    out = bytearray()
    for b in body:
        if b in ESCAPED:
            out += bytes((ESC, b ^ ESC_XOR))
        else:
            out.append(b)
    return bytes(out)


def encode_frame(msg_type: int, seq: int, payload: bytes = b"") -> bytes:
    """One frame on the wire for any TYPE byte (validity of the payload is the caller's)."""
    if not 0 <= seq <= 0xFF:
        raise ValueError(f"seq {seq} out of range: expected 0..255")
    if not 0 <= msg_type <= 0xFF:
        raise ValueError(f"msg_type {msg_type} out of range: expected 0..255")
    if len(payload) > MAX_PAYLOAD:
        raise ValueError(f"payload of {len(payload)} bytes is too long: at most {MAX_PAYLOAD}")
    body = bytes((len(payload), msg_type, seq)) + bytes(payload)
    body += crc16_ccitt(body).to_bytes(2, "big")
    return bytes((SYNC, SYNC)) + _stuff(body) + bytes((END,))


def _u16(value: int, name: str) -> bytes:
    if not 0 <= value <= 0xFFFF:
        raise ValueError(f"{name} {value} out of range: expected 0..65535")
    return int(value).to_bytes(2, "big")


def encode_set_joints_cdeg(seq: int, angles_cdeg: Sequence[Optional[int]]) -> bytes:
    """SET_JOINTS in centidegrees (0..18000); None leaves that joint alone."""
    if not 1 <= len(angles_cdeg) <= MAX_JOINTS:
        raise ValueError(f"{len(angles_cdeg)} joints: expected 1..{MAX_JOINTS}")
    payload = bytearray()
    for i, a in enumerate(angles_cdeg):
        if a is None:
            payload += _u16(ANGLE_KEEP, "angle")
        elif not 0 <= a <= ANGLE_MAX_CDEG:
            raise ValueError(f"joint {i + 1}: {a} cdeg out of range: expected 0..{ANGLE_MAX_CDEG}")
        else:
            payload += _u16(int(a), "angle")
    return encode_frame(MsgType.SET_JOINTS, seq, bytes(payload))


def encode_set_joints(seq: int, angles_deg: Sequence[Optional[float]]) -> bytes:
    """SET_JOINTS from degrees (0..180, rounded to 0.01 deg); None leaves that joint alone."""
    cdeg: list[Optional[int]] = []
    for i, a in enumerate(angles_deg):
        if a is None:
            cdeg.append(None)
            continue
        if not 0.0 <= a <= 180.0:
            raise ValueError(f"joint {i + 1}: {a} deg out of range: expected 0..180")
        cdeg.append(int(round(a * 100.0)))
    return encode_set_joints_cdeg(seq, cdeg)


def encode_config(
    seq: int, joint: int, min_pulse_us: int, max_pulse_us: int, max_speed_dps: int
) -> bytes:
    """CONFIG for one joint (0-based) or every joint (CONFIG_ALL_JOINTS).

    The board rejects out-of-range values with Flag.CONFIG_REJECTED; this encoder lets
    them through so tests can send them.
    """
    if not 0 <= joint <= 0xFF:
        raise ValueError(f"joint {joint} out of range: expected 0..{MAX_JOINTS - 1} or 255")
    payload = (
        bytes((joint,))
        + _u16(min_pulse_us, "min_pulse_us")
        + _u16(max_pulse_us, "max_pulse_us")
        + _u16(max_speed_dps, "max_speed_dps")
    )
    return encode_frame(MsgType.CONFIG, seq, payload)


def encode_estop(seq: int) -> bytes:
    """ESTOP: every pulse off until ARM."""
    return encode_frame(MsgType.ESTOP, seq)


def encode_arm(seq: int) -> bytes:
    """ARM: end an e-stop; the joints resume where they were held."""
    return encode_frame(MsgType.ARM, seq)


def encode_ping(seq: int) -> bytes:
    """PING: a heartbeat that feeds the watchdog and asks for a STATUS reply."""
    return encode_frame(MsgType.PING, seq)


def encode_status(
    seq: int,
    flags: int,
    pulses_us: Sequence[int],
    good_frames: int = 0,
    bad_frames: int = 0,
    dropped_bytes: int = 0,
) -> bytes:
    """STATUS (board to host), for simulated boards and tests."""
    if not 1 <= len(pulses_us) <= MAX_JOINTS:
        raise ValueError(f"{len(pulses_us)} pulses: expected 1..{MAX_JOINTS}")
    if not 0 <= flags <= 0xFF:
        raise ValueError(f"flags {flags} out of range: expected 0..255")
    payload = bytes((int(flags), len(pulses_us)))
    payload += _u16(good_frames, "good_frames") + _u16(bad_frames, "bad_frames")
    payload += _u16(dropped_bytes, "dropped_bytes")
    for p in pulses_us:
        payload += _u16(p, "pulse_us")
    return encode_frame(MsgType.STATUS, seq, payload)


def encode_range(seq: int, distance_mm: Optional[int], tick: int) -> bytes:
    """RANGE (board to host), for simulated boards and tests; None = no valid reading."""
    mm = RANGE_NO_READING if distance_mm is None else int(distance_mm)
    return encode_frame(MsgType.RANGE, seq, _u16(mm, "distance_mm") + _u16(tick, "tick"))


@dataclass(frozen=True)
class SetJointsFrame:
    """Host to board: joint targets."""

    seq: int
    angles_cdeg: tuple[Optional[int], ...]  # None = keep; may exceed 18000 (the board clamps)

    @property
    def angles_deg(self) -> tuple[Optional[float], ...]:
        """The targets in degrees (None = keep)."""
        return tuple(None if a is None else a / 100.0 for a in self.angles_cdeg)


@dataclass(frozen=True)
class ConfigFrame:
    """Host to board: per-joint pulse range and speed limit."""

    seq: int
    joint: int  # 0-based, or CONFIG_ALL_JOINTS
    min_pulse_us: int  # pulse at 0 deg
    max_pulse_us: int  # pulse at 180 deg
    max_speed_dps: int  # deg/s, 0 = unlimited


@dataclass(frozen=True)
class EstopFrame:
    """Host to board: pulses off until ARM."""

    seq: int


@dataclass(frozen=True)
class ArmFrame:
    """Host to board: end an e-stop."""

    seq: int


@dataclass(frozen=True)
class PingFrame:
    """Host to board: heartbeat, asks for STATUS."""

    seq: int


@dataclass(frozen=True)
class StatusFrame:
    """Board to host: the reply to a PING (seq echoes the PING's)."""

    seq: int
    flags: Flag
    pulses_us: tuple[int, ...]  # one per joint on the board; 0 = pulse off
    good_frames: int  # counters wrap modulo 65536: compare deltas
    bad_frames: int
    dropped_bytes: int

    @property
    def n_joints(self) -> int:
        """How many joints the board drives."""
        return len(self.pulses_us)


@dataclass(frozen=True)
class RangeFrame:
    """Board to host: one HC-SR04 reading, sent unasked at RANGE_HZ by a board with a sensor.

    ``seq`` is the board's own RANGE count (a gap means readings were lost); ``tick`` the
    board's 50 Hz tick count when the measurement was triggered (wraps modulo 65536).
    """

    seq: int
    distance_mm: int  # 20..4000, or RANGE_NO_READING
    tick: int

    @property
    def distance_m(self) -> Optional[float]:
        """The distance in metres, or None when the sensor had no valid reading (or the board
        sent a value outside the sensor's 20–4000 mm, which a conforming board never does)."""
        if not RANGE_MIN_MM <= self.distance_mm <= RANGE_MAX_MM:
            return None
        return self.distance_mm / 1000.0


Frame = Union[SetJointsFrame, ConfigFrame, EstopFrame, ArmFrame, PingFrame, StatusFrame, RangeFrame]


def _u16_at(p: bytes, i: int) -> int:
    return (p[i] << 8) | p[i + 1]


def parse_payload(msg_type: int, seq: int, payload: bytes) -> Optional[Frame]:
    """The frame for a CRC-valid TYPE/SEQ/PAYLOAD, or None if the type or length is wrong."""
    n = len(payload)
    if msg_type == MsgType.SET_JOINTS:
        if n < 2 or n > 2 * MAX_JOINTS or n % 2:
            return None
        angles = tuple(_u16_at(payload, i) for i in range(0, n, 2))
        return SetJointsFrame(seq, tuple(None if a == ANGLE_KEEP else a for a in angles))
    if msg_type == MsgType.CONFIG:
        if n != 7:
            return None
        return ConfigFrame(
            seq, payload[0], _u16_at(payload, 1), _u16_at(payload, 3), _u16_at(payload, 5)
        )
    if msg_type in (MsgType.ESTOP, MsgType.ARM, MsgType.PING):
        if n != 0:
            return None
        cls = {MsgType.ESTOP: EstopFrame, MsgType.ARM: ArmFrame, MsgType.PING: PingFrame}
        return cls[MsgType(msg_type)](seq)
    if msg_type == MsgType.STATUS:
        if n < STATUS_HEADER_LEN:
            return None
        joints = payload[1]
        if not 1 <= joints <= MAX_JOINTS or n != STATUS_HEADER_LEN + 2 * joints:
            return None
        pulses = tuple(_u16_at(payload, STATUS_HEADER_LEN + 2 * j) for j in range(joints))
        return StatusFrame(
            seq=seq,
            flags=Flag(payload[0]),
            pulses_us=pulses,
            good_frames=_u16_at(payload, 2),
            bad_frames=_u16_at(payload, 4),
            dropped_bytes=_u16_at(payload, 6),
        )
    if msg_type == MsgType.RANGE:
        if n != RANGE_LEN:
            return None
        return RangeFrame(seq=seq, distance_mm=_u16_at(payload, 0), tick=_u16_at(payload, 2))
    return None


def encode(frame: Frame) -> bytes:
    """Encode a decoded frame again (encode(decode(x)) == x for every valid frame x)."""
    if isinstance(frame, SetJointsFrame):
        payload = b"".join(
            _u16(ANGLE_KEEP if a is None else a, "angle") for a in frame.angles_cdeg
        )
        return encode_frame(MsgType.SET_JOINTS, frame.seq, payload)
    if isinstance(frame, ConfigFrame):
        return encode_config(
            frame.seq, frame.joint, frame.min_pulse_us, frame.max_pulse_us, frame.max_speed_dps
        )
    if isinstance(frame, EstopFrame):
        return encode_estop(frame.seq)
    if isinstance(frame, ArmFrame):
        return encode_arm(frame.seq)
    if isinstance(frame, PingFrame):
        return encode_ping(frame.seq)
    if isinstance(frame, StatusFrame):
        return encode_status(
            frame.seq,
            int(frame.flags),
            frame.pulses_us,
            frame.good_frames,
            frame.bad_frames,
            frame.dropped_bytes,
        )
    if isinstance(frame, RangeFrame):
        return encode_range(frame.seq, frame.distance_mm, frame.tick)
    raise TypeError(f"not a v2 frame: {frame!r}")


# receiver states, as in firmware/src/link.c
_HUNT, _SYNC1, _SYNCED, _BODY, _END = range(5)


class V2Decoder:
    """Incremental v2 decoder: ``feed(bytes) -> [frames]``, resynchronising after garbage.

    Counts exactly as the firmware does (firmware/src/link.c, minus v1):
    ``good_frames`` valid frames; ``bad_frames`` frame attempts rejected (CRC, length,
    escape, unknown type, cut short by a new sync or a stray byte); ``dropped_bytes`` bytes
    outside frames (including a lone F5 and the byte after it, and surplus F5 preamble).
    """

    def __init__(self) -> None:
        self.good_frames = 0
        self.bad_frames = 0
        self.dropped_bytes = 0
        self._state = _HUNT
        self._escaped = False
        self._body = bytearray()

    def reset(self) -> None:
        """Forget a partial frame (e.g. after reopening the port); counters are kept."""
        self._state = _HUNT
        self._escaped = False
        self._body.clear()

    def _reject(self, next_state: int) -> None:
        self.bad_frames += 1
        self._state = next_state

    def _body_byte(self, b: int) -> None:
        if b == SYNC:
            self._reject(_SYNC1)
            return
        if b in V1_SELECTORS or b == END:
            self._reject(_HUNT)
            return
        if self._escaped:
            self._escaped = False
            if (b ^ ESC_XOR) not in ESCAPED:
                self._reject(_HUNT)
                return
            b ^= ESC_XOR
        elif b == ESC:
            self._escaped = True
            return
        self._body.append(b)
        if len(self._body) == 1 and b > MAX_PAYLOAD:
            self._reject(_HUNT)
            return
        if len(self._body) == self._body[0] + 5:
            self._state = _END

    def _finish(self) -> Optional[Frame]:
        self._state = _HUNT
        body = bytes(self._body)
        n = body[0]
        frame = None
        if crc16_ccitt(body[: n + 3]) == _u16_at(body, n + 3):
            frame = parse_payload(body[1], body[2], body[3 : n + 3])
        if frame is None:
            self.bad_frames += 1
        else:
            self.good_frames += 1
        return frame

    def feed(self, data: bytes) -> list[Frame]:
        """Consume bytes; return the frames completed by them, in order."""
        frames: list[Frame] = []
        for b in bytes(data):
            st = self._state
            if st == _HUNT:
                if b == SYNC:
                    self._state = _SYNC1
                else:
                    self.dropped_bytes += 1
            elif st == _SYNC1:
                if b == SYNC:
                    self._state = _SYNCED
                else:
                    self.dropped_bytes += 2
                    self._state = _HUNT
            elif st == _SYNCED:
                if b == SYNC:
                    self.dropped_bytes += 1
                else:
                    self._state = _BODY
                    self._body.clear()
                    self._escaped = False
                    self._body_byte(b)
            elif st == _BODY:
                self._body_byte(b)
            else:  # _END
                if b == END:
                    frame = self._finish()
                    if frame is not None:
                        frames.append(frame)
                else:
                    self._reject(_SYNC1 if b == SYNC else _HUNT)
        return frames


def decode_frame(data: bytes) -> Frame:
    """Decode exactly one complete frame; raise ValueError naming what is wrong."""
    dec = V2Decoder()
    frames = dec.feed(data)
    if len(frames) != 1 or dec.bad_frames or dec.dropped_bytes or dec._state != _HUNT:
        raise ValueError(
            f"not exactly one valid v2 frame: {bytes(data).hex(' ')} "
            f"({len(frames)} frames, {dec.bad_frames} bad, {dec.dropped_bytes} dropped bytes)"
        )
    return frames[0]
