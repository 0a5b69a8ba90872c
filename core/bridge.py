"""Motor bridges: one interface, a simulated servo arm and the seed serial protocol (v1).

``open_bridge("sim://", profile)`` gives the simulated arm; ``/dev/ttyACM0``, ``loop://`` or any
pyserial URL gives the v1 serial bridge. Every bridge clamps again before it writes: no path can
command a servo outside its joint limits or outside 0–180°.
"""
from __future__ import annotations

import math
import threading
from abc import ABC, abstractmethod
from typing import Optional, Sequence

from core.clock import WallClock
from core.messages import BridgeStatus, JointCommand, JointState, SequenceCounter
from core.protocol_v1 import V1_BAUD, encode_v1
from core.safety import to_servo_bytes_deg

BRIDGE_CHOICES = "sim:// (simulated arm) | /dev/ttyACM0, /dev/ttyUSB0, COM3 … (serial, protocol v1) | loop:// (pyserial loopback)"


class BridgeError(RuntimeError):
    """The bridge could not connect or lost its device; the message says what to do."""


class MotorBridge(ABC):
    """Sends joint commands to an arm and reports its joint state.

    Lifecycle: ``connect()``, ``disconnect()``, ``is_connected``, context manager.
    ``send`` returns the servo angles actually sent after clamping.
    """

    has_feedback = False

    def __init__(self, url: str, profile, clock=None):
        self.url = url
        self.profile = profile
        self.clock = clock or WallClock()
        self.commands_sent = 0
        self.bytes_written = 0
        self.last_write_t: Optional[float] = None
        self.last_source_t: Optional[float] = None
        self.message = ""
        self._state_seq = SequenceCounter()
        self._last_sent_deg: Optional[tuple[int, ...]] = None

    @abstractmethod
    def connect(self) -> None: ...

    @abstractmethod
    def disconnect(self) -> None: ...

    @property
    @abstractmethod
    def is_connected(self) -> bool: ...

    @abstractmethod
    def _write_servo_deg(self, servo_deg: tuple[int, ...]) -> int:
        """Write whole-degree servo angles; returns the number of bytes written."""

    def send(self, command: JointCommand) -> tuple[int, ...]:
        """Clamp, convert to servo degrees and write; returns the servo angles sent."""
        servo_deg = to_servo_bytes_deg(command.q, self.profile)
        written = self._write_servo_deg(servo_deg)
        self.commands_sent += 1
        self.bytes_written += written
        self.last_write_t = self.clock.now()
        self.last_source_t = command.source_t
        self._last_sent_deg = servo_deg
        return servo_deg

    def joint_state(self) -> Optional[JointState]:
        """The arm's joint state: measured, or the last command echoed (``measured=False``)."""
        if self._last_sent_deg is None:
            return None
        q = servo_deg_to_q(self._last_sent_deg, self.profile)
        return JointState(seq=self._state_seq.next(), t=self.clock.now(), q=q, measured=False)

    def status(self) -> BridgeStatus:
        return BridgeStatus(
            url=self.url, connected=self.is_connected, message=self.message,
            commands_sent=self.commands_sent, bytes_written=self.bytes_written,
            last_write_t=self.last_write_t, last_source_t=self.last_source_t,
        )

    def __enter__(self):
        self.connect()
        return self

    def __exit__(self, *exc):
        self.disconnect()


def servo_deg_to_q(servo_deg: Sequence[float], profile) -> tuple[float, ...]:
    """Servo angles (deg) -> kinematic joint values (rad) through each joint's offset/direction."""
    return tuple(j.from_servo_deg(d) for j, d in zip(profile.joints, servo_deg))


class SimServoArm(MotorBridge):
    """A simulated hobby-servo arm (MG996R-like).

    Each servo turns toward its commanded angle at ``speed_deg_s`` (~60° in 0.17 s), in whole
    degree steps, updated at ``rate_hz`` (the 50 Hz PWM frame). It starts at the profile's home.
    """

    has_feedback = True

    def __init__(self, profile, clock=None, speed_deg_s: float = 60.0 / 0.17,
                 rate_hz: float = 50.0, url: str = "sim://"):
        super().__init__(url, profile, clock)
        self.speed_deg_s = float(speed_deg_s)
        self.period_s = 1.0 / float(rate_hz)
        home = profile.to_servo_deg(profile.q_home)
        self.position_deg = [float(round(d)) for d in home]
        self.target_deg = list(self.position_deg)
        self._connected = False
        self._last_tick: Optional[float] = None
        self._lock = threading.Lock()

    def connect(self) -> None:
        self._connected = True
        self._last_tick = self.clock.now()
        self.message = "simulated arm"

    def disconnect(self) -> None:
        self._connected = False

    @property
    def is_connected(self) -> bool:
        return self._connected

    def _advance(self) -> None:
        """Run the servo model's 50 Hz ticks up to now."""
        now = self.clock.now()
        if self._last_tick is None:
            self._last_tick = now
        max_step = self.speed_deg_s * self.period_s
        ticks = 0
        while now - self._last_tick >= self.period_s and ticks < 500:
            self._last_tick += self.period_s
            ticks += 1
            for k, (pos, tgt) in enumerate(zip(self.position_deg, self.target_deg)):
                step = max(-max_step, min(max_step, tgt - pos))
                self.position_deg[k] = float(round(pos + step))  # 1° resolution
        if ticks >= 500:
            self._last_tick = now

    def _write_servo_deg(self, servo_deg: tuple[int, ...]) -> int:
        if not self._connected:
            raise BridgeError("simulated arm is not connected")
        with self._lock:
            self._advance()
            self.target_deg = [float(d) for d in servo_deg]
        return len(encode_v1(servo_deg)) if len(servo_deg) <= 3 else 0

    def joint_state(self) -> JointState:
        with self._lock:
            self._advance()
            q = servo_deg_to_q(self.position_deg, self.profile)
        return JointState(seq=self._state_seq.next(), t=self.clock.now(), q=q, measured=True)

    def is_settled(self) -> bool:
        """True when every servo has reached its commanded angle."""
        with self._lock:
            self._advance()
            return all(abs(p - t) < 0.5 for p, t in zip(self.position_deg, self.target_deg))


