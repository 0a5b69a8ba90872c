"""Recordings read back by an independent reader (``mcap`` + ``mcap_ros2``): topics, schemas,
counts and the decoded values equal to what the loop handed the recorder."""
from __future__ import annotations

import io
import json
import threading
from collections import Counter, defaultdict
from pathlib import Path

import numpy as np
import pytest
from mcap_ros2.reader import read_ros2_messages

from core.messages import (
    GroundTruth,
    Goal,
    JointCommand,
    JointState,
    MarkerObservation,
    ObjectTruth,
    PerceptionResult,
    StereoFrame,
    TargetMode,
)
from core.record import TOPICS, Recorder, list_recordings
from core.record.recorder import default_recording_path, recordings_dir
from core.record.topics import SESSION_KEYS

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")


def read_back(folder: Path) -> tuple[dict[str, list], dict[str, str]]:
    """topic -> decoded messages (file order), topic -> schema name, with mcap_ros2 only."""
    mcap = next(Path(folder).glob("*.mcap"))
    messages, schemas = defaultdict(list), {}
    for m in read_ros2_messages(str(mcap), log_time_order=False):
        messages[m.channel.topic].append(m.ros_msg)
        schemas[m.channel.topic] = m.schema.name
    return messages, schemas


class FakeClock:
    simulated = True  # a --fast run's clock: the recording's stamps are its own times (ros_epoch 0)

    def __init__(self, t: float = 100.0):
        self.t = t

    def now(self) -> float:
        return self.t


def session_info_for_tests(calibration_yaml: str = "") -> dict:
    return {"deskarm_version": "test", "robot": "desk_rrr", "camera": "test camera", "pair_id": "pair",
            "calibration_yaml": calibration_yaml, "base_T_camera": np.eye(4).tolist(), "scenario": "static",
            "fps": 30.0}


def sim_calibration():
    from core.sim.rig import SimRig

    return SimRig().calibration()


def test_a_headless_run_records_every_topic_with_counts_and_values_a_reader_can_check(tmp_path):
    from app.headless import run_headless
    from core.kinematics import build_kinematics, load_profile
    from core.session import SessionOptions
    from core.vision.calibration import load_calibration

    path = tmp_path / "run"
    out = io.StringIO()
    code = run_headless(SessionOptions(camera="sim", simulated_clock=True), 5.0, True, out=out, record=str(path))
    assert code == 0
    summary = json.loads(out.getvalue().strip().splitlines()[-1])
    assert summary["record_path"] == str(path) and summary["record_error"] is None
    assert summary["frames_recorded"] > 0 and summary["record_mb"] > 0
    assert summary["frames_recorded"] + summary["frames_dropped"] == summary["frames"]

    messages, schemas = read_back(path)
    assert set(messages) == set(TOPICS), f"missing: {set(TOPICS) - set(messages)}"
    assert schemas == TOPICS
    n = Counter({topic: len(msgs) for topic, msgs in messages.items()})
    frames = summary["frames_recorded"]
    assert n["/deskarm/camera/left/image/compressed"] == n["/deskarm/camera/right/image/compressed"] == frames
    assert n["/deskarm/truth/markers"] == frames  # the simulated desk has truth on every frame
    assert n["/deskarm/markers"] == summary["frames"]  # one array per perception result
    assert n["/deskarm/joint_states/commanded"] == summary["commands_sent"]
    assert n["/deskarm/joint_states/measured"] == n["/tf"] > 0
    for once in ("/deskarm/session", "/tf_static", "/deskarm/camera/left/camera_info",
                 "/deskarm/camera/right/camera_info", "/deskarm/estop"):
        assert n[once] == 1, once

    session = json.loads(messages["/deskarm/session"][0].data)
    assert set(session) == set(SESSION_KEYS) and session["robot"] == "desk_rrr" and session["fps"] == 30.0
    yaml_file = tmp_path / "calibration.yaml"
    yaml_file.write_text(session["calibration_yaml"])
    calib = load_calibration(yaml_file)  # the replay reloads the calibration from the session JSON
    left = messages["/deskarm/camera/left/camera_info"][0]
    right = messages["/deskarm/camera/right/camera_info"][0]
    np.testing.assert_allclose(np.reshape(left.k, (3, 3)), calib.M1, rtol=1e-12)
    np.testing.assert_allclose(np.reshape(right.p, (3, 4)), calib.P2, rtol=1e-12)
    assert left.distortion_model == "plumb_bob" and (left.width, left.height) == calib.image_size
    assert left.header.frame_id == "camera_left" and right.header.frame_id == "camera_right"

    tf_static = messages["/tf_static"][0].transforms[0]
    base_T_camera = np.asarray(session["base_T_camera"])
    assert (tf_static.header.frame_id, tf_static.child_frame_id) == ("robot_base", "camera_left")
    np.testing.assert_allclose([tf_static.transform.translation.x, tf_static.transform.translation.y,
                                tf_static.transform.translation.z], base_T_camera[:3, 3], atol=1e-12)
    assert messages["/deskarm/estop"][0].data is False

    image = messages["/deskarm/camera/left/image/compressed"][0]
    assert image.format == "jpeg" and bytes(image.data[:2]) == b"\xff\xd8"
    import cv2

    decoded = cv2.imdecode(np.frombuffer(bytes(image.data), np.uint8), cv2.IMREAD_COLOR)
    assert decoded.shape == (calib.image_size[1], calib.image_size[0], 3)

    # /tf's tool is the forward kinematics of the measured joints it goes with
    kin = build_kinematics(load_profile("desk_rrr"))
    for state, tf in zip(messages["/deskarm/joint_states/measured"][::25], messages["/tf"][::25]):
        tool = tf.transforms[0].transform.translation
        np.testing.assert_allclose([tool.x, tool.y, tool.z], kin.fk(state.position), atol=1e-9)
        assert list(state.name) == list(load_profile("desk_rrr").joint_names)

    # markers seen sit where the truth says (the perception's 3D error is sub-millimetre here)
    truth = {m.id: m.pose.position for m in messages["/deskarm/truth/markers"][-1].markers}
    seen = {m.id: m.pose.position for m in messages["/deskarm/markers"][-1].markers}
    common = set(truth) & set(seen) - {-1}
    assert common, f"no marker both seen and in the truth: seen {sorted(seen)}, truth {sorted(truth)}"
    for mid in common:
        assert abs(seen[mid].x - truth[mid].x) < 0.01 and abs(seen[mid].y - truth[mid].y) < 0.01
    assert all(m.ns == "aruco" and m.header.frame_id == "robot_base" for m in messages["/deskarm/markers"][-1].markers)

    info = list_recordings(tmp_path)
    assert [i.path for i in info] == [path] and info[0].complete and info[0].robot == "desk_rrr"
    assert info[0].duration_s == pytest.approx(5.0, abs=0.2) and info[0].size_bytes > 0


