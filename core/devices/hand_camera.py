"""The real eye-in-hand camera: any webcam on the arm's hand, and the board's range sensor.

``WebcamHandCamera`` has the interface ``core.motion.assist_loop.AssistLoop`` uses for the
simulated hand camera (``core.sim.hand_camera.SimHandCamera``): ``render(q, t)`` → a frame with
``image`` (BGR), ``t`` and ``base_T_camera``; ``K``; ``project(base_T_camera, points)``. Here
``render`` grabs the newest image from the webcam instead of drawing one, and the camera's pose
comes from the joints (``kinematics.camera_pose(q)``: the camera is fixed on the hand; no shake is
known on a real arm).

Frames are grabbed in the caller's thread (the AssistWorker's): ``cv2.VideoCapture.read`` waits
for the next frame, which paces the loop at the camera's rate; the buffer is kept at one frame so
the image is the newest, not a queued old one. Each frame carries ``capture_monotonic_s`` (the
host's monotonic clock when it arrived).

Unplugged (or not delivering frames ``max_failures`` times in a row): the device is released,
``live`` is False, ``status_message`` says so and how it is retried, and ``render`` returns a
black image of the last size (nothing to detect: the approach loses its target and stops, the
window shows no boxes) — never an exception. Every ``retry_interval_s`` the device is opened
again; when it delivers, the message clears.

Intrinsics: from a calibration file (``calibration=PATH``, an OpenCV FileStorage YAML/JSON with
``camera_matrix`` (or ``K``) and ``image_width``/``image_height`` — what OpenCV's calibration
sample writes; scaled when the webcam delivers another size), else the documented default: the
principal point at the image centre and f = (w / 2) / tan(HFOV / 2) with a 60° horizontal field of
view (a common webcam: 554 px at 640 px wide). Lens distortion is not corrected (the IBVS loop
only needs the target near the image centre, where it is smallest).

``BridgeRangeSensor`` reads the v2 board's HC-SR04 (``SerialV2Bridge.range_m``) with the
``measure(pose, t)`` interface of ``core.sim.range_sensor.SimRangeSensor``.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Optional, Sequence

import numpy as np

from core.capture import default_capture_factory, open_quietly

DEFAULT_HFOV_DEG = 60.0  # the default intrinsics' horizontal field of view (no calibration file)
RETRY_INTERVAL_S = 1.0  # an unplugged webcam is opened again this often
MAX_FAILURES = 5  # this many failed reads in a row: the webcam counts as unplugged


class HandCameraError(RuntimeError):
    """A hand camera that cannot be set up (bad spec, unreadable calibration)."""


def default_intrinsics(width: int, height: int, hfov_deg: float = DEFAULT_HFOV_DEG) -> np.ndarray:
    """The 3x3 camera matrix of an uncalibrated webcam: centred principal point (OpenCV's
    pixel-centre convention), square pixels, f from the horizontal field of view."""
    f = (width / 2.0) / math.tan(math.radians(hfov_deg) / 2.0)
    return np.array([[f, 0.0, (width - 1) / 2.0], [0.0, f, (height - 1) / 2.0], [0.0, 0.0, 1.0]])


def load_mono_calibration(path) -> tuple[np.ndarray, Optional[tuple[int, int]]]:
    """(K, (width, height) or None) from an OpenCV FileStorage file with ``camera_matrix`` or ``K``
    and optionally ``image_width``/``image_height``. HandCameraError naming the file and the fix."""
    import cv2

    path = Path(path)
    if not path.is_file():
        raise HandCameraError(f"hand camera calibration {path}: no such file — give the YAML your camera "
                              f"calibration wrote, or leave it out for the default 60° field of view")
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    try:
        if not fs.isOpened():
            raise HandCameraError(f"hand camera calibration {path}: not an OpenCV YAML/JSON file")
        K = None
        for key in ("camera_matrix", "K"):
            node = fs.getNode(key)
            if not node.empty():
                K = node.mat()
                break
        if K is None or K.shape != (3, 3) or not K[0, 0] > 0 or not K[1, 1] > 0:
            raise HandCameraError(f"hand camera calibration {path}: no 3x3 'camera_matrix' (or 'K') with "
                                  f"positive focal lengths — calibrate the hand camera first")
        w, h = fs.getNode("image_width"), fs.getNode("image_height")
        size = (int(w.real()), int(h.real())) if not w.empty() and not h.empty() else None
    finally:
        fs.release()
    return np.array(K, dtype=float), size


def scaled_intrinsics(K: np.ndarray, calibrated_size: Optional[tuple[int, int]], size: tuple[int, int]) -> np.ndarray:
    """K for images of ``size`` when it was calibrated at ``calibrated_size`` (same aspect assumed)."""
    if calibrated_size is None or tuple(calibrated_size) == tuple(size):
        return np.array(K, dtype=float)
    sx, sy = size[0] / calibrated_size[0], size[1] / calibrated_size[1]
    out = np.array(K, dtype=float)
    out[0, 0] *= sx
    out[0, 2] = (out[0, 2] + 0.5) * sx - 0.5
    out[1, 1] *= sy
    out[1, 2] = (out[1, 2] + 0.5) * sy - 0.5
    return out


def parse_hand_camera_spec(spec: str):
    """``webcam:2`` → 2, ``webcam:/dev/v4l/by-id/…`` → that path; ``sim`` → None (the simulated desk).
    ValueError naming the accepted forms."""
    text = (spec or "").strip()
    if text in ("sim", "sim://"):
        return None
    if text.startswith("webcam:") and len(text) > 7:
        device = text[7:]
        return int(device) if device.isdigit() else device
    raise ValueError(f"hand camera {spec!r}: use webcam:N (a video device number, e.g. webcam:2), "
                     f"webcam:/dev/video2 or a /dev/v4l/by-id/… path, or sim (the simulated desk)")


@dataclass
class HandCameraFrame:
    """One hand-camera image with the camera's pose from the joints (the fields AssistLoop uses)."""

    t: float  # the loop's clock when the frame was taken (s)
    image: np.ndarray  # BGR uint8
    base_T_camera: np.ndarray  # 4x4, robot_base, from the joints
    live: bool = True  # False: the webcam is unplugged and this image is black
    capture_monotonic_s: Optional[float] = None  # the host's monotonic clock when it arrived
    boxes: Optional[dict] = field(default=None)  # no truth on a real desk


