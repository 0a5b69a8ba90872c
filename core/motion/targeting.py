"""Targeting: turn what perception saw (or the user's sliders) into a Goal for the arm.

Modes (``TargetMode``): manual point, follow a marker id, the Lissajous generator, the
cups-and-ball game of the original paper (point at the cup hiding the ball), and follow a
marker-less object (``ObjectFollower``: intercept it while it moves, a cubic approach when it stops),
and teleoperation (``set_teleop``: a ``core.motion.teleop.TeleopController`` maps the user's hand).
Pointing at an object means a point ``standoff_m`` back towards the arm's base and ``hover_m``
above it, so the arm shows the object without covering its marker from the cameras.
"""
from __future__ import annotations

import math
import functools
import threading
from collections import deque
from dataclasses import dataclass, replace
from typing import Callable, Optional

import cv2
import numpy as np

from core.messages import Goal, PerceptionResult, SequenceCounter, TargetMode, as_point
from core.motion.safety import require_finite, require_finite_number
from core.motion.trajectory import PointToPoint, straight_move
from core.settings import LissajousParams, check_range

CUP_LIFTED_M = 0.05  # a cup marker this far above the lowest cup marker is a lifted cup
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


# --- following a marker-less object ----------------------------------------------------------
FOLLOW_WATCH = "watch"  # seen, too slow to call moving, not yet known to be stopped: hold
FOLLOW_TRACK = "track"  # moving: aim at the intercept point (or at the object, without intercept)
FOLLOW_APPROACH = "approach"  # it stopped: a cubic move from the tool to it (zero end velocity)
FOLLOW_ARRIVED = "arrived"  # the approach ended; the object is still: stay on it
FOLLOW_LOST = "lost"  # not seen (or not yet): hold
OBJECT_REACH_TOL_M = 1e-4  # a goal IK reaches within this is "reachable" (no note)
INTERCEPT_REFINE_STEPS = 4  # fixed-point steps after the closed-form lead time (pointing is not a translation)


@dataclass(frozen=True)
class ObjectFollowParams:
    """How OBJECT mode follows a marker-less object (``ObjectFollower``)."""

    intercept: bool = True  # aim where a moving object will be when the tool gets there (False: where it is)
    tool_speed_m_s: float = 0.3  # tool speed assumed for the lead time, 0.01 … 5 m/s (``arm_tool_speed``)
    response_s: float = 0.02  # delay before the tool moves towards a new aim (the servo frame: 50 Hz), 0 … 1 s
    max_lead_s: float = 1.0  # never aim further ahead in time than this, 0 … 5 s
    predict_s: float = 0.5  # after the last 3D measurement, aim at the prediction this long, then hold; 0 … 5 s
    stop_speed_m_s: float = 0.02  # the object is stopped when its speed stays below this …, 0.001 … 1 m/s
    stop_hold_s: float = 0.3  # … for this long (the stopped event), 0 … 5 s
    resume_speed_m_s: float = 0.04  # a stopped object moves again above this (hysteresis), ≥ stop_speed_m_s
    replan_m: float = 0.02  # a still object found this far from the approach's end: approach again, 0.001 … 0.5 m
    approach_speed_m_s: float = 0.15  # peak tool speed of the cubic approach, 0.01 … 5 m/s
    approach_acceleration_m_s2: float = 1.0  # peak tool acceleration of the approach, 0.01 … 50 m/s²
    reacquire_m: float = 0.15  # during predict_s another track of the label is taken only this near the prediction

    def __post_init__(self) -> None:
        check_range("object_follow", "tool_speed_m_s", self.tool_speed_m_s, 0.01, 5.0)
        check_range("object_follow", "response_s", self.response_s, 0.0, 1.0)
        check_range("object_follow", "max_lead_s", self.max_lead_s, 0.0, 5.0)
        check_range("object_follow", "predict_s", self.predict_s, 0.0, 5.0)
        check_range("object_follow", "stop_speed_m_s", self.stop_speed_m_s, 0.001, 1.0)
        check_range("object_follow", "stop_hold_s", self.stop_hold_s, 0.0, 5.0)
        check_range("object_follow", "resume_speed_m_s", self.resume_speed_m_s, self.stop_speed_m_s, 2.0)
        check_range("object_follow", "replan_m", self.replan_m, 0.001, 0.5)
        check_range("object_follow", "approach_speed_m_s", self.approach_speed_m_s, 0.01, 5.0)
        check_range("object_follow", "approach_acceleration_m_s2", self.approach_acceleration_m_s2, 0.01, 50.0)
        check_range("object_follow", "reacquire_m", self.reacquire_m, 0.0, 2.0)


