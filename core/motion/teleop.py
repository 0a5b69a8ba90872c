"""Teleoperation by hand: a hand source, its gestures, the calibrated mapping into the arm's workspace.

The pieces, each usable on its own:

- **Hand sources** (``HandSource.hand(result, t) -> HandObservation | None``): where the user's hand
  is in robot_base, smoothed by a constant-velocity Kalman filter (``core.detect.kalman``):
  ``MarkerHandSource`` (a wristband with an ArUco marker, from ``PerceptionResult.markers``),
  ``ObjectHandSource`` (a coloured glove, from the ``hsv`` detector's ``PerceptionResult.objects``),
  ``PoseHandSource`` (body landmarks of a pose model the user supplies as ONNX, ``core.detect.pose``;
  the right wrist triangulated from both views, the original's gestures from the left view's 2D
  landmarks). ``make_hand_source("marker:23" | "hsv:green" | "pose:model.onnx", …)`` builds one.
- **Gestures** of a stereo hand (``HandGestureDetector``): the calibration gesture is to hold still
  (filtered speed below ``still_speed_m_s``) for ``still_hold_s`` at one corner of the volume you
  want to use, then at the opposite corner; the two points are the hand volume (a box that is too
  thin along an axis is refused with a message). The end gesture is to hold still and cover the band
  (unseen for ``end_cover_s`` right after a still period of ``cover_still_s``), or (optionally) to hold
  the hand above ``end_height_m``. A hand lost while it moves is an occlusion: the arm holds.
  Pose sources give the original's gestures instead (``PoseGestureDetector``): left wrist above the
  left shoulder = calibrate (the right shoulder is the volume's centre, the right arm's length L its
  half size), left wrist above the head = stop.
- **The mapping** (``TeleopMapping``): the hand volume → a target box inside the arm's reachable
  workspace, linear per axis — the original's x_R = (x_Rmax − x_Rmin)/(2L)·(x_H − x_Hmax) + x_Rmax
  with the hand box [x_Hmax − 2L, x_Hmax], generalised to any box → box — clipped to the target box,
  then a dead zone (hand motions within ``dead_zone_m`` of the last mapped point are ignored: the
  output is dragged, never jumps), exponential smoothing (``smoothing_s``) and a speed limit
  (``max_speed_m_s``) on the mapped target.
- **The state machine** (``TeleopController``): CALIBRATING → FOLLOWING ⇄ HOLDING (hand lost) →
  ENDED. ``goal(result, t)`` returns the target (robot_base, m) while FOLLOWING, else None with a
  note; the Targeter's TELEOP mode turns None into an invalid goal (the arm holds) and the point into
  a goal for the normal control step (IK, clamps, e-stop).

Frames: every point is robot_base (m); the hand volume's axes are robot_base's (move the hand +x,
the tool moves +x). Pure Python + numpy (+ OpenCV for the pose source), no Qt.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Optional, Protocol, Sequence

import numpy as np

from core.detect.kalman import ConstantVelocityKalman
from core.settings import check_range

# states of the teleop state machine (TeleopController.state)
CALIBRATING = "calibrating"  # waiting for the calibration gesture: the arm holds
FOLLOWING = "following"  # the tool follows the mapped hand
HOLDING = "holding"  # the hand is lost (or being covered): the arm holds where it is
ENDED = "ended"  # the end gesture was made: the arm holds until ``restart``
STATES = (CALIBRATING, FOLLOWING, HOLDING, ENDED)

# gesture events (GestureEvent.event)
EVENT_CORNER = "corner"  # first calibration corner held
EVENT_CALIBRATE = "calibrate"  # the hand volume is set (second corner, or the pose gesture)
EVENT_REJECTED = "rejected"  # a second corner that makes a degenerate box (the message says why)
EVENT_LOST = "lost"
EVENT_FOUND = "found"
EVENT_END = "end"

REACH_TOL_M = 1e-3  # a target box corner IK reaches within this counts as reachable
# a box every built-in profile reaches (desk_rrr, delta, umi_rtx, assistive_5dof; checked by tests):
# the default teleop target box, shrunk further for a profile that does not reach all of it
COMMON_TARGET_BOX = ((-0.05, 0.08, 0.04), (0.05, 0.15, 0.10))
# the target box of a kind of arm whose links would stand between the cameras and the hand over the
# common box. A delta (kind "delta3") reaching forward to the common box lifts the upper arm that
# points towards the cameras (arm 0, azimuth 90°) and its forearm into the line of sight of a hand
# above the desk's front (the teleop scenario's band was hidden for good after 1.6 s of following);
# under its base plate and higher, every arm stays behind the hand (checked with the simulated desk,
# all three arms drawn one at a time over the scenario's whole path: tests/sim/test_teleop_views.py)
TARGET_BOX_BY_KIND = {"delta3": ((-0.05, -0.02, 0.10), (0.05, 0.06, 0.16))}


def default_target_box(kinematics) -> "Box":
    """The teleop target box to start from for ``kinematics``' arm: its kind's
    (``TARGET_BOX_BY_KIND``, the profile's ``kind``), else ``COMMON_TARGET_BOX``."""
    kind = getattr(getattr(kinematics, "profile", None), "kind", None)
    return Box(*TARGET_BOX_BY_KIND.get(kind, COMMON_TARGET_BOX))


# ----------------------------------------------------------------------------------------------
# boxes and the mapping


@dataclass(frozen=True)
class Box:
    """An axis-aligned box in robot_base (m): ``lo`` ≤ p ≤ ``hi`` on every axis."""

    lo: tuple[float, float, float]
    hi: tuple[float, float, float]

    def __post_init__(self) -> None:
        lo = tuple(float(v) for v in self.lo)
        hi = tuple(float(v) for v in self.hi)
        if len(lo) != 3 or len(hi) != 3 or not all(map(math.isfinite, lo + hi)):
            raise ValueError(f"box corners {self.lo!r}, {self.hi!r}: need two finite 3-D points (m)")
        object.__setattr__(self, "lo", tuple(min(a, b) for a, b in zip(lo, hi)))
        object.__setattr__(self, "hi", tuple(max(a, b) for a, b in zip(lo, hi)))

    @classmethod
    def from_corners(cls, a: Sequence[float], b: Sequence[float]) -> "Box":
        """The box with opposite corners ``a`` and ``b`` (any order per axis)."""
        return cls(tuple(a), tuple(b))

    @property
    def extent(self) -> np.ndarray:
        return np.subtract(self.hi, self.lo)

    @property
    def centre(self) -> np.ndarray:
        return (np.asarray(self.lo) + np.asarray(self.hi)) / 2

    def contains(self, p, tol: float = 1e-9) -> bool:
        a = np.asarray(p, float)
        return bool(np.all(a >= np.asarray(self.lo) - tol) and np.all(a <= np.asarray(self.hi) + tol))

    def clip(self, p) -> np.ndarray:
        return np.clip(np.asarray(p, float), self.lo, self.hi)

    def corners(self) -> np.ndarray:
        """The 8 corners (8, 3)."""
        lo, hi = self.lo, self.hi
        return np.array([(x, y, z) for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])

    def grid(self, n: int = 3) -> np.ndarray:
        """n×n×n points spread evenly over the box, corners included (n³, 3)."""
        axes = [np.linspace(a, b, n) for a, b in zip(self.lo, self.hi)]
        return np.array([(x, y, z) for x in axes[0] for y in axes[1] for z in axes[2]])

    def shrunk(self, factor: float) -> "Box":
        """The box scaled by ``factor`` about its centre."""
        c, h = self.centre, self.extent / 2 * factor
        return Box(tuple(c - h), tuple(c + h))

    def describe_cm(self) -> str:
        e = self.extent * 100
        return f"{e[0]:.1f} × {e[1]:.1f} × {e[2]:.1f} cm"


def box_problem(box: Box, min_extent_m: float) -> str:
    """Why ``box`` is no usable hand volume ("" when it is): an axis thinner than ``min_extent_m``."""
    thin = [axis for axis, e in zip("xyz", box.extent) if e < min_extent_m]
    if not thin:
        return ""
    return (f"hand volume {box.describe_cm()} is too thin along {', '.join(thin)} — hold still at two "
            f"opposite corners at least {min_extent_m * 100:.0f} cm apart along x, y and z")


def map_box_to_box(p, source: Box, target: Box, clip: bool = True) -> np.ndarray:
    """``p`` in ``source`` mapped linearly per axis into ``target`` (corners to corners), clipped to
    ``target`` when ``clip``. With source [x_Hmax − 2L, x_Hmax] this is the original's
    x_R = (x_Rmax − x_Rmin)/(2L)·(x_H − x_Hmax) + x_Rmax. A source axis of zero extent maps to the
    target's centre on that axis."""
    a = np.asarray(p, float)
    ext = source.extent
    usable = ext > 1e-9  # a (near) zero extent would overflow the division
    safe = np.where(usable, ext, 1.0)
    s = np.where(usable, (a - np.asarray(source.lo)) / safe, 0.5)
    if clip:
        s = np.clip(s, 0.0, 1.0)
    return np.asarray(target.lo) + s * target.extent


@dataclass(frozen=True)
class TeleopParams:
    """How teleoperation reads gestures and shapes the mapped target."""

    still_speed_m_s: float = 0.015  # the hand is still below this filtered speed, 0.001 … 0.2 m/s
    still_hold_s: float = 1.0  # a calibration corner: still for this long, 0.2 … 5 s
    speed_window_s: float = 0.3  # stillness speed: slope of a line fitted to the last this-long of positions, 0.05 … 2 s
    min_box_m: float = 0.03  # the hand volume's smallest extent per axis, 0.005 … 0.5 m
    cover_still_s: float = 0.5  # the end gesture: still for this long right before the band vanished …
    end_cover_s: float = 1.0  # … and unseen for this long (s), 0.2 … 10 s
    end_height_m: Optional[float] = None  # the end gesture: the hand held above this z (m), None: off
    end_raise_s: float = 0.5  # … for this long, 0 … 5 s
    dead_zone_m: float = 0.0015  # mapped motions within this of the last output are ignored, 0 … 0.05 m
    smoothing_s: float = 0.03  # time constant of the exponential smoothing of the mapped target, 0 … 2 s
    max_speed_m_s: float = 0.25  # speed limit of the mapped target, 0.005 … 5 m/s

    def __post_init__(self) -> None:
        check_range("teleop", "still_speed_m_s", self.still_speed_m_s, 0.001, 0.2)
        check_range("teleop", "still_hold_s", self.still_hold_s, 0.2, 5.0)
        check_range("teleop", "speed_window_s", self.speed_window_s, 0.05, 2.0)
        check_range("teleop", "min_box_m", self.min_box_m, 0.005, 0.5)
        check_range("teleop", "cover_still_s", self.cover_still_s, 0.0, 5.0)
        check_range("teleop", "end_cover_s", self.end_cover_s, 0.2, 10.0)
        if self.end_height_m is not None:
            check_range("teleop", "end_height_m", self.end_height_m, -1.0, 3.0)
        check_range("teleop", "end_raise_s", self.end_raise_s, 0.0, 5.0)
        check_range("teleop", "dead_zone_m", self.dead_zone_m, 0.0, 0.05)
        check_range("teleop", "smoothing_s", self.smoothing_s, 0.0, 2.0)
        check_range("teleop", "max_speed_m_s", self.max_speed_m_s, 0.005, 5.0)


class TeleopMapping:
    """Hand volume → target box, then dead zone, smoothing and speed limit (see the module doc).

    ``map(p)`` is the pure mapping (clipped); ``step(p, t)`` the shaped target at time t: the first
    call (or the first after ``reset``) starts at ``start`` when given (the arm's last target:
    the speed limit then brings it to the hand smoothly), else at the mapped point. Every output is
    finite and inside the target box (a non-finite input gives the last output).
    """

    def __init__(self, hand_box: Box, target_box: Box, params: Optional[TeleopParams] = None):
        self.hand_box = hand_box
        self.target_box = target_box
        self.params = params or TeleopParams()
        self.reset()

    def reset(self, start=None) -> None:
        self._anchor: Optional[np.ndarray] = None  # the dead zone's dragged point
        self._smooth: Optional[np.ndarray] = None
        self._out: Optional[np.ndarray] = None
        self._t: Optional[float] = None
        if start is not None:
            a = np.asarray(start, float).reshape(-1)
            if a.shape == (3,) and np.all(np.isfinite(a)):
                self._smooth = self._out = self.target_box.clip(a)

    def map(self, base_p_hand) -> np.ndarray:
        """The mapped point of a hand position (the pure, clipped linear map)."""
        return map_box_to_box(base_p_hand, self.hand_box, self.target_box, clip=True)

    @property
    def output(self) -> Optional[np.ndarray]:
        return None if self._out is None else self._out.copy()

    def step(self, base_p_hand, t: float) -> np.ndarray:
        prm = self.params
        p = np.asarray(base_p_hand, float).reshape(-1)
        t = float(t)
        if p.shape != (3,) or not np.all(np.isfinite(p)) or not math.isfinite(t):
            if self._out is not None:
                return self._out.copy()
            return self.target_box.centre
        raw = self.map(p)
        dt = 0.0 if self._t is None else max(0.0, t - self._t)
        self._t = t
        # dead zone: the anchor is dragged so that it stays within dead_zone_m of the raw point
        if self._anchor is None:
            self._anchor = raw.copy()
        else:
            d = raw - self._anchor
            n = float(np.linalg.norm(d))
            if n > prm.dead_zone_m:
                self._anchor = self._anchor + d * (1.0 - prm.dead_zone_m / n)
        # exponential smoothing
        if self._smooth is None:
            self._smooth = self._anchor.copy()
        elif prm.smoothing_s > 0.0:
            self._smooth = self._smooth + (self._anchor - self._smooth) * (1.0 - math.exp(-dt / prm.smoothing_s))
        else:
            self._smooth = self._anchor.copy()
        # speed limit
        if self._out is None:
            out = self._smooth.copy()
        else:
            d = self._smooth - self._out
            n = float(np.linalg.norm(d))
            limit = prm.max_speed_m_s * dt
            out = self._out + (d * (limit / n) if n > limit else d)
        self._out = self.target_box.clip(out)
        return self._out.copy()


def reachable_target_box(kinematics, desk_margin_m: float = 0.0, box: Optional[Box] = None,
                         shrink: float = 0.85, tries: int = 12, grid: int = 3) -> Box:
    """A target box inside what ``kinematics`` reaches: ``box`` (default ``default_target_box``: the
    arm kind's, else ``COMMON_TARGET_BOX``) raised above ``desk_margin_m``, shrunk about its centre by ``shrink`` until IK reaches every
    point of a ``grid``³ sample within REACH_TOL_M. ValueError when even the last try does not fit."""
    box = box or default_target_box(kinematics)
    lo = list(box.lo)
    if lo[2] < desk_margin_m:
        lo[2] = desk_margin_m
        box = Box(tuple(lo), box.hi)
    current = box
    for _ in range(max(1, tries)):
        if all(_reaches(kinematics, p) for p in current.grid(grid)):
            return current
        current = current.shrunk(shrink)
    raise ValueError(f"the arm reaches no teleop target box around {np.round(box.centre, 3).tolist()} m "
                     f"(tried down to {current.describe_cm()}): choose a target box inside its workspace")


def _reaches(kinematics, p) -> bool:
    try:
        ik = kinematics.ik(tuple(float(v) for v in p))
    except (ValueError, ArithmeticError):
        return False
    return bool(ik.reachable) and float(ik.error_m) <= REACH_TOL_M


# ----------------------------------------------------------------------------------------------
# hand sources


@dataclass(frozen=True)
class HandObservation:
    """Where the hand is at one instant (robot_base), from a HandSource."""

    t: float  # the measurement's capture time (s)
    seen: bool  # measured in this frame (False: the filter's prediction, or nothing)
    base_p: Optional[tuple[float, float, float]]  # Kalman-filtered position (m), None before any measurement
    velocity: Optional[tuple[float, float, float]]  # Kalman velocity (m/s)
    measured_p: Optional[tuple[float, float, float]] = None  # this frame's raw measurement (m)
    gesture: str = ""  # pose sources: "calibrate" | "stop" | "" (from the 2D landmarks)
    calibration_box: Optional[Box] = None  # pose sources, with "calibrate": the hand volume it defines

    @property
    def speed(self) -> Optional[float]:
        return None if self.velocity is None else float(np.linalg.norm(self.velocity))


class HandSource(Protocol):
    """Anything that says where the user's hand is, one perception result at a time."""

    name: str

    def hand(self, result, t: float) -> Optional[HandObservation]:
        """The hand for ``result`` (a PerceptionResult, or None without a camera) at time ``t``."""
        ...

    def reset(self) -> None:
        ...


def _finite3(p) -> Optional[np.ndarray]:
    if p is None:
        return None
    a = np.asarray(p, float).reshape(-1)
    return a if a.shape == (3,) and np.all(np.isfinite(a)) else None


class _FilteredSource:
    """Shared part of the 3-D hand sources: a Kalman filter on the measured point."""

    name = ""

    def __init__(self, process_noise: float = 2.0, measurement_noise: float = 0.001):
        self.kalman = ConstantVelocityKalman(process_noise=process_noise, measurement_noise=measurement_noise,
                                             jump_m=0.15)

    def reset(self) -> None:
        self.kalman.reset()

    def _observe(self, t: float, measured, **extra) -> Optional[HandObservation]:
        if self.kalman.t is not None and t < self.kalman.t:
            t = self.kalman.t  # a late result: never backwards
        p, v = self.kalman.update(t, measured)
        if p is None:
            return HandObservation(t, False, None, None, **extra)
        tp = lambda a: tuple(float(x) for x in a)  # noqa: E731
        return HandObservation(t, measured is not None, tp(p), tp(v),
                               None if measured is None else tp(measured), **extra)


class MarkerHandSource(_FilteredSource):
    """A wristband marker: ``PerceptionResult.markers``' ``base_p_centre`` of ``marker_id``."""

    def __init__(self, marker_id: int, **kalman):
        super().__init__(**kalman)
        self.marker_id = int(marker_id)
        self.name = f"marker:{self.marker_id}"

    def hand(self, result, t: float) -> Optional[HandObservation]:
        obs = result.marker(self.marker_id) if result is not None else None
        measured = _finite3(obs.base_p_centre) if obs is not None and obs.found else None
        t = float(result.t) if result is not None else float(t)
        return self._observe(t, measured)


class ObjectHandSource(_FilteredSource):
    """A coloured glove: the triangulated object of ``PerceptionResult.objects`` labelled ``label``
    (the ``hsv`` detector labels by colour), the one nearest to the last hand position first."""

    def __init__(self, label: str, **kalman):
        super().__init__(**kalman)
        self.label = str(label).strip().lower()
        self.name = f"hsv:{self.label}"

    def hand(self, result, t: float) -> Optional[HandObservation]:
        measured = None
        if result is not None:
            found = [o for o in getattr(result, "objects", ())
                     if (str(o.label).lower() == self.label or str(getattr(o, "kind", "")).lower() == self.label)
                     and o.triangulated and _finite3(o.base_p) is not None]
            if found:
                last = self.kalman.position
                if last is not None:
                    found.sort(key=lambda o: float(np.linalg.norm(np.asarray(o.base_p) - last)))
                measured = _finite3(found[0].base_p)
        t = float(result.t) if result is not None else float(t)
        return self._observe(t, measured)


# ----------------------------------------------------------------------------------------------
# gestures


@dataclass(frozen=True)
class GestureEvent:
    """A gesture (or a hand found/lost) at time ``t`` (the observation's time)."""

    event: str  # EVENT_*
    t: float
    base_p: Optional[tuple[float, float, float]] = None  # where (a corner: the mean still position)
    message: str = ""


class HandGestureDetector:
    """The stereo hand's gestures from its filtered positions and speeds (see the module doc).

    ``update(obs)`` → the events of this observation (usually none). ``calibrating`` says whether
    corners count (``TeleopController`` sets it); the corner events carry the mean position over the
    still second. Events: corner, calibrate (with ``box``), rejected, lost, found, end.
    """

    def __init__(self, params: Optional[TeleopParams] = None):
        self.params = params or TeleopParams()
        self.reset()

    def reset(self) -> None:
        self.calibrating = True
        self._recent: deque = deque()  # (t, measured p) over speed_window_s, for the stillness speed
        self.corner_a: Optional[np.ndarray] = None
        self.box: Optional[Box] = None
        self._still: deque = deque()  # (t, p) of the current still run (seen, below the speed)
        self._still_used = False  # this still run already gave a corner
        self._still_run_t0: Optional[float] = None  # when the current still run began
        self._seen = False
        self._lost_t: Optional[float] = None
        self._lost_after_still = False
        self._raised_since: Optional[float] = None
        self._calibrated_t: Optional[float] = None  # covers count only for still runs after this
        self.ended = False

    def _window_speed(self, now: float, p: np.ndarray) -> Optional[float]:
        """The hand's speed for stillness: the slope of a least-squares line through the positions of
        the last ``speed_window_s`` (a Kalman velocity at 30 fps is too noisy: ~2 cm/s at rest with
        0.5 mm measurement noise); None until the window holds 4 positions spanning half of it."""
        recent = self._recent
        recent.append((now, p))
        while len(recent) > 2 and now - recent[0][0] > self.params.speed_window_s + 1e-9:
            recent.popleft()
        if len(recent) < 4 or recent[-1][0] - recent[0][0] < self.params.speed_window_s / 2:
            return None
        ts = np.array([a for a, _ in recent]) - now
        ps = np.array([b for _, b in recent])
        tc = ts - ts.mean()
        slope = (tc[:, None] * (ps - ps.mean(axis=0))).sum(axis=0) / float(tc @ tc)
        return float(np.linalg.norm(slope))

    def _still_s(self) -> float:
        return self._still[-1][0] - self._still[0][0] if self._still else 0.0

    def update(self, obs: Optional[HandObservation], t: Optional[float] = None) -> list[GestureEvent]:
        prm = self.params
        events: list[GestureEvent] = []
        if obs is None:
            now = float(t) if t is not None else (self._still[-1][0] if self._still else 0.0)
            seen, p, speed = False, None, None
        else:
            now, seen, p = float(obs.t), bool(obs.seen), _finite3(obs.base_p)
            if p is None:
                seen = False
        if not seen:
            self._recent.clear()
            if self._seen:
                # vanished: a cover when the hand was still right before (cover_still_s), in a still
                # run that began after the calibration (not the second corner's own hold)
                run_t0 = self._still_run_t0 if self._still else None
                self._lost_after_still = (run_t0 is not None and self._calibrated_t is not None
                                          and run_t0 > self._calibrated_t
                                          and self._still[-1][0] - run_t0 >= prm.cover_still_s - 1e-9)
                self._lost_t = now
                self._seen = False
                events.append(GestureEvent(EVENT_LOST, now, message="still, covered?" if self._lost_after_still
                                           else "moving"))
            self._still.clear()
            self._still_used = False
            self._raised_since = None
            if (not self.calibrating and not self.ended and self._lost_after_still and self._lost_t is not None
                    and now - self._lost_t >= prm.end_cover_s - 1e-9):
                self.ended = True
                events.append(GestureEvent(EVENT_END, now, message=f"band covered for {prm.end_cover_s:g} s"))
            return events
        if not self._seen:
            self._seen = True
            self._lost_t = None
            self._lost_after_still = False
            events.append(GestureEvent(EVENT_FOUND, now, tuple(p)))
        # stillness
        measured = _finite3(obs.measured_p)
        speed = self._window_speed(now, measured if measured is not None else p)
        if speed is not None and speed < prm.still_speed_m_s:
            if not self._still:
                self._still_run_t0 = now
            self._still.append((now, p))
        else:
            self._still.clear()
            self._still_used = False
        while len(self._still) > 2 and self._still[-1][0] - self._still[1][0] >= prm.still_hold_s:
            self._still.popleft()  # keep the last still_hold_s (for the mean corner position)
        if self.calibrating and not self._still_used and self._still_s() >= prm.still_hold_s - 1e-9:
            self._still_used = True
            corner = np.mean([q for _, q in self._still], axis=0)
            events.extend(self._corner(now, corner))
        # raise above a height
        if prm.end_height_m is not None and not self.calibrating and not self.ended:
            if p[2] >= prm.end_height_m:
                self._raised_since = now if self._raised_since is None else self._raised_since
                if now - self._raised_since >= prm.end_raise_s - 1e-9:
                    self.ended = True
                    events.append(GestureEvent(EVENT_END, now, tuple(p),
                                               message=f"hand above {prm.end_height_m * 100:.0f} cm"))
            else:
                self._raised_since = None
        return events

    def _corner(self, now: float, corner: np.ndarray) -> list[GestureEvent]:
        c = tuple(float(v) for v in corner)
        if self.corner_a is None:
            self.corner_a = corner
            return [GestureEvent(EVENT_CORNER, now, c, "first corner: now hold still at the opposite corner")]
        if float(np.max(np.abs(corner - self.corner_a))) < self.params.min_box_m / 2:
            # still again where the first corner is (a pause there, or a marker lying on the desk):
            # no try at the opposite corner — refusing a "0.0 × 0.0 × 0.0 cm" volume each time told
            # the user nothing; the first corner stays and the wait for the opposite one goes on
            return []
        box = Box.from_corners(self.corner_a, corner)
        problem = box_problem(box, self.params.min_box_m)
        if problem:
            self.corner_a = corner  # this one is the first corner of the next try
            return [GestureEvent(EVENT_REJECTED, now, c, problem + " (this corner is the new first one)")]
        self.box = box
        self.calibrating = False
        self._calibrated_t = now
        return [GestureEvent(EVENT_CALIBRATE, now, c, f"hand volume {box.describe_cm()}")]


@dataclass(frozen=True)
class PoseGestureParams:
    """How the original's gestures are read from 2D landmarks (image y grows downwards)."""

    min_score: float = 0.3  # landmarks below this confidence are ignored, 0 … 1
    hold_frames: int = 3  # a gesture must show in this many frames in a row, 1 … 60
    margin_px: float = 5.0  # "above" means at least this many px above, 0 … 200

    def __post_init__(self) -> None:
        check_range("pose_gestures", "min_score", self.min_score, 0.0, 1.0)
        check_range("pose_gestures", "hold_frames", self.hold_frames, 1, 60)
        check_range("pose_gestures", "margin_px", self.margin_px, 0.0, 200.0)


HEAD_LANDMARKS = ("nose", "left_eye", "right_eye")


class PoseGestureDetector:
    """The original's gestures on 2D body landmarks: left wrist above the left shoulder (and below
    the head) = "calibrate"; left wrist above the head (the highest of nose and eyes) = "stop".

    ``update(landmarks)`` takes {name: (x_px, y_px, score)} of one image and returns the gesture
    that has just been held ``hold_frames`` frames in a row ("calibrate" / "stop"), once per hold,
    else "". ``current(landmarks)`` is the raw per-frame reading.
    """

    def __init__(self, params: Optional[PoseGestureParams] = None):
        self.params = params or PoseGestureParams()
        self._last = ""
        self._count = 0
        self._fired = False

    def _y(self, landmarks, name) -> Optional[float]:
        v = landmarks.get(name)
        if v is None or len(v) < 2:
            return None
        score = float(v[2]) if len(v) > 2 else 1.0
        y = float(v[1])
        return y if score >= self.params.min_score and math.isfinite(y) else None

    def current(self, landmarks) -> str:
        wrist = self._y(landmarks, "left_wrist")
        if wrist is None:
            return ""
        heads = [y for y in (self._y(landmarks, n) for n in HEAD_LANDMARKS) if y is not None]
        m = self.params.margin_px
        if heads and wrist < min(heads) - m:
            return "stop"
        shoulder = self._y(landmarks, "left_shoulder")
        if shoulder is not None and wrist < shoulder - m:
            return "calibrate"
        return ""

    def update(self, landmarks) -> str:
        g = self.current(landmarks)
        if g != self._last:
            self._last, self._count, self._fired = g, 0, False
        self._count += 1
        if g and not self._fired and self._count >= self.params.hold_frames:
            self._fired = True
            return g
        return ""


# ----------------------------------------------------------------------------------------------
# the state machine


@dataclass(frozen=True)
class TeleopStatus:
    """What teleoperation is doing, for the banner, the twin and the headless metrics."""

    state: str  # CALIBRATING | FOLLOWING | HOLDING | ENDED
    source: str  # the hand source's name ("marker:23")
    message: str  # a line for the banner ("teleop: following")
    hand_seen: bool
    base_p_hand: Optional[tuple[float, float, float]]  # filtered hand position (robot_base, m)
    base_p_mapped: Optional[tuple[float, float, float]]  # the last target handed out (robot_base, m)
    corner_a: Optional[tuple[float, float, float]]  # the first calibration corner, once held
    hand_box: Optional[Box]  # the calibrated hand volume
    target_box: Box  # where the hand volume maps to
    events: tuple[GestureEvent, ...]  # every gesture event so far (lost/found included)
    state_s: dict  # seconds spent in each state


class TeleopController:
    """Hand source + gestures + mapping: ``goal(result, t)`` → (target or None, note). See the module doc.

    Not thread-safe on its own: the Targeter calls it under its lock.
    """

    def __init__(self, source: HandSource, target_box: Box, params: Optional[TeleopParams] = None):
        self.source = source
        self.params = params or TeleopParams()
        self.target_box = target_box
        self.gestures = HandGestureDetector(self.params)
        self.restart()

    def restart(self) -> None:
        """Back to CALIBRATING (a new calibration gesture is needed); the hand filter starts afresh."""
        self.state = CALIBRATING
        self.gestures.reset()
        self.source.reset()
        self.mapping: Optional[TeleopMapping] = None
        self.events: list[GestureEvent] = []
        self.state_s = {s: 0.0 for s in STATES}
        self._t: Optional[float] = None
        self._last_obs: Optional[HandObservation] = None
        self._last_target: Optional[np.ndarray] = None
        self.message = "teleop: calibrating — hold still 1 s at one corner of your hand volume"

    def set_target_box(self, box: Box) -> None:
        """Where the hand volume maps to (the window's choice); keeps the calibration."""
        self.target_box = box
        if self.mapping is not None:
            self.mapping = TeleopMapping(self.mapping.hand_box, box, self.params)
            self.mapping.reset(self._last_target)

    def set_hand_box(self, box: Box, t: Optional[float] = None) -> None:
        """Calibrate directly (a saved volume, or the pose gesture): FOLLOWING from now on."""
        self.mapping = TeleopMapping(box, self.target_box, self.params)
        self.mapping.reset(self._last_target)
        self.gestures.calibrating = False
        self.gestures.box = box
        self.gestures._calibrated_t = t if t is not None else self._t
        self._enter(FOLLOWING, "teleop: following")

    def _enter(self, state: str, message: str) -> None:
        self.state = state
        self.message = message

    def _account(self, t: float) -> None:
        if self._t is not None and t > self._t:
            self.state_s[self.state] += t - self._t
        self._t = t if self._t is None else max(self._t, t)

    def goal(self, result, t: float) -> tuple[Optional[tuple[float, float, float]], str]:
        """The target (robot_base, m) for this perception result while FOLLOWING, else (None, note)."""
        obs = self.source.hand(result, t)
        now = float(obs.t) if obs is not None else float(t)
        self._account(now)
        self._last_obs = obs
        if obs is not None and obs.gesture:
            self._pose_gesture(obs, now)
        else:
            for ev in self.gestures.update(obs, now):
                self._on_event(ev)
        seen = obs is not None and obs.seen and obs.base_p is not None
        if self.state == HOLDING and seen and not self.gestures.ended:
            self._enter(FOLLOWING, "teleop: following")
            if self.mapping is not None:
                self.mapping.reset(self._last_target)  # from where the arm holds, at the speed limit
        if self.state == FOLLOWING and not seen:
            self._enter(HOLDING, "teleop: hand lost — holding")
        if self.state != FOLLOWING or self.mapping is None:
            return None, self.message
        target = self.mapping.step(obs.base_p, now)
        self._last_target = target
        return tuple(float(v) for v in target), self.message

    def _on_event(self, ev: GestureEvent) -> None:
        self.events.append(ev)
        if ev.event == EVENT_CORNER:
            self.message = "teleop: calibrating — first corner set, hold still 1 s at the opposite corner"
        elif ev.event == EVENT_REJECTED:
            self.message = f"teleop: calibrating — {ev.message}"
        elif ev.event == EVENT_CALIBRATE:
            self.mapping = TeleopMapping(self.gestures.box, self.target_box, self.params)
            self.mapping.reset(self._last_target)
            self._enter(FOLLOWING, "teleop: following")
        elif ev.event == EVENT_LOST and self.state == FOLLOWING:
            self._enter(HOLDING, "teleop: hand lost — holding" if ev.message == "moving"
                        else "teleop: hand covered — holding (keep it covered to end)")
        elif ev.event == EVENT_END and self.state != CALIBRATING:
            self._enter(ENDED, "teleop: ended — holding (restart to calibrate again)")

    def _pose_gesture(self, obs: HandObservation, now: float) -> None:
        if obs.gesture == "stop" and self.state in (FOLLOWING, HOLDING):
            self.gestures.ended = True
            self._on_event(GestureEvent(EVENT_END, now, message="left hand above the head"))
        elif obs.gesture == "calibrate" and obs.calibration_box is not None:
            problem = box_problem(obs.calibration_box, self.params.min_box_m)
            if problem:
                self.events.append(GestureEvent(EVENT_REJECTED, now, message=problem))
                self.message = f"teleop: calibrating — {problem}"
                return
            self.events.append(GestureEvent(EVENT_CALIBRATE, now, message="left hand above the left shoulder"))
            self.gestures.ended = False
            self.set_hand_box(obs.calibration_box, now)

    def status(self) -> TeleopStatus:
        obs = self._last_obs
        hand_box = self.mapping.hand_box if self.mapping is not None else None
        a = self.gestures.corner_a
        return TeleopStatus(
            state=self.state, source=getattr(self.source, "name", type(self.source).__name__),
            message=self.message, hand_seen=bool(obs is not None and obs.seen),
            base_p_hand=None if obs is None else obs.base_p,
            base_p_mapped=None if self._last_target is None else tuple(float(v) for v in self._last_target),
            corner_a=None if a is None else tuple(float(v) for v in a), hand_box=hand_box,
            target_box=self.target_box, events=tuple(self.events), state_s=dict(self.state_s))


# ----------------------------------------------------------------------------------------------
# the source spec ("marker:23" | "hsv:green" | "pose:PATH.onnx")

SOURCE_KINDS = ("marker", "hsv", "pose")


def parse_teleop_source(spec: str) -> tuple[str, str]:
    """("marker", "23") for "marker:23", etc.; ValueError naming the valid forms otherwise."""
    text = str(spec or "").strip()
    kind, sep, arg = text.partition(":")
    kind, arg = kind.strip().lower(), arg.strip()
    forms = "marker:ID (a wristband marker), hsv:COLOUR (a coloured glove), pose:PATH.onnx (a body pose model)"
    if not sep or kind not in SOURCE_KINDS or not arg:
        raise ValueError(f"teleop source {spec!r}: expected one of {forms}")
    if kind == "marker":
        try:
            marker_id = int(arg)
        except ValueError:
            raise ValueError(f"teleop source {spec!r}: the marker id must be a whole number, e.g. marker:23") from None
        if not 0 <= marker_id < 1000:
            raise ValueError(f"teleop source {spec!r}: marker id {marker_id} is outside 0…999")
    return kind, arg


def make_hand_source(spec: str, calibration=None, base_T_camera=None) -> HandSource:
    """The hand source a spec names; the pose source needs the stereo ``calibration`` and
    ``base_T_camera`` (camera_left → robot_base) to triangulate the wrist."""
    kind, arg = parse_teleop_source(spec)
    if kind == "marker":
        return MarkerHandSource(int(arg))
    if kind == "hsv":
        return ObjectHandSource(arg)
    if calibration is None or base_T_camera is None:
        raise ValueError(f"teleop source {spec!r}: a pose source needs a stereo calibration and camera→arm pose")
    from core.detect.pose import OnnxPoseModel  # lazily: cv2.dnn only when asked for

    return PoseHandSource(OnnxPoseModel(arg), calibration, base_T_camera)


class PoseHandSource(_FilteredSource):
    """Body landmarks of a pose model on both views: the right wrist triangulated (robot_base),
    the original's gestures from the left view's 2D landmarks (``PoseGestureDetector``).

    3D: the right wrist's pixel in each raw view is undistorted and triangulated with the stereo
    calibration (camera_left frame), then mapped to robot_base with ``base_T_camera``. The
    calibrate gesture's hand volume: the right shoulder (triangulated) ± L on every axis, L the right
    arm's length (shoulder–elbow + elbow–wrist, triangulated), as in the original.
    """

    def __init__(self, model, calibration, base_T_camera, gestures: Optional[PoseGestureDetector] = None, **kalman):
        super().__init__(**kalman)
        self.model = model
        self.calibration = calibration
        self.base_T_camera = np.asarray(base_T_camera, float)
        self.gesture_detector = gestures or PoseGestureDetector()
        self.name = f"pose:{getattr(model, 'path', 'model')}"
        self.last_landmarks: tuple[dict, dict] = ({}, {})

    def reset(self) -> None:
        super().reset()
        self.gesture_detector = PoseGestureDetector(self.gesture_detector.params)

    def triangulate(self, left_px, right_px) -> Optional[np.ndarray]:
        """One point seen at ``left_px`` and ``right_px`` (raw images) → robot_base (m)."""
        import cv2

        c = self.calibration
        a = cv2.undistortPoints(np.asarray(left_px, np.float64).reshape(1, 1, 2), c.M1, c.D1).reshape(2, 1)
        b = cv2.undistortPoints(np.asarray(right_px, np.float64).reshape(1, 1, 2), c.M2, c.D2).reshape(2, 1)
        P1 = np.hstack([np.eye(3), np.zeros((3, 1))])
        P2 = np.hstack([np.asarray(c.R, float), np.asarray(c.T, float).reshape(3, 1)])
        X = cv2.triangulatePoints(P1, P2, a, b)  # (2, N) points: OpenCV 5 reads (2,) as a row
        if abs(float(X[3, 0])) < 1e-12:
            return None
        camera_p = X[:3, 0] / X[3, 0]
        if camera_p[2] <= 0:
            return None
        base = self.base_T_camera[:3, :3] @ camera_p + self.base_T_camera[:3, 3]
        return base if np.all(np.isfinite(base)) else None

    def _point(self, left: dict, right: dict, name: str) -> Optional[np.ndarray]:
        min_score = self.gesture_detector.params.min_score
        a, b = left.get(name), right.get(name)
        if a is None or b is None or a[2] < min_score or b[2] < min_score:
            return None
        return self.triangulate(a[:2], b[:2])

    def hand(self, result, t: float) -> Optional[HandObservation]:
        frame = getattr(result, "frame", None) if result is not None else None
        t = float(result.t) if result is not None else float(t)
        if frame is None:
            return self._observe(t, None)
        left = self.model.landmarks(frame.left)
        right = self.model.landmarks(frame.right)
        self.last_landmarks = (left, right)
        wrist = self._point(left, right, "right_wrist")
        gesture = self.gesture_detector.update(left)
        box = None
        if gesture == "calibrate":
            shoulder = self._point(left, right, "right_shoulder")
            elbow = self._point(left, right, "right_elbow")
            if shoulder is not None and elbow is not None and wrist is not None:
                arm_m = float(np.linalg.norm(elbow - shoulder) + np.linalg.norm(wrist - elbow))
                box = Box(tuple(shoulder - arm_m), tuple(shoulder + arm_m))
        return self._observe(t, wrist, gesture=gesture, calibration_box=box)
