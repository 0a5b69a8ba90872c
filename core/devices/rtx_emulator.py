"""An emulated UMI-RTX controller and arm, to test the RTX bridge against (``rtx:sim``).

``RtxController`` is the controller's logic, driven by ``handle(command_bytes, t)`` and
``advance(t)``: both chips (IP0: WRIST1, WRIST2; IP1: ELBOW, SHOULDER, ZED, YAW, GRIPPER), the
line handed between them (TOGGLE_ONCE / TOGGLE_ON / TOGGLE_OFF), the restarted state after power-up
(every command but GO answered 0x0F), the parameters of each motor controller, numeric moves
(NEW_POSITION, then GO with the motors' bits), manual drive, stops, status and position reads,
DEF_HOME and IM_WRITE_CP (the encoder initialisation's tools). Every reply has the driver's code
and length (``core.devices.rtx_protocol``).

The arm behind it: each motor has end stops, a speed (the SPEED parameter, counts per second —
the real unit is not in the driver's sources; this emulator's assumption only sets how long
moves take) and an acceleration (SPEED / ACCELERATION_TIME ms). The measured position follows
the setpoint with a 30 ms lag and stops at the end stops; when the following error exceeds the
ERROR_LIMIT parameter the controller stops that axis and flags it (error limit + reset bits) —
which is how the driver's initialisation finds the end stops. The wrist motors drive roll and
pitch together (WRIST1 = roll + pitch, WRIST2 = pitch − roll), so a roll or pitch stop blocks
both. At power-up the encoders read 0 wherever the arm is: positions mean nothing until the
initialisation has driven to the stops and written their counts.

Strict: it rejects what the real controller would — an unknown command (CMD_NOT_SUPPORTED), a
controller not fitted on that chip (SELECT_OOR), a parameter code or value out of range
(PARAM_OOR), writing a read-only parameter (READ_ONLY), DEF_WRITE2 / DEF_READ2 without the
selecting DEF_WRITE1 / DEF_READ1 just before on that chip (CMD_OOR), GO for a motor still moving
(AXIS_BUSY), a command certainly written closer than 8 ms after the previous one (FRAME_OVERRUN;
bytes a starved emulator or the pty delivers late or bunched are not held against the host), a
multi-byte command whose bytes stop arriving (FRAME_TIMEOUT), anything but GO while restarted.

Faults on request: ``no_answer(n)`` (the next n commands get no reply; ``None`` = silent until
``clear_faults()``), ``garbage(n)`` (replies replaced by bytes no command is answered with),
``restart()`` (both chips power-cycle mid-session), ``obstacle(motor)`` (an end stop where the
motor is now: moving on into it trips the error limit).

``RtxEmulator`` serves a controller on a pseudo-terminal from a thread (``rtx:sim``). Run as a
program it serves one on a pty and prints ``PORT <path>`` first, like ``firmware/host_firmware``::

    python -m core.devices.rtx_emulator --pty [--link PATH] [--time-scale 10] [--state FILE]

``--link`` makes a stable symlink to the pty (a restarted emulator keeps the path), ``--state``
keeps the arm's positions and the controller's initialisation in a file so that an emulator killed
and started again is the same arm behind a replugged cable; without it a restart is a power-cycle.
Lines on stdin inject faults: ``no-answer N``, ``silent``, ``garbage N``, ``restart``,
``obstacle MOTOR``, ``clear``.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import select
import signal
import sys
import threading
import time
import tty
from dataclasses import dataclass, field
from typing import Callable, Optional

from core.devices import rtx_protocol as p

FRAME_TIMEOUT_S = 0.05  # a multi-byte command's bytes must follow within this
LAG_S = 0.03  # the measured position follows the setpoint with this time constant
TICK_S = 0.002  # the serving thread's physics step when the line is quiet
# RtxEmulator: the longest stretch of wall time simulated at once. A longer gap means the host
# starved the emulator (a real controller never stops); the arm's time waits for it instead of
# being caught up in one go before the next reply (at --time-scale 60 a starved second costs
# ~0.3 s of CPU, which on a loaded host delays the reply past the bridge's timeout, and so on)
MAX_CATCH_UP_S = 0.02
READ_SIZE = 256  # bytes read from the pty at once
SAVE_EVERY_S = 0.1  # --state: how often a changed state is written

# the arm's end stops in counts once initialised (the initialisation writes these counts at the
# stops, core.kinematics.umi_rtx.INIT_STOP_COUNTS); the far sides a little beyond the driver's
# software limits
STOPS = {
    p.ELBOW: (-2629.0, 2250.0),
    p.SHOULDER: (-2680.0, 2630.0),
    p.ZED: (-3550.0, 0.0),
    p.YAW: (-1947.0, 1947.0),
    p.GRIPPER: (-30.0, 1260.0),
}
WRIST_SUM_STOPS = (-2642.0, 160.0)  # WRIST1 + WRIST2 (pitch), counts
WRIST_DIFF_STOPS = (-3560.0, 4950.0)  # WRIST1 − WRIST2 (roll)
POWER_ON = {  # where the arm is at power-up (counts, initialised frame): anywhere inside
    p.ELBOW: 300.0, p.SHOULDER: -400.0, p.ZED: -1200.0, p.YAW: 200.0, p.GRIPPER: 400.0,
    p.WRIST1: -404.0, p.WRIST2: -674.0,  # roll 10°, pitch −40°
}
DEFAULT_SPEED = {p.ELBOW: 1400, p.SHOULDER: 2200, p.ZED: 500, p.YAW: 1400, p.GRIPPER: 1000,
                 p.WRIST1: 3000, p.WRIST2: 3000}  # counts/s (assumed unit, see the docstring)
MAX_SPEED = {m: 2 * v for m, v in DEFAULT_SPEED.items()}  # SPEED above this: PARAM_OOR
DEFAULT_PARAMS = {p.Param.ERROR_LIMIT: 300, p.Param.KP: 40, p.Param.KI: 4, p.Param.KD: 80,
                  p.Param.DEAD_BAND: 2, p.Param.OFFSET: 0, p.Param.MAX_FORCE: 100,
                  p.Param.ACCELERATION_TIME: 100, p.Param.USER_RAM: 0, p.Param.USER_IO: 0}
PARAM_RANGE = {p.Param.ERROR_LIMIT: (1, 32767), p.Param.NEW_POSITION: (p.WORD_MIN, p.WORD_MAX),
               p.Param.KP: (0, 255), p.Param.KI: (0, 255), p.Param.KD: (0, 255),
               p.Param.DEAD_BAND: (0, 255), p.Param.OFFSET: (-255, 255), p.Param.MAX_FORCE: (0, 255),
               p.Param.ACCELERATION_TIME: (1, 10000), p.Param.USER_RAM: (p.WORD_MIN, p.WORD_MAX),
               p.Param.USER_IO: (0, 255)}
READ_ONLY = (p.Param.ERROR, p.Param.CURRENT_FORCE)
VERSION_WORD = 0x0105


@dataclass
class Axis:
    """One motor controller and its motor."""

    motor: int
    true_pos: float  # where the motor is, counts in the initialised frame
    shift: float  # encoder reading = true_pos + shift
    setpoint: float = 0.0  # encoder frame
    target: float = 0.0  # a numeric move's destination: NEW_POSITION when GO was accepted
    velocity: float = 0.0  # of the setpoint, counts/s
    params: dict = field(default_factory=dict)
    mode: str = "idle"  # idle | numeric | manual | free
    drive: int = 0  # manual: +1 / −1
    status: int = 0  # STAT_* bits (in progress is computed)
    obstacle: Optional[float] = None  # an extra end stop (true counts), from obstacle()

    @property
    def reading(self) -> float:
        return self.true_pos + self.shift

    @property
    def busy(self) -> bool:
        return self.mode in ("numeric", "manual")

    def status_byte(self) -> int:
        return self.status | (p.STAT_IN_PROGRESS if self.busy else 0)


class Chip:
    """One controller chip (IP)."""

    def __init__(self, ip: int):
        self.ip = ip
        self.restarted = True
        self.toggle = False
        self.selected: Optional[tuple[str, int]] = None  # ("w"|"r", code) from DEF_WRITE1/READ1
        self.last_cmd: Optional[int] = None


class RtxController:
    """The emulated controller and arm (see the module docstring). Thread-safe: one lock."""

    def __init__(self, time_scale: float = 1.0, clock: Callable[[], float] = time.monotonic,
                 spacing_s: float = p.COMMAND_SPACING_S, max_catch_up_s: Optional[float] = None):
        if not time_scale > 0:
            raise ValueError(f"time_scale = {time_scale}: must be > 0")
        if max_catch_up_s is not None and not max_catch_up_s > 0:
            raise ValueError(f"max_catch_up_s = {max_catch_up_s}: must be > 0 (or None: every gap simulated)")
        self.time_scale = float(time_scale)
        # a clock gap longer than this is simulated as this long (None: all of it); RtxEmulator sets
        # MAX_CATCH_UP_S so that a starved emulator answers at once and its arm waits
        self.max_catch_up_s = max_catch_up_s
        self.clock = clock
        self.spacing_s = float(spacing_s)
        self.lock = threading.RLock()
        self.received: list[tuple[float, int, bytes]] = []  # (arrival t, chip, command)
        self.replies: list[bytes] = []
        self.rejected: list[tuple[bytes, int]] = []  # (command, error reply)
        self.position_writes: list[tuple[int, int]] = []  # (motor, NEW_POSITION counts) accepted
        self.spacing_violations = 0
        self.power_cycles = 0
        self._no_answer: Optional[int] = 0  # commands left without a reply; None = silent
        self._garbage = 0
        self._t: Optional[float] = None
        self._last_rx: Optional[float] = None  # the previous command's earliest possible write time
        self.dirty = True
        self._power_up(first=True)

    # ------------------------------------------------------------ state

    def _power_up(self, first: bool = False) -> None:
        old = getattr(self, "axes", None)
        self.chips = {p.IP0: Chip(p.IP0), p.IP1: Chip(p.IP1)}
        self.line = p.IP0  # the chip listening
        self.axes: dict[int, Axis] = {}
        for m in p.MOTOR_IP:
            true = POWER_ON[m] if first or old is None else old[m].true_pos
            ax = Axis(motor=m, true_pos=true, shift=-true, obstacle=None if old is None else old[m].obstacle)
            self._default_params(ax)
            ax.setpoint = ax.reading  # 0
            self.axes[m] = ax
        self.dirty = True

    def _default_params(self, ax: Axis) -> None:
        ax.params = dict(DEFAULT_PARAMS)
        ax.params[p.Param.SPEED] = DEFAULT_SPEED[ax.motor]
        ax.params[p.Param.NEW_POSITION] = int(round(ax.reading))

    def axis(self, ip: int, ctl: int) -> Optional[Axis]:
        m = p.motor_of(ip, ctl)
        return None if m is None else self.axes[m]

    def readings(self) -> dict[int, int]:
        """Every motor's encoder reading (counts)."""
        with self.lock:
            return {m: int(round(a.reading)) for m, a in self.axes.items()}

    def true_positions(self) -> dict[int, float]:
        """Where each motor really is, in the initialised frame (counts)."""
        with self.lock:
            return {m: a.true_pos for m, a in self.axes.items()}

    # ------------------------------------------------------------ faults

    def no_answer(self, n: Optional[int] = 1) -> None:
        """The next ``n`` commands get no reply (None: none until ``clear_faults``)."""
        with self.lock:
            self._no_answer = n

    def garbage(self, n: int = 1) -> None:
        """The next ``n`` replies are bytes no command is answered with."""
        with self.lock:
            self._garbage = int(n)

    def restart(self) -> None:
        """Both chips power-cycle: restarted state, encoders read 0, parameters default."""
        with self.lock:
            self.power_cycles += 1
            self._power_up()

    def obstacle(self, motor: int, at: Optional[float] = None) -> None:
        """An end stop at ``at`` (true counts; default: where the motor is now)."""
        with self.lock:
            ax = self.axes[motor]
            ax.obstacle = ax.true_pos if at is None else float(at)

    def clear_faults(self) -> None:
        with self.lock:
            self._no_answer = 0
            self._garbage = 0
            for ax in self.axes.values():
                ax.obstacle = None

    # ------------------------------------------------------------ physics

    def advance(self, t: float) -> None:
        """Move the arm to time ``t`` (the clock's seconds)."""
        with self.lock:
            if self._t is None:
                self._t = t
                return
            gap = t - self._t
            if self.max_catch_up_s is not None:
                gap = min(gap, self.max_catch_up_s)
            dt = gap * self.time_scale
            self._t = t
            while dt > 0:
                step = min(dt, 0.01)
                self._step(step)
                dt -= step

    def _step(self, dt: float) -> None:
        for ax in self.axes.values():
            self._move_setpoint(ax, dt)
        alpha = min(1.0, dt / LAG_S)
        wanted = {}
        for m, ax in self.axes.items():
            if ax.mode == "free":
                wanted[m] = ax.true_pos
            else:
                target = ax.setpoint - ax.shift
                wanted[m] = ax.true_pos + (target - ax.true_pos) * alpha
        for m, (lo, hi) in STOPS.items():
            wanted[m] = min(max(wanted[m], lo), hi)
        # the wrist: roll and pitch stops block both motors
        w1, w2 = wanted[p.WRIST1], wanted[p.WRIST2]
        s = min(max(w1 + w2, WRIST_SUM_STOPS[0]), WRIST_SUM_STOPS[1])
        d = min(max(w1 - w2, WRIST_DIFF_STOPS[0]), WRIST_DIFF_STOPS[1])
        wanted[p.WRIST1], wanted[p.WRIST2] = 0.5 * (s + d), 0.5 * (s - d)
        for m, ax in self.axes.items():
            new = wanted[m]
            if ax.obstacle is not None:  # cannot pass it from the side it is on
                if ax.true_pos <= ax.obstacle < new:
                    new = ax.obstacle
                elif new < ax.obstacle <= ax.true_pos:
                    new = ax.obstacle
            if new != ax.true_pos:
                self.dirty = True
            ax.true_pos = new
            if ax.mode in ("numeric", "manual", "idle"):
                error = ax.setpoint - ax.reading
                if abs(error) > ax.params[p.Param.ERROR_LIMIT]:
                    # the controller gives up on the axis: stop it where it is, flag it
                    ax.mode = "idle"
                    ax.velocity = 0.0
                    ax.setpoint = ax.reading
                    ax.params[p.Param.NEW_POSITION] = int(round(ax.reading))
                    ax.status |= p.STAT_ERROR_LIMIT | p.STAT_RESET | p.STAT_STOPPED

    def _move_setpoint(self, ax: Axis, dt: float) -> None:
        speed = float(ax.params[p.Param.SPEED])
        accel = speed / max(ax.params[p.Param.ACCELERATION_TIME] / 1000.0, 1e-3)
        if ax.mode == "manual":
            want_v = ax.drive * speed
        elif ax.mode == "numeric":
            left = ax.target - ax.setpoint
            if abs(left) < 0.5 and abs(ax.velocity) <= accel * dt + 1e-9:
                ax.setpoint = ax.target
                ax.velocity = 0.0
                ax.mode = "idle"
                return
            want_v = math.copysign(min(speed, math.sqrt(2.0 * accel * abs(left))), left)
        else:
            ax.velocity = 0.0
            return
        dv = max(-accel * dt, min(accel * dt, want_v - ax.velocity))
        ax.velocity += dv
        step = ax.velocity * dt
        if ax.mode == "numeric":
            left = ax.target - ax.setpoint
            if abs(step) >= abs(left):
                step = left
        ax.setpoint += step
        self.dirty = True

    # ------------------------------------------------------------ commands

    def handle(self, cmd: bytes, t: Optional[float] = None, written_after: Optional[float] = None) -> Optional[bytes]:
        """Process one whole command arriving at ``t``; the reply, or None (no answer).

        ``written_after``: the earliest the host can have written it (default ``t``) — the last
        moment the emulator saw the line empty. A command is refused as too close (FRAME_OVERRUN)
        only when it arrived less than the spacing after the EARLIEST moment the previous one can
        have been written: the host certainly wrote them too close. Bytes that reach the emulator
        late or bunched (a starved emulator, a pty delivering two writes in one read) widen that
        window, so they are never counted against the host."""
        t = self.clock() if t is None else t
        earliest = t if written_after is None else min(written_after, t)
        with self.lock:
            self.advance(t)
            chip = self.chips[self.line]
            self.received.append((t, chip.ip, bytes(cmd)))
            too_close = self._last_rx is not None and t - self._last_rx < self.spacing_s - 1e-6
            self._last_rx = earliest
            if self._no_answer is None:
                return None
            if self._no_answer > 0:
                self._no_answer -= 1
                return None
            if too_close:
                self.spacing_violations += 1
                reply = bytes([p.ReplyCode.FRAME_OVERRUN])
            else:
                reply = self._execute(chip, bytes(cmd))
            if reply[0] != p.RESP_ACK and 0x01 <= reply[0] <= 0x0F and len(reply) == 1:
                self.rejected.append((bytes(cmd), reply[0]))
            chip.last_cmd = cmd[0]
            if self._garbage > 0:
                self._garbage -= 1
                reply = bytes([0x5A, 0x3C])[: len(reply)] if len(reply) > 1 else b"\x3c"
            self.replies.append(reply)
            return reply

    def frame_timeout(self) -> bytes:
        """The reply to a command whose bytes stopped arriving."""
        with self.lock:
            return bytes([p.ReplyCode.FRAME_TIMEOUT])

    def _execute(self, chip: Chip, cmd: bytes) -> bytes:
        b0 = cmd[0]
        err = lambda code: bytes([code])  # noqa: E731
        if chip.restarted:
            if b0 == p.CMD_GO:
                chip.restarted = False
                return bytes([p.RESP_ACK])
            return bytes([p.RESP_IP_RESTART])
        selected, chip.selected = chip.selected, None  # a selection is good for the next command only
        if b0 == p.CMD_GO:
            return bytes([p.RESP_ACK])
        if b0 == p.CMD_IDENTIFY:
            return bytes([p.RESP_IDENTIFY_0 | chip.ip])
        if b0 == p.CMD_VERSION:
            return bytes([p.RESP_IDENTIFY_0 | chip.ip, VERSION_WORD & 0xFF, VERSION_WORD >> 8])
        if b0 in (p.CMD_TOGGLE_OFF, p.CMD_TOGGLE_ONCE, p.CMD_TOGGLE_ON):
            if b0 == p.CMD_TOGGLE_OFF:
                chip.toggle = False
            elif b0 == p.CMD_TOGGLE_ON:
                chip.toggle = True
                self.line = 1 - chip.ip
            else:
                self.line = 1 - chip.ip
            return bytes([p.RESP_ACK])
        if chip.toggle:
            self.line = 1 - chip.ip  # toggling: the other chip listens after this reply
        if p.CMD_STAT_CTL <= b0 <= p.CMD_STAT_CTL + 4:
            ax = self.axis(chip.ip, b0 - p.CMD_STAT_CTL)
            if ax is None:
                return err(p.ReplyCode.SELECT_OOR)
            return bytes([b0, ax.status_byte(), chip.ip])
        if b0 == p.CMD_STAT_GENERAL:
            bits = 0
            for ax in self._chip_axes(chip.ip):
                s = ax.status_byte()
                bits |= (p.GEN_TASKS if s & p.STAT_IN_PROGRESS else 0) | (p.GEN_AXIS_STOPPED if s & p.STAT_STOPPED else 0)
                bits |= (p.GEN_ERROR_LIMITS if s & p.STAT_ERROR_LIMIT else 0) | (p.GEN_AXIS_RESET if s & p.STAT_RESET else 0)
            return bytes([p.CMD_STAT_GENERAL, bits, chip.ip])
        if p.CMD_MODE_SET <= b0 <= p.CMD_MODE_SET + 5:
            if self.axis(chip.ip, cmd[1]) is None:
                return err(p.ReplyCode.SELECT_OOR)
            return bytes([p.RESP_ACK]) if b0 == p.CMD_MODE_SET else err(p.ReplyCode.CMD_NOT_SUPPORTED)
        if b0 == p.CMD_IP_RESET:
            self.chips[chip.ip] = Chip(chip.ip)
            for ax in self._chip_axes(chip.ip):
                self._default_params(ax)
            return bytes([p.RESP_IP_RESTART])
        if b0 == p.CMD_IP_DEF_HOME:
            for ax in self._chip_axes(chip.ip):
                ax.shift = -ax.true_pos
                ax.setpoint = 0.0
                ax.velocity = 0.0
                ax.mode = "idle" if ax.mode != "free" else "free"
                ax.params[p.Param.NEW_POSITION] = 0
            self.dirty = True
            return bytes([p.RESP_ACK])
        if b0 == p.CMD_IP_DEFAULT:
            for ax in self._chip_axes(chip.ip):
                new_pos = ax.params[p.Param.NEW_POSITION]
                self._default_params(ax)
                ax.params[p.Param.NEW_POSITION] = new_pos
            return bytes([p.RESP_ACK])
        if p.CMD_STOP <= b0 <= p.CMD_STOP + 3:
            mode = p.StopMode(b0 - p.CMD_STOP)
            for ax in self._chip_axes(chip.ip):
                if mode is p.StopMode.FREE:
                    ax.mode = "free"
                else:
                    ax.mode = "idle"
                    ax.setpoint = ax.reading if mode is p.StopMode.FREE_OFF else ax.setpoint
                ax.velocity = 0.0  # NEW_POSITION stays: the driver writes it, stops, then GOes
                if mode is not p.StopMode.FREE_OFF:
                    ax.status |= p.STAT_STOPPED
            return bytes([p.RESP_ACK])
        if b0 & 0xF8 in (p.CMD_IM_READ_CP, p.CMD_IM_READ_ERR) and b0 < 0x50:
            ax = self.axis(chip.ip, b0 & 0x07)
            if ax is None:
                return err(p.ReplyCode.SELECT_OOR)
            value = ax.setpoint if b0 & 0xF8 == p.CMD_IM_READ_CP else ax.setpoint - ax.reading
            return p.word_reply(p.RESP_TYPE_IM_READ, _clip_word(value))
        if b0 & 0xF8 == p.CMD_IM_WRITE_CP:
            ax = self.axis(chip.ip, b0 & 0x07)
            if ax is None:
                return err(p.ReplyCode.SELECT_OOR)
            if ax.busy:
                return err(p.ReplyCode.AXIS_BUSY)
            value = _signed(cmd[1], cmd[2])
            ax.shift = value - ax.true_pos
            ax.setpoint = float(value)
            ax.params[p.Param.NEW_POSITION] = value
            self.dirty = True
            return p.write_ack(p.RESP_TYPE_IM_WRITE, cmd[1], cmd[2])
        if b0 in (p.CMD_DEF_WRITE1, p.CMD_DEF_READ1):
            try:
                code = p.Param(cmd[1])
            except ValueError:
                return err(p.ReplyCode.PARAM_OOR)
            if b0 == p.CMD_DEF_WRITE1:
                if code in READ_ONLY or code is p.Param.CURRENT_POSITION:
                    return err(p.ReplyCode.READ_ONLY)
                chip.selected = ("w", code)
                return bytes([p.RESP_TYPE_DEF_W1])
            chip.selected = ("r", code)
            return bytes([p.RESP_TYPE_DEF_R1])
        if b0 & 0xF8 == p.CMD_DEF_WRITE2:
            if selected is None or selected[0] != "w":
                return err(p.ReplyCode.CMD_OOR)
            ax = self.axis(chip.ip, b0 & 0x07)
            if ax is None:
                return err(p.ReplyCode.SELECT_OOR)
            code, value = selected[1], _signed(cmd[1], cmd[2])
            if code is p.Param.SPEED:
                lo, hi = 1, MAX_SPEED[ax.motor]
            else:
                lo, hi = PARAM_RANGE.get(code, (p.WORD_MIN, p.WORD_MAX))
            if not lo <= value <= hi:
                return err(p.ReplyCode.PARAM_OOR)
            ax.params[code] = value
            if code is p.Param.NEW_POSITION:
                self.position_writes.append((ax.motor, value))
            return p.write_ack(p.RESP_TYPE_DEF_W2, cmd[1], cmd[2])
        if b0 & 0xF8 == p.CMD_DEF_READ2:
            if selected is None or selected[0] != "r":
                return err(p.ReplyCode.CMD_OOR)
            ax = self.axis(chip.ip, b0 & 0x07)
            if ax is None:
                return err(p.ReplyCode.SELECT_OOR)
            code = selected[1]
            if code is p.Param.CURRENT_POSITION:
                value = ax.setpoint
            elif code is p.Param.ERROR:
                value = ax.setpoint - ax.reading
            elif code is p.Param.CURRENT_FORCE:
                value = 0
            else:
                value = ax.params[code]
            return p.word_reply(p.RESP_TYPE_DEF_R2, _clip_word(value))
        if b0 & 0xE0 == p.CMD_DIR_NUM:
            ctls = [c for c in range(p.CTL_COUNT) if b0 & (1 << c)]
            axes = []
            for c in ctls:
                ax = self.axis(chip.ip, c)
                if ax is None:
                    return err(p.ReplyCode.SELECT_OOR)
                axes.append(ax)
            if any(ax.busy for ax in axes):
                return err(p.ReplyCode.AXIS_BUSY)
            for ax in axes:
                ax.mode = "numeric"
                ax.target = float(ax.params[p.Param.NEW_POSITION])
                ax.status = 0
            return bytes([p.RESP_ACK])
        if b0 == p.CMD_DIR_MAN:
            bits = cmd[1] | (cmd[2] << 8)
            if bits >> (2 * p.CTL_COUNT):
                return err(p.ReplyCode.PARAM_OOR)
            drives = {c: (bits >> (2 * c)) & 3 for c in range(p.CTL_COUNT)}
            axes = []
            for c, d in drives.items():
                if d == p.Drive.STOP:
                    continue
                ax = self.axis(chip.ip, c)
                if ax is None:
                    return err(p.ReplyCode.SELECT_OOR)
                axes.append((ax, d))
            if any(ax.busy for ax, _ in axes):
                return err(p.ReplyCode.AXIS_BUSY)
            for ax, d in axes:
                if d == p.Drive.OFF:
                    ax.mode = "free"
                else:
                    ax.mode = "manual"
                    ax.drive = 1 if d == p.Drive.FWD else -1
                ax.status = 0
            return bytes([p.RESP_ACK])
        if b0 & 0xF0 == p.CMD_INTERP:
            return err(p.ReplyCode.CMD_NOT_SUPPORTED)  # the bridge never interpolates
        return err(p.ReplyCode.CMD_NOT_SUPPORTED)

    def _chip_axes(self, ip: int) -> list[Axis]:
        return [self.axes[m] for m in p.MOTOR_IP if p.MOTOR_IP[m] == ip]

    # ------------------------------------------------------------ persistence (--state)

    def to_json(self) -> dict:
        with self.lock:
            return {"axes": {p.MOTOR_NAMES[m]: {"true_pos": a.true_pos, "shift": a.shift,
                                                 "params": {int(k): v for k, v in a.params.items()}}
                             for m, a in self.axes.items()},
                    "restarted": {str(ip): c.restarted for ip, c in self.chips.items()}}

    def load_json(self, data: dict) -> None:
        """Resume a saved arm: same positions and encoder counts, the chips still powered."""
        with self.lock:
            for name, a in data["axes"].items():
                ax = self.axes[p.MOTOR_BY_NAME[name]]
                ax.true_pos, ax.shift = float(a["true_pos"]), float(a["shift"])
                ax.params = {p.Param(int(k)): int(v) for k, v in a["params"].items()}
                ax.setpoint = ax.reading
                ax.params[p.Param.NEW_POSITION] = int(round(ax.reading))
            for ip, restarted in data.get("restarted", {}).items():
                self.chips[int(ip)].restarted = bool(restarted)


