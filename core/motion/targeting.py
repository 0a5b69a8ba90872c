"""Targeting: turn what perception saw (or the user's sliders) into a Goal for the arm.

Modes (``TargetMode``): manual point, follow a marker id, the Lissajous generator, and the
cups-and-ball game of the original paper (point at the cup hiding the ball).
Pointing at an object means a point ``standoff_m`` back towards the arm's base and ``hover_m``
above it, so the arm shows the object without covering its marker from the cameras.
"""
from __future__ import annotations

import math
import functools
import threading
from dataclasses import dataclass
from typing import Callable, Optional

import cv2
import numpy as np

from core.messages import Goal, PerceptionResult, SequenceCounter, TargetMode, as_point
from core.motion.safety import require_finite, require_finite_number
from core.settings import LissajousParams, check_range

_RPY = ("roll", "pitch", "yaw")


@dataclass(frozen=True)
class PointingOffset:
    """Where the tool goes relative to an object it points at."""

    standoff_m: float = 0.05  # back towards the base, horizontally, 0 … 0.15 m
    hover_m: float = 0.04  # above the marker, 0 … 0.2 m

    def __post_init__(self) -> None:
        check_range("pointing", "standoff_m", self.standoff_m, 0.0, 0.15)
        check_range("pointing", "hover_m", self.hover_m, 0.0, 0.2)

    def apply(self, base_p_object) -> tuple[float, float, float]:
        """The pointing position for an object at ``base_p_object`` (robot_base, m)."""
        x, y, z = (float(v) for v in base_p_object)
        rho = math.hypot(x, y)
        if rho > 1e-9:
            back = min(self.standoff_m, rho) / rho
            x, y = x - x * back, y - y * back
        return (x, y, z + self.hover_m)


class BallFinder:
    """Finds the red ball of the cups game in a BGR image (HSV threshold on a downscaled copy)."""

    def __init__(self, scale: float = 0.25, min_area_px: float = 3.0):
        self.scale = scale
        self.min_area_px = min_area_px
        self._last: tuple = (None, None)  # (image, answer): a repeated frame's very array

    def find(self, bgr: np.ndarray) -> Optional[tuple[float, float]]:
        """Pixel centre (x, y) of the largest red blob in full-image coordinates, or None.

        The very array of the previous call (a source re-delivering a still frame) gets the
        previous answer without looking again."""
        if bgr is self._last[0]:
            return self._last[1]
        found = self._find(bgr)
        self._last = (bgr, found)
        return found

    def _find(self, bgr: np.ndarray) -> Optional[tuple[float, float]]:
        small = cv2.resize(bgr, None, fx=self.scale, fy=self.scale, interpolation=cv2.INTER_AREA)
        hsv = cv2.cvtColor(small, cv2.COLOR_BGR2HSV)
        # red wraps around hue 0: two bands
        mask = cv2.inRange(hsv, (0, 120, 70), (8, 255, 255)) | cv2.inRange(hsv, (172, 120, 70), (180, 255, 255))
        n, _, stats, centroids = cv2.connectedComponentsWithStats(mask)
        if n <= 1:
            return None
        k = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
        if stats[k, cv2.CC_STAT_AREA] < self.min_area_px:
            return None
        cx, cy = centroids[k]
        return ((cx + 0.5) / self.scale - 0.5, (cy + 0.5) / self.scale - 0.5)


def _checked_lissajous(params: LissajousParams) -> LissajousParams:
    """``params`` when every field is finite, else ValueError naming it (LissajousParams checks
    its ranges, but a NaN slipped in by ``object.__setattr__`` or a look-alike would not be)."""
    for name, unit in (("centre", "m"), ("amplitude", "m"), ("frequency_hz", "Hz"), ("phase_rad", "rad")):
        require_finite(f"lissajous.{name}", getattr(params, name), unit)
    return params


def _user_input(setter):
    """A Targeter setter: after it, tell the listeners (the control loop steps at once)."""

    @functools.wraps(setter)
    def wrapped(self, *args, **kwargs):
        out = setter(self, *args, **kwargs)
        for listener in tuple(self.listeners):
            listener()
        return out

    return wrapped


