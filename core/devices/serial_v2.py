"""Protocol v2 over pyserial: measured joint states, heartbeat, watchdog and e-stop.

``SerialV2Bridge("v2:/dev/ttyACM0", profile)`` talks to a board running the deskarm firmware
(``firmware/PROTOCOL.md``). It is chosen only by the ``v2:`` prefix, never by probing: see
``core.devices.bridge`` for why a probe could move an arm that runs the original firmware.

Threads. The caller (the bridge worker) calls ``send``, ``estop``, ``rearm``, ``status`` and
``joint_state``. One daemon I/O thread per connection reads with a short timeout, feeds the
``V2Decoder``, turns each STATUS into a measured ``JointState`` (and each RANGE, from a board
with an HC-SR04, into the latest ``RangeReading``), sends the 10 Hz heartbeat PING
and flushes a command that had to wait for its 20 ms slot. Every write to the port, from
either thread, happens under one lock (``_write_lock``); what the I/O thread learns is kept
under ``_cond``. Framing is pure code in ``core.devices.protocol_v2``.

Units: radians inside, servo degrees (floats, 0.01° steps) at ``send``'s return, centidegrees
and microseconds on the wire.
"""
from __future__ import annotations

import math
import statistics
import threading
import time
from collections import deque
from dataclasses import dataclass
from typing import Callable, Optional, Sequence

from core.devices.bridge import (
    V2_PREFIX,
    BridgeError,
    MotorBridge,
    close_quietly,
    explain_serial_error,
    lost_port_error,
)
from core.devices.protocol_v2 import (
    MAX_JOINTS,
    PULSE_MAX_US,
    PULSE_MIN_US,
    SPEED_MAX_DPS,
    Flag,
    RangeFrame,
    StatusFrame,
    V2Decoder,
    encode_arm,
    encode_config,
    encode_estop,
    encode_ping,
    encode_set_joints_cdeg,
)
from core.kinematics.profile import SERVO_MAX_DEG, SERVO_MIN_DEG
from core.messages import BridgeStatus, JointCommand, JointState
from core.motion.safety import clamp_to_limits

V2_BAUD = 9600
DEFAULT_MIN_PULSE_US = 900  # pulse at 0°: the seed firmware's mapping, 900 + 10·deg µs
DEFAULT_MAX_PULSE_US = 2700  # pulse at 180°
HEARTBEAT_HZ = 10.0  # PING rate: feeds the board's 500 ms watchdog, brings STATUS back
MAX_COMMAND_HZ = 50.0  # SET_JOINTS rate cap: the servo frame rate; 14 B at 9600 baud fit 68/s
REPLY_TIMEOUT_S = 1.0  # connect() waits this long for the first STATUS
IO_POLL_S = 0.005  # I/O thread read timeout: how late a waiting command can be flushed
WRITE_TIMEOUT_S = 1.0  # a write blocked this long means the port is dead
STALE_STATUS_S = 1.0  # no STATUS for this long while pinging: the status bar says so
RTT_KEEP = 1000  # round-trip samples kept for status() and the bench
RANGE_STALE_S = 0.5  # range_m() ignores a reading older than this (the board sends 10 a second)

FLAG_WORDS = {
    Flag.ESTOP: "e-stop (pulses off until re-armed)",
    Flag.WATCHDOG: "watchdog tripped (no frame for 0.5 s: holding)",
    Flag.MOVING: "moving",
    Flag.CONFIG_REJECTED: "CONFIG rejected by the board",
    Flag.CLAMPED: "an angle was clamped by the board",
}


def describe_flags(flags: int) -> list[str]:
    """STATUS flags in words, most important first (V2_MODE, the normal case, is left out)."""
    return [words for flag, words in FLAG_WORDS.items() if int(flags) & int(flag)]


