"""Camera sources: webcams (with fake captures), side-by-side, folders of pairs, specs, controls."""
import threading

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from core.clock import SimClock
from core.sim.camera import SimStereoCamera
from core.vision.cameras import (
    CameraControl,
    CameraError,
    FolderStereoCamera,
    WebcamStereoCamera,
    camera_spec,
    find_image_pairs,
    open_camera,
    pair_image_files,
    parse_camera_spec,
    pick_pair,
    v4l2_control_ranges,
)

W, H = 64, 48
BRIGHTNESS_CID, EXPOSURE_CID, EXPOSURE_AUTO_CID, GAIN_CID = 0x00980900, 0x009A0902, 0x009A0901, 0x00980913


class FakeDevice:
    """A webcam a test can unplug: frame pixel (0,0) is the device number, (0,1) the frame count."""

    def __init__(self, number: int, width: int = W, period_s: float = 0.002):
        self.number = number
        self.width = width
        self.period_s = period_s
        self.plugged = threading.Event()
        self.plugged.set()
        self.props = {cv2.CAP_PROP_BRIGHTNESS: 128.0, cv2.CAP_PROP_EXPOSURE: 250.0,
                      cv2.CAP_PROP_AUTO_EXPOSURE: 3.0, cv2.CAP_PROP_GAIN: 0.0}
        self.set_calls = []
        self.opens = 0
        self.count = 0
        self._pace = threading.Event()


class FakeCapture:
    """cv2.VideoCapture's interface over a FakeDevice."""

    def __init__(self, device: FakeDevice):
        self.device = device
        self.is_open = device.plugged.is_set()
        if self.is_open:
            device.opens += 1

    def isOpened(self):
        return self.is_open

    def set(self, prop, value):
        self.device.set_calls.append((prop, value))
        self.device.props[prop] = float(value)
        return True

    def get(self, prop):
        if prop == cv2.CAP_PROP_FRAME_WIDTH:
            return float(self.device.props.get(prop, 0))
        return float(self.device.props.get(prop, -1.0))

    def grab(self):
        self.device._pace.wait(self.device.period_s)  # the device's frame interval
        return self.is_open and self.device.plugged.is_set()

    def retrieve(self):
        if not (self.is_open and self.device.plugged.is_set()):
            return False, None
        self.device.count += 1
        img = np.zeros((H, self.device.width, 3), np.uint8)
        img[..., 0] = self.device.number
        img[0, 1, 1] = self.device.count % 256
        if self.device.width == 2 * W:  # side by side: halves marked 1 (left) and 2 (right)
            img[:, :W, 2] = 1
            img[:, W:, 2] = 2
        return True, img

    def release(self):
        self.is_open = False


def fake_ranges(device):
    return {BRIGHTNESS_CID: (0, 255, 1, 128), EXPOSURE_CID: (3, 2047, 1, 250), EXPOSURE_AUTO_CID: (0, 3, 1, 3),
            GAIN_CID: (0, 100, 5, 0)}


@pytest.fixture
def devices():
    return {0: FakeDevice(1), 2: FakeDevice(2)}


@pytest.fixture
def webcams(devices):
    cam = WebcamStereoCamera(0, 2, width=W, height=H, capture_factory=lambda d: FakeCapture(devices[d]),
                             retry_interval_s=0.01, max_failures=3, read_timeout_s=2.0, control_query=fake_ranges)
    cam.connect()
    yield cam
    cam.disconnect()


# ---------------------------------------------------------------------------------------------
# specs


def test_existing_camera_values_keep_their_meaning():
    assert parse_camera_spec("auto") == ("auto", (0, 1))
    assert parse_camera_spec("sim") == ("sim", ())
    assert parse_camera_spec("0,2") == ("webcam", (0, 2))
    assert parse_camera_spec("/dev/video0,/dev/video2") == ("webcam", ("/dev/video0", "/dev/video2"))


def test_new_camera_values_parse():
    by_id = "/dev/v4l/by-id/usb-046d_C525_ABC-video-index0"
    assert parse_camera_spec(f"{by_id},{by_id.replace('ABC', 'DEF')}")[0] == "webcam"
    path = "/dev/v4l/by-path/pci-0000:00:14.0-usb-0:1:1.0-video-index0"
    assert parse_camera_spec(f"sbs:{path}") == ("sbs", (path,))
    assert parse_camera_spec("sbs:0") == ("sbs", (0,))
    s = camera_spec("0,2@320x240@15@yuyv")
    assert (s.kind, s.devices, s.size, s.fps, s.fourcc) == ("webcam", (0, 2), (320, 240), 15.0, "YUYV")
    assert parse_camera_spec("folder:/some/where") == ("folder", ("/some/where",))


def test_an_existing_folder_path_is_a_folder_source(tmp_path):
    assert parse_camera_spec(str(tmp_path)) == ("folder", (str(tmp_path),))