@dataclass(frozen=True)
class ObjectFollowStatus:
    """What the object follower is doing, for status lines and the headless metrics."""

    phase: str  # FOLLOW_WATCH | FOLLOW_TRACK | FOLLOW_APPROACH | FOLLOW_ARRIVED | FOLLOW_LOST
    object_id: Optional[int]  # the track followed (latched), None before one was seen
    label: str  # the followed object's label as the detector gives it ("green"), "" before one was seen
    seen: bool  # the latest update had a triangulated measurement of it
    base_p_object: Optional[tuple[float, float, float]]  # its estimated position now (robot_base, m)
    velocity: Optional[tuple[float, float, float]]  # its velocity (robot_base, m/s)
    stops: int  # stopped events so far (each one starts an approach)
    approaches: int  # approaches planned (stops and re-plans of a still object that was moved)
    approach_t0: Optional[float]  # the latest approach: start time (s, the targeter's clock) …
    approach_t_end: Optional[float]  # … and end time
    approach_goal: Optional[tuple[float, float, float]]  # … and end point (robot_base, m)
    lead_s: float  # the intercept's lead time of the latest goal (0 when not intercepting)


def arm_tool_speed(profile, kinematics) -> float:
    """A tool speed (m/s) the arm can sustain, for the intercept's lead time.

    Simple on purpose: the slowest joint's velocity limit (rad/s) times half the arm's reach
    (``workspace_radius_range``), the lever a joint typically moves the tool with. desk_rrr:
    5.24 rad/s × 0.108 m ≈ 0.56 m/s. Clipped to ``ObjectFollowParams``'s 0.01 … 5 m/s.
    """
    try:
        omega = min(float(v) for v in profile.velocity_limits)
        reach = float(kinematics.workspace_radius_range()[1])
    except (AttributeError, TypeError, ValueError):
        return ObjectFollowParams.tool_speed_m_s
    speed = omega * 0.5 * reach
    return min(5.0, max(0.01, speed)) if math.isfinite(speed) else ObjectFollowParams.tool_speed_m_s


def object_label_matches(wanted: str, label: str, kind: str = "") -> bool:
    """Does the user's ``wanted`` ("green ball", "green", "ball") name an observation labelled
    ``label`` ("green") of kind ``kind`` ("colour")? Yes for the label or the kind itself, and for
    "<colour> <kind>" when the label is its colour or its kind (an HSV detector labels by colour)."""
    words = str(wanted).strip().lower().split()
    label, kind = str(label).strip().lower(), str(kind).strip().lower()
    if not words or not (label or kind):
        return False
    whole = " ".join(words)
    if whole in (label, kind):
        return True
    return len(words) > 1 and label in (" ".join(words[:-1]), words[-1])


def _finite_point(p) -> Optional[np.ndarray]:
    if p is None:
        return None
    a = np.asarray(p, dtype=float).reshape(-1)
    return a if a.shape == (3,) and np.all(np.isfinite(a)) else None


def intercept_lead_time(base_p_aim_now, velocity, base_p_tool, tool_speed: float,
                        max_lead_s: float) -> float:
    """Time (s) for a tool at ``base_p_tool`` moving at ``tool_speed`` to meet an aim point now at
    ``base_p_aim_now`` moving with ``velocity`` (m/s): the positive root of |r + v·τ| = s·τ, r the aim
    minus the tool. ``max_lead_s`` when there is none (an object faster than the tool, moving away)."""
    r = np.asarray(base_p_aim_now, float) - np.asarray(base_p_tool, float)
    v = np.asarray(velocity, float)
    a = float(v @ v) - tool_speed * tool_speed
    b = 2.0 * float(r @ v)
    c = float(r @ r)
    if abs(a) < 1e-12:  # as fast as the tool: linear
        tau = -c / b if b < 0 else math.inf
    else:
        disc = b * b - 4.0 * a * c
        if disc < 0:
            tau = math.inf
        else:
            roots = [(-b - math.sqrt(disc)) / (2 * a), (-b + math.sqrt(disc)) / (2 * a)]
            positive = [x for x in roots if x >= 0.0]
            tau = min(positive) if positive else math.inf
    return min(max(0.0, tau), max_lead_s) if math.isfinite(tau) else max_lead_s