@dataclass(frozen=True)
class JointPulseConfig:
    """What CONFIG tells the board about one joint."""

    min_pulse_us: int  # pulse at 0°, 400 … max_pulse_us
    max_pulse_us: int  # pulse at 180°, min_pulse_us … 3000
    max_speed_dps: int  # the board's rate limit, 1 … 1000 °/s

    def __post_init__(self) -> None:
        if not PULSE_MIN_US <= self.min_pulse_us < self.max_pulse_us <= PULSE_MAX_US:
            raise ValueError(
                f"min_pulse_us = {self.min_pulse_us}, max_pulse_us = {self.max_pulse_us}: expected "
                f"{PULSE_MIN_US} ≤ min_pulse_us < max_pulse_us ≤ {PULSE_MAX_US}"
            )
        if not 1 <= self.max_speed_dps <= SPEED_MAX_DPS:
            raise ValueError(f"max_speed_dps = {self.max_speed_dps} is outside 1…{SPEED_MAX_DPS}")

    def pulse_to_servo_deg(self, pulse_us: int) -> float:
        """Servo angle (deg, 0…180) for a pulse width the board reports (not 0 = off)."""
        span = self.max_pulse_us - self.min_pulse_us
        deg = (pulse_us - self.min_pulse_us) * (SERVO_MAX_DEG / span)
        return min(max(deg, SERVO_MIN_DEG), SERVO_MAX_DEG)


def pulse_configs(profile) -> tuple[JointPulseConfig, ...]:
    """Per-joint CONFIG values from a profile: its pulse fields if it has them, else 900–2700 µs,
    and its ``max_speed_deg_s`` capped at the protocol's 1000 °/s."""
    out = []
    for joint in profile.joints:
        lo = getattr(joint, "min_pulse_us", None)
        hi = getattr(joint, "max_pulse_us", None)
        speed = min(float(SPEED_MAX_DPS), float(joint.max_speed_deg_s))
        try:
            out.append(JointPulseConfig(
                min_pulse_us=int(DEFAULT_MIN_PULSE_US if lo is None else lo),
                max_pulse_us=int(DEFAULT_MAX_PULSE_US if hi is None else hi),
                max_speed_dps=max(1, int(round(speed))),
            ))
        except ValueError as exc:
            raise BridgeError(f"profile {profile.name!r}, joint {joint.name!r}: {exc}") from None
    return tuple(out)


def to_servo_cdeg(q: Sequence[float], profile) -> tuple[int, ...]:
    """Centidegrees for ``q`` (rad), each inside its joint's servo range and 0…18000.

    As ``core.motion.safety.to_servo_bytes_deg`` but at 0.01°: clamp to the joint limits (NaN → middle),
    convert, round half up, clamp again so rounding never leaves the range.
    """
    q_safe, _ = clamp_to_limits(q, profile)
    out = []
    for v, joint in zip(q_safe, profile.joints):
        lo = max(SERVO_MIN_DEG, joint.servo_min_deg)
        hi = min(SERVO_MAX_DEG, joint.servo_max_deg)
        # round(…, 6) first: 12.34 * 100 is 1233.9999999999998, and its ceil must be 1234
        lo_c, hi_c = math.ceil(round(lo * 100.0, 6)), math.floor(round(hi * 100.0, 6))
        deg = joint.to_servo_deg(v)
        c = math.floor(deg * 100.0 + 0.5) if math.isfinite(deg) else lo_c
        out.append(min(max(c, lo_c), hi_c))
    return tuple(out)


@dataclass(frozen=True)
class V2Counters:
    """Link health, for the status bar and the tests. Board counts are since this connect."""

    host_good_frames: int  # valid frames we decoded
    host_bad_frames: int  # frame attempts we rejected (corrupted replies)
    host_dropped_bytes: int  # bytes outside frames on our side
    board_good_frames: int  # valid frames the board accepted since connect
    board_bad_frames: int  # frame attempts the board rejected since connect
    board_dropped_bytes: int  # bytes the board dropped since connect
    status_frames: int  # STATUS replies received on this connection
    commands_written: int  # SET_JOINTS frames written (all connections)
    commands_coalesced: int  # commands replaced by a newer one before their slot
    pings_sent: int  # PINGs written (heartbeat and ping())
    board_resets: int  # board restarts noticed (its frame counter went back)
    range_frames: int = 0  # RANGE readings received on this connection


