"""The webcam hand camera (core/devices/hand_camera.py) against a fake cv2.VideoCapture: frames with the
pose from the joints, intrinsics (default 60° HFOV, or a calibration file), unplug → a visible state and
a black image (never an exception), replug → frames again; the range sensor used for depth when present."""
import math

import numpy as np
import pytest

from core.devices.hand_camera import (BridgeRangeSensor, HandCameraError, WebcamHandCamera, default_intrinsics,
                                      parse_hand_camera_spec)


class FakeKinematics:
    camera_frame = "camera_optical"

    def camera_pose(self, q):
        T = np.eye(4)
        T[:3, 3] = [float(q[0]), 0.0, 0.3]
        return T


class FakeCapture:
    """cv2.VideoCapture-like: frames until ``unplugged``; then read fails (and reopening fails)."""

    def __init__(self, world):
        self.world = world
        self.opened = not world["unplugged"]

    def isOpened(self):
        return self.opened

    def set(self, prop, value):
        return True

    def get(self, prop):
        return 0.0

    def read(self):
        if self.world["unplugged"]:
            return False, None
        self.world["n"] += 1
        return True, np.full((480, 640, 3), self.world["n"] % 250, np.uint8)

    def release(self):
        self.opened = False


class Clock:
    def __init__(self):
        self.t = 0.0

    def __call__(self):
        return self.t


def make_camera(world, clock, **kw):
    return WebcamHandCamera(2, FakeKinematics(), capture_factory=lambda dev: FakeCapture(world), clock=clock,
                            retry_interval_s=1.0, max_failures=3, **kw)


def test_frames_carry_the_image_the_time_and_the_pose_from_the_joints():
    world, clock = {"unplugged": False, "n": 0}, Clock()
    cam = make_camera(world, clock)
    assert cam.connect() and cam.live and cam.status_message == ""
    frame = cam.render((0.1, 0, 0, 0, 0), 1.5)
    assert frame.live and frame.t == 1.5 and frame.image.shape == (480, 640, 3)
    assert frame.base_T_camera[0, 3] == pytest.approx(0.1)
    # default intrinsics: 60° horizontal field of view, centred
    assert cam.K[0, 0] == pytest.approx(320 / math.tan(math.radians(30)))
    assert cam.K[0, 2] == pytest.approx(319.5) and cam.K[1, 2] == pytest.approx(239.5)
    uv, z = cam.project(frame.base_T_camera, [[0.1, 0.0, 0.8]])
    assert uv[0] == pytest.approx([319.5, 239.5]) and z[0] == pytest.approx(0.5)


def test_unplug_gives_a_state_and_a_message_never_an_exception_and_replug_recovers():
    world, clock = {"unplugged": False, "n": 0}, Clock()
    cam = make_camera(world, clock)
    cam.connect()
    cam.render((0,) * 5, 0.0)
    world["unplugged"] = True
    frames = [cam.render((0,) * 5, 0.1 * i) for i in range(3)]
    assert not frames[-1].live and not cam.live and not frames[-1].image.any()
    assert "unplugged" in cam.status_message and "retrying" in cam.status_message
    world["unplugged"] = False
    assert not cam.render((0,) * 5, 0.4).live  # not before the retry interval
    clock.t = 1.5
    frame = cam.render((0,) * 5, 0.5)
    assert frame.live and cam.live and cam.status_message == ""


def test_a_missing_webcam_keeps_trying_or_names_the_fix():
    world, clock = {"unplugged": True, "n": 0}, Clock()
    cam = make_camera(world, clock)
    assert cam.connect(keep_trying=True) is False
    assert "did not open" in cam.status_message and "v4l2-ctl" in cam.status_message
    with pytest.raises(HandCameraError, match="plugged in"):
        make_camera(world, clock).connect(keep_trying=False)


def test_intrinsics_from_a_calibration_file_scaled_to_the_image(tmp_path):
    import cv2

    path = tmp_path / "hand.yaml"
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    fs.write("image_width", 1280)
    fs.write("image_height", 960)
    fs.write("camera_matrix", np.array([[1000.0, 0, 639.5], [0, 1000.0, 479.5], [0, 0, 1]]))
    fs.release()
    cam = make_camera({"unplugged": False, "n": 0}, Clock(), calibration=path)
    assert cam.K[0, 0] == pytest.approx(500.0) and cam.K[0, 2] == pytest.approx(319.5)
    with pytest.raises(HandCameraError, match="no such file"):
        make_camera({"unplugged": False, "n": 0}, Clock(), calibration=tmp_path / "none.yaml")


def test_hand_camera_specs():
    assert parse_hand_camera_spec("webcam:2") == 2
    assert parse_hand_camera_spec("webcam:/dev/video4") == "/dev/video4"
    assert parse_hand_camera_spec("sim") is None
    with pytest.raises(ValueError, match="webcam:N"):
        parse_hand_camera_spec("usb2")
    assert default_intrinsics(640, 480)[0, 0] == pytest.approx(554.256, abs=1e-3)


class FakeBridge:
    def __init__(self, reading):
        self.reading = reading

    def range_m(self, max_age_s=0.5):
        return self.reading


def test_the_range_sensor_gives_the_depth_when_present_and_the_size_otherwise():
    """AssistLoop with depth 'auto' on the simulated desk: the board's range when it has one, the
    button's known size when it does not (the range sensor absent or out of range)."""
    from app.assist_window import build_sim_loop
    from core.motion.assist_loop import AssistLoop

    sim, q = build_sim_loop(0)
    bridge = FakeBridge(None)
    loop = AssistLoop(sim.kin, sim.camera, sim.detector, sim.servo, sim.assist_config, q, depth_source="auto",
                      range_sensor=BridgeRangeSensor(bridge))
    assert len(loop.offer()) == 9
    loop.select(4)
    assert loop.last_depth_source == "size"
    size_depth = loop._obs.depth_m if hasattr(loop._obs, "depth_m") else loop._obs[1]
    bridge.reading = 0.2
    loop.reset(q)
    loop.offer()
    loop.select(4)
    assert loop.last_depth_source == "range"
    range_depth = loop._obs.depth_m if hasattr(loop._obs, "depth_m") else loop._obs[1]
    assert range_depth != pytest.approx(size_depth)
    with pytest.raises(HandCameraError, match="no range sensor"):
        BridgeRangeSensor(object())
