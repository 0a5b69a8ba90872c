"""A running host_firmware (the firmware logic on a pseudo-terminal) for the tests that talk to it."""
from __future__ import annotations

import queue
import signal
import subprocess
import threading
import time
from pathlib import Path
from typing import Optional

import serial

from core.devices import protocol_v2 as p

TIMEOUT_S = 3.0  # generous: a loaded CI machine must not fail these
SILENCE_S = 0.3  # 15 ticks without a PWM line: the ramp has stopped


class V2Ports:
    """Ports on a board's serial line (``self.path``; opened ones kept in ``self.ports``) and the
    v2 PING → STATUS exchange, stopping its process; the host firmware's Board and the emulated Arduino
    share it."""

    timeout_s = TIMEOUT_S

    def open(self) -> serial.Serial:
        port = serial.Serial(self.path, 9600, timeout=0.05)
        self.ports.append(port)
        return port

    def next_seq(self) -> int:
        self._seq = (self._seq + 1) % 256
        return self._seq

    def status(self, port: serial.Serial, timeout: Optional[float] = None) -> p.StatusFrame:
        """PING and return the STATUS reply that echoes its seq."""
        timeout = self.timeout_s if timeout is None else timeout
        seq = self.next_seq()
        port.write(p.encode_ping(seq))
        dec = p.V2Decoder()
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            for frame in dec.feed(port.read(max(1, port.in_waiting))):
                if isinstance(frame, p.StatusFrame) and frame.seq == seq:
                    return frame
        raise AssertionError(f"no STATUS reply to PING seq {seq} within {timeout} s")

    def stop(self, sig: int = signal.SIGTERM) -> Optional[int]:
        """Close the ports, then end the board's process (``self.proc``): ``sig``, killed after 5 s."""
        for port in self.ports:
            port.close()
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
            try:
                self.proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        return self.proc.returncode


class Board(V2Ports):
    """A running host_firmware: its stdout lines, its port, and helpers to talk to it."""

    def __init__(self, exe: Path, *args: str) -> None:
        self.proc = subprocess.Popen(
            [str(exe), *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        self.lines: "queue.Queue[str]" = queue.Queue()
        self._reader = threading.Thread(target=self._read_stdout, daemon=True)
        self._reader.start()
        self._seq = 0
        self.ports: list[serial.Serial] = []
        first = self.next_line()
        assert first.startswith("PORT "), f"expected 'PORT <path>' first, got {first!r}"
        self.path = first.split(" ", 1)[1]

    def _read_stdout(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.put(line.rstrip("\n"))

    def next_line(self, timeout: float = TIMEOUT_S) -> str:
        try:
            return self.lines.get(timeout=timeout)
        except queue.Empty:
            raise AssertionError(f"host_firmware printed nothing for {timeout} s") from None

    def next_pwm(self, timeout: float = TIMEOUT_S) -> tuple[int, ...]:
        """The next PWM line's pulse widths (µs)."""
        line = self.next_line(timeout)
        assert line.startswith("PWM "), f"unexpected line {line!r}"
        return tuple(int(x) for x in line.split()[1:])

    def wait_pwm(self, *pulses: int, timeout: float = TIMEOUT_S) -> list[tuple[int, ...]]:
        """Read PWM lines until one equals ``pulses``; return every PWM line read."""
        seen: list[tuple[int, ...]] = []
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                raise AssertionError(f"no 'PWM {pulses}' within {timeout} s; saw {seen}")
            seen.append(self.next_pwm(left))
            if seen[-1] == pulses:
                return seen

    def pwm_until_silent(self, silence: float = SILENCE_S) -> list[tuple[int, ...]]:
        """Read PWM lines until none arrives for ``silence`` seconds."""
        seen: list[tuple[int, ...]] = []
        while True:
            try:
                line = self.lines.get(timeout=silence)
            except queue.Empty:
                return seen
            seen.append(tuple(int(x) for x in line.split()[1:]))