@pytest.mark.parametrize("value", ["usb-left", "0", "0,1,2", "sbs:", "sbs:cam", "0,2@640x", "folder:"])
def test_unknown_camera_values_name_the_value_and_the_valid_forms(value):
    with pytest.raises(ValueError) as info:
        parse_camera_spec(value)
    assert str(info.value).startswith(f"unknown --camera value {value!r}; valid: auto")


# ---------------------------------------------------------------------------------------------
# pairing by timestamp


def test_pairs_match_the_lagging_cameras_newest_frame_with_the_closest_partner():
    left = [(0.000, 1), (0.033, 2), (0.066, 3)]
    right = [(0.010, 1), (0.043, 2), (0.076, 3)]
    il, ir = pick_pair(left, right)
    assert (left[il][1], right[ir][1]) == (3, 3)
    assert pick_pair(left, right, last=(3, 3)) is None  # nothing new on both sides
    left.append((0.100, 4))
    assert pick_pair(left, right, last=(3, 3)) is None  # the right frame closest to 0.076 is already used
    right.append((0.110, 4))
    il, ir = pick_pair(left, right, last=(3, 3))
    assert (left[il][1], right[ir][1]) == (4, 4)


def test_a_slower_camera_sets_the_pace_without_repeating_frames():
    left = [(k / 30, k) for k in range(1, 5)]  # 30 fps
    right = [(k / 15, k) for k in range(1, 3)]  # 15 fps, the newest at 2/15 = 4/30
    il, ir = pick_pair(left, right)
    assert (left[il][1], right[ir][1]) == (4, 2)
    assert pick_pair([], right) is None


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(0, 1), min_size=1, max_size=6), st.lists(st.floats(0, 1), min_size=1, max_size=6),
       st.tuples(st.integers(0, 7), st.integers(0, 7)))
def test_a_pair_is_always_new_on_both_sides_and_the_closest_in_time(tl, tr, last):
    left = [(t, k + 1) for k, t in enumerate(sorted(tl))]
    right = [(t, k + 1) for k, t in enumerate(sorted(tr))]
    pick = pick_pair(left, right, last)
    if pick is None:
        return
    (t_l, n_l), (t_r, n_r) = left[pick[0]], right[pick[1]]
    assert n_l > last[0] and n_r > last[1]
    if left[-1][0] <= right[-1][0]:  # the left camera lags: its newest frame is the anchor
        assert pick[0] == len(left) - 1 and abs(t_r - t_l) == min(abs(t - t_l) for t, _ in right)
    else:
        assert pick[1] == len(right) - 1 and abs(t_r - t_l) == min(abs(t - t_r) for t, _ in left)


# ---------------------------------------------------------------------------------------------
# webcams


def test_webcams_deliver_pairs_from_both_devices_with_their_skew(webcams):
    numbers = []
    for _ in range(8):
        f = webcams.read()
        assert f is not None
        assert f.left[0, 0, 0] == 1 and f.right[0, 0, 0] == 2
        assert 0.0 <= f.skew_s < 1.0
        numbers.append(f.seq)
    assert numbers == sorted(set(numbers))
    med, worst = webcams.skew_stats()
    assert 0.0 <= med <= worst
    assert webcams.is_connected and webcams.status_message == ""
    assert webcams.pair_id == "webcam:0,2"


def test_resolution_fps_fourcc_and_a_one_frame_buffer_are_requested(devices, webcams):
    calls = dict(devices[0].set_calls)
    assert calls[cv2.CAP_PROP_FRAME_WIDTH] == W and calls[cv2.CAP_PROP_FRAME_HEIGHT] == H
    assert calls[cv2.CAP_PROP_FPS] == 30.0 and calls[cv2.CAP_PROP_BUFFERSIZE] == 1
    assert calls[cv2.CAP_PROP_FOURCC] == cv2.VideoWriter_fourcc(*"MJPG")
    assert webcams.actual_mode[0][0] == W


def test_a_side_by_side_camera_is_split_in_halves():
    dev = FakeDevice(7, width=2 * W)
    cam = WebcamStereoCamera(0, None, width=W, height=H, side_by_side=True,
                             capture_factory=lambda d: FakeCapture(dev), control_query=fake_ranges)
    with cam:
        f = cam.read()
        assert f is not None and f.left.shape == (H, W, 3) and f.right.shape == (H, W, 3)
        assert np.all(f.left[..., 2] == 1) and np.all(f.right[..., 2] == 2) and f.skew_s == 0.0
    assert dict(dev.set_calls)[cv2.CAP_PROP_FRAME_WIDTH] == 2 * W
    assert cam.pair_id == "sbs:0"


