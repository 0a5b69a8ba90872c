"""The recording's topics and the pure conversions from deskarm messages to ROS 2 messages.

A recording is a rosbag2 folder (MCAP storage, ROS 2 CDR) with exactly the topics of ``TOPICS``;
the replay reader is written against this table, so names and types never change here without
it. Every function is pure: deskarm message in, rosbags message object out (no I/O, no thread).

Times are the clock's seconds (``time.monotonic()`` or the simulated clock) split into
``sec``/``nanosec``; frames are deskarm's frame names (``robot_base``, ``camera_left``, …).
"""
from __future__ import annotations

import json
import math
import weakref
from typing import Callable, Optional, Sequence

import numpy as np
from rosbags.typesys import Stores, get_typestore

from core.messages import (
    FRAME_CAMERA_LEFT,
    FRAME_CAMERA_RIGHT,
    FRAME_ROBOT_BASE,
    FRAME_TOOL,
)
from core.vision.calibration import ros_distortion

TYPESTORE = get_typestore(Stores.ROS2_HUMBLE)
T = TYPESTORE.types  # msgtype name -> message class

CAMERA_LEFT_IMAGE = "/deskarm/camera/left/image/compressed"
CAMERA_RIGHT_IMAGE = "/deskarm/camera/right/image/compressed"
CAMERA_LEFT_INFO = "/deskarm/camera/left/camera_info"
CAMERA_RIGHT_INFO = "/deskarm/camera/right/camera_info"
JOINTS_COMMANDED = "/deskarm/joint_states/commanded"
JOINTS_MEASURED = "/deskarm/joint_states/measured"
TF_STATIC = "/tf_static"
TF = "/tf"
MARKERS = "/deskarm/markers"
TRUTH_MARKERS = "/deskarm/truth/markers"
GOAL = "/deskarm/goal"
ESTOP = "/deskarm/estop"
SESSION = "/deskarm/session"

# topic name -> ROS 2 message type (the contract the replay reader reads against)
TOPICS: dict[str, str] = {
    CAMERA_LEFT_IMAGE: "sensor_msgs/msg/CompressedImage",
    CAMERA_RIGHT_IMAGE: "sensor_msgs/msg/CompressedImage",
    CAMERA_LEFT_INFO: "sensor_msgs/msg/CameraInfo",
    CAMERA_RIGHT_INFO: "sensor_msgs/msg/CameraInfo",
    JOINTS_COMMANDED: "sensor_msgs/msg/JointState",
    JOINTS_MEASURED: "sensor_msgs/msg/JointState",
    TF_STATIC: "tf2_msgs/msg/TFMessage",
    TF: "tf2_msgs/msg/TFMessage",
    MARKERS: "visualization_msgs/msg/MarkerArray",
    TRUTH_MARKERS: "visualization_msgs/msg/MarkerArray",
    GOAL: "geometry_msgs/msg/PointStamped",
    ESTOP: "std_msgs/msg/Bool",
    SESSION: "std_msgs/msg/String",
}

# /tf_static must reach late subscribers (and rosbag2 players) as ROS 2 latches it
TRANSIENT_LOCAL_TOPICS = (TF_STATIC, CAMERA_LEFT_INFO, CAMERA_RIGHT_INFO, SESSION, ESTOP)

SESSION_KEYS = ("deskarm_version", "robot", "camera", "pair_id", "calibration_yaml", "base_T_camera",
                "scenario", "fps")
MARKER_SIZE_M = 0.03  # drawn size of a marker cube (the printed cards are ~3 cm)
TRUTH_BALL_ID = -1  # ObjectTruth.marker_id of the cups game's ball


def serialize(msg) -> bytes:
    """ROS 2 CDR bytes of a rosbags message object (with the 4-byte encapsulation header)."""
    return TYPESTORE.serialize_cdr(msg, msg.__msgtype__)


