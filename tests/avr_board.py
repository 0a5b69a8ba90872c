"""The ATmega328P firmware image running in simavr (firmware/sim/avr_harness), for the tests.

The harness prints ``PORT <pty>`` first, then what it measures on the emulated pins:
``PULSE <pin> <t_us> <width_us> <period_us>``, ``OFF <pin> <t_us>``, ``CLOCK <emulated_s>
<wall_s>``, and on exit ``END …`` and ``STACK <bytes>`` (see firmware/sim/avr_harness.c). Times are emulated microseconds
since reset, from the pins' change cycles; nothing comes from the firmware's own output.
"""
from __future__ import annotations

import queue
import signal
import subprocess
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Optional, Union

import serial

from core.devices import protocol_v2 as p
from tests.host_board import V2Ports

TIMEOUT_S = 10.0  # a give-up, not a timing check: the emulation runs in real time when it can
PINS = ("D9", "D10", "D11")  # joints 1, 2, 3 (PB1, PB2, PB3)


@dataclass(frozen=True)
class Pulse:
    pin: str
    t_us: float       # rising edge, emulated µs since reset
    width_us: float   # high time
    period_us: float  # since the pin's previous rising edge; 0 for the first of a train


@dataclass(frozen=True)
class Off:
    pin: str
    t_us: float  # emulated time when the pin had gone 25 ms without a rising edge


@dataclass(frozen=True)
class Clock:
    emulated_s: float
    wall_s: float


Event = Union[Pulse, Off, Clock]


class AvrBoard(V2Ports):
    """A running avr_harness: its measured events, its port, and helpers to talk to it."""

    timeout_s = TIMEOUT_S  # the emulation may run slower than real time on a loaded machine

    def __init__(self, harness: Path, firmware: Path, *args: str) -> None:
        self.proc = subprocess.Popen(
            [str(harness), *args, str(firmware)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
            text=True,
        )
        self.events: "queue.Queue[Optional[Event]]" = queue.Queue()
        self.clocks: list[Clock] = []
        self.stack_bytes: Optional[int] = None  # the harness's STACK line, once it has exited
        self._port_line: "queue.Queue[str]" = queue.Queue()
        self._reader = threading.Thread(target=self._read_stdout, daemon=True)
        self._reader.start()
        self._seq = 0
        self.ports: list[serial.Serial] = []
        try:
            first = self._port_line.get(timeout=TIMEOUT_S)
        except queue.Empty:
            self.stop()
            raise AssertionError("avr_harness printed no PORT line") from None
        assert first.startswith("PORT "), f"expected 'PORT <path>' first, got {first!r}"
        self.path = first.split(" ", 1)[1]

    def _read_stdout(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            word, *rest = line.split()
            if word == "PORT":
                self._port_line.put(line.strip())
            elif word == "PULSE":
                self.events.put(Pulse(rest[0], float(rest[1]), float(rest[2]), float(rest[3])))
            elif word == "OFF":
                self.events.put(Off(rest[0], float(rest[1])))
            elif word == "CLOCK":
                clock = Clock(float(rest[0]), float(rest[1]))
                self.clocks.append(clock)
                self.events.put(clock)
            elif word == "STACK":
                self.stack_bytes = int(rest[0])
        self.events.put(None)  # the harness ended

    def next_event(self, timeout: float = TIMEOUT_S) -> Event:
        try:
            ev = self.events.get(timeout=timeout)
        except queue.Empty:
            raise AssertionError(f"avr_harness measured nothing for {timeout} s") from None
        if ev is None:
            err = self.proc.stderr.read() if self.proc.stderr else ""
            raise AssertionError(f"avr_harness ended (status {self.proc.poll()}): {err}")
        return ev

    def read_until(self, done: Callable[[list[Event]], bool], timeout: float = TIMEOUT_S,
                   what: str = "the expected pulses") -> list[Event]:
        """Read events until ``done(events read so far)``; return them."""
        seen: list[Event] = []
        deadline = time.monotonic() + timeout
        while not done(seen):
            left = deadline - time.monotonic()
            if left <= 0:
                pulses = [e for e in seen if not isinstance(e, Clock)]
                raise AssertionError(f"no {what} within {timeout} s; last events {pulses[-9:]}")
            seen.append(self.next_event(left))
        return seen

    def wait_widths(self, *widths_us: float, tol_us: float = 2.0,
                    timeout: float = TIMEOUT_S) -> list[Event]:
        """Read until the last pulse on D9, D10, D11 is each within tol of ``widths_us``."""
        def done(seen: list[Event]) -> bool:
            last = last_widths(seen)
            return all(pin in last and abs(last[pin] - w) <= tol_us
                       for pin, w in zip(PINS, widths_us))
        return self.read_until(done, timeout, what=f"pulses {widths_us} µs")

    def collect(self, n: int, timeout: float = TIMEOUT_S) -> dict[str, list[Pulse]]:
        """The next ``n`` pulses of each pin."""
        by_pin: dict[str, list[Pulse]] = {pin: [] for pin in PINS}

        def done(seen: list[Event]) -> bool:
            if seen and isinstance(seen[-1], Pulse):
                by_pin[seen[-1].pin].append(seen[-1])
            return all(len(v) >= n for v in by_pin.values())
        self.read_until(done, timeout, what=f"{n} pulses on each pin")
        return {pin: v[:n] for pin, v in by_pin.items()}


    def speed_ratio(self) -> Optional[float]:
        """Emulated seconds per wall second over the run so far (None before the first CLOCK)."""
        if not self.clocks:
            return None
        last = self.clocks[-1]
        return last.emulated_s / last.wall_s if last.wall_s > 0 else None

    def stop(self, sig: int = signal.SIGTERM) -> Optional[int]:
        super().stop(sig)
        self._reader.join(timeout=5)
        return self.proc.returncode


def last_widths(events: list[Event]) -> dict[str, float]:
    """The most recent pulse width seen on each pin (pins gone OFF are dropped)."""
    last: dict[str, float] = {}
    for ev in events:
        if isinstance(ev, Pulse):
            last[ev.pin] = ev.width_us
        elif isinstance(ev, Off):
            last.pop(ev.pin, None)
    return last
