"""The UMI-RTX controller's serial protocol: command bytes, reply parsing, chip selection — pure code.

Facts (bytes, command codes, reply types, error codes, motor-to-chip mapping, the 8 ms spacing,
9600 baud 8N1, the start-up handshake) are taken from the University of Amsterdam RTX driver as
published in ``gardegu/LAB42_RTX_control`` (non-commercial licence: facts only, no code):
``umi-drivers/rtxcmds.h`` (codes), ``umi-drivers/rtx.h`` (motors, modes, parameters, error
numbers), ``rtxlib/rtxcmds.c`` (which chip and controller a motor is on, GO bit layout, the
4-bit checksum, how each command is answered). That repository does not store the daemon's
``ttyio.c`` nor ``rtxlib/raw.c``; the line-level facts (8 ms between writes, 100 ms read
timeout retried once, the handshake, resynchronisation, toggle handling) come from a copy of
``ttyio.c`` (``$Id: ttyio.c,v 1.7 2006/06/21``) found in another stored repository.

The line. One RS-232 line at 9600 baud, 8 data bits, no parity, 1 stop bit, carries both
controller chips ("IPs"): IP0 drives WRIST1 and WRIST2, IP1 drives ELBOW, SHOULDER, ZED, YAW and
the GRIPPER. Only one chip listens at a time. TOGGLE_ONCE hands the line to the other chip after
its reply; TOGGLE_ON makes a chip hand it over after every reply; TOGGLE_OFF stops that. deskarm
runs with toggling off and selects a chip with TOGGLE_ONCE when it needs the other one.

A command is 1 or 3 bytes (the first byte says which); every command gets a reply of 1 or 3
bytes whose first byte's high nibble says its type. Replies 0x01–0x0F are errors (0x0E/0x0F: the
chip restarted and answers nothing else until it gets GO, 0x00).

Units: encoder counts (signed 16-bit) on the wire; conversions to joint values live in
``core.kinematics.umi_rtx``.
"""
from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Mapping, Optional

BAUDRATE = 9600
BITS_PER_BYTE = 10  # start + 8 data + stop
COMMAND_SPACING_S = 0.008  # the driver never writes two commands closer than 8 ms
READ_TIMEOUT_S = 0.1  # the driver's VTIME: one byte must arrive within 100 ms (retried once)
WORD_MIN, WORD_MAX = -32768, 32767  # parameters are signed 16-bit

IP0, IP1 = 0, 1

# ---------------------------------------------------------------- command bytes (first byte)
CMD_GO = 0x00  # also "leave the restarted state"
CMD_IDENTIFY = 0x01
CMD_STAT_CTL = 0x10  # + controller 0..4: 3-byte reply
CMD_STAT_GENERAL = 0x17
CMD_MODE_SET = 0x18  # + mode 0..5, then controller, 0
CMD_IP_RESET = 0x20
CMD_IP_DEF_HOME = 0x21  # every encoder of the chip := 0 ("define origin")
CMD_IP_DEFAULT = 0x22  # reload the default PID parameters
CMD_STOP = 0x24  # + stop mode 0..3
CMD_TOGGLE_OFF = 0x28
CMD_TOGGLE_ONCE = 0x29
CMD_TOGGLE_ON = 0x2A
CMD_VERSION = 0x38
CMD_IM_READ_ERR = 0x40  # + controller: following error
CMD_IM_READ_CP = 0x48  # + controller: current (setpoint) position
CMD_IM_WRITE_CP = 0x58  # + controller, lo, hi: set the encoder count
CMD_DEF_READ1 = 0x60  # , code, 0: choose the parameter to read
CMD_DEF_READ2 = 0x68  # + controller: read it
CMD_DEF_WRITE1 = 0x70  # , code, 0: choose the parameter to write
CMD_DEF_WRITE2 = 0x78  # + controller, lo, hi: write it
CMD_DIR_MAN = 0x80  # , lo, hi: manual drive, 2 bits per controller
CMD_DIR_NUM = 0xA0  # | 1 bit per controller: go to NEW_POSITION
CMD_INTERP = 0xE0

