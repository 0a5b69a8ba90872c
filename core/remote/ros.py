"""ROS 2 on Zenoh without ROS: topics, key expressions, attachments and message conversions.

The message contract is the recordings' (ROS 2 Humble message definitions from rosbags' type
store, CDR little-endian with the 4-byte encapsulation header that ``serialize_cdr`` writes).
Key expressions follow rmw_zenoh's design document::

    <domain_id>/<topic without leading slash>/<pkg>::msg::dds_::<Type>_/<type hash>

The type hash is RIHS01 from ``typestore.hash_rihs01`` (Iron and later; rmw_zenoh on Humble
writes ``TypeHashNotSupported`` instead: pass ``type_hash="humble"``). Subscribers here match
any hash (``*``), so both forms are read. Every sample carries rmw_zenoh's attachment (≥ 0.2.4):
int64 sequence number, int64 source timestamp (ns since the UNIX epoch), then the 16-byte
publisher GID as zenoh-ext serializes a byte array (a 1-byte length 16, then the bytes) — 33
bytes, little-endian. No liveliness tokens are declared, so rmw_zenoh's graph (``ros2 topic
list``) does not see these publishers; data reaches a subscriber that names the topic.

Times: message stamps are wall-clock seconds (``time.time()``) — the capture instant mapped from
the session's monotonic clock — so a client on another machine can compute latency, as far as
the two machines' clocks agree.
"""
from __future__ import annotations

import json
import math
import struct
import time
from dataclasses import dataclass
from functools import lru_cache
from typing import Optional

import numpy as np

from core.messages import (
    FRAME_CAMERA_LEFT,
    FRAME_CAMERA_RIGHT,
    FRAME_ROBOT_BASE,
    FRAME_TOOL,
)

# topic -> ROS 2 message type
TOPICS: dict[str, str] = {
    "/deskarm/camera/left/image/compressed": "sensor_msgs/msg/CompressedImage",
    "/deskarm/camera/right/image/compressed": "sensor_msgs/msg/CompressedImage",
    "/deskarm/camera/left/camera_info": "sensor_msgs/msg/CameraInfo",
    "/deskarm/camera/right/camera_info": "sensor_msgs/msg/CameraInfo",
    "/deskarm/joint_states/commanded": "sensor_msgs/msg/JointState",
    "/deskarm/joint_states/measured": "sensor_msgs/msg/JointState",
    "/tf": "tf2_msgs/msg/TFMessage",
    "/tf_static": "tf2_msgs/msg/TFMessage",
    "/deskarm/markers": "visualization_msgs/msg/MarkerArray",
    "/deskarm/goal": "geometry_msgs/msg/PointStamped",
    "/deskarm/estop": "std_msgs/msg/Bool",
    "/deskarm/session": "std_msgs/msg/String",
}
# client -> server
COMMANDS: dict[str, str] = {
    "/deskarm/cmd/goal": "geometry_msgs/msg/PointStamped",
    "/deskarm/cmd/estop": "std_msgs/msg/Bool",
    "/deskarm/cmd/settings": "std_msgs/msg/String",
    "/deskarm/cmd/heartbeat": "std_msgs/msg/Header",
}
ALL_TOPICS = {**TOPICS, **COMMANDS}
IMAGE_TOPICS = {"left": "/deskarm/camera/left/image/compressed", "right": "/deskarm/camera/right/image/compressed"}
HUMBLE_HASH = "TypeHashNotSupported"  # what rmw_zenoh writes on Humble, which has no type hashes
GID_SIZE = 16
ATTACHMENT_SIZE = 8 + 8 + 1 + GID_SIZE