def test_controls_come_with_their_ranges_and_are_clamped(devices, webcams):
    controls = {c.name: c for c in webcams.controls("left")}
    assert set(controls) == {"brightness", "exposure", "gain"}  # what the device reports
    b = controls["brightness"]
    assert (b.minimum, b.maximum, b.default, b.value, b.auto) == (0, 255, 128, 128, None)
    assert controls["exposure"].auto is True
    applied = webcams.set_control("brightness", 999)
    assert applied.value == 255 and devices[0].props[cv2.CAP_PROP_BRIGHTNESS] == 255
    assert devices[2].props[cv2.CAP_PROP_BRIGHTNESS] == 255  # both cameras of the pair
    assert webcams.set_control("gain", 42, side="right").value == 40  # snapped to the step of 5
    assert devices[0].props[cv2.CAP_PROP_GAIN] == 0
    # a manual exposure turns automatic exposure off (V4L2 menu: 1 = manual)
    e = webcams.set_control("exposure", 100)
    assert e.value == 100 and e.auto is False and devices[0].props[cv2.CAP_PROP_AUTO_EXPOSURE] == 1
    assert webcams.set_auto("exposure", True).auto is True and devices[2].props[cv2.CAP_PROP_AUTO_EXPOSURE] == 3
    with pytest.raises(KeyError, match="unknown camera control 'zoom'"):
        webcams.set_control("zoom", 1)
    with pytest.raises(KeyError, match="no control 'focus'"):
        webcams.set_control("focus", 1)
    with pytest.raises(KeyError, match="no automatic mode"):
        webcams.set_auto("brightness", True)


def test_control_clamping_snaps_to_the_step():
    c = CameraControl("gain", "Gain", 0, 100, 5, 0, 0)
    assert [c.clamp(v) for v in (-3, 12.4, 13, 101)] == [0, 10, 15, 100]


def test_unplugging_shows_a_status_and_replugging_resumes_with_the_chosen_controls(devices, webcams):
    assert webcams.read() is not None
    webcams.set_control("brightness", 77)
    devices[2].plugged.clear()
    assert webcams.wait_connected(False, timeout=5.0)
    assert "camera 2 unplugged" in webcams.status_message and "retrying" in webcams.status_message
    devices[2].props[cv2.CAP_PROP_BRIGHTNESS] = 128  # a replugged camera starts from its defaults
    devices[2].plugged.set()
    assert webcams.wait_connected(True, timeout=5.0)
    assert webcams.status_message == ""
    f = webcams.read()
    assert f is not None and f.right[0, 0, 0] == 2
    assert devices[2].opens == 2 and devices[2].props[cv2.CAP_PROP_BRIGHTNESS] == 77


def test_interrupt_wakes_a_waiting_read(devices, webcams):
    devices[0].plugged.clear()
    assert webcams.wait_connected(False, timeout=5.0)
    result = []
    t = threading.Thread(target=lambda: result.append(webcams.read()))
    t.start()
    webcams.interrupt()
    t.join(timeout=5.0)
    assert not t.is_alive() and result == [None]


def test_a_named_camera_that_does_not_open_is_a_visible_missing_state_never_the_simulated_desk():
    """`--camera 0,2` with the cameras unplugged: no simulated scene (a real arm would follow
    markers that do not exist), no frames, a banner and a status naming the camera, and the
    source keeps trying until the camera is plugged in."""
    device = FakeDevice(1)
    device.plugged.clear()
    for fallback in (True, False):  # whatever the arm
        cam, banner = open_camera("0,2", clock=SimClock(), fallback_to_sim=fallback,
                                  capture_factory=lambda d: FakeCapture(device))
        try:
            assert cam.kind == "webcam" and not cam.is_connected
            assert banner.startswith("CAMERA MISSING — camera 0 did not open") and "arm holds" in banner
            assert "cameras 0, 2 unplugged" in cam.status_message and "retrying" in cam.status_message
            cam.read_timeout_s = 0.01
            assert cam.read() is None
        finally:
            cam.disconnect()
    cam, _ = open_camera("0,2", clock=SimClock(), capture_factory=lambda d: FakeCapture(device))
    try:
        cam.retry_interval_s = 0.01
        device.plugged.set()  # plugged in later: frames come
        assert cam.wait_connected(True, timeout=5.0)
    finally:
        cam.disconnect()


def test_auto_falls_back_to_the_simulated_desk_only_with_a_simulated_arm():
    device = FakeDevice(1)
    device.plugged.clear()
    cam, banner = open_camera("auto", clock=SimClock(), capture_factory=lambda d: FakeCapture(device))
    try:
        assert cam.kind == "sim" and banner == "SIMULATED DESK — no camera found"
    finally:
        cam.disconnect()
    cam, banner = open_camera("auto", clock=SimClock(), fallback_to_sim=False,
                              capture_factory=lambda d: FakeCapture(device))
    try:
        assert cam.kind == "webcam" and not cam.is_connected and banner.startswith("CAMERA MISSING")
    finally:
        cam.disconnect()