# ---------------------------------------------------------------- replies
RESP_ACK = 0x00
RESP_TYPE_MASK = 0xF0
RESP_TYPE_SIMPLE = 0x00
RESP_TYPE_STAT = 0x10
RESP_TYPE_ID = 0x20
RESP_TYPE_IM_READ = 0x80
RESP_TYPE_IM_WRITE = 0xA0
RESP_TYPE_DEF_R1 = 0xC0
RESP_TYPE_DEF_R2 = 0xD0
RESP_TYPE_DEF_W1 = 0xE0
RESP_TYPE_DEF_W2 = 0xF0
RESP_IDENTIFY_0 = 0x20  # | chip number
RESP_IP_RESTART1 = 0x0E
RESP_IP_RESTART = 0x0F
THREE_BYTE_REPLIES = (RESP_TYPE_STAT, RESP_TYPE_IM_READ, RESP_TYPE_DEF_R2)


class ReplyCode(enum.IntEnum):
    """The controller's one-byte error replies (0x01–0x0F)."""

    PROGRESS = 0x01
    STORED = 0x02
    AXIS_BUSY = 0x03
    IP_BUSY = 0x04
    PARAM_OOR = 0x05
    READ_ONLY = 0x06
    READ_ONLY1 = 0x07
    SELECT_OOR = 0x08
    CMD_OOR = 0x09
    CMD_NOT_SUPPORTED = 0x0A
    FRAME_TIMEOUT = 0x0B
    FRAME_OVERRUN = 0x0C
    PARITY = 0x0D
    RESTART1 = 0x0E
    RESTART = 0x0F


REPLY_TEXT = {
    ReplyCode.PROGRESS: "command still in progress",
    ReplyCode.STORED: "command stored, not yet executed",
    ReplyCode.AXIS_BUSY: "axis busy: the motor is still executing its previous move",
    ReplyCode.IP_BUSY: "controller chip busy (decoder busy)",
    ReplyCode.PARAM_OOR: "parameter out of range",
    ReplyCode.READ_ONLY: "parameter is read-only",
    ReplyCode.READ_ONLY1: "parameter is read-only",
    ReplyCode.SELECT_OOR: "no such motor controller on this chip",
    ReplyCode.CMD_OOR: "command out of range",
    ReplyCode.CMD_NOT_SUPPORTED: "command not supported by the controller",
    ReplyCode.FRAME_TIMEOUT: "frame timeout: the command's bytes arrived too far apart",
    ReplyCode.FRAME_OVERRUN: "frame overrun: bytes arrived while the controller was busy",
    ReplyCode.PARITY: "parity error on the line (check 9600 baud, 8N1)",
    ReplyCode.RESTART1: "the controller restarted (power cycle or reset): encoder positions are lost",
    ReplyCode.RESTART: "the controller restarted (power cycle or reset): encoder positions are lost",
}


def describe_reply(code: int) -> str:
    """A controller error reply (0x01–0x0F) in words."""
    try:
        return REPLY_TEXT[ReplyCode(code)]
    except ValueError:
        return f"unknown reply 0x{code:02X}"


# ---------------------------------------------------------------- motors
ELBOW, SHOULDER, ZED, WRIST1, WRIST2, YAW, GRIPPER = range(7)  # the driver's motor numbers
MOTOR_NAMES = ("ELBOW", "SHOULDER", "ZED", "WRIST1", "WRIST2", "YAW", "GRIPPER")
MOTOR_BY_NAME = {n: i for i, n in enumerate(MOTOR_NAMES)}
MOTOR_IP = {ELBOW: IP1, SHOULDER: IP1, ZED: IP1, YAW: IP1, GRIPPER: IP1, WRIST1: IP0, WRIST2: IP0}
MOTOR_CTL = {ELBOW: 0, SHOULDER: 1, ZED: 2, WRIST1: 2, YAW: 3, WRIST2: 3, GRIPPER: 4}
CTL_COUNT = 5  # controllers per chip (IP0 has only 2 and 3 fitted)
FITTED = {IP0: frozenset({2, 3}), IP1: frozenset({0, 1, 2, 3, 4})}


def motor_of(ip: int, ctl: int) -> Optional[int]:
    """The motor on chip ``ip``, controller ``ctl`` (None: not fitted)."""
    for m, i in MOTOR_IP.items():
        if i == ip and MOTOR_CTL[m] == ctl:
            return m
    return None


class Param(enum.IntEnum):
    """Parameter (data) codes of a motor controller."""

    ERROR = 0
    CURRENT_POSITION = 1
    ERROR_LIMIT = 2
    NEW_POSITION = 3
    SPEED = 4
    KP = 5
    KI = 6
    KD = 7
    DEAD_BAND = 8
    OFFSET = 9
    MAX_FORCE = 10
    CURRENT_FORCE = 11
    ACCELERATION_TIME = 12
    USER_RAM = 13
    USER_IO = 14