@lru_cache(maxsize=1)
def typestore():
    """rosbags' ROS 2 Humble type store (the recordings' message definitions)."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_HUMBLE)


def dds_type_name(msgtype: str) -> str:
    """``sensor_msgs/msg/JointState`` -> ``sensor_msgs::msg::dds_::JointState_`` (rmw's mangling)."""
    pkg, kind, name = msgtype.split("/")
    return f"{pkg}::{kind}::dds_::{name}_"


@lru_cache(maxsize=None)
def type_hash(msgtype: str, style: str = "rihs01") -> str:
    """The key expression's last chunk: RIHS01 (``style="rihs01"``) or Humble's placeholder."""
    if style == "humble":
        return HUMBLE_HASH
    if style != "rihs01":
        raise ValueError(f"type hash style {style!r}: expected rihs01 or humble")
    return typestore().hash_rihs01(msgtype)


def key_expr(topic: str, msgtype: Optional[str] = None, domain_id: int = 0, hash_style: str = "rihs01") -> str:
    """The Zenoh key expression of ``topic`` as rmw_zenoh names it."""
    msgtype = msgtype or ALL_TOPICS[topic]
    return f"{int(domain_id)}/{topic.strip('/')}/{dds_type_name(msgtype)}/{type_hash(msgtype, hash_style)}"


def key_pattern(topic: str, msgtype: Optional[str] = None, domain_id: int = 0) -> str:
    """A key expression matching ``topic`` whatever the type hash (RIHS01 or Humble's)."""
    msgtype = msgtype or ALL_TOPICS[topic]
    return f"{int(domain_id)}/{topic.strip('/')}/{dds_type_name(msgtype)}/*"


def topic_of_key(key: str) -> tuple[str, str]:
    """(topic, message type) of a key expression made by :func:`key_expr`."""
    chunks = str(key).split("/")
    if len(chunks) < 4 or "::dds_::" not in chunks[-2]:
        raise ValueError(f"{key!r} is not <domain>/<topic>/<type>/<hash>")
    pkg, kind, _, name = chunks[-2].split("::")
    return "/" + "/".join(chunks[1:-2]), f"{pkg}/{kind}/{name[:-1]}"


@dataclass(frozen=True)
class Attachment:
    """rmw_zenoh's per-sample attachment."""

    seq: int
    source_timestamp_ns: int
    gid: bytes

    def encode(self) -> bytes:
        gid = bytes(self.gid)[:GID_SIZE].ljust(GID_SIZE, b"\0")
        return struct.pack("<qqB", int(self.seq), int(self.source_timestamp_ns), GID_SIZE) + gid

    @classmethod
    def decode(cls, data: bytes) -> "Attachment":
        data = bytes(data)
        if len(data) != ATTACHMENT_SIZE or data[16] != GID_SIZE:
            raise ValueError(f"attachment of {len(data)} bytes: expected {ATTACHMENT_SIZE} (seq, stamp, gid)")
        seq, stamp = struct.unpack_from("<qq", data)
        return cls(seq, stamp, data[17:])


def serialize(msg, msgtype: str) -> bytes:
    return bytes(typestore().serialize_cdr(msg, msgtype))


def deserialize(data: bytes, msgtype: str):
    return typestore().deserialize_cdr(bytes(data), msgtype)


# ---- conversions: deskarm -> ROS 2 messages ---------------------------------------------------

def _t(name: str):
    return typestore().types[name]


def ros_time(wall_s: float):
    """builtin_interfaces/Time from wall seconds."""
    sec = math.floor(wall_s)
    nsec = min(int(round((wall_s - sec) * 1e9)), 999_999_999)
    return _t("builtin_interfaces/msg/Time")(sec=int(sec), nanosec=nsec)


def stamp_s(stamp) -> float:
    """Wall seconds of a builtin_interfaces/Time."""
    return stamp.sec + stamp.nanosec * 1e-9


def header(wall_s: float, frame_id: str = ""):
    return _t("std_msgs/msg/Header")(stamp=ros_time(wall_s), frame_id=frame_id)


def compressed_image(jpeg: bytes, wall_s: float, frame_id: str):
    return _t("sensor_msgs/msg/CompressedImage")(header=header(wall_s, frame_id), format="jpeg",
                                                 data=np.frombuffer(jpeg, dtype=np.uint8))


def camera_info(calibration, side: str, wall_s: float):
    """sensor_msgs/CameraInfo of one camera of a StereoCalibration (the rectified P, as ROS does)."""
    left = side == "left"
    K = calibration.M1 if left else calibration.M2
    D = np.asarray(calibration.D1 if left else calibration.D2, float).reshape(-1)
    R = calibration.R1 if left else calibration.R2
    P = calibration.P1 if left else calibration.P2
    w, h = calibration.image_size
    roi = _t("sensor_msgs/msg/RegionOfInterest")(x_offset=0, y_offset=0, height=0, width=0, do_rectify=False)
    return _t("sensor_msgs/msg/CameraInfo")(
        header=header(wall_s, FRAME_CAMERA_LEFT if left else FRAME_CAMERA_RIGHT), height=int(h), width=int(w),
        distortion_model="plumb_bob" if D.size <= 5 else "rational_polynomial", d=D.astype(np.float64),
        k=np.asarray(K, np.float64).reshape(9), r=np.asarray(R, np.float64).reshape(9),
        p=np.asarray(P, np.float64).reshape(12), binning_x=0, binning_y=0, roi=roi)


def joint_state(names, q, wall_s: float):
    return _t("sensor_msgs/msg/JointState")(
        header=header(wall_s, FRAME_ROBOT_BASE), name=list(names), position=np.asarray(q, np.float64),
        velocity=np.zeros(0, np.float64), effort=np.zeros(0, np.float64))


def quaternion_xyzw(R) -> tuple[float, float, float, float]:
    """A rotation matrix as a unit quaternion (x, y, z, w)."""
    R = np.asarray(R, float)[:3, :3]
    tr = np.trace(R)
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        w, x, y, z = 0.25 * s, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s
    else:
        i = int(np.argmax(np.diag(R)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = math.sqrt(1.0 + R[i, i] - R[j, j] - R[k, k]) * 2
        q = [0.0, 0.0, 0.0]
        q[i] = 0.25 * s
        q[j] = (R[j, i] + R[i, j]) / s
        q[k] = (R[k, i] + R[i, k]) / s
        w = (R[k, j] - R[j, k]) / s
        x, y, z = q
    n = math.sqrt(x * x + y * y + z * z + w * w) or 1.0
    return (x / n, y / n, z / n, w / n)


def transform_stamped(parent_T_child, parent: str, child: str, wall_s: float):
    T = np.asarray(parent_T_child, float)
    x, y, z, w = quaternion_xyzw(T[:3, :3])
    tf = _t("geometry_msgs/msg/Transform")(
        translation=_t("geometry_msgs/msg/Vector3")(x=float(T[0, 3]), y=float(T[1, 3]), z=float(T[2, 3])),
        rotation=_t("geometry_msgs/msg/Quaternion")(x=x, y=y, z=z, w=w))
    return _t("geometry_msgs/msg/TransformStamped")(header=header(wall_s, parent), child_frame_id=child, transform=tf)


def tf_message(transforms):
    return _t("tf2_msgs/msg/TFMessage")(transforms=list(transforms))


def marker_array(result, wall_s: float):
    """visualization_msgs/MarkerArray of the markers found, exactly as the recordings write it
    (``core.record.topics.marker_array``: ns "aruco", id = marker id, position in robot_base)."""
    from core.record.topics import marker_array as recorded_marker_array

    return recorded_marker_array(result, wall_s)


def point_stamped(base_p, wall_s: float, frame_id: str = FRAME_ROBOT_BASE):
    x, y, z = (float(v) for v in base_p)
    return _t("geometry_msgs/msg/PointStamped")(header=header(wall_s, frame_id),
                                                point=_t("geometry_msgs/msg/Point")(x=x, y=y, z=z))


def bool_msg(value: bool):
    return _t("std_msgs/msg/Bool")(data=bool(value))


def string_msg(text: str):
    return _t("std_msgs/msg/String")(data=str(text))


def json_msg(obj) -> object:
    return string_msg(json.dumps(obj, sort_keys=True))


# ---- conversions: ROS 2 messages -> plain values ----------------------------------------------

def markers_of(msg) -> dict[int, tuple[float, float, float]]:
    """{marker id: position in robot_base (m)} of the markers a MarkerArray adds."""
    out = {}
    for m in msg.markers:
        if m.action == m.ADD:
            p = m.pose.position
            out[int(m.id)] = (float(p.x), float(p.y), float(p.z))
    return out


def wall_now() -> float:
    return time.time()


FRAMES = (FRAME_ROBOT_BASE, FRAME_CAMERA_LEFT, FRAME_CAMERA_RIGHT, FRAME_TOOL)