def _signed(lo: int, hi: int) -> int:
    v = lo | (hi << 8)
    return v - 0x10000 if v > 0x7FFF else v


def _clip_word(value: float) -> int:
    return max(p.WORD_MIN, min(p.WORD_MAX, int(round(value))))


class RtxEmulator:
    """Serves an ``RtxController`` on a pseudo-terminal from a thread.

    ``start()`` returns the pty path a bridge opens like a serial port; ``stop()`` joins the
    thread and closes the pty. Bytes are framed into commands by their first byte
    (``rtx_protocol.command_length``); a command's arrival time is when its first byte was read,
    and the earliest the host can have written it is the last time the line was seen empty before
    that read (the controller judges the 8 ms spacing by that window). The controller simulates at
    most ``MAX_CATCH_UP_S`` of a longer gap (the host starved this thread): replies stay prompt.
    """

    def __init__(self, controller: Optional[RtxController] = None, time_scale: float = 1.0,
                 on_tick: Optional[Callable[[], None]] = None):
        self.controller = controller or RtxController(time_scale=time_scale)
        if self.controller.max_catch_up_s is None:
            self.controller.max_catch_up_s = MAX_CATCH_UP_S
        self.path: Optional[str] = None
        self._master: Optional[int] = None
        self._slave: Optional[int] = None
        self._thread: Optional[threading.Thread] = None
        self._stop = threading.Event()
        self._on_tick = on_tick

    def start(self) -> str:
        master, slave = os.openpty()
        tty.setraw(master)
        tty.setraw(slave)
        self._master, self._slave = master, slave  # the slave stays open: no hang-up between clients
        self.path = os.ttyname(slave)
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, daemon=True, name="deskarm RTX emulator")
        self._thread.start()
        return self.path

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=5.0)
        self._thread = None
        for fd in (self._master, self._slave):
            if fd is not None:
                try:
                    os.close(fd)
                except OSError:
                    pass
        self._master = self._slave = None

    def _run(self) -> None:
        ctl = self.controller
        buf = bytearray()
        first_t = 0.0
        first_written_after = 0.0
        quiet_t = ctl.clock()  # the line held no unread byte at this moment: later bytes were written after it
        master = self._master
        while not self._stop.is_set():
            polled = ctl.clock()
            try:
                ready, _, _ = select.select([master], [], [], TICK_S)
            except (OSError, ValueError):
                return
            now = ctl.clock()
            if ready:
                written_after = quiet_t
                before_read = ctl.clock()
                try:
                    data = os.read(master, READ_SIZE)
                except OSError:
                    data = b""
                if len(data) < READ_SIZE:
                    quiet_t = before_read  # what this read left behind arrives after it
                for b in data:
                    if not buf:
                        first_t = now
                        first_written_after = written_after
                    buf.append(b)
                    need = p.command_length(buf[0])
                    if len(buf) >= need:
                        reply = ctl.handle(bytes(buf[:need]), first_t, first_written_after)
                        del buf[:need]
                        if reply:
                            self._write(reply)
            else:
                quiet_t = polled
                if buf and now - first_t > FRAME_TIMEOUT_S:
                    buf.clear()
                    self._write(ctl.frame_timeout())
            ctl.advance(now)
            if self._on_tick is not None:
                self._on_tick()

    def _write(self, data: bytes) -> None:
        try:
            os.write(self._master, data)
        except OSError:
            pass


