"""Test helper: a few seconds of the simulated desk written as a deskarm recording, with rosbags
directly (the recording topic contract), and the same frames scored live.

``make_recording(folder)`` renders the desk on a simulated clock, runs the session's perception on
every frame (scored against the ground truth as the headless runner scores it), and writes the
images (JPEG), camera infos, session info, /tf_static, joint states, goals, perceived and true
markers. It returns what was scored live, so a test can compare a replay with it.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from core.clock import SimClock
from core.kinematics import build_kinematics, load_profile
from core.sim.camera import SimStereoCamera
from core.vision.calibration import load_calibration, save_calibration
from core.vision.perception import StereoMarkerPerception

TS = get_typestore(Stores.ROS2_HUMBLE)
T = TS.types
NS = 1_000_000_000
LOG_OFFSET_NS = 7 * NS  # log times on another clock than the header stamps (as a recorder's may be)

TOPICS = {
    "/deskarm/camera/left/image/compressed": "sensor_msgs/msg/CompressedImage",
    "/deskarm/camera/right/image/compressed": "sensor_msgs/msg/CompressedImage",
    "/deskarm/camera/left/camera_info": "sensor_msgs/msg/CameraInfo",
    "/deskarm/camera/right/camera_info": "sensor_msgs/msg/CameraInfo",
    "/deskarm/joint_states/commanded": "sensor_msgs/msg/JointState",
    "/deskarm/joint_states/measured": "sensor_msgs/msg/JointState",
    "/tf_static": "tf2_msgs/msg/TFMessage",
    "/tf": "tf2_msgs/msg/TFMessage",
    "/deskarm/markers": "visualization_msgs/msg/MarkerArray",
    "/deskarm/truth/markers": "visualization_msgs/msg/MarkerArray",
    "/deskarm/goal": "geometry_msgs/msg/PointStamped",
    "/deskarm/estop": "std_msgs/msg/Bool",
    "/deskarm/session": "std_msgs/msg/String",
}


@dataclass
class LiveRun:
    """What the recorded frames gave live."""

    path: Path
    frames: int = 0
    frame_times: list = field(default_factory=list)  # capture time of each frame (simulated clock, s)
    error_3d_mm: list = field(default_factory=list)  # per (frame, visible marker found), as headless scores
    measured_q: list = field(default_factory=list)  # (t, q) written on /deskarm/joint_states/measured
    left_images: list = field(default_factory=list)  # the decoded JPEGs as written (first few)

    @property
    def error_3d_mm_p50(self) -> float:
        return float(np.percentile(self.error_3d_mm, 50))


def _stamp(t: float):
    ns = max(0, int(round(t * NS)))
    return T["builtin_interfaces/msg/Time"](sec=ns // NS, nanosec=ns % NS)


def _header(t: float, frame_id: str):
    return T["std_msgs/msg/Header"](stamp=_stamp(t), frame_id=frame_id)


def _marker(marker_id: int, ns: str, p, t: float, text: str = ""):
    Marker = T["visualization_msgs/msg/Marker"]
    V3, Q = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Quaternion"]
    return Marker(
        header=_header(t, "robot_base"), ns=ns, id=int(marker_id), type=Marker.CUBE, action=Marker.ADD,
        pose=T["geometry_msgs/msg/Pose"](position=T["geometry_msgs/msg/Point"](x=float(p[0]), y=float(p[1]),
                                                                                z=float(p[2])),
                                         orientation=Q(x=0.0, y=0.0, z=0.0, w=1.0)),
        scale=V3(x=0.03, y=0.03, z=0.002), color=T["std_msgs/msg/ColorRGBA"](r=0.2, g=0.4, b=1.0, a=0.6),
        lifetime=T["builtin_interfaces/msg/Duration"](sec=0, nanosec=0), frame_locked=False, points=[],
        colors=[], texture_resource="",
        texture=T["sensor_msgs/msg/CompressedImage"](header=_header(0.0, ""), format="", data=np.zeros(0, np.uint8)),
        uv_coordinates=[], text=text, mesh_resource="",
        mesh_file=T["visualization_msgs/msg/MeshFile"](filename="", data=np.zeros(0, np.uint8)),
        mesh_use_embedded_materials=False)


def _camera_info(calib, side: str, t: float):
    M, D, R, P = ((calib.M1, calib.D1, calib.R1, calib.P1) if side == "left"
                  else (calib.M2, calib.D2, calib.R2, calib.P2))
    w, h = calib.image_size
    return T["sensor_msgs/msg/CameraInfo"](
        header=_header(t, f"camera_{side}"), height=int(h), width=int(w), distortion_model="plumb_bob",
        d=np.asarray(D, np.float64).reshape(-1)[:5].copy(), k=np.asarray(M, np.float64).reshape(9).copy(),
        r=np.asarray(R, np.float64).reshape(9).copy(), p=np.asarray(P, np.float64).reshape(12).copy(),
        binning_x=0, binning_y=0,
        roi=T["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False))


def _joint_state(q, t: float):
    empty = np.zeros(0, np.float64)
    return T["sensor_msgs/msg/JointState"](header=_header(t, ""), name=[f"joint{i + 1}" for i in range(len(q))],
                                            position=np.asarray(q, np.float64), velocity=empty, effort=empty)


def _tf_static(base_T_camera, t: float):
    m = np.asarray(base_T_camera, float)
    qx, qy, qz, qw = _quaternion(m[:3, :3])
    tr = T["geometry_msgs/msg/Transform"](
        translation=T["geometry_msgs/msg/Vector3"](x=float(m[0, 3]), y=float(m[1, 3]), z=float(m[2, 3])),
        rotation=T["geometry_msgs/msg/Quaternion"](x=qx, y=qy, z=qz, w=qw))
    ts = T["geometry_msgs/msg/TransformStamped"](header=_header(t, "robot_base"), child_frame_id="camera_left",
                                                 transform=tr)
    return T["tf2_msgs/msg/TFMessage"](transforms=[ts])


def _quaternion(R):
    w = np.sqrt(max(0.0, 1.0 + R[0, 0] + R[1, 1] + R[2, 2])) / 2
    x = np.copysign(np.sqrt(max(0.0, 1.0 + R[0, 0] - R[1, 1] - R[2, 2])) / 2, R[2, 1] - R[1, 2])
    y = np.copysign(np.sqrt(max(0.0, 1.0 - R[0, 0] + R[1, 1] - R[2, 2])) / 2, R[0, 2] - R[2, 0])
    z = np.copysign(np.sqrt(max(0.0, 1.0 - R[0, 0] - R[1, 1] + R[2, 2])) / 2, R[1, 0] - R[0, 1])
    return float(x), float(y), float(z), float(w)


def make_recording(folder, seconds: float = 3.0, fps: float = 15.0, scenario: str = "wander",
                   quality: int = 95, robot: str = "desk_rrr", deskarm_version: str | None = None,
                   chunk_every_s: float = 0.5, keep_images: int = 3) -> LiveRun:
    """Record ``seconds`` of the simulated desk into the new rosbag2 folder ``folder``."""
    from core.record.reader import deskarm_version as installed_version

    folder = Path(folder)
    clock = SimClock()
    cam = SimStereoCamera(scenario=scenario, fps=fps, clock=clock)
    cam.connect()
    profile = load_profile(robot)
    kin = build_kinematics(profile)
    # the session's calibration as the session has it: written and read back through the YAML
    yaml_path = folder.parent / f"{folder.name}.calibration.yaml"
    save_calibration(yaml_path, cam.calibration())
    calib = load_calibration(yaml_path, expected_size=cam.calibration().image_size)
    base_T_camera = cam.base_T_camera()
    perception = StereoMarkerPerception(calib, base_T_camera, marker_ids=(23, 50))
    live = LiveRun(folder)
    session = {"deskarm_version": installed_version() if deskarm_version is None else deskarm_version,
               "robot": robot, "camera": "sim", "pair_id": cam.pair_id,
               "calibration_yaml": yaml_path.read_text(encoding="utf-8"),
               "base_T_camera": np.asarray(base_T_camera).tolist(), "scenario": scenario, "fps": fps}
    writer = Writer(folder, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.open()
    conns = {topic: writer.add_connection(topic, msgtype, typestore=TS) for topic, msgtype in TOPICS.items()}

    def write(topic, t, msg):
        writer.write(conns[topic], int(round(t * NS)) + LOG_OFFSET_NS, TS.serialize_cdr(msg, msg.__msgtype__))

    t0 = clock.now()
    write("/deskarm/session", t0, T["std_msgs/msg/String"](data=json.dumps(session)))
    write("/tf_static", t0, _tf_static(base_T_camera, t0))
    write("/deskarm/camera/left/camera_info", t0, _camera_info(calib, "left", t0))
    write("/deskarm/camera/right/camera_info", t0, _camera_info(calib, "right", t0))
    write("/deskarm/estop", t0, T["std_msgs/msg/Bool"](data=False))
    q = np.asarray(profile.q_home, float)
    cam.set_arm_points(kin.chain_points(q))
    last_chunk = t0
    while clock.now() - t0 < seconds:
        frame = cam.read()
        t = frame.t
        ok_l, jl = cv2.imencode(".jpg", frame.left, [cv2.IMWRITE_JPEG_QUALITY, quality])
        ok_r, jr = cv2.imencode(".jpg", frame.right, [cv2.IMWRITE_JPEG_QUALITY, quality])
        assert ok_l and ok_r
        for side, data in (("left", jl), ("right", jr)):
            write(f"/deskarm/camera/{side}/image/compressed", t,
                  T["sensor_msgs/msg/CompressedImage"](header=_header(t, f"camera_{side}"), format="jpeg",
                                                       data=np.asarray(data, np.uint8).reshape(-1)))
        if len(live.left_images) < keep_images:
            live.left_images.append(cv2.imdecode(jl, cv2.IMREAD_COLOR))
        write("/deskarm/truth/markers", t, T["visualization_msgs/msg/MarkerArray"](markers=[
            _marker(o.marker_id, "ball" if o.marker_id < 0 else "aruco", o.base_p_centre, t, o.label)
            for o in frame.truth.objects]))
        # live scoring: the very images that are written, decoded, as the replay will see them
        decoded = frame.__class__(seq=frame.seq, t=t, left=cv2.imdecode(jl, cv2.IMREAD_COLOR),
                                  right=cv2.imdecode(jr, cv2.IMREAD_COLOR), truth=frame.truth,
                                  repeated=frame.repeated)
        result = perception.process(decoded)
        for obj in frame.truth.objects:
            if obj.marker_id < 0 or not (obj.visible_left and obj.visible_right):
                continue
            obs = result.marker(obj.marker_id)
            if obs is not None and obs.found:
                live.error_3d_mm.append(float(np.linalg.norm(np.subtract(obs.base_p_centre, obj.base_p_centre))) * 1e3)
        write("/deskarm/markers", t, T["visualization_msgs/msg/MarkerArray"](markers=[
            _marker(m.marker_id, "aruco", m.base_p_centre, t) for m in result.markers if m.found]))
        # a slowly moving arm: commanded, and measured a little behind
        q = q + np.array([0.01, -0.005, 0.004])[: q.size]
        write("/deskarm/joint_states/commanded", t, _joint_state(q, t))
        write("/deskarm/joint_states/measured", t + 0.001, _joint_state(q - 0.002, t + 0.001))
        live.measured_q.append((t + 0.001, tuple(q - 0.002)))
        if result.markers and result.markers[0].found:
            p = result.markers[0].base_p_centre
            write("/deskarm/goal", t, T["geometry_msgs/msg/PointStamped"](
                header=_header(t, "robot_base"), point=T["geometry_msgs/msg/Point"](x=p[0], y=p[1], z=p[2])))
        live.frames += 1
        live.frame_times.append(t)
        if t - last_chunk >= chunk_every_s:  # small chunks, as a recorder flushing every so often writes
            writer.storage.close_chunk() if hasattr(writer, "storage") else None
            last_chunk = t
    cam.disconnect()
    writer.close()
    yaml_path.unlink()
    return live