class StopMode(enum.IntEnum):
    DEAD = 0  # stop at once and hold
    RAMP = 1  # decelerate, then hold
    FREE = 2  # motors unpowered
    FREE_OFF = 3  # end FREE: motors powered again (the driver's "enable PWM output")


class Drive(enum.IntEnum):
    """Manual drive per motor (2 bits each)."""

    STOP = 0
    FWD = 1  # encoder counts increase
    RVS = 2
    OFF = 3


# motor status bits (reply to STAT_CTL) and general status bits (STAT_GENERAL)
STAT_IN_PROGRESS = 0x01
STAT_STOPPED = 0x02
STAT_ERROR_LIMIT = 0x04
STAT_RESET = 0x08  # the axis was reset: it stopped on its error limit (end stop, obstacle)
GEN_TASKS = 0x01
GEN_AXIS_STOPPED = 0x02
GEN_ERROR_LIMITS = 0x04
GEN_AXIS_RESET = 0x08


class RtxProtocolError(ValueError):
    """A value that cannot be encoded, or a reply that does not parse; the text says which."""


def _byte(v: int) -> int:
    return int(v) & 0xFF


def _word(value: int, what: str) -> tuple[int, int]:
    v = int(value)
    if not WORD_MIN <= v <= WORD_MAX:
        raise RtxProtocolError(f"{what} = {v} does not fit the controller's 16-bit word ({WORD_MIN}…{WORD_MAX})")
    v &= 0xFFFF
    return v & 0xFF, v >> 8


def _ctl(ctl: int) -> int:
    if not 0 <= int(ctl) < CTL_COUNT:
        raise RtxProtocolError(f"controller {ctl} is outside 0…{CTL_COUNT - 1}")
    return int(ctl)


def command_length(first: int) -> int:
    """How many bytes a command has, from its first byte (1 or 3)."""
    first &= 0xFF
    if CMD_MODE_SET <= first <= CMD_MODE_SET + 5:
        return 3
    if first >= 0x80:  # directives and interpolation
        return 1 if first & 0xE0 == CMD_DIR_NUM else 3
    if first & 0xF8 in (CMD_IM_WRITE_CP, CMD_DEF_READ1, CMD_DEF_WRITE1, CMD_DEF_WRITE2):
        return 3
    return 1


def reply_length(first: int, command_first: int) -> int:
    """How many bytes a reply has, from its first byte and the command it answers (1 or 3)."""
    kind = first & RESP_TYPE_MASK
    if kind in THREE_BYTE_REPLIES:
        return 3
    if kind == RESP_TYPE_ID and (command_first & 0xFF) == CMD_VERSION:
        return 3
    return 1


def is_known_reply_type(first: int) -> bool:
    """False for first bytes no command is answered with (0x3_–0x7_, 0x9_, 0xB_): garbage."""
    return (first & RESP_TYPE_MASK) in (RESP_TYPE_SIMPLE, RESP_TYPE_STAT, RESP_TYPE_ID, RESP_TYPE_IM_READ,
                                        RESP_TYPE_IM_WRITE, RESP_TYPE_DEF_R1, RESP_TYPE_DEF_R2,
                                        RESP_TYPE_DEF_W1, RESP_TYPE_DEF_W2)


def checksum(b1: int, b2: int) -> int:
    """The 4-bit checksum of a data word (low byte, high byte): both nibbles of both, XORed."""
    return ((b1 >> 4) ^ b1 ^ (b2 >> 4) ^ b2) & 0x0F


# ---------------------------------------------------------------- encoders (one command each)

def identify() -> bytes:
    return bytes([CMD_IDENTIFY])


def go_restart() -> bytes:
    """GO (0x00): a restarted chip answers ACK and works again."""
    return bytes([CMD_GO])


def toggle_off() -> bytes:
    return bytes([CMD_TOGGLE_OFF])


def toggle_once() -> bytes:
    return bytes([CMD_TOGGLE_ONCE])


def toggle_on() -> bytes:
    return bytes([CMD_TOGGLE_ON])


def version() -> bytes:
    return bytes([CMD_VERSION])


def stop(mode: StopMode) -> bytes:
    return bytes([CMD_STOP | StopMode(mode)])


def define_home() -> bytes:
    return bytes([CMD_IP_DEF_HOME])


def reload_pids() -> bytes:
    return bytes([CMD_IP_DEFAULT])


