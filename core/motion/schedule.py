"""When the control step runs: at once when a new goal arrives, else on the fixed tick.

The window's control worker and the headless runner both ask one ``ControlSchedule``:

- ``goal_arrived(t)`` — a new perception result or a user input changed what the arm should
  do: the next step is due now (or as soon as the bridge's rate cap allows);
- otherwise a step is due one ``period_s`` after the last one (the 50 Hz tick that carries
  trajectories, holds and the serial heartbeat of feedback-less boards);
- never two steps closer than ``min_interval_s`` (1 / the bridge's command rate cap).

``event_driven=False`` gives the old behaviour, kept for the bench's comparison: a fixed tick
grid, and a new goal waits for the next tick.

The per-step joint rate limit scales with the time since the previous step
(``ArmController.step``), so steps that come sooner move the joints less: the speed limits hold
whatever the schedule does.
"""
from __future__ import annotations

import math
from typing import Optional


class ControlSchedule:
    """Decides when the next control step is due (times in the session clock's seconds)."""

    def __init__(self, period_s: float, min_interval_s: float = 0.0, event_driven: bool = True):
        if not (period_s > 0 and math.isfinite(period_s)):
            raise ValueError(f"period_s = {period_s}: must be a positive number of seconds")
        if not (0.0 <= min_interval_s <= period_s):
            raise ValueError(f"min_interval_s = {min_interval_s}: must be within 0…{period_s} s (the tick period)")
        self.period_s = float(period_s)
        self.min_interval_s = float(min_interval_s)
        self.event_driven = bool(event_driven)
        self.last_run_t: Optional[float] = None
        self._next_tick_t: Optional[float] = None
        self._goal_t: Optional[float] = None  # a goal waiting for a step (event-driven only)
        self.event_steps = 0  # steps run early for a new goal
        self.tick_steps = 0  # steps run on the tick

    def goal_arrived(self, t: float) -> None:
        """A new goal (perception result, user input) at time ``t``: step as soon as allowed."""
        if self.event_driven and self._goal_t is None:
            self._goal_t = float(t)

    @property
    def goal_waiting(self) -> bool:
        return self._goal_t is not None

    def next_due(self, now: float, next_goal_t: Optional[float] = None) -> float:
        """When the next step should run (≤ ``now`` means: run it now).

        ``next_goal_t``: when the next goal is expected (a clock-paced camera's next frame), if
        known. A tick that would fall just before it — so close that the rate cap would make
        the goal wait — is moved onto it (by less than half a period): the goal's step does the
        tick's work.
        """
        if self.last_run_t is None:
            return now
        tick = self._next_tick_t if self._next_tick_t is not None else self.last_run_t + self.period_s
        if self._goal_t is not None:
            return min(tick, max(self._goal_t, self.last_run_t + self.min_interval_s))
        if (self.event_driven and next_goal_t is not None
                and 0.0 < next_goal_t - tick < min(self.min_interval_s, 0.5 * self.period_s)):
            return next_goal_t
        return tick

    def due(self, now: float, next_goal_t: Optional[float] = None) -> bool:
        return now >= self.next_due(now, next_goal_t)

    def ran(self, now: float) -> None:
        """A step ran at ``now``: count it and plan the next tick."""
        early = self._goal_t is not None and (self._next_tick_t is None or now < self._next_tick_t - 1e-9)
        if early and self.last_run_t is not None:
            self.event_steps += 1
        else:
            self.tick_steps += 1
        self._goal_t = None
        if self.event_driven:
            self._next_tick_t = now + self.period_s  # the tick restarts after every step
        else:
            # a fixed grid; after a stall skip ahead instead of bursting
            grid = self._next_tick_t if self._next_tick_t is not None else now
            self._next_tick_t = max(grid + self.period_s, now - self.period_s + 1e-9)
            if self._next_tick_t <= now:
                self._next_tick_t = now + self.period_s
        self.last_run_t = now


def rate_cap_interval(bridge, period_s: float) -> float:
    """The shortest time between two commands ``bridge`` accepts (its ``max_command_hz``), at most a tick."""
    cap_hz = float(getattr(bridge, "max_command_hz", 0.0) or 0.0)
    return min(period_s, 1.0 / cap_hz) if cap_hz > 0 else 0.0


def schedule_for(period_s: float, bridge, event_driven: bool = True) -> ControlSchedule:
    """The schedule of a control step with tick ``period_s`` writing to ``bridge`` (its rate cap)."""
    return ControlSchedule(period_s, rate_cap_interval(bridge, period_s), event_driven)