def test_recorded_values_equal_what_the_loop_handed_the_recorder(tmp_path):
    calib = sim_calibration()
    clock = FakeClock(100.0)
    rec = Recorder(tmp_path / "bag", session_info_for_tests(), clock=clock, joint_names=("a", "b", "c"),
                   fk=lambda q: np.array([q[0], q[1], q[2]]) * 2)
    base_T_camera = np.eye(4)
    base_T_camera[:3, 3] = (0.1, -0.2, 0.3)
    rec.start(calib, base_T_camera, estopped=False)
    yy, xx = np.mgrid[0:48, 0:64]
    left = np.dstack([xx * 4, yy * 5, (xx + yy) * 2]).astype(np.uint8)  # smooth: JPEG keeps it closely
    truth = GroundTruth(objects=(ObjectTruth(23, (0.05, 0.1, 0.0), True, True, "card 23"),
                                 ObjectTruth(-1, (0.0, 0.2, 0.01), True, False, "ball")))
    rec.frame(StereoFrame(seq=1, t=100.25, left=left, right=left[::-1].copy(), truth=truth))
    rec.result(PerceptionResult(seq=1, t=100.25, timings_ms={"total": 1.0}, full_frame_search=True, markers=(
        MarkerObservation(23, True, base_p_centre=(0.051, 0.099, 0.001)),
        MarkerObservation(50, False))))
    goal = Goal(seq=4, t=100.3, base_p_target=(0.05, 0.1, 0.05), mode=TargetMode.FOLLOW)
    rec.command(JointCommand(seq=1, t=100.3, q=(0.1, -0.2, 0.3)), goal)
    rec.command(JointCommand(seq=2, t=100.32, q=(0.11, -0.2, 0.3)), goal)  # same goal: written once
    rec.command(JointCommand(seq=3, t=100.34, q=(0.12, -0.2, 0.3)),
                Goal(seq=5, t=100.34, base_p_target=(1, 1, 1), mode=TargetMode.FOLLOW, valid=False))
    rec.state(JointState(seq=7, t=100.31, q=(0.1, -0.2, 0.3)))
    rec.state(JointState(seq=7, t=100.31, q=(0.1, -0.2, 0.3)))  # the same state again: once
    rec.estop(False)  # unchanged: not written
    clock.t = 101.0
    rec.estop(True)
    rec.close()
    assert rec.error == "" and rec.frames_written == 1 and rec.frames_dropped == 0
    messages, schemas = read_back(tmp_path / "bag")

    img = messages["/deskarm/camera/left/image/compressed"][0]
    assert (img.header.stamp.sec, img.header.stamp.nanosec) == (100, 250_000_000)
    assert img.header.frame_id == "camera_left" and img.format == "jpeg"
    import cv2

    back = cv2.imdecode(np.frombuffer(bytes(img.data), np.uint8), cv2.IMREAD_COLOR)
    assert np.abs(back.astype(int) - left.astype(int)).mean() < 3  # JPEG: close, not equal
    markers = messages["/deskarm/markers"][0].markers
    assert [(m.id, m.ns, m.type) for m in markers] == [(23, "aruco", 1)]  # CUBE; the lost 50 is left out
    assert (markers[0].pose.position.x, markers[0].pose.position.y, markers[0].pose.position.z) == (0.051, 0.099, 0.001)
    truth_markers = messages["/deskarm/truth/markers"][0].markers
    assert [(m.id, m.ns, m.text) for m in truth_markers] == [(23, "aruco", "card 23"), (-1, "ball", "ball")]
    assert list(messages["/deskarm/joint_states/commanded"][0].position) == [0.1, -0.2, 0.3]
    assert len(messages["/deskarm/joint_states/commanded"]) == 3
    state = messages["/deskarm/joint_states/measured"]
    assert len(state) == 1 and list(state[0].name) == ["a", "b", "c"] and list(state[0].position) == [0.1, -0.2, 0.3]
    tool = messages["/tf"][0].transforms[0]
    assert (tool.header.frame_id, tool.child_frame_id) == ("robot_base", "tool")
    assert (tool.transform.translation.x, tool.transform.translation.z) == (0.2, 0.6)
    goals = messages["/deskarm/goal"]
    assert len(goals) == 1 and (goals[0].point.x, goals[0].point.y, goals[0].point.z) == (0.05, 0.1, 0.05)
    assert goals[0].header.frame_id == "robot_base"
    assert [m.data for m in messages["/deskarm/estop"]] == [False, True]
    np.testing.assert_array_equal(np.reshape(messages["/deskarm/camera/left/camera_info"][0].k, (3, 3)), calib.M1)
    assert messages["/tf_static"][0].transforms[0].transform.translation.y == -0.2
    assert schemas["/deskarm/goal"] == "geometry_msgs/msg/PointStamped"


