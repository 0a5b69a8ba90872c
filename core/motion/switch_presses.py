"""A switch user's presses, without Qt: which press is held, when a hold becomes a stop (or a
re-arm), and which key releases are only X11 auto-repeat.

``SwitchPresses`` keeps the one switch held now (``HeldSwitch``; a second switch pressed meanwhile
is ignored) and, for key switches, a release that may be half of an auto-repeat pair
(``PendingRelease``). The X server sends a held key's repeat as a release and a press carrying one
timestamp, flagged as auto-repeat by Qt only when the press is already queued (measured under Xvfb
with the assistive window running: every pair came unflagged). So a key release with a timestamp
waits ``KEY_REPEAT_GRACE_S``: a press of the same key with the same timestamp cancels it (the key
never came up), anything else lets it act, as if released when it came. The caller (the
assistive view's switch input) feeds presses, releases and the time on its own clock, and acts on
what comes back; it also runs the timer that ends a pending release's wait.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

# a key switch's release waits this long for the press of an auto-repeat pair (the X server sends
# both at once with one timestamp; measured under Xvfb: the press arrives 1–2 ms after the release)
KEY_REPEAT_GRACE_S = 0.1


def is_auto_repeat_pair(release_stamp: int, press_stamp: int) -> bool:
    """True when a key press is the second half of an auto-repeat pair with a release: the X
    server stamps both with the same time (ms); a person cannot release and press again within
    the same millisecond. Unknown (0) timestamps never pair."""
    return bool(release_stamp) and release_stamp == press_stamp


@dataclass
class HeldSwitch:
    """The switch held now: its name, its role ("next", "confirm", "single"), when it went down,
    whether its hold already acted, and whether the arm was stopped when it went down."""

    name: str
    role: str
    t: float
    engaged_at_press: bool
    fired: bool = False


@dataclass(frozen=True)
class PendingRelease:
    """A key switch's release kept for a possible auto-repeat press: its name, when it came (on
    the caller's clock) and its X server timestamp (ms)."""

    name: str
    t: float
    stamp: int


class SwitchPresses:
    """The held switch, its long hold and the key releases that wait for an auto-repeat press."""

    def __init__(self, grace_s: float = KEY_REPEAT_GRACE_S):
        self.grace_s = float(grace_s)
        self.down: Optional[HeldSwitch] = None
        self.pending: Optional[PendingRelease] = None

    def reset(self) -> None:
        """Forget the held switch and any pending release (a new input mode starts clean)."""
        self.down = None
        self.pending = None

    def press(self, name: str, role: str, now: float, engaged: bool) -> bool:
        """Switch ``name`` went down; True when it is now the held switch (False: another is held)."""
        if self.down is not None:
            return False
        self.down = HeldSwitch(name, role, float(now), bool(engaged))
        return True

    def hold(self, now: float, long_press_s: float) -> Optional[str]:
        """"stop" (or "rearm", when the press began stopped) once the held switch has been down for
        ``long_press_s``; None otherwise. A pending release of it counts as released then, unless a
        press of the same instant shows an auto-repeat."""
        down, pending = self.down, self.pending
        if pending is not None and down is not None and pending.name == down.name:
            now = pending.t
        if down is None or down.fired or now - down.t < long_press_s:
            return None
        down.fired = True
        return "rearm" if down.engaged_at_press else "stop"

    def release(self, name: str) -> Optional[HeldSwitch]:
        """The held switch ``name`` came up: it (no longer held), or None when ``name`` is not the held one."""
        down = self.down
        if down is None or down.name != name:
            return None
        self.down = None
        return down

    def keep_release(self, name: str, now: float, stamp: int) -> bool:
        """A key's release: True when it is kept pending (it has a timestamp and is the held key);
        False when it acts at once (a synthetic event, stamp 0, cannot be told apart)."""
        if not stamp or self.down is None or self.down.name != name:
            return False
        self.pending = PendingRelease(name, float(now), int(stamp))
        return True

    def is_repeat_press(self, name: str, stamp: int) -> bool:
        """True when a key press is the auto-repeat of the pending release (which is then dropped:
        the key never came up)."""
        pending = self.pending
        if pending is None or pending.name != name or not is_auto_repeat_pair(pending.stamp, stamp):
            return False
        self.pending = None
        return True

    def due_release(self, now: Optional[float] = None) -> Optional[PendingRelease]:
        """The pending release once its grace has passed (``now`` None: at once), taken out; else None."""
        pending = self.pending
        if pending is None or (now is not None and now - pending.t < self.grace_s):
            return None
        self.pending = None
        return pending
