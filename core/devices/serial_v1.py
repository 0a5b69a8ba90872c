"""The seed protocol v1 over pyserial: ``FB a1 FC a2 FD a3`` at 9600 baud, no feedback."""
from __future__ import annotations

import threading

from core.devices.bridge import BridgeError, MotorBridge, explain_serial_error
from core.devices.protocol_v1 import V1_BAUD, encode_v1


class SerialV1Bridge(MotorBridge):
    """The seed protocol over pyserial: ``FB a1 FC a2 FD a3`` at 9600 baud, no feedback."""

    has_feedback = False

    def __init__(self, url: str, profile, clock=None, serial_factory=None):
        super().__init__(url, profile, clock)
        if len(profile.joints) > 3:
            raise BridgeError(f"protocol v1 drives 3 joints; profile {profile.name!r} has {len(profile.joints)}")
        if not getattr(profile, "has_servos", True):
            raise BridgeError(
                f"protocol v1 drives hobby servos; profile {profile.name!r} has no servo mapping "
                f"(servo_min_deg/offset_deg/direction) — use sim:// or add the servo fields"
            )
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