class ObjectFollower:
    """OBJECT mode's state: which track it follows, how it moves, the approach when it stops.

    - Which object: the latched track id while perception reports it; when that track is gone,
      the object matching the label (``object_label_matches``; triangulated first, nearest to the
      prediction — only within ``reacquire_m`` of it while the prediction is fresh — or to the
      tool), and its id is latched.
    - Where it is: the last triangulated measurement (position, Kalman velocity, capture time)
      extrapolated to now; for ``predict_s`` after it (an occlusion, one view only) the goal keeps
      following that prediction, then it holds with a note.
    - Moving (speed ≥ ``stop_speed_m_s``): the intercept point — where the object will be when the
      tool gets there, the lead time from the tool's distance and ``tool_speed_m_s`` (closed form,
      then refined through the pointing offset) plus the measurement's age and ``response_s``.
    - Stopped (below ``stop_speed_m_s`` for ``stop_hold_s``, the stopped event): a cubic
      ``straight_move`` from the tool to the object (zero end velocity), sampled at each update;
      speed above ``resume_speed_m_s`` cancels it (back to intercepting); a still object found
      ``replan_m`` away from the approach's end (put down elsewhere) gets a new approach.
    - A newly acquired object that is slow is watched (hold) until it is known to be stopped or
      moving, so a still object is reached by one cubic move, not by a rush at it first.

    Every goal is clipped to the workspace when the arm is known (``set_arm``): not below the desk
    margin and reachable (the nearest reachable point otherwise, with a note). Not thread-safe on
    its own: the Targeter calls it under its lock.
    """

    def __init__(self, pointing: PointingOffset, params: Optional[ObjectFollowParams] = None):
        self.pointing = pointing
        self.params = params or ObjectFollowParams()
        self.kinematics = None
        self.desk_margin_m = 0.0
        self._q_seed = None
        self.wanted_label = ""
        self.wanted_id: Optional[int] = None
        self.tool_p: Optional[np.ndarray] = None
        self.reset()

    def reset(self) -> None:
        """Forget the object (a new one to follow); the tool position and the arm stay known."""
        self.object_id = self.wanted_id
        self.seen_label = ""
        self.seen_kind = ""
        self.last_t: Optional[float] = None  # capture time of the last triangulated measurement
        self.last_p: Optional[np.ndarray] = None
        self.last_v: Optional[np.ndarray] = None
        self.speeds: deque = deque()  # (capture time, Kalman speed) of the triangulated measurements
        self.phase = FOLLOW_LOST
        self.seen = False
        self.approach: Optional[PointToPoint] = None
        self.approach_t0: Optional[float] = None
        self.approach_object_p: Optional[np.ndarray] = None  # where the object was when it was planned
        self.approach_goal: Optional[tuple] = None
        self.stops = 0
        self.approaches = 0
        self.lead_s = 0.0
        self.last_goal: Optional[tuple] = None

    def follow(self, label: str, object_id: Optional[int]) -> None:
        self.wanted_label = str(label or "")
        self.wanted_id = None if object_id is None else int(object_id)
        self.reset()

    # --- the arm ---------------------------------------------------------------------------
    def set_arm(self, kinematics, desk_margin_m: float = 0.0) -> None:
        self.kinematics = kinematics
        self.desk_margin_m = float(desk_margin_m)

    def clip(self, base_p) -> tuple[tuple[float, float, float], str]:
        """``base_p`` brought into the workspace: z at least the desk margin, then the nearest point
        the IK reaches; the note says by how much it was out of reach ("" when it was not)."""
        x, y, z = (float(v) for v in base_p)
        z = max(z, self.desk_margin_m)
        p = (x, y, z)
        if self.kinematics is None:
            return p, ""
        ik = self.kinematics.ik(p, self._q_seed)
        if ik.success:
            self._q_seed = ik.q
            return p, ""
        reached = as_point(ik.base_p_reached)
        if reached[2] < self.desk_margin_m:  # the nearest point lies under the margin: lift it and look again
            ik2 = self.kinematics.ik((reached[0], reached[1], self.desk_margin_m), ik.q)
            reached = as_point(ik2.base_p_reached)
            ik = ik2 if reached[2] >= self.desk_margin_m - 1e-9 else ik
            reached = as_point(ik.base_p_reached)
        self._q_seed = ik.q
        gap = math.dist(p, reached)
        if gap <= OBJECT_REACH_TOL_M:
            return reached, ""
        return reached, f"out of reach by {gap * 1e3:.0f} mm — aiming at the nearest point"

    def set_tool(self, base_p_tool) -> None:
        p = _finite_point(base_p_tool)
        if p is not None:
            self.tool_p = p

    def _tool(self) -> Optional[np.ndarray]:
        """Where the tool is: as told (``set_tool``), else the last goal (the arm goes there)."""
        if self.tool_p is not None:
            return self.tool_p
        return None if self.last_goal is None else np.asarray(self.last_goal, float)

    # --- which object ------------------------------------------------------------------------
    def _matches(self, o) -> bool:
        if self.wanted_label:
            return object_label_matches(self.wanted_label, o.label, o.kind)
        if self.seen_label:  # an id given alone: its label (as last seen) names it afterwards
            return o.label == self.seen_label and o.kind == self.seen_kind
        return False

    def _select(self, objects, now: float):
        if self.object_id is not None:
            for o in objects:
                if o.object_id == self.object_id and _finite_point(o.base_p) is not None:
                    return o
        candidates = [o for o in objects if self._matches(o) and _finite_point(o.base_p) is not None]
        if not candidates:
            return None
        predicted = self.predicted(now)
        fresh = predicted is not None and now - self.last_t <= self.params.predict_s
        ref = predicted if predicted is not None else self._tool()
        scored = []
        for o in candidates:
            dist = math.inf if ref is None else float(np.linalg.norm(np.asarray(o.base_p, float) - ref))
            if fresh and dist > self.params.reacquire_m:
                continue  # another object of the label while this one is only briefly hidden
            scored.append((not o.triangulated, dist, o.object_id, o))
        if not scored:
            return None
        scored.sort(key=lambda item: item[:3])
        chosen = scored[0][3]
        if chosen.object_id != self.object_id:  # a new track: its motion history starts afresh
            self.object_id = chosen.object_id
            self.speeds.clear()
        return chosen

    def predicted(self, now: float) -> Optional[np.ndarray]:
        """The object's position at ``now`` from its last measurement (constant velocity)."""
        if self.last_p is None:
            return None
        v = self.last_v if self.last_v is not None else np.zeros(3)
        return self.last_p + v * max(0.0, now - self.last_t)

    def _note(self, o, t: float) -> None:
        """Remember a triangulated measurement (once per capture time: results may repeat)."""
        self.seen_label, self.seen_kind = o.label, o.kind
        if self.last_t is not None and t <= self.last_t:
            return
        self.last_t, self.last_p = t, np.asarray(o.base_p, float)
        v = _finite_point(o.velocity_base)
        self.last_v = v
        if v is not None:  # a new track has no velocity yet: its motion is unknown
            self.speeds.append((t, float(np.linalg.norm(v))))
            while len(self.speeds) > 2 and self.speeds[1][0] < t - max(5.0, 2 * self.params.stop_hold_s):
                self.speeds.popleft()

    def speed(self) -> Optional[float]:
        return self.speeds[-1][1] if self.speeds else None

    def stopped(self) -> bool:
        """The stopped event's condition: speed below ``stop_speed_m_s`` for ``stop_hold_s``."""
        if not self.speeds:
            return False
        run_start = None
        for t, speed in reversed(self.speeds):
            if speed >= self.params.stop_speed_m_s:
                break
            run_start = t
        return run_start is not None and self.speeds[-1][0] - run_start >= self.params.stop_hold_s - 1e-9

    # --- the goal ----------------------------------------------------------------------------
    def goal(self, objects, now: float, t_result: Optional[float]):
        """(goal point or None to hold, note) for this perception result at ``now``."""
        prm = self.params
        obs = self._select(objects, now)
        what = self.wanted_label or (f"object {self.wanted_id}" if self.wanted_id is not None else "object")
        self.seen = obs is not None and obs.triangulated and t_result is not None
        if self.seen:
            self._note(obs, float(t_result))
        if self.last_p is None:
            self.phase = FOLLOW_LOST
            return None, f"{what} not seen — holding"
        name = f"{what} #{self.object_id}"
        age = now - self.last_t
        if age > prm.predict_s:
            self._cancel_approach()
            self.phase = FOLLOW_LOST
            return None, f"{name} not seen for {age:.1f} s — holding"
        object_p = self.predicted(now)
        hidden = "" if self.seen else f" (predicted, not seen for {age:.2f} s)"
        speed = self.speed()

        if self.phase in (FOLLOW_APPROACH, FOLLOW_ARRIVED):
            if speed is not None and speed >= prm.resume_speed_m_s:
                self._cancel_approach()
                self.phase = FOLLOW_TRACK  # it moves again: intercept
            elif (self.seen and self.approach_object_p is not None
                  and np.linalg.norm(object_p - self.approach_object_p) > prm.replan_m and self.stopped()):
                self._plan_approach(object_p, now)  # put down elsewhere: go there
        elif self.phase in (FOLLOW_LOST, FOLLOW_WATCH, FOLLOW_TRACK):
            if self.seen and self.stopped():
                self.stops += 1
                self._plan_approach(object_p, now)
            elif speed is not None and speed >= prm.stop_speed_m_s:
                self.phase = FOLLOW_TRACK
            elif self.phase == FOLLOW_LOST:
                self.phase = FOLLOW_WATCH

        self.lead_s = 0.0
        if self.phase == FOLLOW_WATCH:
            return None, f"{name}: watching whether it moves{hidden}"
        if self.phase == FOLLOW_APPROACH:
            t_in = now - self.approach_t0
            if t_in >= self.approach.duration:
                self.phase = FOLLOW_ARRIVED
            else:
                p, note = self.clip(self.approach.sample(t_in).q)
                self.last_goal = p
                return p, self._join(f"{name}: stopped — approaching ({t_in:.1f}/{self.approach.duration:.1f} s)"
                                     f"{hidden}", note)
        if self.phase == FOLLOW_ARRIVED:
            p, note = self.clip(self.approach_goal)
            self.last_goal = p
            return p, self._join(f"{name}: stopped — there{hidden}", note)
        # tracking
        aim = self._intercept(object_p, now) if prm.intercept else np.asarray(self.pointing.apply(object_p))
        p, note = self.clip(aim)
        self.last_goal = p
        lead = f", lead {self.lead_s * 1e3:.0f} ms" if prm.intercept else ""
        return p, self._join(f"{name}: moving{lead}{hidden}", note)

    @staticmethod
    def _join(text: str, note: str) -> str:
        return f"{text}; {note}" if note else text

    def _intercept(self, object_p: np.ndarray, now: float) -> np.ndarray:
        """The pointing position of the object when the tool gets there (see the class doc)."""
        prm = self.params
        v = self.last_v if self.last_v is not None else np.zeros(3)
        tool = self._tool()
        # during the response delay the object moves on; then the tool travels to meet it
        base = object_p + v * prm.response_s
        travel = 0.0
        if tool is not None:
            travel = intercept_lead_time(self.pointing.apply(base), v, tool, prm.tool_speed_m_s, prm.max_lead_s)
            for _ in range(INTERCEPT_REFINE_STEPS):  # the pointing offset turns with the object: refine
                aim = np.asarray(self.pointing.apply(base + v * travel))
                travel = min(float(np.linalg.norm(aim - tool)) / prm.tool_speed_m_s, prm.max_lead_s)
        self.lead_s = min(prm.response_s + travel, prm.max_lead_s)
        return np.asarray(self.pointing.apply(object_p + v * self.lead_s))

    def _plan_approach(self, object_p: np.ndarray, now: float) -> None:
        prm = self.params
        goal, _ = self.clip(self.pointing.apply(object_p))
        start = self._tool()
        if start is None:
            start = np.asarray(goal)
        start, _ = self.clip(start)
        self.approach = straight_move(start, goal, prm.approach_speed_m_s, prm.approach_acceleration_m_s2)
        self.approach_t0 = now
        self.approach_object_p = np.asarray(object_p, float).copy()
        self.approach_goal = goal
        self.approaches += 1
        self.phase = FOLLOW_APPROACH

    def _cancel_approach(self) -> None:
        self.approach = None
        self.approach_object_p = None

    def status(self, now: float) -> ObjectFollowStatus:
        p = self.predicted(now) if self.last_p is not None else None
        t_end = None if self.approach is None else self.approach_t0 + self.approach.duration
        return ObjectFollowStatus(
            phase=self.phase, object_id=self.object_id, label=self.seen_label, seen=self.seen,
            base_p_object=None if p is None else as_point(p),
            velocity=None if self.last_v is None else as_point(self.last_v),
            stops=self.stops, approaches=self.approaches,
            approach_t0=self.approach_t0 if self.approach is not None else None, approach_t_end=t_end,
            approach_goal=self.approach_goal if self.approach is not None else None, lead_s=self.lead_s)


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
                 pointing: PointingOffset | None = None, cup_ids=(23, 50),
                 object_follow: ObjectFollowParams | None = None):
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
        self.follower = ObjectFollower(self.pointing, object_follow)  # OBJECT mode's state
        self.teleop = None  # TELEOP mode's core.motion.teleop.TeleopController (set_teleop), None: hold
        self._last_mode = self.mode
        # OBJECT mode follows only objects these thresholds call sure (``is_sure(observation)``, e.g.
        # core.detect.thresholds.ClassThresholds: per-class scores); None: every object
        self.object_thresholds = None

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
            self.follower.follow(self.follow_object_label, self.follow_object_id)

    @_user_input
    def set_object_thresholds(self, thresholds) -> None:
        """OBJECT mode ignores objects ``thresholds.is_sure(observation)`` calls unsure (None: none)."""
        if thresholds is not None and not callable(getattr(thresholds, "is_sure", None)):
            raise TypeError(f"object thresholds need is_sure(observation), got {type(thresholds).__name__}")
        with self._lock:
            self.object_thresholds = thresholds

    @_user_input
    def set_object_follow_params(self, params: ObjectFollowParams) -> None:
        """How OBJECT mode follows (intercept on/off, speeds, thresholds); the state is kept."""
        if not isinstance(params, ObjectFollowParams):
            raise TypeError(f"expected ObjectFollowParams, got {type(params).__name__}")
        with self._lock:
            self.follower.params = params

    def set_arm(self, kinematics, profile=None, tool_speed: bool = True) -> None:
        """The arm OBJECT mode aims for: its goals are clipped to where ``kinematics`` reaches and
        above the desk margin of ``profile.workspace``; with ``tool_speed`` the intercept's tool speed
        becomes ``arm_tool_speed(profile, kinematics)``. Not a user input (no listeners)."""
        workspace = getattr(profile, "workspace", None)
        margin = float(getattr(workspace, "desk_margin_m", 0.0) or 0.0)
        with self._lock:
            self.follower.set_arm(kinematics, margin)
            if tool_speed and profile is not None:
                self.follower.params = replace(self.follower.params,
                                               tool_speed_m_s=arm_tool_speed(profile, kinematics))

    def set_tool_position(self, base_p_tool) -> None:
        """Where the tool is now (robot_base, m: FK of the latest joint state), for the intercept's
        lead time and the start of an approach; whoever reads the joint state calls it. Without it
        the follower takes the last goal for the tool. A non-finite point is ignored."""
        with self._lock:
            self.follower.set_tool(base_p_tool)

    @_user_input
    def set_teleop(self, controller) -> None:
        """The teleop controller TELEOP mode asks for its goal (``core.motion.teleop.TeleopController``:
        ``goal(result, t) -> (point or None, note)``), or None (TELEOP holds)."""
        with self._lock:
            self.teleop = controller

    def teleop_status(self):
        """What TELEOP mode is doing (``TeleopStatus``), None without a teleop controller."""
        with self._lock:
            return None if self.teleop is None else self.teleop.status()

    def set_teleop_target_box(self, box) -> bool:
        """Give the teleop controller a new target box, under the lock the control worker calls it
        under; False when there is no controller or it has no box (the keyboard)."""
        with self._lock:
            if not hasattr(self.teleop, "set_target_box"):
                return False
            self.teleop.set_target_box(box)
            return True

    @_user_input
    def restart_teleop(self) -> None:
        """Teleop back to calibrating (after the end gesture, or to calibrate again)."""
        with self._lock:
            if self.teleop is not None:
                self.teleop.restart()

    def object_follow_status(self) -> ObjectFollowStatus:
        """What OBJECT mode is doing (phase, followed id, stops, the current approach)."""
        with self._lock:
            return self.follower.status(self.clock.now())

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
            if mode is TargetMode.OBJECT and self._last_mode is not TargetMode.OBJECT:
                self.follower.reset()  # (back) into OBJECT mode: what it knew is stale
            self._last_mode = mode
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
            if mode is TargetMode.TELEOP:
                return self._goal_for_teleop(result, mode, t, source_t)
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
        """OBJECT mode: the follower's goal (``ObjectFollower``), or hold with its note."""
        objects = result.objects if result is not None else ()
        thresholds = self.object_thresholds
        if thresholds is not None:  # an unsure object is shown (grey), never followed
            objects = tuple(o for o in objects if thresholds.is_sure(o))
        p, note = self.follower.goal(objects, t, source_t)
        if p is None or not all(map(math.isfinite, p)):
            return Goal(self._seq.next(), t, self.manual_target, mode, source_t, valid=False,
                        note=note if p is None else f"{note} — position not finite, holding")
        return Goal(self._seq.next(), t, as_point(p), mode, source_t, note=note)

    def _goal_for_teleop(self, result, mode, t, source_t) -> Goal:
        """TELEOP mode: the teleop controller's mapped hand target, or hold with its note."""
        if self.teleop is None:  # no hand source: hold
            return Goal(self._seq.next(), t, self.manual_target, mode, source_t, valid=False,
                        note="teleop: no hand source — holding")
        p, note = self.teleop.goal(result, t)
        if p is None or not all(map(math.isfinite, p)):
            return Goal(self._seq.next(), t, self.manual_target, mode, source_t, valid=False,
                        note=note if p is None else f"{note} — target not finite, holding")
        return Goal(self._seq.next(), t, as_point(p), mode, source_t, note=note)

    def _update_ball_cup(self, result: Optional[PerceptionResult]) -> None:
        """When the ball is visible, the cup that hides it next: the lifted cup (the ball is shown
        by lifting its cup), else the cup nearest to it in the left image.

        Nearest alone was wrong for most of each show: a lifted cup's marker rises ~15 cm above
        the ball in the image while the other cup's marker, on the desk, stays beside it (the
        cups score of ``deskarm --headless --scenario cups`` found it)."""
        if result is None or result.ball_left_px is None:
            return
        bx, by = result.ball_left_px
        cups = [m for m in result.markers if m.marker_id in self.cup_ids and m.found and m.left_corners]
        heights = [m.base_p_centre[2] for m in cups if m.base_p_centre is not None]
        if heights:
            resting = min(heights)
            lifted = [m for m in cups if m.base_p_centre is not None and m.base_p_centre[2] > resting + CUP_LIFTED_M]
            cups = lifted or cups
        best, best_d = None, float("inf")
        for m in cups:
            cx, cy = np.mean(np.asarray(m.left_corners), axis=0)
            d = math.hypot(cx - bx, cy - by)
            if d < best_d:
                best, best_d = m.marker_id, d
        if best is not None:
            self.ball_cup_id = best
