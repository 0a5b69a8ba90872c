"""Clocks: wall time for the app, a simulated clock for ``--fast`` runs and tests.

Every component that needs the time takes a clock, so the headless runner can run the very same
objects faster than real time and still get consistent timestamps.
"""
from __future__ import annotations

import threading
import time


class WallClock:
    """Monotonic wall time; ``wait_until`` blocks (interruptibly) until the deadline."""

    simulated = False

    def __init__(self) -> None:
        self._wake = threading.Event()

    def now(self) -> float:
        return time.monotonic()

    def wait_until(self, deadline: float) -> bool:
        """Block until ``deadline`` or ``interrupt()``; True when the deadline was reached."""
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            return True
        interrupted = self._wake.wait(remaining)
        if interrupted:
            self._wake.clear()
        return not interrupted

    def interrupt(self) -> None:
        """Wake a thread blocked in ``wait_until`` (used on shutdown)."""
        self._wake.set()


class SimClock:
    """A clock that only moves when told to: ``wait_until`` jumps straight to the deadline."""

    simulated = True

    def __init__(self, start: float = 0.0) -> None:
        self._now = float(start)
        self._lock = threading.Lock()

    def now(self) -> float:
        with self._lock:
            return self._now

    def advance(self, dt: float) -> None:
        with self._lock:
            self._now += max(0.0, float(dt))

    def wait_until(self, deadline: float) -> bool:
        with self._lock:
            self._now = max(self._now, float(deadline))
        return True

    def interrupt(self) -> None:
        pass