def test_a_full_queue_drops_the_oldest_image_pair_and_never_blocks_the_caller(tmp_path):
    rec = Recorder(tmp_path / "bag", session_info_for_tests(), queue_size=4, clock=FakeClock(1.0))
    entered, release = threading.Event(), threading.Event()
    write_frame = rec._write_frame

    def slow_disk(bag, frame):  # the first frame holds the recorder thread until released
        if frame.seq == 1:
            entered.set()
            assert release.wait(10)
        write_frame(bag, frame)

    rec._write_frame = slow_disk
    rec.start()
    image = np.zeros((16, 16, 3), np.uint8)
    rec.frame(StereoFrame(seq=1, t=1.0, left=image, right=image))
    assert entered.wait(10)
    for seq in range(2, 9):  # 7 more while the thread is stuck: 4 fit, the 3 oldest go
        rec.frame(StereoFrame(seq=seq, t=float(seq), left=image, right=image))
    assert rec.frames_dropped == 3
    release.set()
    rec.close()
    assert rec.frames_written == 5 and rec.error == ""
    messages, _ = read_back(tmp_path / "bag")
    stamps = [m.header.stamp.sec for m in messages["/deskarm/camera/left/image/compressed"]]
    assert stamps == [1, 5, 6, 7, 8]


def test_recordings_go_to_the_data_folder_with_a_dated_name_and_are_listed(tmp_path, monkeypatch):
    from datetime import datetime

    monkeypatch.setenv("DESKARM_HOME", str(tmp_path))
    now = datetime(2026, 3, 4, 5, 6, 7)
    first = default_recording_path(now)
    assert first == tmp_path / "data" / "recordings" / "deskarm-20260304-050607"
    rec = Recorder(None, session_info_for_tests())
    assert rec.path.parent == recordings_dir()
    rec.start()
    rec.close()
    first.mkdir(parents=True)
    assert default_recording_path(now) == first.with_name("deskarm-20260304-050607-2")
    listed = list_recordings()
    assert [i.path for i in listed] == [rec.path]  # the empty folder is not a recording
    with pytest.raises(ValueError, match="already exists"):
        Recorder(rec.path, session_info_for_tests())