@dataclass(frozen=True)
class RangeReading:
    """The newest RANGE from the board's HC-SR04 (along the hand camera's axis on the
    assistive arm)."""

    distance_m: Optional[float]  # None: no echo, nearer than 20 mm or farther than 4 m
    t: float  # arrival time on the bridge's clock (s)
    monotonic_t: float  # arrival time, time.monotonic() (s): for ages
    seq: int  # the board's RANGE count (0–255): a gap means lost readings
    board_tick: int  # the board's 50 Hz tick when it triggered the measurement (wraps at 65536)


def _delta16(new: int, old: int) -> int:
    return (new - old) & 0xFFFF


class SerialV2Bridge(MotorBridge):
    """Protocol v2 over pyserial: CONFIG + PING on connect, SET_JOINTS ≤ 50 Hz, 10 Hz heartbeat,
    measured joint states from STATUS, e-stop that switches the pulses off on the board."""

    has_feedback = True

    def __init__(
        self,
        url: str,
        profile,
        clock=None,
        serial_factory: Optional[Callable[..., object]] = None,
        *,
        heartbeat_hz: float = HEARTBEAT_HZ,
        max_command_hz: float = MAX_COMMAND_HZ,
        reply_timeout_s: float = REPLY_TIMEOUT_S,
        baudrate: int = V2_BAUD,
    ):
        port = url[len(V2_PREFIX):].strip() if url.lower().startswith(V2_PREFIX) else url
        super().__init__(V2_PREFIX + port, profile, clock)
        if not 1 <= len(profile.joints) <= MAX_JOINTS:
            raise BridgeError(
                f"protocol v2 drives 1–{MAX_JOINTS} joints; profile {profile.name!r} has {len(profile.joints)}"
            )
        if not getattr(profile, "has_servos", True):
            raise BridgeError(
                f"protocol v2 drives hobby servos; profile {profile.name!r} has joints without a servo "
                "mapping — use sim:// for it"
            )
        if not heartbeat_hz >= 0 or not max_command_hz >= 0 or not reply_timeout_s > 0:
            raise ValueError("heartbeat_hz and max_command_hz must be ≥ 0 (0 = off), reply_timeout_s > 0")
        self.port_url = port  # what pyserial opens
        self.heartbeat_hz = float(heartbeat_hz)  # 0 = no heartbeat (the board's watchdog trips)
        self.max_command_hz = float(max_command_hz)  # 0 = no cap (bench only)
        self.reply_timeout_s = float(reply_timeout_s)
        self.baudrate = int(baudrate)
        self.configs = pulse_configs(profile)
        self._factory = serial_factory
        self._home_cdeg = to_servo_cdeg(profile.q_home, profile)

        self._write_lock = threading.Lock()  # every port write, and the write-side state below
        self._port = None
        self._connected = False
        self._seq = 0
        self._pending: Optional[tuple[tuple[int, ...], Optional[float]]] = None  # (cdeg, source_t)
        self._next_slot = 0.0  # monotonic time the next SET_JOINTS may go out
        self._ping_sent: dict[int, float] = {}  # seq -> monotonic write time
        self._estop_written_t: Optional[float] = None
        self._queued_cdeg: Optional[tuple[int, ...]] = None  # the newest command accepted
        self.commands_coalesced = 0
        self.pings_sent = 0

        self._cond = threading.Condition()  # what the I/O thread learns, below
        self._decoder = V2Decoder()
        self._status: Optional[StatusFrame] = None
        self._status_t: Optional[float] = None  # monotonic arrival time
        self._status_count = 0
        self._board_base: Optional[tuple[int, int, int]] = None  # board counters at connect
        self._board_last_good: Optional[int] = None
        self._board_resets = 0
        self._measured_deg: list[Optional[float]] = [None] * len(profile.joints)
        self._state: Optional[JointState] = None
        self._pulses_off = False
        self._rtt_s: deque[float] = deque(maxlen=RTT_KEEP)
        self._note = ""  # one-off remark for the status bar (e.g. a board reset)
        self._range: Optional[RangeReading] = None  # newest RANGE on this connection
        self._range_count = 0

        self._thread: Optional[threading.Thread] = None
        self._stop = threading.Event()
        self._link_down = threading.Event()
        self._link_down.set()

    # ---------------------------------------------------------------- lifecycle

    @property
    def is_connected(self) -> bool:
        return self._connected

    def connect(self) -> None:
        """Open the port, send CONFIG per joint and a PING, and require a STATUS reply.

        Raises BridgeError with a plain message: permission denied, port busy, no such port,
        no reply (wrong firmware or baud rate), or a board that cannot drive this profile.
        Calling it again after a lost link reopens the port (the bridge worker does, with backoff).
        """
        if self._connected:
            return
        self._teardown()
        import serial

        factory = self._factory or serial.serial_for_url
        try:
            port = factory(self.port_url, baudrate=self.baudrate, bytesize=8, parity="N", stopbits=1,
                           timeout=IO_POLL_S, write_timeout=WRITE_TIMEOUT_S, exclusive=True)
        except (serial.SerialException, OSError, ValueError) as exc:
            raise BridgeError(explain_serial_error(self.port_url, exc)) from None
        try:
            self._handshake(port)
        except BridgeError:
            close_quietly(port)
            raise
        except Exception as exc:  # SerialException, OSError, or a port that vanished meanwhile
            close_quietly(port)
            raise BridgeError(explain_serial_error(self.port_url, exc)) from None
        stop = threading.Event()
        with self._write_lock:
            self._port, self._stop, self._connected = port, stop, True
            self._link_down.clear()
        self._thread = threading.Thread(target=self._run, args=(port, stop), daemon=True,
                                        name=f"deskarm v2 I/O {self.port_url}")
        self._thread.start()

    def disconnect(self) -> None:
        """Stop the I/O thread, join it and close the port; safe to call twice."""
        was = self._connected
        self._teardown()
        if was:
            self.message = "disconnected"

    def _teardown(self) -> None:
        self._stop.set()
        thread, self._thread = self._thread, None
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout=WRITE_TIMEOUT_S + 1.0)
        with self._write_lock:
            port, self._port = self._port, None
            self._connected = False
            self._pending = None
            self._link_down.set()
        if port is not None:
            close_quietly(port)
        with self._cond:
            self._cond.notify_all()

    def wait_disconnected(self, timeout: float) -> bool:
        """Block until the link is down (lost or closed); False after ``timeout`` s."""
        return self._link_down.wait(timeout)

    # ---------------------------------------------------------------- handshake

    def _handshake(self, port) -> None:
        """CONFIG every joint (and ESTOP if we are e-stopped), PING, wait for its STATUS."""
        self._decoder.reset()
        self._note = ""
        try:
            port.reset_input_buffer()  # stale replies from a previous session
        except Exception:  # noqa: BLE001 - optional on some URL handlers
            pass
        with self._write_lock:
            data = b"".join(self._config_frames())
            if self._estopped:
                data += encode_estop(self._next_seq())
                self._estop_written_t = time.monotonic()
            ping_seq = self._next_seq()
            data += encode_ping(ping_seq)
            port.write(data)
            self._ping_sent[ping_seq] = time.monotonic()
            self.pings_sent += 1
        with self._cond:
            self._status, self._status_t, self._status_count = None, None, 0
            self._board_base = None
            self._board_last_good = None
            self._range, self._range_count = None, 0
        deadline = time.monotonic() + self.reply_timeout_s
        reply = None
        while reply is None and time.monotonic() < deadline:
            data = port.read(max(1, port.in_waiting or 0))
            now = time.monotonic()
            for frame in self._decoder.feed(data):
                if isinstance(frame, StatusFrame):
                    self._on_status(frame, now)
                    if frame.seq == ping_seq:
                        reply = frame
                elif isinstance(frame, RangeFrame):
                    self._on_range(frame, now)
        if reply is None:
            raise BridgeError(
                f"{self.port_url}: no reply — wrong firmware or baud rate? This needs the deskarm "
                f"firmware at {self.baudrate} baud (boards with the original firmware: use "
                f"v1:{self.port_url})"
            )
        n = len(self.profile.joints)
        if reply.n_joints < n:
            raise BridgeError(
                f"{self.port_url}: the board drives {reply.n_joints} joints but profile "
                f"{self.profile.name!r} needs {n} — flash firmware built for {n} joints or choose another profile"
            )
        if Flag.CONFIG_REJECTED in reply.flags:
            cfg = ", ".join(f"{c.min_pulse_us}–{c.max_pulse_us} µs {c.max_speed_dps} °/s" for c in self.configs)
            raise BridgeError(
                f"{self.port_url}: the board rejected CONFIG ({cfg}); expected {PULSE_MIN_US} ≤ min < max "
                f"≤ {PULSE_MAX_US} µs and speed ≤ {SPEED_MAX_DPS} °/s"
            )
        if Flag.ESTOP in reply.flags and not self._estopped:
            self._estopped = True  # someone stopped it; only the user may re-arm
            self._note = "the board was e-stopped"
        self.message = f"protocol v2, {reply.n_joints} joints on the board"

    def _config_frames(self) -> list[bytes]:
        return [
            encode_config(self._next_seq(), j, c.min_pulse_us, c.max_pulse_us, c.max_speed_dps)
            for j, c in enumerate(self.configs)
        ]

    def _next_seq(self) -> int:
        """The next frame SEQ (caller holds ``_write_lock``)."""
        self._seq = (self._seq + 1) & 0xFF
        return self._seq

    # ---------------------------------------------------------------- I/O thread

    def _run(self, port, stop: threading.Event) -> None:
        next_ping = time.monotonic() + (1.0 / self.heartbeat_hz if self.heartbeat_hz > 0 else 0.0)
        try:
            while not stop.is_set():
                data = port.read(max(1, port.in_waiting or 0))
                now = time.monotonic()
                if data:
                    for frame in self._decoder.feed(data):
                        if isinstance(frame, StatusFrame):
                            self._after_status(port, frame, *self._on_status(frame, now))
                        elif isinstance(frame, RangeFrame):
                            self._on_range(frame, now)
                self._flush_pending(port, now)
                hz = self.heartbeat_hz
                if hz <= 0:
                    next_ping = now
                elif now >= next_ping:
                    with self._write_lock:
                        self._write_ping(port)
                    next_ping = max(next_ping + 1.0 / hz, now + 0.5 / hz)
        except Exception as exc:  # noqa: BLE001 - unplugged, closed under us: never a crash
            if not stop.is_set():
                self._lost(port, exc)

    def _lost(self, port, exc: Exception) -> None:
        """The link broke: mark disconnected with a plain message; connect() reopens."""
        # a port closed under a blocked read makes pyserial fail with a TypeError or similar:
        # lost_port_error reads that as the device gone
        message = str(lost_port_error(self.port_url, port, exc))
        with self._write_lock:
            if self._port is not port:
                return
            self._port = None
            self._connected = False
            self._pending = None
            self.message = message
            self._link_down.set()
        close_quietly(port)
        with self._cond:
            self._cond.notify_all()

    def _write(self, port, data: bytes) -> None:
        """Write under ``_write_lock`` (held by the caller); a failure loses the link."""
        try:
            port.write(data)
        except Exception as exc:  # noqa: BLE001 - every way a port fails is a lost link
            error = lost_port_error(self.port_url, port, exc)
            self._write_lock.release()
            try:
                self._lost(port, exc)
            finally:
                self._write_lock.acquire()
            raise error from None

    def _write_ping(self, port) -> int:
        seq = self._next_seq()
        self._ping_sent[seq] = time.monotonic()
        self._write(port, encode_ping(seq))
        self.pings_sent += 1
        return seq

    def _flush_pending(self, port, now: float) -> None:
        with self._write_lock:
            if self._pending is not None and now >= self._next_slot and self._port is port:
                cdeg, source_t = self._pending
                if self._estopped:
                    self._pending = None
                else:
                    self._write_set_joints(port, cdeg, source_t, now)

    def _write_set_joints(self, port, cdeg: tuple[int, ...], source_t, now: float) -> None:
        """Write one SET_JOINTS and book the next 20 ms slot (caller holds ``_write_lock``)."""
        data = encode_set_joints_cdeg(self._next_seq(), cdeg)
        self._pending = None
        self._write(port, data)
        self.commands_sent += 1
        self.bytes_written += len(data)
        self.last_write_t = self.clock.now()
        self.last_source_t = source_t
        if self.max_command_hz > 0:
            period = 1.0 / self.max_command_hz
            # keep the slot grid when on time or a little late; after a pause start afresh
            base = now if now >= self._next_slot + period else self._next_slot
            self._next_slot = max(base + period, now + 0.5 * period)

    def _on_status(self, frame: StatusFrame, now: float) -> tuple[Optional[float], bool]:
        """A STATUS arrived: counters, round trip, measured joint state.

        Returns (write time of the PING it answers or None, whether the board restarted).
        """
        with self._write_lock:
            sent = self._ping_sent.pop(frame.seq, None)
        counts = (frame.good_frames, frame.bad_frames, frame.dropped_bytes)
        with self._cond:
            reset_seen = False
            if self._board_base is None:
                self._board_base = counts
            elif _delta16(frame.good_frames, self._board_last_good) > 0x8000:
                # the count went back: the board restarted and forgot its CONFIG
                self._board_resets += 1
                self._board_base = (0, 0, 0)
                reset_seen = True
            self._board_last_good = frame.good_frames
            if sent is not None:
                self._rtt_s.append(now - sent)
            deg = []
            measured = True
            off = False
            for j, cfg in enumerate(self.configs):
                pulse = frame.pulses_us[j] if j < frame.n_joints else 0
                if pulse:
                    self._measured_deg[j] = cfg.pulse_to_servo_deg(pulse)
                else:
                    off = True
                d = self._measured_deg[j]
                if d is None:  # never driven: the servo's position is unknown
                    measured = False
                    queued = self._queued_cdeg or self._home_cdeg
                    d = queued[j] / 100.0
                deg.append(d)
            q = tuple(jt.from_servo_deg(d) for jt, d in zip(self.profile.joints, deg))
            self._pulses_off = off
            self._state = JointState(seq=self._state_seq.next(), t=self.clock.now(), q=q, measured=measured)
            self._status, self._status_t = frame, now
            self._status_count += 1
            self._cond.notify_all()
        return sent, reset_seen

    def _on_range(self, frame: RangeFrame, now: float) -> None:
        """A RANGE arrived: keep it as the newest reading."""
        reading = RangeReading(distance_m=frame.distance_m, t=self.clock.now(), monotonic_t=now,
                               seq=frame.seq, board_tick=frame.tick)
        with self._cond:
            self._range = reading
            self._range_count += 1
            self._cond.notify_all()

    def _after_status(self, port, frame: StatusFrame, ping_t: Optional[float], reset_seen: bool) -> None:
        """Repairs a STATUS asks for: CONFIG after a board restart, ESTOP if ours was lost."""
        with self._write_lock:
            if self._port is not port:
                return
            data = b""
            if reset_seen:
                data += b"".join(self._config_frames())
                self._note = "board restart noticed: CONFIG sent again"
            if self._estopped and Flag.ESTOP not in frame.flags:
                # the board should be stopped: resend, unless this STATUS answers a PING
                # written before our ESTOP (then the ESTOP may simply not have arrived yet)
                written = self._estop_written_t
                if reset_seen or written is None or (ping_t is not None and ping_t > written):
                    data += encode_estop(self._next_seq())
                    self._estop_written_t = time.monotonic()
            if data:
                self._write(port, data)

    # ---------------------------------------------------------------- commands

    def send(self, command: JointCommand) -> tuple[float, ...]:
        """Clamp, convert to centidegrees and write SET_JOINTS (at most ``max_command_hz``).

        A caller faster than the cap keeps only its newest command: the I/O thread writes it at
        the next slot. Returns the servo angles (deg, 0.01° steps) queued, or ``()`` while
        e-stopped (nothing is written). Raises BridgeError when not connected.
        """
        if self._estopped:
            return ()
        cdeg = to_servo_cdeg(command.q, self.profile)
        with self._write_lock:
            port = self._port
            if port is None or not self._connected:
                raise BridgeError(f"{self.url}: not connected")
            if self._estopped:
                return ()
            self._queued_cdeg = cdeg
            now = time.monotonic()
            if self.max_command_hz <= 0 or now >= self._next_slot:
                self._write_set_joints(port, cdeg, command.source_t, now)
            else:
                if self._pending is not None:
                    self.commands_coalesced += 1
                self._pending = (cdeg, command.source_t)
        self._last_sent_deg = tuple(c / 100.0 for c in cdeg)
        return self._last_sent_deg

    def _write_servo_deg(self, servo_deg: tuple[int, ...]) -> int:
        """Write whole-degree servo angles at once (the base interface; ``send`` is the way in)."""
        cdeg = tuple(int(d) * 100 for d in servo_deg)
        with self._write_lock:
            if self._port is None:
                raise BridgeError(f"{self.url}: not connected")
            before = self.bytes_written
            self._write_set_joints(self._port, cdeg, None, time.monotonic())
            return self.bytes_written - before

    def _on_estop(self) -> None:
        """Send ESTOP (every pulse off on the board) and drop a waiting command."""
        with self._write_lock:
            self._pending = None
            port = self._port
            if port is None:
                return  # sent on the next connect
            self._write(port, encode_estop(self._next_seq()))
            self._estop_written_t = time.monotonic()

    def _on_rearm(self) -> None:
        """Send ARM: pulses resume where they were held; nothing moves until the next command."""
        with self._write_lock:
            self._estop_written_t = None
            port = self._port
            if port is None:
                return  # a board still e-stopped at the next connect is adopted as e-stopped
            self._write(port, encode_arm(self._next_seq()))

    def _estop_text(self) -> str:
        return "E-STOP: pulses off on the board; re-arm to resume"

    def ping(self) -> int:
        """Send a PING now (besides the heartbeat); returns its SEQ, echoed by the STATUS reply."""
        with self._write_lock:
            if self._port is None:
                raise BridgeError(f"{self.url}: not connected")
            return self._write_ping(self._port)

    def write_raw(self, data: bytes) -> int:
        """Write bytes exactly as given, under the write lock (tests and line diagnostics only)."""
        with self._write_lock:
            if self._port is None:
                raise BridgeError(f"{self.url}: not connected")
            self._write(self._port, bytes(data))
        return len(data)

    # ---------------------------------------------------------------- state and status

    def joint_state(self) -> Optional[JointState]:
        """The joint state measured from the newest STATUS (None before the first one).

        A joint whose pulse is off (e-stop) keeps its last measured angle (see ``pulses_off``);
        a joint never driven shows the commanded or home angle and ``measured=False``.
        """
        with self._cond:
            return self._state

    @property
    def pulses_off(self) -> bool:
        """True when the newest STATUS reports a joint with its pulse off (limp servo)."""
        with self._cond:
            return self._pulses_off

    @property
    def last_status(self) -> Optional[StatusFrame]:
        """The newest STATUS frame (this connection), or None."""
        with self._cond:
            return self._status

    def wait_for_status(self, timeout: float, predicate: Optional[Callable[[StatusFrame], bool]] = None,
                        seq: Optional[int] = None) -> Optional[StatusFrame]:
        """Block until a STATUS arriving after this call (answering PING ``seq`` if given, and
        satisfying ``predicate``); None after ``timeout`` s or when the link goes down."""
        deadline = time.monotonic() + timeout
        with self._cond:
            seen = self._status_count
            while True:
                if self._status_count > seen:
                    seen = self._status_count
                    st = self._status
                    if (seq is None or st.seq == seq) and (predicate is None or predicate(st)):
                        return st
                left = deadline - time.monotonic()
                if left <= 0 or not self._connected:
                    return None
                self._cond.wait(left)

    def range_reading(self) -> Optional[RangeReading]:
        """The newest range reading on this connection, however old; None from a board without
        a range sensor (or firmware that predates RANGE) and before the first reading."""
        with self._cond:
            return self._range

    def range_m(self, max_age_s: float = RANGE_STALE_S) -> Optional[float]:
        """The distance the board's range sensor measures now (m), or None: no sensor, no valid
        echo, or no reading for ``max_age_s`` seconds (lost readings are never reused)."""
        reading = self.range_reading()
        if reading is None or time.monotonic() - reading.monotonic_t > max_age_s:
            return None
        return reading.distance_m

    def wait_for_range(self, timeout: float,
                       predicate: Optional[Callable[[RangeReading], bool]] = None) -> Optional[RangeReading]:
        """Block until a RANGE arriving after this call (satisfying ``predicate``); None after
        ``timeout`` s or when the link goes down."""
        deadline = time.monotonic() + timeout
        with self._cond:
            seen = self._range_count
            while True:
                if self._range_count > seen:
                    seen = self._range_count
                    if predicate is None or predicate(self._range):
                        return self._range
                left = deadline - time.monotonic()
                if left <= 0 or not self._connected:
                    return None
                self._cond.wait(left)

    def rtt_samples_s(self) -> list[float]:
        """PING → STATUS round trips measured so far (s), oldest first."""
        with self._cond:
            return list(self._rtt_s)

    def counters(self) -> V2Counters:
        """Frame counters on both ends of the line, for the status bar and tests."""
        with self._cond:
            st, base = self._status, self._board_base or (0, 0, 0)
            board = (0, 0, 0) if st is None else (
                _delta16(st.good_frames, base[0]), _delta16(st.bad_frames, base[1]),
                _delta16(st.dropped_bytes, base[2]))
            d = self._decoder
            return V2Counters(
                host_good_frames=d.good_frames, host_bad_frames=d.bad_frames,
                host_dropped_bytes=d.dropped_bytes, board_good_frames=board[0],
                board_bad_frames=board[1], board_dropped_bytes=board[2],
                status_frames=self._status_count, commands_written=self.commands_sent,
                commands_coalesced=self.commands_coalesced, pings_sent=self.pings_sent,
                board_resets=self._board_resets, range_frames=self._range_count,
            )

    def status(self) -> BridgeStatus:
        """Connection state; the message names the flags, bad frames and the round trip."""
        if self._connected:
            c = self.counters()
            with self._cond:
                st, st_t, rtts = self._status, self._status_t, list(self._rtt_s)[-50:]
                off = self._pulses_off
            parts = [self.message or "protocol v2"]
            if st is not None:
                flags = st.flags & ~Flag.ESTOP if self._estopped else st.flags  # said in front
                parts += describe_flags(flags)
                if off and Flag.ESTOP not in st.flags:
                    parts.append("some servos not driven yet (pulse off)")
            parts.append(f"bad frames: {c.board_bad_frames} at the board, {c.host_bad_frames} here")
            if c.board_dropped_bytes or c.host_dropped_bytes:
                parts.append(f"dropped bytes: {c.board_dropped_bytes} at the board, {c.host_dropped_bytes} here")
            if rtts:
                parts.append(f"round trip {statistics.median(rtts) * 1e3:.1f} ms")
            if self.heartbeat_hz > 0 and st_t is not None and time.monotonic() - st_t > STALE_STATUS_S:
                parts.append(f"no STATUS for {time.monotonic() - st_t:.1f} s — board not answering (reset? unplugged?)")
            with self._cond:
                reading = self._range
            if reading is not None and time.monotonic() - reading.monotonic_t <= RANGE_STALE_S:
                d = reading.distance_m
                parts.append("range: no echo" if d is None else f"range {d * 1e3:.0f} mm")
            if self._note:
                parts.append(self._note)
            message = " · ".join(parts)
        else:
            message = self.message or "not connected"
        if self._estopped:
            message = f"{self._estop_text()} · {message}"
        return BridgeStatus(
            url=self.url, connected=self._connected, message=message,
            commands_sent=self.commands_sent, bytes_written=self.bytes_written,
            last_write_t=self.last_write_t, last_source_t=self.last_source_t,
            request_failed=self.request_failed,
        )