def explain_serial_error(url: str, exc: Exception) -> str:
    """Turn a pyserial/OS error into a sentence that says what to do."""
    text = str(exc)
    low = text.lower()
    if "permission denied" in low or "errno 13" in low:
        return f"{url}: permission denied — add your user to the 'dialout' group and log in again"
    if "no such file" in low or "errno 2" in low or "could not open port" in low and "filenotfound" in low:
        return f"{url}: no such port — is the board plugged in? Valid ports look like /dev/ttyACM0, /dev/ttyUSB0 or COM3"
    if "busy" in low or "errno 16" in low:
        return f"{url}: port busy — close the other program using it (serial monitor, another deskarm)"
    return f"{url}: {text or type(exc).__name__}"


class SerialV1Bridge(MotorBridge):
    """The seed protocol over pyserial: ``FB a1 FC a2 FD a3`` at 9600 baud, no feedback."""

    has_feedback = False

    def __init__(self, url: str, profile, clock=None, serial_factory=None):
        super().__init__(url, profile, clock)
        if len(profile.joints) > 3:
            raise BridgeError(f"protocol v1 drives 3 joints; profile {profile.name!r} has {len(profile.joints)}")
        self._factory = serial_factory
        self._port = None
        self._lock = threading.Lock()

    def connect(self) -> None:
        import serial

        factory = self._factory or serial.serial_for_url
        try:
            self._port = factory(self.url, baudrate=V1_BAUD, bytesize=8, parity="N", stopbits=1,
                                 timeout=0, write_timeout=1.0)
        except (serial.SerialException, OSError, ValueError) as exc:
            raise BridgeError(explain_serial_error(self.url, exc)) from None
        self.message = "protocol v1 — no feedback: the twin shows commanded angles"

    def disconnect(self) -> None:
        with self._lock:
            if self._port is not None:
                try:
                    self._port.close()
                finally:
                    self._port = None

    @property
    def is_connected(self) -> bool:
        return self._port is not None and bool(getattr(self._port, "is_open", True))

    def _write_servo_deg(self, servo_deg: tuple[int, ...]) -> int:
        import serial

        data = encode_v1(servo_deg)
        with self._lock:
            if self._port is None:
                raise BridgeError(f"{self.url}: not connected")
            try:
                n = self._port.write(data)
                self._port.flush()
            except (serial.SerialException, OSError) as exc:
                self._port = None
                raise BridgeError(explain_serial_error(self.url, exc)) from None
        return int(n or 0)

    def read_available(self) -> bytes:
        """Bytes waiting on the port (a loop:// test reads its own echo here)."""
        with self._lock:
            if self._port is None:
                return b""
            return self._port.read(self._port.in_waiting or 0)


def parse_bridge_url(url: str) -> str:
    """'sim' or 'serial'; ValueError naming the value and the valid forms."""
    url = (url or "sim://").strip()
    if url in ("sim", "sim://"):
        return "sim"
    if url.startswith(("/dev/", "COM", "loop://", "socket://", "rfc2217://", "spy://", "hwgrep://")) or (
        url.startswith("/") and "tty" in url
    ):
        return "serial"
    raise ValueError(f"unknown --bridge value {url!r}; valid: {BRIDGE_CHOICES}")


def open_bridge(url: str, profile, clock=None) -> MotorBridge:
    """The bridge named by ``url`` (not yet connected)."""
    kind = parse_bridge_url(url)
    if kind == "sim":
        return SimServoArm(profile, clock=clock)
    return SerialV1Bridge(url, profile, clock=clock)


def is_finite_q(q: Sequence[float]) -> bool:
    return all(math.isfinite(v) for v in q)