class WebcamHandCamera:
    """A webcam on the arm's hand (see the module docstring).

    ``capture_factory(device)`` → a cv2.VideoCapture-like object (``read``, ``set``, ``get``,
    ``isOpened``, ``release``): tests pass fakes. ``clock``: monotonic seconds (retry timing).
    """

    def __init__(self, device, kinematics, *, width: int = 640, height: int = 480, fps: float = 30.0,
                 calibration=None, capture_factory: Optional[Callable] = None,
                 retry_interval_s: float = RETRY_INTERVAL_S, max_failures: int = MAX_FAILURES,
                 clock: Callable[[], float] = time.monotonic):
        if getattr(kinematics, "camera_frame", "") in ("", None):
            raise HandCameraError("the robot profile has no eye-in-hand camera frame: set geometry.camera_frame "
                                  "in its .toml to the URDF frame the webcam is mounted on")
        if not (16 <= width <= 4096 and 16 <= height <= 4096):
            raise HandCameraError(f"hand camera size {width}x{height} px: need 16…4096 px a side")
        self.device = device
        self.kinematics = kinematics
        self.width, self.height, self.fps = int(width), int(height), float(fps)
        self._factory = capture_factory or default_capture_factory
        self.retry_interval_s = float(retry_interval_s)
        self.max_failures = int(max_failures)
        self._clock = clock
        self._calibration = None if calibration is None else load_mono_calibration(calibration)
        self.intrinsics_source = (f"calibration {calibration}" if calibration is not None
                                  else f"default: {DEFAULT_HFOV_DEG:g}° horizontal field of view")
        self.size = (self.width, self.height)
        self.K = self._intrinsics(self.size)
        self._cap = None
        self._failures = 0
        self._next_retry = 0.0
        self.live = False
        self.frames = 0
        self.status_message = f"hand camera {device} not opened yet"

    def _intrinsics(self, size: tuple[int, int]) -> np.ndarray:
        if self._calibration is None:
            return default_intrinsics(*size)
        K, calibrated = self._calibration
        return scaled_intrinsics(K, calibrated, size)

    # -- the device ---------------------------------------------------------------------------

    def connect(self, keep_trying: bool = True) -> bool:
        """Open the webcam; True when it opened. Not opened: with ``keep_trying`` the message says
        so and ``render`` keeps retrying; without, HandCameraError naming the fix."""
        if self._open():
            return True
        if not keep_trying:
            raise HandCameraError(self.status_message)
        return False

    def _open(self) -> bool:
        import cv2

        self._next_retry = self._clock() + self.retry_interval_s
        try:
            cap = open_quietly(self._factory, self.device)  # a missing camera is reported by us, once
        except Exception as exc:  # noqa: BLE001 — a backend failure is a missing camera, reported below
            cap, reason = None, f" ({type(exc).__name__}: {exc})"
        else:
            reason = ""
        if cap is None or not cap.isOpened():
            if cap is not None:
                cap.release()
            self.live = False
            self.status_message = (f"hand camera {self.device} did not open{reason} — is it plugged in and not "
                                   f"used by another program? (list devices with `v4l2-ctl --list-devices`; "
                                   f"your user must be in the `video` group) — retrying every "
                                   f"{self.retry_interval_s:g} s")
            return False
        cap.set(cv2.CAP_PROP_FRAME_WIDTH, self.width)
        cap.set(cv2.CAP_PROP_FRAME_HEIGHT, self.height)
        cap.set(cv2.CAP_PROP_FPS, self.fps)
        cap.set(cv2.CAP_PROP_BUFFERSIZE, 1)  # the newest frame, not a queue of old ones
        self._cap, self._failures = cap, 0
        self.live = True
        self.status_message = ""
        return True

    def release(self) -> None:
        """Close the webcam (``render`` opens it again on its next retry)."""
        cap, self._cap = self._cap, None
        if cap is not None:
            cap.release()
        self.live = False

    disconnect = release

    def _grab(self) -> Optional[np.ndarray]:
        """The next image from the device (None: not open, or this read failed)."""
        if self._cap is None:
            if self._clock() < self._next_retry or not self._open():
                return None
        try:
            ok, image = self._cap.read()
        except Exception:  # noqa: BLE001 — a backend error on unplug counts as a failed read
            ok, image = False, None
        if not ok or image is None or getattr(image, "ndim", 0) not in (2, 3):
            self._failures += 1
            if self._failures >= self.max_failures:
                self.release()
                self._next_retry = self._clock() + self.retry_interval_s
                self.status_message = (f"hand camera {self.device} unplugged or not delivering frames — "
                                       f"retrying every {self.retry_interval_s:g} s")
            return None
        self._failures = 0
        if image.ndim == 2:
            import cv2

            image = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
        size = (int(image.shape[1]), int(image.shape[0]))
        if size != self.size:  # the device chose another mode: the intrinsics follow it
            self.size = size
            self.K = self._intrinsics(size)
        self.frames += 1
        self.live = True
        self.status_message = ""
        return image

    # -- the AssistLoop interface -----------------------------------------------------------------

    def render(self, q: Sequence[float], t: float) -> HandCameraFrame:
        """The newest webcam image at joints q and loop time t (a black image while unplugged)."""
        image = self._grab()
        pose = np.array(self.kinematics.camera_pose(q), dtype=float)
        if image is None:
            black = np.zeros((self.size[1], self.size[0], 3), dtype=np.uint8)
            return HandCameraFrame(float(t), black, pose, live=False)
        return HandCameraFrame(float(t), image, pose, live=True, capture_monotonic_s=self._clock())

    def project(self, base_T_camera: np.ndarray, base_points) -> tuple[np.ndarray, np.ndarray]:
        """Pixels (N, 2) and depths (N,) of robot_base points (N, 3) seen from ``base_T_camera``."""
        pts = np.atleast_2d(np.asarray(base_points, dtype=float))
        camera_p = (np.linalg.inv(base_T_camera) @ np.column_stack([pts, np.ones(len(pts))]).T)[:3]
        uv = (self.K @ camera_p)[:2] / camera_p[2]
        return uv.T, camera_p[2]


class BridgeRangeSensor:
    """The v2 board's ultrasonic range sensor as the loop's range sensor: ``measure(pose, t)`` →
    the newest distance (m) no older than ``max_age_s``, or None (no sensor, no echo, stale).
    The pose and time are ignored: the board measures where the sensor really is, now."""

    def __init__(self, bridge, max_age_s: Optional[float] = None):
        if not callable(getattr(bridge, "range_m", None)):
            raise HandCameraError(f"{type(bridge).__name__} has no range sensor: the range is read from a v2 board "
                                  f"(serial2://…) with an HC-SR04; use depth 'size' instead")
        self.bridge = bridge
        self.max_age_s = max_age_s

    def measure(self, pose=None, t: float = 0.0) -> Optional[float]:
        reading = self.bridge.range_m() if self.max_age_s is None else self.bridge.range_m(self.max_age_s)
        return None if reading is None or not reading > 0 else float(reading)
