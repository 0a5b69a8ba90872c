"""The assistive arm's approach state machine: align on the chosen object, approach it, act, return.

As in the YOLOv2 assistive-arm system: IDLE → ALIGN (IBVS until the object's image centre is
inside a ``align_box_px`` square around the feature point) → APPROACH (along the optical axis,
still servoing laterally; back to ALIGN when the centre drifts more than ``drift_px`` from the
feature point) → ACT once the tool is ``act_distance_m`` from the object (press: a blind move in
along the axis to ``press_depth_m`` past the surface and back out; touch: to the surface and back)
→ IDLE. Each state has a timeout; a target unseen for ``lost_after_s`` is "lost target" (→ IDLE,
the arm holds). Every transition is an ``AssistEvent`` (time, from, to, reason) in ``events``.

The image centre goes through a constant-velocity Kalman filter (``core.detect.kalman``, used here
on (u, v) in pixels) in ALIGN and APPROACH: frames without a measurement are bridged by its
prediction, and a hand shaking the camera is smoothed out. Depth comes with each observation
(range sensor or known size; ``TargetObservation.depth_m``); the depth used is the median of the
latest readings, and an observation whose depth jumps away from it is dropped as a mis-detection.

Pure logic over an ``IbvsController``: ``step(t, q, observation)`` returns the next joint values;
the caller owns time (a simulated clock or a real one) and the arm.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum
from typing import Optional, Sequence

import numpy as np

from core.detect.kalman import ConstantVelocityKalman
from core.motion.servoing import IbvsController


class AssistState(str, Enum):
    IDLE = "IDLE"
    ALIGN = "ALIGN"
    APPROACH = "APPROACH"
    ACT = "ACT"


@dataclass(frozen=True)
class AssistConfig:
    """Thresholds, speeds and timeouts of the approach."""

    align_box_px: float = 25.0  # ALIGN ends when |e_u| and |e_v| are both within half of this square
    drift_px: float = 35.0  # APPROACH falls back to ALIGN beyond this error (either axis)
    act_distance_m: float = 0.03  # tool-to-surface distance at which ACT begins
    act_tolerance_px: float = 2.0  # … once the error is also within this (fine alignment at the end)
    approach_speed_m_s: float = 0.06  # forward speed in APPROACH (slowed down near the act distance)
    slow_down_m: float = 0.04  # the approach slows linearly over this last stretch
    min_approach_speed_m_s: float = 0.01
    action: str = "press"  # "press" (move in press_depth_m past the surface, and back) or "touch"
    press_depth_m: float = 0.004  # how far past the estimated surface a press goes
    act_speed_m_s: float = 0.03  # speed of the blind move in and out
    dwell_s: float = 0.2  # held at the bottom of the press
    align_timeout_s: float = 8.0
    approach_timeout_s: float = 10.0
    act_timeout_s: float = 5.0
    lost_after_s: float = 1.0  # no measurement for this long: "lost target"
    depth_window: int = 5  # the depth is the median of this many latest readings (moved along with the approach)
    depth_outlier_frac: float = 0.05  # a reading this far (fraction) from that median is an outlier: the
    # whole observation is dropped (a mis-fitted ellipse is wrong about the centre too); 3 in a row restart the window

    def __post_init__(self) -> None:
        if self.action not in ("press", "touch"):
            raise ValueError(f"assist action {self.action!r}: use 'press' or 'touch'")
        if not 0 < self.align_box_px < self.drift_px * 2:
            raise ValueError(f"align_box_px = {self.align_box_px} must be > 0 and the square within the drift limit "
                             f"(drift_px = {self.drift_px})")
        for name in ("act_distance_m", "approach_speed_m_s", "act_speed_m_s", "align_timeout_s",
                     "approach_timeout_s", "act_timeout_s", "lost_after_s", "act_tolerance_px"):
            if not getattr(self, name) > 0:
                raise ValueError(f"assist {name} = {getattr(self, name)} must be > 0")
        if not 1 <= self.depth_window <= 100:
            raise ValueError(f"assist depth_window = {self.depth_window}: need 1…100 readings")
        if not 0 < self.depth_outlier_frac <= 1:
            raise ValueError(f"assist depth_outlier_frac = {self.depth_outlier_frac}: need 0 < f ≤ 1")


@dataclass(frozen=True)
class TargetObservation:
    """Where the chosen object is in this image: centre (px) and its depth (m), if known."""

    centre_px: tuple[float, float]
    depth_m: Optional[float] = None


@dataclass(frozen=True)
class AssistEvent:
    t: float  # s
    from_state: AssistState
    to_state: AssistState
    reason: str

    def to_dict(self) -> dict:
        return {"t": round(self.t, 4), "from": self.from_state.value, "to": self.to_state.value, "reason": self.reason}


@dataclass
class AssistStatus:
    """What ``step`` did this tick (for the display and the log)."""

    state: AssistState
    q: tuple[float, ...]
    error_px: Optional[np.ndarray] = None
    feature_px: Optional[tuple[float, float]] = None
    depth_m: Optional[float] = None
    filtered_px: Optional[np.ndarray] = None


@dataclass
class _Act:
    start_tool: np.ndarray  # tool point at ACT entry (robot_base)
    travel_m: float  # how far in to go
    phase: str = "in"  # in → dwell → out
    dwell_until: float = 0.0
    deepest_tool: Optional[np.ndarray] = None


class ApproachFsm:
    """IDLE → ALIGN → APPROACH → ACT → IDLE around an ``IbvsController``."""

    def __init__(self, servo: IbvsController, config: AssistConfig = AssistConfig(),
                 kalman_process_noise: float = 4.0e4, kalman_measurement_px: float = 1.5):
        self.servo = servo
        self.config = config
        self.state = AssistState.IDLE
        self.events: list[AssistEvent] = []
        self.target_label: Optional[str] = None
        self.outcome: Optional[str] = None  # the reason of the last return to IDLE
        self.deepest_tool: Optional[np.ndarray] = None  # ACT: the tool point deepest into the target
        self._kalman_args = (kalman_process_noise, kalman_measurement_px)
        self._kalman = ConstantVelocityKalman(kalman_process_noise, kalman_measurement_px, jump_m=80.0, jump_sigma=12.0,
                                              initial_speed_sigma=50.0)
        self._state_since = 0.0
        self._last_seen: Optional[float] = None
        self._depth: Optional[float] = None
        self._depths: list[float] = []  # latest depth readings (m), oldest first
        self._outliers = 0
        self._act: Optional[_Act] = None

    # -- transitions -----------------------------------------------------------------------

    def _go(self, t: float, to: AssistState, reason: str) -> None:
        self.events.append(AssistEvent(float(t), self.state, to, reason))
        self.state = to
        self._state_since = float(t)
        if to == AssistState.IDLE:
            self.outcome = reason

    def start(self, t: float, target_label: str = "target") -> None:
        """The user chose a target: IDLE → ALIGN (ValueError when already busy)."""
        if self.state != AssistState.IDLE:
            raise ValueError(f"the arm is busy ({self.state.value}): stop it before choosing another target")
        self.target_label = str(target_label)
        self.outcome = None
        self.deepest_tool = None
        self._kalman = ConstantVelocityKalman(self._kalman_args[0], self._kalman_args[1], jump_m=80.0, jump_sigma=12.0,
                                              initial_speed_sigma=50.0)
        self._last_seen = float(t)
        self._depth = None
        self._depths = []
        self._outliers = 0
        self._act = None
        self._go(t, AssistState.ALIGN, f"target chosen: {self.target_label}")

    def stop(self, t: float, reason: str = "stopped by the user") -> None:
        """STOP from any state: back to IDLE, the arm holds where it is."""
        if self.state != AssistState.IDLE:
            self._go(t, AssistState.IDLE, reason)

    # -- one tick --------------------------------------------------------------------------

    def _accept_depth(self, depth_m: Optional[float]) -> bool:
        """Take a depth reading into the window; False when it is an outlier (see AssistConfig)."""
        c = self.config
        if depth_m is None or not math.isfinite(depth_m) or depth_m <= 0:
            return True  # no reading: nothing to judge the observation by
        if len(self._depths) >= 3 and abs(depth_m - self._depth) > c.depth_outlier_frac * self._depth:
            self._outliers += 1
            if self._outliers < 3:
                return False
            self._depths.clear()  # three in a row: the depth really changed
        self._outliers = 0
        self._depths.append(float(depth_m))
        del self._depths[:-c.depth_window]
        self._depth = float(np.median(self._depths))
        return True

    def _filtered(self, t: float, obs: Optional[TargetObservation]) -> Optional[np.ndarray]:
        if obs is not None and not self._accept_depth(obs.depth_m):
            obs = None
        p = None if obs is None else (obs.centre_px[0], obs.centre_px[1], 0.0)
        pos, _ = self._kalman.update(t, p)
        if obs is not None:
            self._last_seen = t
        return None if pos is None else pos[:2].copy()

    def step(self, t: float, q: Sequence[float], observation: Optional[TargetObservation], dt: float) -> AssistStatus:
        """Advance the machine at time t (s) by one tick of ``dt`` s: the next joint values."""
        c = self.config
        t = float(t)
        q = tuple(float(v) for v in q)
        if self.state == AssistState.IDLE:
            return AssistStatus(self.state, q)
        if self.state == AssistState.ACT:
            return self._act_step(t, q, dt)
        filtered = self._filtered(t, observation)
        in_state = t - self._state_since
        if self._last_seen is not None and t - self._last_seen > c.lost_after_s:
            self._go(t, AssistState.IDLE, f"lost target: unseen for {t - self._last_seen:.2f} s")
            return AssistStatus(self.state, q)
        if self.state == AssistState.ALIGN and in_state > c.align_timeout_s:
            self._go(t, AssistState.IDLE, f"timeout: not aligned within {c.align_timeout_s:g} s")
            return AssistStatus(self.state, q)
        if self.state == AssistState.APPROACH and in_state > c.approach_timeout_s:
            self._go(t, AssistState.IDLE, f"timeout: not at the act distance within {c.approach_timeout_s:g} s")
            return AssistStatus(self.state, q)
        if filtered is None or self._depth is None:
            return AssistStatus(self.state, q, depth_m=self._depth)  # nothing yet: hold
        Z = self._depth
        distance = self.servo.tool_distance(Z)
        target = np.asarray(self.servo.feature_point(Z))
        err = filtered - target
        half = c.align_box_px / 2
        if self.state == AssistState.ALIGN and np.all(np.abs(err) <= half):
            self._go(t, AssistState.APPROACH, f"aligned: error ({err[0]:+.1f}, {err[1]:+.1f}) px within the "
                                              f"{c.align_box_px:g} px square")
        elif self.state == AssistState.APPROACH and np.any(np.abs(err) > c.drift_px):
            self._go(t, AssistState.ALIGN, f"drifted: error ({err[0]:+.1f}, {err[1]:+.1f}) px beyond {c.drift_px:g} px")
        forward = 0.0
        if self.state == AssistState.APPROACH:
            to_go = distance - c.act_distance_m
            if to_go <= 0.0 and np.all(np.abs(err) <= c.act_tolerance_px):
                self._begin_act(t, q, distance)
                return AssistStatus(self.state, q, err, tuple(target), Z, filtered)
            if to_go > 0.0:
                forward = max(c.min_approach_speed_m_s, c.approach_speed_m_s * min(1.0, to_go / c.slow_down_m))
                forward = min(forward, to_go / dt)
        step = self.servo.step(q, filtered, Z, dt, forward_speed_m_s=forward)
        # the camera moves between frames: what the filter predicts is where it was, not where it
        # will be — for Z shrinking by forward·dt its drift is small; the next measurement corrects it
        if self._depth is not None and forward > 0:  # the readings so far, moved with the camera
            self._depths = [max(1e-3, d - forward * dt) for d in self._depths]
            self._depth = max(1e-3, self._depth - forward * dt)
        return AssistStatus(self.state, step.q, step.error_px, step.feature_px, Z, filtered)

    def _begin_act(self, t: float, q: tuple, distance: float) -> None:
        c = self.config
        travel = max(0.0, distance) + (c.press_depth_m if c.action == "press" else 0.0)
        tool = np.asarray(self.servo.kinematics.fk(q))
        self._act = _Act(start_tool=tool, travel_m=travel, deepest_tool=tool.copy())
        self._go(t, AssistState.ACT, f"at the act distance: tool {distance * 1000:.1f} mm from the surface; "
                                     f"{c.action} {travel * 1000:.1f} mm in")

    def _act_step(self, t: float, q: tuple, dt: float) -> AssistStatus:
        c = self.config
        act = self._act
        if t - self._state_since > c.act_timeout_s:
            self._go(t, AssistState.IDLE, f"timeout: the {c.action} did not finish within {c.act_timeout_s:g} s")
            return AssistStatus(self.state, q)
        tool = np.asarray(self.servo.kinematics.fk(q))
        axis = self.servo.base_T_camera(q)[:3, :3] @ self.servo.camera_axis_tool
        done = float((tool - act.start_tool) @ axis)  # how far in the tool is (m)
        if act.phase == "in":
            if (tool - act.start_tool) @ axis >= (act.deepest_tool - act.start_tool) @ axis:
                act.deepest_tool = tool.copy()
                self.deepest_tool = tool.copy()
            if done >= act.travel_m - 1e-4:
                act.phase = "dwell"
                act.dwell_until = t + c.dwell_s
                return AssistStatus(self.state, q)
            speed = min(c.act_speed_m_s, (act.travel_m - done) / dt)
            return AssistStatus(self.state, self.servo.move_along_axis(q, speed, dt).q)
        if act.phase == "dwell":
            if t >= act.dwell_until:
                act.phase = "out"
            return AssistStatus(self.state, q)
        if done <= 1e-4:
            self._go(t, AssistState.IDLE, f"{'pressed' if c.action == 'press' else 'touched'} and back at the act distance")
            return AssistStatus(self.state, q)
        speed = -min(c.act_speed_m_s, done / dt)
        return AssistStatus(self.state, self.servo.move_along_axis(q, speed, dt).q)

    def event_log(self) -> list[dict]:
        """The transitions as plain dicts (t, from, to, reason), oldest first."""
        return [e.to_dict() for e in self.events]
