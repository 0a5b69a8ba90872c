"""Keeping a motor bridge connected: retry ``connect()`` with a growing delay, count the outages.

The window's bridge worker and the headless runner share this, so both come back the same way
after a board is unplugged or reset: the first retry at once, then after 0.5 s, 1 s, 2 s, 4 s,
5 s, 5 s … until the board answers again. Time comes from a clock function (the session's
clock in the headless runner, so a ``--fast`` run backs off in simulated time).
"""
from __future__ import annotations

import time
from typing import Callable, Optional

from core.devices.bridge import BridgeError, MotorBridge

FIRST_RETRY_S = 0.5  # wait after the first failed connect; a replugged board is usually back by then
MAX_RETRY_S = 5.0  # the wait doubles after each failure up to this


class Reconnector:
    """Connects a bridge when needed, with backoff, and measures how long it was away.

    ``ensure(bridge)`` is cheap while connected; call it before each use of the bridge.
    ``lost(bridge, exc)`` reports a BridgeError from ``send``/``joint_state``. Not thread-safe:
    one thread (the bridge's user) calls it.
    """

    def __init__(self, now: Callable[[], float] = time.monotonic, first_retry_s: float = FIRST_RETRY_S,
                 max_retry_s: float = MAX_RETRY_S):
        if not 0 < first_retry_s <= max_retry_s:
            raise ValueError(f"first_retry_s = {first_retry_s}, max_retry_s = {max_retry_s}: "
                             "expected 0 < first_retry_s ≤ max_retry_s")
        self._now = now
        self.first_retry_s = float(first_retry_s)
        self.max_retry_s = float(max_retry_s)
        self.delay_s = self.first_retry_s  # wait after the next failed connect
        self.retry_at = float("-inf")  # no connect attempt before this time
        self.disconnects = 0  # links lost after being up (not failed connects)
        self.attempts = 0  # connect() calls made
        self._up = False  # the link was up when last looked at
        self._down_since: Optional[float] = None  # start of the current outage
        self._down_total_s = 0.0  # ended outages

    def reset(self) -> None:
        """Forget the backoff (a new bridge was chosen): the next connect is tried at once."""
        self.delay_s = self.first_retry_s
        self.retry_at = float("-inf")

    def ensure(self, bridge: MotorBridge) -> bool:
        """True when ``bridge`` is connected, connecting it first if its retry time has come.

        A failed connect leaves the reason in ``bridge.message`` and doubles the wait.
        """
        now = self._now()
        if bridge.is_connected:
            self._mark_up(now)
            return True
        self._mark_down(now)
        if now < self.retry_at:
            return False
        self.attempts += 1
        try:
            bridge.connect()
        except BridgeError as exc:
            bridge.message = f"{exc} — retrying in {self.delay_s:g} s"
            self.retry_at = now + self.delay_s
            self.delay_s = min(self.delay_s * 2.0, self.max_retry_s)
            return False
        self.delay_s = self.first_retry_s
        self._mark_up(self._now())
        return True

    def lost(self, bridge: MotorBridge, exc: BaseException) -> None:
        """``bridge`` raised ``exc`` (a BridgeError) while in use: count the outage, make sure it
        is disconnected (so ``ensure`` reconnects) and keep the reason as its message."""
        if bridge.is_connected:
            try:
                bridge.disconnect()
            except BridgeError:
                pass
        self._mark_down(self._now())
        bridge.message = str(exc)

    def disconnected_s(self) -> float:
        """Total time spent disconnected after a loss, the current outage included (s)."""
        ongoing = 0.0 if self._down_since is None else max(0.0, self._now() - self._down_since)
        return self._down_total_s + ongoing

    @property
    def is_down(self) -> bool:
        """True during an outage (from a loss until the link is up again)."""
        return self._down_since is not None

    def _mark_up(self, now: float) -> None:
        if self._down_since is not None:
            self._down_total_s += max(0.0, now - self._down_since)
            self._down_since = None
        self._up = True

    def _mark_down(self, now: float) -> None:
        if self._up:  # a link that was up went away: one disconnect, one outage starts
            self._up = False
            self.disconnects += 1
            self._down_since = now
