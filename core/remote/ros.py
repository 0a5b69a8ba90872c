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
bytes, little-endian. The server declares rmw_zenoh's liveliness tokens (``core.remote.graph``)
so ``ros2 node list`` / ``ros2 topic list`` / ``ros2 topic echo`` find its node and topics.

Times: message stamps are ROS time — wall-clock seconds since the epoch, the capture instant
mapped from the session's monotonic clock by ``core.record.topics.ros_epoch`` (the very offset the
recordings use, so a frame has the same stamp on the stream and in a bag) — so a client on
another machine can compute latency, as far as the two machines' clocks agree.
"""
from __future__ import annotations

import json
import struct
import time
from dataclasses import dataclass
from functools import lru_cache
from typing import Optional

from core.messages import (
    FRAME_CAMERA_LEFT,
    FRAME_CAMERA_RIGHT,
    FRAME_ROBOT_BASE,
    FRAME_TOOL,
)
from core.record import topics as _rec

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
# standard ROS 2 topics the server publishes too (not recorded: the bag has the deskarm ones)
STANDARD_TOPICS: dict[str, str] = {
    "/joint_states": "sensor_msgs/msg/JointState",  # measured (commanded when the arm has no feedback)
    "/robot_description": "std_msgs/msg/String",  # URDF, transient local (a late joiner gets it)
}
# client -> server
COMMANDS: dict[str, str] = {
    "/deskarm/cmd/goal": "geometry_msgs/msg/PointStamped",
    "/deskarm/cmd/estop": "std_msgs/msg/Bool",  # true = STOP (anyone who sees the arm); false is refused
    "/deskarm/cmd/settings": "std_msgs/msg/String",
    "/deskarm/cmd/heartbeat": "std_msgs/msg/Header",  # frame_id = the controlling client's id
    "/deskarm/cmd/rearm": "std_msgs/msg/Header",  # held (sent at 10 Hz) for REARM_HOLD_S by the controller
    "/deskarm/cmd/control": "std_msgs/msg/String",  # JSON {"claim"|"release": id, "take": bool}
}
# the ROS interface's commands (a ROS 2 machine with rmw_zenoh and the controller credential)
ROS_COMMANDS: dict[str, str] = {
    "/target_position": "geometry_msgs/msg/Point",  # robot_base, m: a manual goal
    "/target_pitch": "std_msgs/msg/Float64",  # rad: the tool's pitch (arms with a wrist)
    "/target_roll": "std_msgs/msg/Float64",  # rad: the tool's roll (arms with a wrist)
}
ALL_COMMANDS = {**COMMANDS, **ROS_COMMANDS}
ALL_TOPICS = {**TOPICS, **STANDARD_TOPICS, **ALL_COMMANDS}
IMAGE_TOPICS = {"left": "/deskarm/camera/left/image/compressed", "right": "/deskarm/camera/right/image/compressed"}
HUMBLE_HASH = "TypeHashNotSupported"  # what rmw_zenoh writes on Humble, which has no type hashes
GID_SIZE = 16
ATTACHMENT_SIZE = 8 + 8 + 1 + GID_SIZE


def typestore():
    """rosbags' ROS 2 Humble type store — the recordings' own (core.record.topics)."""
    return _rec.TYPESTORE



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


# The messages are the recordings' (core.record.topics builds them); these wrappers keep the
# remote desk's argument order (wall seconds last) and its frames.
def ros_time(wall_s: float):
    """builtin_interfaces/Time from wall seconds."""
    return _rec.stamp(wall_s)


def stamp_s(stamp) -> float:
    """Wall seconds of a builtin_interfaces/Time."""
    return stamp.sec + stamp.nanosec * 1e-9


def header(wall_s: float, frame_id: str = ""):
    return _rec.header(wall_s, frame_id)


def compressed_image(jpeg: bytes, wall_s: float, frame_id: str):
    return _rec.compressed_image(jpeg, wall_s, frame_id)


def camera_info(calibration, side: str, wall_s: float):
    """sensor_msgs/CameraInfo of one camera of a StereoCalibration (the rectified P, as ROS does)."""
    return _rec.camera_info(calibration, side, wall_s)


def joint_state(names, q, wall_s: float):
    return _rec.joint_state(q, wall_s, names, frame_id=FRAME_ROBOT_BASE)


quaternion_xyzw = _rec.quaternion_xyzw


def transform_stamped(parent_T_child, parent: str, child: str, wall_s: float):
    return _rec.transform_stamped(parent_T_child, wall_s, parent, child)


tf_message = _rec.tf_message


def marker_array(result, wall_s: float):
    """visualization_msgs/MarkerArray of the markers found, exactly as the recordings write it
    (ns "aruco", id = marker id, position in robot_base)."""
    return _rec.marker_array(result, wall_s)


def point_stamped(base_p, wall_s: float, frame_id: str = FRAME_ROBOT_BASE):
    x, y, z = (float(v) for v in base_p)
    return _t("geometry_msgs/msg/PointStamped")(header=header(wall_s, frame_id),
                                                point=_t("geometry_msgs/msg/Point")(x=x, y=y, z=z))


bool_msg = _rec.bool_msg


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