def _fault_line(ctl: RtxController, line: str) -> str:
    words = line.split()
    if not words:
        return ""
    cmd = words[0].lower()
    if cmd == "no-answer":
        ctl.no_answer(int(words[1]) if len(words) > 1 else 1)
    elif cmd == "silent":
        ctl.no_answer(None)
    elif cmd == "garbage":
        ctl.garbage(int(words[1]) if len(words) > 1 else 1)
    elif cmd == "restart":
        ctl.restart()
    elif cmd == "obstacle":
        ctl.obstacle(p.MOTOR_BY_NAME[words[1].upper()])
    elif cmd == "clear":
        ctl.clear_faults()
    else:
        return f"unknown fault {line!r}: no-answer N | silent | garbage N | restart | obstacle MOTOR | clear"
    return f"OK {line.strip()}"


def main(argv: Optional[list[str]] = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m core.devices.rtx_emulator",
                                     description="An emulated UMI-RTX controller on a pseudo-terminal.")
    parser.add_argument("--pty", action="store_true", required=True, help="serve on a new pseudo-terminal")
    parser.add_argument("--link", help="also make this symlink to the pty (stable across restarts)")
    parser.add_argument("--time-scale", type=float, default=1.0,
                        help="the arm moves this many times faster than a real one (default 1)")
    parser.add_argument("--state", help="keep the arm's state in this file (a restart is a replugged "
                        "cable, not a power cycle)")
    args = parser.parse_args(argv)
    ctl = RtxController(time_scale=args.time_scale)
    if args.state and os.path.exists(args.state):
        try:
            with open(args.state) as f:
                ctl.load_json(json.load(f))
        except (OSError, ValueError, KeyError) as exc:
            print(f"rtx_emulator: {args.state}: {exc} — starting powered up", file=sys.stderr)
    last_save = [0.0]

    def save() -> None:
        if not args.state:
            return
        now = time.monotonic()
        if ctl.dirty and now - last_save[0] >= SAVE_EVERY_S:
            ctl.dirty = False
            last_save[0] = now
            tmp = args.state + ".tmp"
            with open(tmp, "w") as f:
                json.dump(ctl.to_json(), f)
            os.replace(tmp, args.state)

    emu = RtxEmulator(ctl, on_tick=save)
    path = emu.start()
    if args.link:
        try:
            os.unlink(args.link)
        except FileNotFoundError:
            pass
        os.symlink(path, args.link)
    print(f"PORT {path}", flush=True)
    done = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: done.set())
    signal.signal(signal.SIGINT, lambda *_: done.set())

    def read_stdin() -> None:
        for line in sys.stdin:
            print(_fault_line(ctl, line), flush=True)

    threading.Thread(target=read_stdin, daemon=True).start()
    done.wait()
    emu.stop()
    ctl.dirty = True
    last_save[0] = 0.0
    save()
    return 0


if __name__ == "__main__":
    sys.exit(main())
