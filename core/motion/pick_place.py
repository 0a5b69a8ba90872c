"""Pick and place to a named spot, as a sequence of tool targets the normal control step follows.

The markers file can give a marker the action ``pick_place`` with a place name (``[places]``).
Choosing it runs: above the marker → down to it (close the gripper) → up → above the place →
down (open) → up. Each waypoint is handed to the targeter as the manual target, so every
command still passes the control step's limits, rate clamps, workspace checks and e-stop; the
sequence only moves on when the *measured* tool point is within ``tolerance_m`` of the waypoint,
and gives up with a message after ``timeout_s`` on one. Arms without a gripper point, touch and
carry nothing: the motion is the same. No Qt.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from core.motion.safety import require_finite

HOVER_M = 0.05  # approach and retreat this far above the pick and place points
TOLERANCE_M = 0.012  # the measured tool is "there" within this (1° servo steps: ~3 mm)
TIMEOUT_S = 8.0  # a waypoint not reached by then ends the sequence


@dataclass(frozen=True)
class PickPlaceStep:
    """Where to go now, and what the sequence is doing."""

    target: Optional[tuple[float, float, float]]  # tool point (robot_base, m); None when finished
    grip_closed: bool  # the gripper should hold the object (arms with a gripper)
    message: str
    done: bool
    failed: bool


class PickPlaceSequence:
    """Six waypoints from ``pick_p`` to ``place_p`` (robot_base, m), stepped with the measured tool."""

    def __init__(self, pick_p: Sequence[float], place_p: Sequence[float], hover_m: float = HOVER_M,
                 tolerance_m: float = TOLERANCE_M, timeout_s: float = TIMEOUT_S, label: str = "object"):
        pick = np.asarray(require_finite("pick point", pick_p, "m"), float)
        place = np.asarray(require_finite("place point", place_p, "m"), float)
        up = np.array([0.0, 0.0, float(hover_m)])
        self.label = label
        self.waypoints = [  # (point, gripper closed after arriving, what happens)
            (pick + up, False, f"above {label}"),
            (pick, True, f"down to {label}"),
            (pick + up, True, f"lifting {label}"),
            (place + up, True, "above the place"),
            (place, False, "down to the place"),
            (place + up, False, "back up"),
        ]
        self.tolerance_m = float(tolerance_m)
        self.timeout_s = float(timeout_s)
        self.index = 0
        self._t_enter: Optional[float] = None
        self.grip_closed = False
        self.failed = False
        self.message = f"pick and place: {self.waypoints[0][2]}"

    @property
    def done(self) -> bool:
        return self.index >= len(self.waypoints) or self.failed

    def step(self, t: float, tool_p: Optional[Sequence[float]]) -> PickPlaceStep:
        """Advance with the time and the measured tool point (None or NaN: not known yet)."""
        if self.done:
            return PickPlaceStep(None, self.grip_closed, self.message, True, self.failed)
        point, closes, what = self.waypoints[self.index]
        if self._t_enter is None or not math.isfinite(self._t_enter):
            self._t_enter = t
        tool = None if tool_p is None else np.asarray(tool_p, float)
        if tool is not None and np.all(np.isfinite(tool)) and np.linalg.norm(tool - point) <= self.tolerance_m:
            self.grip_closed = closes
            self.index += 1
            self._t_enter = t
            if self.done:
                self.message = f"pick and place: {self.label} placed"
                return PickPlaceStep(None, self.grip_closed, self.message, True, False)
            point, _, what = self.waypoints[self.index]
        elif t - self._t_enter > self.timeout_s:
            away = "unknown" if tool is None else f"{np.linalg.norm(tool - point) * 1e3:.0f} mm"
            self.failed = True
            self.message = (f"pick and place stopped: '{what}' not reached in {self.timeout_s:g} s (tool {away} "
                            "away) — is it within reach and outside keep-out boxes?")
            return PickPlaceStep(None, self.grip_closed, self.message, True, True)
        self.message = f"pick and place: {what} ({self.index + 1}/{len(self.waypoints)})"
        return PickPlaceStep(tuple(float(v) for v in point), self.grip_closed, self.message, False, False)

    def advance(self, t: float, kinematics, q_measured, gripper=None) -> "PickPlaceCommand":
        """One step with the measured joints ``q_measured`` (None: not known yet): where the tool
        goes and the gripper opening (``gripper``: the profile's, None for arms without one), and
        the message to show when it changed or the sequence ended ("" otherwise)."""
        tool = None if q_measured is None else np.asarray(kinematics.fk(q_measured), float)[:3]
        before = self.message
        step = self.step(t, tool)
        grip = None
        if step.target is not None and gripper is not None:
            grip = gripper.min_m if step.grip_closed else gripper.max_m
        note = step.message if step.message != before or step.done else ""
        return PickPlaceCommand(step.target, grip, note, step.done)


@dataclass(frozen=True)
class PickPlaceCommand:
    """What one step of a running pick and place asks of the arm and the user."""

    target: Optional[tuple[float, float, float]]  # the manual target (robot_base, m); None: none now
    grip_m: Optional[float]  # the gripper opening (m); None: no gripper or no target
    note: str  # a message to show now ("" when nothing new)
    done: bool  # the sequence ended (placed or stopped)


def start_pick_place(config, marker_id: int, observation) -> tuple[Optional[PickPlaceSequence], str]:
    """A pick and place of the marker ``marker_id`` to the place the markers file (``config``) names
    for it, from its ``observation`` (MarkerObservation or None): (the sequence, "") or (None, why not)."""
    name = config.name_of(marker_id)
    place = config.place_of(marker_id)
    if place is None:
        return None, f"{name} has no place in the markers file"
    obs = observation
    if obs is None or not obs.found or obs.base_p_centre is None:
        return None, f"pick and place {name}: it must be seen by both cameras"
    return PickPlaceSequence(obs.base_p_centre, place, label=name), ""