def motor_status(ctl: int) -> bytes:
    return bytes([CMD_STAT_CTL | _ctl(ctl)])


def general_status() -> bytes:
    return bytes([CMD_STAT_GENERAL])


def read_position(ctl: int) -> bytes:
    """IM_READ_CP: the controller's current (setpoint) position."""
    return bytes([CMD_IM_READ_CP | _ctl(ctl)])


def read_error(ctl: int) -> bytes:
    """IM_READ_ERR: setpoint minus measured position (actual = position − error)."""
    return bytes([CMD_IM_READ_ERR | _ctl(ctl)])


def write_position(ctl: int, counts: int) -> bytes:
    """IM_WRITE_CP: make the encoder read ``counts`` where the motor is now."""
    lo, hi = _word(counts, "position")
    return bytes([CMD_IM_WRITE_CP | _ctl(ctl), lo, hi])


def select_write(code: Param) -> bytes:
    """DEF_WRITE1: the parameter the next DEF_WRITE2 writes."""
    return bytes([CMD_DEF_WRITE1, Param(code), 0])


def write_param(ctl: int, value: int) -> bytes:
    """DEF_WRITE2: write the selected parameter of one controller."""
    lo, hi = _word(value, "parameter")
    return bytes([CMD_DEF_WRITE2 | _ctl(ctl), lo, hi])


def select_read(code: Param) -> bytes:
    """DEF_READ1: the parameter the next DEF_READ2 reads."""
    return bytes([CMD_DEF_READ1, Param(code), 0])


def read_param(ctl: int) -> bytes:
    return bytes([CMD_DEF_READ2 | _ctl(ctl)])


def numeric_go(ctls) -> bytes:
    """DIR_NUM: every listed controller of this chip moves to its NEW_POSITION."""
    bits = 0
    for c in ctls:
        bits |= 1 << _ctl(c)
    return bytes([CMD_DIR_NUM | bits])


def manual_go(drives: Mapping[int, Drive]) -> bytes:
    """DIR_MAN: drive controllers forward/reverse at their speed until stopped (2 bits each)."""
    bits = 0
    for c, d in drives.items():
        bits |= int(Drive(d)) << (2 * _ctl(c))
    return bytes([CMD_DIR_MAN, bits & 0xFF, bits >> 8])


def split_by_chip(motors) -> dict[int, list[int]]:
    """{chip: [controller, …]} for motor numbers."""
    out: dict[int, list[int]] = {}
    for m in motors:
        out.setdefault(MOTOR_IP[m], []).append(MOTOR_CTL[m])
    return out


# ---------------------------------------------------------------- replies

@dataclass(frozen=True)
class Reply:
    """One reply from a chip: its bytes and what they mean."""

    data: bytes

    @property
    def first(self) -> int:
        return self.data[0]

    @property
    def is_error(self) -> bool:
        return 0x01 <= self.first <= 0x0F

    @property
    def is_restart(self) -> bool:
        return self.first in (RESP_IP_RESTART, RESP_IP_RESTART1)

    def identified_chip(self) -> Optional[int]:
        """The chip a reply to IDENTIFY names (None: not an identify reply)."""
        if len(self.data) == 1 and self.first in (RESP_IDENTIFY_0, RESP_IDENTIFY_0 | 1):
            return self.first & 0x07
        return None

    def word(self) -> int:
        """The signed 16-bit value of a 3-byte read reply; RtxProtocolError on a bad checksum."""
        if len(self.data) != 3:
            raise RtxProtocolError(f"reply {self.data.hex()} carries no value")
        lo, hi = self.data[1], self.data[2]
        if (self.first & 0x0F) != checksum(lo, hi) and (self.first & RESP_TYPE_MASK) != RESP_TYPE_STAT:
            raise RtxProtocolError(f"reply {self.data.hex()}: checksum mismatch")
        v = lo | (hi << 8)
        return v - 0x10000 if v > 0x7FFF else v


def word_reply(kind: int, value: int) -> bytes:
    """A 3-byte read reply (type ``kind``) carrying ``value`` with its checksum (the emulator's side)."""
    lo, hi = _word(value, "value")
    return bytes([kind | checksum(lo, hi), lo, hi])


def write_ack(kind: int, lo: int, hi: int) -> bytes:
    """The 1-byte reply to a 3-byte write (IM_WRITE, DEF_WRITE2): type and the data's checksum."""
    return bytes([kind | checksum(lo, hi)])