CLOCK_ROS = "ros"  # stamps are ROS time: wall-clock seconds since the UNIX epoch (live runs)
CLOCK_SIMULATED = "simulated"  # stamps are the simulated clock's seconds since the run started (--fast)
_epochs: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()
_monotonic_epoch: list = []


def ros_epoch(clock=None) -> float:
    """Seconds to add to ``clock``'s times to get the stamps deskarm writes (one per clock, fixed at
    its first use, so the stream and a recording stamp the same instant alike): wall time minus
    the clock's time for a live clock (``time.monotonic`` when None), 0 for a simulated clock."""
    import time

    if clock is None:
        if not _monotonic_epoch:
            _monotonic_epoch.append(time.time() - time.monotonic())
        return _monotonic_epoch[0]
    if getattr(clock, "simulated", False):
        return 0.0
    try:
        return _epochs[clock]
    except KeyError:
        epoch = _epochs[clock] = time.time() - clock.now()
        return epoch
    except TypeError:  # a clock that cannot be weakly referenced: measured now
        return time.time() - clock.now()


def clock_kind(clock=None) -> str:
    """CLOCK_ROS or CLOCK_SIMULATED: what the stamps of ``clock`` (via ``ros_epoch``) are."""
    return CLOCK_SIMULATED if getattr(clock, "simulated", False) else CLOCK_ROS


def time_ns(t: float) -> int:
    """Clock seconds as integer nanoseconds (never negative: ROS times are unsigned)."""
    return max(0, int(round(float(t) * 1e9)))


