"""A physical STOP and RE-ARM for the main window: the rules, as a pure state machine (no Qt, no clock).

The window (``app.estop_switches``) feeds it every press and release of the switches it was
given — a key, a gamepad button, a GPIO pin, named as in ``core.devices.switches`` — with the
time, tells it when the arm stopped or was re-armed by anything else (the STOP button, Esc, a
fault), and asks it on a timer whether a re-arm hold has completed. It answers "stop", "rearm"
or None.

The rules, chosen so that a held, latched, stuck or bouncing switch never re-arms:

- A STOP switch's press stops the arm, every time (stopping twice is stopping).
- While any STOP switch is down the arm cannot be re-armed at all, from a switch or from the
  screen (``rearmed()`` answers "stop"): a latched mushroom button keeps the arm stopped.
- Only a RE-ARM switch re-arms, and a STOP switch can never be one (``EStopSwitchLogic`` refuses
  the same name in both roles).
- A RE-ARM press counts only when it is *fresh*: it began strictly after the last STOP input
  ended (a STOP switch pressed or released, any other stop) and was seen as a press edge. A switch
  already down when the arm stopped, found down when its device appeared (``found_down``), or
  reported pressed twice without a release in between (a release was lost) never re-arms, however
  long it is held: it has to be released and pressed again.
- The fresh press must be held without a break for ``hold_s`` (the on-screen RE-ARM's hold,
  ``widgets.estop.REARM_HOLD_MS``); any release — a bounce — ends it, and the next press starts
  the hold again from zero.

Times are seconds on any one monotonic clock. An event may carry a time a little earlier than
one already seen (a device thread stamped it before the GUI thread stopped the arm): it is
judged by its own time, which can only make a press older, never fresher.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Optional

REARM_HOLD_S = 1.0  # the on-screen RE-ARM's hold (widgets.estop.REARM_HOLD_MS; a test keeps them equal)

STOP, REARM = "stop", "rearm"


@dataclass(frozen=True)
class RearmHold:
    """How a RE-ARM switch that is down stands: ``fresh`` (may re-arm), ``held_s`` so far."""

    name: str
    fresh: bool
    held_s: float
    why_not: str  # "" when fresh; else "before_stop", "stop_down", "armed"


class EStopSwitchLogic:
    """STOP and RE-ARM switches (see the module docstring); ``feed`` and ``poll`` answer "stop",
    "rearm" or None.

    Args:
        stop_switches: names whose press stops (at least one of the two lists is not empty).
        rearm_switches: names whose fresh, full hold re-arms; none may be a STOP switch.
        hold_s: how long a RE-ARM press must be held (s, > 0).
        armed: whether the arm is armed now.
    """

    def __init__(self, stop_switches: Iterable[str], rearm_switches: Iterable[str] = (),
                 hold_s: float = REARM_HOLD_S, armed: bool = True):
        self.stop_switches = tuple(dict.fromkeys(stop_switches))
        self.rearm_switches = tuple(dict.fromkeys(rearm_switches))
        both = sorted(set(self.stop_switches) & set(self.rearm_switches))
        if both:
            raise ValueError(f"{', '.join(both)} is both a STOP and a RE-ARM switch: re-arming must take a "
                             f"different switch (a held STOP would re-arm the arm)")
        if not (isinstance(hold_s, (int, float)) and math.isfinite(hold_s) and hold_s > 0):
            raise ValueError(f"hold_s = {hold_s!r}: the RE-ARM hold must be a positive number of seconds")
        self.hold_s = float(hold_s)
        self._armed = bool(armed)
        self._stop_down: dict[str, float] = {}  # STOP switch → when it went down
        self._rearm_down: dict[str, tuple[float, bool]] = {}  # RE-ARM switch → (when down, seen as an edge)
        self._last_stop_t = -math.inf  # the end of the last STOP input (press, release, other stop)

    # -- what happened ----------------------------------------------------------------------------
    @property
    def armed(self) -> bool:
        """Whether the arm is armed, as far as this machine knows."""
        return self._armed

    def feed(self, name: str, pressed: bool, t: float) -> Optional[str]:
        """A switch went down (``pressed``) or up at ``t``: "stop" for a STOP press, else None."""
        if name in self.stop_switches:
            if pressed:
                self._stop_down.setdefault(name, t)
                return self._stop(t)
            if self._stop_down.pop(name, None) is not None:
                self._note_stop_input(t)  # the STOP input ends now: a RE-ARM press must begin later
            return None
        if name in self.rearm_switches:
            if not pressed:
                self._rearm_down.pop(name, None)
            elif name in self._rearm_down:  # down twice: a release was lost, the hold is not known
                self._rearm_down[name] = (self._rearm_down[name][0], False)
            else:
                self._rearm_down[name] = (t, True)
        return None

    def found_down(self, name: str, t: float) -> Optional[str]:
        """A switch is down and its press was not seen (found down when its device appeared, a key
        arriving as auto-repeat only): a STOP switch stops; a RE-ARM switch is held but never fresh."""
        if name in self.stop_switches:
            return self.feed(name, True, t)
        if name in self.rearm_switches:
            since = self._rearm_down.get(name, (t, False))[0]
            self._rearm_down[name] = (since, False)
        return None

    def stopped(self, t: float) -> None:
        """The arm was stopped at ``t`` by something else (the STOP button, Esc, a fault)."""
        self._stop(t)

    def rearmed(self, t: float) -> Optional[str]:
        """The arm was re-armed by something else (the on-screen RE-ARM): "stop" when a STOP
        switch is down (the arm must be stopped again at once), else None."""
        if self._stop_down:
            return self._stop(t)
        self._armed = True
        return None

    def poll(self, t: float) -> Optional[str]:
        """"rearm" once when a fresh RE-ARM press has been held ``hold_s`` by ``t``, else None."""
        if self._armed or self._stop_down:
            return None
        for name in self.rearm_switches:
            hold = self.hold(name, t)
            if hold is not None and hold.fresh and hold.held_s >= self.hold_s:
                self._armed = True
                return REARM
        return None

    # -- what the window shows ----------------------------------------------------------------------
    def is_down(self, name: str) -> bool:
        """Whether the switch is down as far as this machine knows."""
        return name in self._stop_down or name in self._rearm_down

    def stop_switches_down(self) -> list[str]:
        """The STOP switches down now, in the order given (each keeps the arm stopped)."""
        return [n for n in self.stop_switches if n in self._stop_down]

    def hold(self, name: str, t: float) -> Optional[RearmHold]:
        """How the RE-ARM switch ``name`` stands at ``t`` (None when it is up or not a RE-ARM switch)."""
        if name not in self._rearm_down:
            return None
        since, edge = self._rearm_down[name]
        if not edge or since <= self._last_stop_t:
            why = "before_stop"
        elif self._stop_down:
            why = "stop_down"
        elif self._armed:
            why = "armed"
        else:
            why = ""
        return RearmHold(name, not why, max(0.0, t - since), why)

    # -- inside ---------------------------------------------------------------------------------------
    def _note_stop_input(self, t: float) -> None:
        self._last_stop_t = max(self._last_stop_t, t)

    def _stop(self, t: float) -> str:
        self._armed = False
        self._note_stop_input(t)
        return STOP


__all__ = ["REARM", "REARM_HOLD_S", "STOP", "EStopSwitchLogic", "RearmHold"]
