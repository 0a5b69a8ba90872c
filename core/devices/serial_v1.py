"""The seed protocol v1 over pyserial: ``FB a1 FC a2 FD a3`` at 9600 baud, no feedback.

A port that goes away (unplugged board, closed pty) fails in many ways — SerialException,
OSError, ``termios.error`` from ``flush``, ValueError or TypeError on a closed fd — and each
becomes a BridgeError and leaves the bridge disconnected, so the caller's reconnect path runs.
"""
from __future__ import annotations

import threading

from core.devices.bridge import (
    BridgeError,
    MotorBridge,
    close_quietly,
    explain_serial_error,
    lost_port_error,
    serial_error_types,
)
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
        """Open the port (again, after a lost link); BridgeError says what went wrong."""
        import serial

        if self.is_connected:
            return
        self.disconnect()  # a port left half-open: close it before opening a new one
        factory = self._factory or serial.serial_for_url
        try:
            # exclusive: a second deskarm (or a serial monitor using the lock) is told the port
            # is busy instead of driving the same arm, as v2 does
            port = factory(self.url, baudrate=V1_BAUD, bytesize=8, parity="N", stopbits=1,
                           timeout=0, write_timeout=1.0, exclusive=True)
        except (serial.SerialException, OSError, ValueError) as exc:
            raise BridgeError(explain_serial_error(self.url, exc)) from None
        with self._lock:
            self._port = port
        self.message = "protocol v1 — no feedback: the twin shows commanded angles"

    def disconnect(self) -> None:
        """Close the port; safe to call twice, and never raises: a port that fails to close is
        gone anyway (the failure is kept in ``message``)."""
        with self._lock:
            port, self._port = self._port, None
        if port is not None:
            try:
                port.close()
            except serial_error_types() as exc:
                self.message = explain_serial_error(self.url, exc)

    @property
    def is_connected(self) -> bool:
        return self._port is not None and bool(getattr(self._port, "is_open", True))

    def _lost(self, port, exc: BaseException) -> BridgeError:
        """The port failed: drop and close it, say why; the caller raises what this returns.
        Caller holds ``_lock``."""
        error = lost_port_error(self.url, port, exc)
        self._port = None
        close_quietly(port)
        self.message = str(error)
        return error

    def _write_servo_deg(self, servo_deg: tuple[int, ...]) -> int:
        data = encode_v1(servo_deg)
        with self._lock:
            port = self._port
            if port is None:
                raise BridgeError(f"{self.url}: not connected")
            try:
                n = port.write(data)
                port.flush()  # tcdrain: termios.error, not SerialException, when the device is gone
            except serial_error_types() as exc:
                raise self._lost(port, exc) from None
        return int(n or 0)

    def read_available(self) -> bytes:
        """Bytes waiting on the port (a loop:// test reads its own echo here)."""
        with self._lock:
            port = self._port
            if port is None:
                return b""
            try:
                return port.read(port.in_waiting or 0)
            except serial_error_types() as exc:
                raise self._lost(port, exc) from None