def stamp(t: float):
    """builtin_interfaces/msg/Time of clock seconds ``t``."""
    ns = time_ns(t)
    return T["builtin_interfaces/msg/Time"](sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def header(t: float, frame_id: str):
    return T["std_msgs/msg/Header"](stamp=stamp(t), frame_id=frame_id)


def compressed_image(jpeg: bytes, t: float, frame_id: str):
    """sensor_msgs/CompressedImage, format "jpeg", stamped with the capture time."""
    return T["sensor_msgs/msg/CompressedImage"](header=header(t, frame_id), format="jpeg",
                                                 data=np.frombuffer(jpeg, dtype=np.uint8))


def camera_info(calib, side: str, t: float):
    """sensor_msgs/CameraInfo of one camera of a StereoCalibration, as ROS camera_calibration writes
    it: K, D (plumb_bob; rational_polynomial for 8 coefficients), the rectifying R and the
    projection P (the right camera's P carries Tx = −fx'·baseline)."""
    if side not in ("left", "right"):
        raise ValueError(f"side {side!r}; valid: left, right")
    M, D, R, P = ((calib.M1, calib.D1, calib.R1, calib.P1) if side == "left"
                  else (calib.M2, calib.D2, calib.R2, calib.P2))
    model, d = ros_distortion(D)
    w, h = (int(v) for v in calib.image_size)
    frame = FRAME_CAMERA_LEFT if side == "left" else FRAME_CAMERA_RIGHT
    roi = T["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False)
    return T["sensor_msgs/msg/CameraInfo"](
        header=header(t, frame), height=h, width=w, distortion_model=model, d=d.copy(),
        k=np.asarray(M, np.float64).reshape(9).copy(), r=np.asarray(R, np.float64).reshape(9).copy(),
        p=np.asarray(P, np.float64).reshape(12).copy(), binning_x=0, binning_y=0, roi=roi)


def joint_state(q: Sequence[float], t: float, names: Sequence[str], frame_id: str = ""):
    """sensor_msgs/JointState: positions q (rad or m) named from the robot profile."""
    q = np.asarray(q, dtype=np.float64).reshape(-1)
    names = list(names)[: q.size]
    names += [f"joint{i + 1}" for i in range(len(names), q.size)]  # a profile shorter than q
    empty = np.zeros(0, dtype=np.float64)
    return T["sensor_msgs/msg/JointState"](header=header(t, frame_id), name=names, position=q.copy(),
                                            velocity=empty, effort=empty)


def quaternion_xyzw(R: np.ndarray) -> tuple[float, float, float, float]:
    """(x, y, z, w) of a rotation matrix (Shepperd's method, numerically safe)."""
    R = np.asarray(R, dtype=np.float64)
    tr = R[0, 0] + R[1, 1] + R[2, 2]
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        w, x, y, z = 0.25 * s, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s
    elif R[0, 0] > R[1, 1] and R[0, 0] > R[2, 2]:
        s = math.sqrt(1.0 + R[0, 0] - R[1, 1] - R[2, 2]) * 2
        w, x, y, z = (R[2, 1] - R[1, 2]) / s, 0.25 * s, (R[0, 1] + R[1, 0]) / s, (R[0, 2] + R[2, 0]) / s
    elif R[1, 1] > R[2, 2]:
        s = math.sqrt(1.0 + R[1, 1] - R[0, 0] - R[2, 2]) * 2
        w, x, y, z = (R[0, 2] - R[2, 0]) / s, (R[0, 1] + R[1, 0]) / s, 0.25 * s, (R[1, 2] + R[2, 1]) / s
    else:
        s = math.sqrt(1.0 + R[2, 2] - R[0, 0] - R[1, 1]) * 2
        w, x, y, z = (R[1, 0] - R[0, 1]) / s, (R[0, 2] + R[2, 0]) / s, (R[1, 2] + R[2, 1]) / s, 0.25 * s
    n = math.sqrt(x * x + y * y + z * z + w * w) or 1.0
    return (x / n, y / n, z / n, w / n)


def transform_stamped(parent_T_child, t: float, parent: str, child: str):
    """geometry_msgs/TransformStamped of a 4x4 pose ``parent_T_child`` (or a 3-vector: no rotation)."""
    m = np.asarray(parent_T_child, dtype=np.float64)
    if m.shape == (3,):
        m = np.block([[np.eye(3), m.reshape(3, 1)], [np.zeros((1, 3)), np.ones((1, 1))]])
    if m.shape != (4, 4):
        raise ValueError(f"{parent}_T_{child} has shape {m.shape}; expected 4x4 or 3")
    qx, qy, qz, qw = quaternion_xyzw(m[:3, :3])
    tr = T["geometry_msgs/msg/Transform"](
        translation=T["geometry_msgs/msg/Vector3"](x=float(m[0, 3]), y=float(m[1, 3]), z=float(m[2, 3])),
        rotation=T["geometry_msgs/msg/Quaternion"](x=qx, y=qy, z=qz, w=qw))
    return T["geometry_msgs/msg/TransformStamped"](header=header(t, parent), child_frame_id=child, transform=tr)


def tf_message(transforms: Sequence) -> object:
    return T["tf2_msgs/msg/TFMessage"](transforms=list(transforms))


def tf_base_camera(base_T_camera, t: float):
    """/tf_static: robot_base → camera_left (perception's camera→arm transform)."""
    return tf_message([transform_stamped(base_T_camera, t, FRAME_ROBOT_BASE, FRAME_CAMERA_LEFT)])


def tf_base_tool(q: Sequence[float], t: float, fk: Callable[[Sequence[float]], np.ndarray]):
    """/tf: robot_base → tool from the forward kinematics of joint positions ``q``."""
    return tf_message([transform_stamped(fk(q), t, FRAME_ROBOT_BASE, FRAME_TOOL)])


def _marker(marker_id: int, ns: str, p, t: float, shape: int, rgba, text: str = ""):
    Marker = T["visualization_msgs/msg/Marker"]
    pose = T["geometry_msgs/msg/Pose"](
        position=T["geometry_msgs/msg/Point"](x=float(p[0]), y=float(p[1]), z=float(p[2])),
        orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0))
    size = MARKER_SIZE_M
    return Marker(
        header=header(t, FRAME_ROBOT_BASE), ns=ns, id=int(marker_id), type=shape, action=Marker.ADD, pose=pose,
        scale=T["geometry_msgs/msg/Vector3"](x=size, y=size, z=0.002 if shape == Marker.CUBE else size),
        color=T["std_msgs/msg/ColorRGBA"](r=rgba[0], g=rgba[1], b=rgba[2], a=rgba[3]),
        lifetime=T["builtin_interfaces/msg/Duration"](sec=0, nanosec=0), frame_locked=False, points=[],
        colors=[], texture_resource="", texture=T["sensor_msgs/msg/CompressedImage"](
            header=header(0.0, ""), format="", data=np.zeros(0, np.uint8)),
        uv_coordinates=[], text=text, mesh_resource="",
        mesh_file=T["visualization_msgs/msg/MeshFile"](filename="", data=np.zeros(0, np.uint8)),
        mesh_use_embedded_materials=False)


def marker_array(result, t: Optional[float] = None):
    """/deskarm/markers: one CUBE per found marker (ns "aruco", id = marker id), at base_p_centre
    in robot_base; an empty array when nothing was found (one array per perception result)."""
    t = result.t if t is None else t
    return found_marker_array([(m.marker_id, m.base_p_centre) for m in result.markers
                               if m.found and m.base_p_centre is not None], t)


def found_marker_array(found: Sequence[tuple[int, Sequence[float]]], t: float):
    """/deskarm/markers from (marker id, base_p_centre in robot_base) pairs."""
    Marker = T["visualization_msgs/msg/Marker"]
    return T["visualization_msgs/msg/MarkerArray"](markers=[
        _marker(mid, "aruco", p, t, Marker.CUBE, (0.1, 0.8, 0.2, 1.0)) for mid, p in found])


def truth_marker_array(truth, t: float):
    """/deskarm/truth/markers: the simulated desk's ground truth (duck-typed: ``truth.objects`` with
    ``marker_id``, ``base_p_centre``, ``label``). Markers are CUBEs in ns "aruco"; the cups game's
    ball (id −1) is a SPHERE in ns "ball"; ``text`` holds the object's label."""
    Marker = T["visualization_msgs/msg/Marker"]
    out = []
    for obj in truth.objects:
        ball = int(obj.marker_id) == TRUTH_BALL_ID
        out.append(_marker(obj.marker_id, "ball" if ball else "aruco", obj.base_p_centre, t,
                           Marker.SPHERE if ball else Marker.CUBE,
                           (0.9, 0.1, 0.1, 1.0) if ball else (0.2, 0.4, 1.0, 0.6), str(getattr(obj, "label", ""))))
    return T["visualization_msgs/msg/MarkerArray"](markers=out)


def goal_point(goal, t: Optional[float] = None):
    """/deskarm/goal: the target in robot_base, stamped ``t`` (default: the goal's own time); None
    for a goal that is not valid (not written)."""
    if goal is None or not goal.valid:
        return None
    p = goal.base_p_target
    return T["geometry_msgs/msg/PointStamped"](
        header=header(goal.t if t is None else t, FRAME_ROBOT_BASE),
        point=T["geometry_msgs/msg/Point"](x=float(p[0]), y=float(p[1]), z=float(p[2])))


def bool_msg(value: bool):
    return T["std_msgs/msg/Bool"](data=bool(value))


def session_msg(info: dict):
    """/deskarm/session: the session's JSON (keys SESSION_KEYS; ValueError naming a missing one)."""
    missing = [k for k in SESSION_KEYS if k not in info]
    if missing:
        raise ValueError(f"session info lacks {', '.join(missing)}; expected keys: {', '.join(SESSION_KEYS)}")
    return T["std_msgs/msg/String"](data=json.dumps(info, default=_json_default))


def _json_default(value):
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"{type(value).__name__} is not JSON serializable")
