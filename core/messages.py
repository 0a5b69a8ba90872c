"""The frozen messages that travel along deskarm's data flow.

CameraSource --StereoFrame--> Perception --PerceptionResult--> Targeting --Goal--> IK
--JointCommand--> Safety --> MotorBridge --JointState--> (twin, simulated desk renderer)

Every message carries a monotonic timestamp ``t`` (seconds, ``time.monotonic()`` clock or the
simulated clock) and a sequence number ``seq``. Units are SI: metres, radians, seconds.
Poses and points name their frames: ``base_p_marker`` is a point in ``robot_base``.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum
from typing import Mapping, Optional

import numpy as np

FRAME_CAMERA_LEFT = "camera_left"
FRAME_CAMERA_RIGHT = "camera_right"
FRAME_ROBOT_BASE = "robot_base"
FRAME_TOOL = "tool"


@dataclass(frozen=True)
class ObjectTruth:
    """Ground truth of one simulated object (only simulated sources fill it)."""

    marker_id: int
    base_p_centre: tuple[float, float, float]  # marker centre, in robot_base (m)
    visible_left: bool  # fully inside the left image and not occluded
    visible_right: bool
    label: str = ""  # e.g. "cup A (ball)"
    kind: str = "marker"  # "marker" (cards, cups with markers), "ball" (the cups game's), or a thing's kind


@dataclass(frozen=True)
class GroundTruth:
    """What really happened on the simulated desk at the instant a frame was taken."""

    objects: tuple[ObjectTruth, ...]
    pointing_target_id: Optional[int] = None  # cups scenario: the marker id hiding the ball

    def by_id(self) -> dict[int, ObjectTruth]:
        return {o.marker_id: o for o in self.objects}


@dataclass(frozen=True, eq=False)
class StereoFrame:
    """One left/right image pair, BGR uint8, as grabbed (not rectified)."""

    seq: int
    t: float  # capture time (s); latency is measured from here
    left: np.ndarray
    right: np.ndarray
    skew_s: float = 0.0  # |t_left - t_right| for real cameras
    truth: Optional[GroundTruth] = None  # simulated sources only
    # the source knows these images equal the previous frame's (it re-delivers the very same
    # arrays): perception may reuse its last answer and views need no redraw
    repeated: bool = False


@dataclass(frozen=True)
class MarkerObservation:
    """One marker seen (or lost) by the perception stage."""

    marker_id: int
    found: bool
    # corners in the *raw* left/right images (4x2 lists, pixels); empty when not seen
    left_corners: tuple[tuple[float, float], ...] = ()
    right_corners: tuple[tuple[float, float], ...] = ()
    camera_p_centre: Optional[tuple[float, float, float]] = None  # in camera_left (m)
    base_p_centre: Optional[tuple[float, float, float]] = None  # in robot_base (m)
    epipolar_dy_px: Optional[float] = None  # rectified vertical offset of matched centres
    frames_since_seen: int = 0


@dataclass(frozen=True, eq=False)
class PerceptionResult:
    """Everything perception learned from one StereoFrame."""

    seq: int
    t: float  # the StereoFrame's capture time
    markers: tuple[MarkerObservation, ...]
    timings_ms: Mapping[str, float]  # per stage: rectify, detect, triangulate, total
    full_frame_search: bool  # True when this frame ran a full-frame detection
    frame: Optional[StereoFrame] = None  # the frame, for display
    disparity: Optional[np.ndarray] = None  # float32 px, rectified left, when requested
    ball_left_px: Optional[tuple[float, float]] = None  # cups game: red ball in the left image
    reused: bool = False  # the frame was ``repeated``: the previous answer, re-stamped, nothing computed
    # marker-less objects of this frame (``core.detect.stereo.ObjectObservation``), when an object
    # perception runs (``--detector``); typed loosely so that messages never import a wing
    objects: tuple = ()

    def object_observation(self, object_id: Optional[int] = None, label: Optional[str] = None):
        """The object with ``object_id`` (when given) or else the first one labelled ``label``
        (triangulated ones first), None when there is none."""
        if object_id is not None:
            for o in self.objects:
                if o.object_id == object_id:
                    return o
        if label:
            found = [o for o in self.objects if o.label == label or o.kind == label]
            found.sort(key=lambda o: (not o.triangulated, o.object_id))
            return found[0] if found else None
        return None

    def marker(self, marker_id: int) -> Optional[MarkerObservation]:
        for m in self.markers:
            if m.marker_id == marker_id:
                return m
        return None


class TargetMode(str, Enum):
    """How the goal is chosen."""

    MANUAL = "manual"  # sliders or a click in a camera view
    FOLLOW = "follow"  # follow one marker id
    LISSAJOUS = "lissajous"  # trajectory generator
    CUPS = "cups"  # point at the cup hiding the ball (the original game)
    OBJECT = "object"  # follow a marker-less object (by track id, or by label / class)
    TELEOP = "teleop"  # follow the user's hand (gestures, a calibrated hand volume mapped into the workspace)


@dataclass(frozen=True)
class Goal:
    """Where the tool should go, in robot_base."""

    seq: int
    t: float
    base_p_target: tuple[float, float, float]  # m, in robot_base
    mode: TargetMode
    source_t: Optional[float] = None  # capture time of the frame the goal came from
    valid: bool = True  # False: marker lost — hold position
    note: str = ""
    orientation_rpy: Optional[tuple[float, float, float]] = None  # tool roll, pitch, yaw (rad), 6-DOF arms
    grip_m: Optional[float] = None  # gripper opening per finger (m), arms with a gripper
    # joint-space jogging: go to these joint values (rad or m, kinematic) instead of solving IK
    # for base_p_target (safety clamps apply as to every command)
    joint_target: Optional[tuple[float, ...]] = None


@dataclass(frozen=True)
class JointCommand:
    """Joint positions to send, after safety clamps."""

    seq: int
    t: float
    q: tuple[float, ...]  # rad, kinematic joint values
    source_t: Optional[float] = None  # capture time of the frame behind it (latency)
    reachable: bool = True
    reach_error_m: float = 0.0  # distance from the goal to the workspace (0 when reachable)
    base_p_target: Optional[tuple[float, float, float]] = None  # the point actually aimed at
    clamped: bool = False  # safety changed the IK's answer


@dataclass(frozen=True)
class JointState:
    """Measured (or, for feedback-less bridges, commanded) joint positions."""

    seq: int
    t: float
    q: tuple[float, ...]  # rad
    measured: bool = True  # False: the bridge has no feedback and echoes commands


@dataclass(frozen=True)
class BridgeStatus:
    """The motor bridge's connection state, for the status bar."""

    url: str
    connected: bool
    message: str = ""
    commands_sent: int = 0
    bytes_written: int = 0
    last_write_t: Optional[float] = None
    last_source_t: Optional[float] = None  # capture time behind the last command written
    request_failed: bool = False  # the user's last switch/e-stop request failed; message says why


def as_point(p) -> tuple[float, float, float]:
    """A 3-vector (list, array) as a plain float tuple, for frozen messages."""
    a = np.asarray(p, dtype=float).reshape(3)
    return (float(a[0]), float(a[1]), float(a[2]))


@dataclass
class SequenceCounter:
    """Monotonic sequence numbers for one message stream."""

    value: int = field(default=0)

    def next(self) -> int:
        self.value += 1
        return self.value