class Targeter:
    """Keeps the targeting state the GUI edits and makes a Goal from each perception result.

    Thread-safe: setters may be called from the GUI thread while ``update`` runs in a worker.
    ``listeners`` (callables without arguments) are called after every setter, in the caller's
    thread: the control worker uses it to run its step at once for a user's new goal.

    Setters refuse a NaN or infinite value with a ValueError naming the field (the state and
    the listeners are left alone); ``update`` turns a non-finite marker position or Lissajous
    point into an invalid goal (hold) with a note saying why.
    """

    def __init__(self, clock, mode: TargetMode = TargetMode.MANUAL,
                 manual_target=(0.0, 0.15, 0.10), follow_id: int = 23,
                 lissajous: LissajousParams | None = None,
                 pointing: PointingOffset | None = None, cup_ids=(23, 50)):
        self.clock = clock
        self._lock = threading.Lock()
        self.mode = TargetMode(mode)
        self.manual_target = as_point(require_finite("manual target", manual_target, "m"))
        self.manual_rpy: Optional[tuple[float, float, float]] = None  # 6-DOF arms: tool orientation
        self.manual_grip_m: Optional[float] = None
        self.follow_id = int(follow_id)
        # OBJECT mode: a marker-less object, by its track id and/or its label ("red ball") or kind
        self.follow_object_label: str = ""
        self.follow_object_id: Optional[int] = None
        self.lissajous = _checked_lissajous(lissajous or LissajousParams())
        self.lissajous_running = False
        self._lissajous_t0 = 0.0
        self._lissajous_paused_at = 0.0
        self.pointing = pointing or PointingOffset()
        self.cup_ids = tuple(cup_ids)
        self.ball_cup_id: Optional[int] = None  # the cup believed to hide the ball
        self._seq = SequenceCounter()
        self.listeners: list[Callable[[], None]] = []

    # --- setters (GUI thread) ---------------------------------------------------------------
    @_user_input
    def set_mode(self, mode) -> None:
        with self._lock:
            self.mode = TargetMode(mode)

    @_user_input
    def set_manual_target(self, base_p) -> None:
        """Manual target (x, y, z in m, robot_base); ValueError for a NaN or infinite value."""
        p = as_point(require_finite("manual target", base_p, "m"))
        with self._lock:
            self.manual_target = p

    @_user_input
    def set_manual_pose(self, base_p, rpy=None, grip_m: Optional[float] = None) -> None:
        """Manual target with a tool orientation (roll, pitch, yaw in rad) and a grip (m).

        ValueError naming the field for a NaN or infinite value, or a negative grip; nothing
        changes then.
        """
        p = as_point(require_finite("manual target", base_p, "m"))
        r = None if rpy is None else as_point(require_finite("manual orientation", rpy, "rad", _RPY))
        g = None if grip_m is None else require_finite_number("manual grip_m", grip_m, "m")
        if g is not None and g < 0.0:
            raise ValueError(f"manual grip_m = {g!r} must be ≥ 0 m (an opening per finger)")
        with self._lock:
            self.manual_target = p
            self.manual_rpy = r
            self.manual_grip_m = g

    @_user_input
    def set_follow_id(self, marker_id: int) -> None:
        with self._lock:
            self.follow_id = int(marker_id)

    @_user_input
    def set_follow_object(self, label: str = "", object_id: Optional[int] = None) -> None:
        """Follow a marker-less object (OBJECT mode): its track ``object_id`` when given, else (or
        once that track is gone) the nearest object labelled ``label`` (a label or a kind)."""
        with self._lock:
            self.follow_object_label = str(label or "")
            self.follow_object_id = None if object_id is None else int(object_id)

    @_user_input
    def set_lissajous(self, params: LissajousParams) -> None:
        """The Lissajous curve; ValueError naming the field for a NaN or infinite parameter."""
        params = _checked_lissajous(params)
        with self._lock:
            self.lissajous = params

    @_user_input
    def set_lissajous_running(self, running: bool) -> None:
        with self._lock:
            now = self.clock.now()
            if running and not self.lissajous_running:
                self._lissajous_t0 = now - self._lissajous_paused_at
            elif not running and self.lissajous_running:
                self._lissajous_paused_at = now - self._lissajous_t0
            self.lissajous_running = bool(running)

    def lissajous_time(self) -> float:
        if self.lissajous_running:
            return self.clock.now() - self._lissajous_t0
        return self._lissajous_paused_at

    # --- per perception result (worker thread) ----------------------------------------------
    def update(self, result: Optional[PerceptionResult]) -> Goal:
        """The goal for the latest perception result (None when there is no camera result)."""
        with self._lock:
            mode = self.mode
            t = self.clock.now()
            source_t = result.t if result is not None else None
            if mode is TargetMode.MANUAL:
                return Goal(self._seq.next(), t, self.manual_target, mode, source_t,
                            orientation_rpy=self.manual_rpy, grip_m=self.manual_grip_m)
            if mode is TargetMode.LISSAJOUS:
                t_curve = self.lissajous_time()
                # math.sin raises for an infinite time: check before evaluating the curve
                p = self.lissajous.point(t_curve) if math.isfinite(t_curve) else (math.nan,) * 3
                if not all(map(math.isfinite, p)):
                    return Goal(self._seq.next(), t, self.manual_target, mode, source_t, valid=False,
                                note=f"Lissajous point at t = {t_curve!r} s is not finite — holding")
                return Goal(self._seq.next(), t, as_point(p), mode, source_t)
            if mode is TargetMode.FOLLOW:
                return self._goal_for_marker(self.follow_id, result, mode, t, source_t)
            if mode is TargetMode.OBJECT:
                return self._goal_for_object(result, mode, t, source_t)
            # cups game
            self._update_ball_cup(result)
            if self.ball_cup_id is None:
                return Goal(self._seq.next(), t, self.manual_target, mode, source_t, valid=False,
                            note="watching for the ball")
            return self._goal_for_marker(self.ball_cup_id, result, mode, t, source_t)

    def _goal_for_marker(self, marker_id, result, mode, t, source_t) -> Goal:
        obs = result.marker(marker_id) if result is not None else None
        if obs is None or not obs.found or obs.base_p_centre is None:
            return Goal(self._seq.next(), t, self.manual_target, mode, source_t, valid=False,
                        note=f"marker {marker_id} lost — holding")
        p = self.pointing.apply(obs.base_p_centre)
        if not all(map(math.isfinite, p)):  # a degenerate triangulation
            return Goal(self._seq.next(), t, self.manual_target, mode, source_t, valid=False,
                        note=f"marker {marker_id} position is not finite — holding")
        return Goal(self._seq.next(), t, p, mode, source_t, note=f"marker {marker_id}")

    def _goal_for_object(self, result, mode, t, source_t) -> Goal:
        obs = None if result is None else result.object_observation(self.follow_object_id,
                                                                     self.follow_object_label)
        what = self.follow_object_label or f"object {self.follow_object_id}"
        if obs is None or obs.base_p is None or not obs.triangulated:
            return Goal(self._seq.next(), t, self.manual_target, mode, source_t, valid=False,
                        note=f"{what} not seen — holding")
        p = self.pointing.apply(obs.base_p)
        if not all(map(math.isfinite, p)):
            return Goal(self._seq.next(), t, self.manual_target, mode, source_t, valid=False,
                        note=f"{what} position is not finite — holding")
        return Goal(self._seq.next(), t, p, mode, source_t, note=f"{obs.label} #{obs.object_id}")

    def _update_ball_cup(self, result: Optional[PerceptionResult]) -> None:
        """When the ball is visible, the cup nearest to it (in the left image) hides it next."""
        if result is None or result.ball_left_px is None:
            return
        bx, by = result.ball_left_px
        best, best_d = None, float("inf")
        for m in result.markers:
            if m.marker_id in self.cup_ids and m.found and m.left_corners:
                cx, cy = np.mean(np.asarray(m.left_corners), axis=0)
                d = math.hypot(cx - bx, cy - by)
                if d < best_d:
                    best, best_d = m.marker_id, d
        if best is not None:
            self.ball_cup_id = best