def test_querying_control_ranges_without_a_device_gives_nothing():
    assert v4l2_control_ranges(99) == {} and v4l2_control_ranges("not-a-device") == {}


# ---------------------------------------------------------------------------------------------
# folders of pairs


def _write(folder, names, value):
    folder.mkdir(parents=True, exist_ok=True)
    for k, name in enumerate(names):
        img = np.full((H, W, 3), value + k, np.uint8)
        cv2.imwrite(str(folder / name), img)


def test_a_folder_of_pairs_plays_in_order_and_loops(tmp_path):
    _write(tmp_path, ["left_01.png", "left_02.png"], 10)
    _write(tmp_path, ["right_01.png", "right_02.png"], 100)
    cam = FolderStereoCamera(tmp_path, clock=SimClock())
    with cam:
        values = [(f.left[0, 0, 0], f.right[0, 0, 0]) for f in (cam.read() for _ in range(3))]
    assert values == [(10, 100), (11, 101), (10, 100)]
    assert cam.pair_id.startswith("folder:")


def test_a_folder_can_stop_at_the_end(tmp_path):
    _write(tmp_path / "left", ["a.png"], 1)
    _write(tmp_path / "right", ["a.png"], 2)
    cam = FolderStereoCamera(tmp_path, clock=SimClock(), loop=False)
    with cam:
        assert cam.read() is not None
        assert cam.read() is None and not cam.is_connected and "end of the 1 image pairs" in cam.status_message


def test_an_empty_or_missing_folder_says_what_it_expected(tmp_path):
    with pytest.raises(CameraError, match="no image pairs found — expected left_"):
        FolderStereoCamera(tmp_path).connect()
    with pytest.raises(CameraError, match="no such folder"):
        FolderStereoCamera(tmp_path / "nope").connect()
    with pytest.raises(CameraError, match="no such folder"):  # a typo in a path: one clear line
        open_camera(f"folder:{tmp_path / 'nope'}", clock=SimClock())


def test_open_camera_opens_a_folder(tmp_path):
    _write(tmp_path, ["left_1.png"], 5)
    _write(tmp_path, ["right_1.png"], 6)
    cam, banner = open_camera(str(tmp_path), clock=SimClock())
    with cam:
        assert cam.kind == "folder" and banner == "" and cam.read().right[0, 0, 0] == 6


@pytest.mark.parametrize("lefts, rights, expected", [
    (["left_001.png", "left_002.png"], ["right_002.png", "right_001.png"],
     [("left_001.png", "right_001.png"), ("left_002.png", "right_002.png")]),
    (["left01.jpg", "left02.jpg"], ["right01.jpg", "right02.jpg"],
     [("left01.jpg", "right01.jpg"), ("left02.jpg", "right02.jpg")]),
    (["cam0_img7.png", "cam0_img9.png"], ["cam1_img9.png", "cam1_img7.png"],
     [("cam0_img7.png", "cam1_img7.png"), ("cam0_img9.png", "cam1_img9.png")]),
])
def test_image_files_pair_by_name(tmp_path, lefts, rights, expected):
    pairs, lone_l, lone_r = pair_image_files([tmp_path / n for n in lefts], [tmp_path / n for n in rights])
    assert [(a.name, b.name) for a, b in pairs] == expected and lone_l == [] and lone_r == []


def test_unmatched_files_are_reported(tmp_path):
    pairs, lone_l, lone_r = pair_image_files([tmp_path / "left_1.png", tmp_path / "left_2.png"],
                                             [tmp_path / "right_1.png"])
    assert len(pairs) == 1 and [p.name for p in lone_l] == ["left_2.png"] and lone_r == []


def test_find_image_pairs_ignores_other_files(tmp_path):
    _write(tmp_path, ["left_1.png", "right_1.png"], 0)
    (tmp_path / "notes.txt").write_text("x")
    (tmp_path / "session.toml").write_text("x")
    assert [(a.name, b.name) for a, b in find_image_pairs(tmp_path)] == [("left_1.png", "right_1.png")]


# ---------------------------------------------------------------------------------------------
# simulated camera


def test_the_simulated_camera_lists_and_clamps_its_controls():
    cam = SimStereoCamera(clock=SimClock())
    names = [c.name for c in cam.controls()]
    assert names == ["exposure", "gain", "brightness", "contrast"]
    applied = cam.set_control("gain", 99)
    assert applied.value == 24.0 and cam.settings.gain == 24.0 and cam.desk.settings.gain == 24.0
    with pytest.raises(KeyError, match="no control 'focus'"):
        cam.set_control("focus", 1)
    assert cam.pair_id == "sim"
