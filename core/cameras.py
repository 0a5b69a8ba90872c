"""Stereo camera sources: one interface, a simulated desk and real webcams.

``open_camera("sim")`` gives the simulated desk; ``open_camera("0,2")`` two V4L2 webcams.
Every source follows one lifecycle: ``connect()``, ``disconnect()``, ``is_connected``, context
manager; ``read()`` returns the latest StereoFrame or None.
"""
from __future__ import annotations

import threading
from abc import ABC, abstractmethod
from typing import Callable, Optional

import numpy as np

from core.calibration import StereoCalibration
from core.clock import SimClock, WallClock
from core.messages import SequenceCounter, StereoFrame
from core.settings import CameraSettings


class CameraError(RuntimeError):
    """A camera could not be opened or stopped delivering frames."""


class CameraSource(ABC):
    """A stereo pair of images, read one frame at a time."""

    kind = "abstract"

    def __init__(self) -> None:
        self.settings = CameraSettings()
        self.status_message = ""

    @property
    @abstractmethod
    def name(self) -> str:
        """Human-readable name for the status bar."""

    @abstractmethod
    def connect(self) -> None:
        """Open the device(s); raises CameraError with a message a user can act on."""

    @abstractmethod
    def disconnect(self) -> None:
        """Release the device(s); safe to call twice."""

    @property
    @abstractmethod
    def is_connected(self) -> bool: ...

    @abstractmethod
    def read(self) -> Optional[StereoFrame]:
        """The next stereo frame (paced at the camera rate), or None if none is available."""

    def set_settings(self, settings: CameraSettings) -> None:
        """Apply exposure, gain, brightness and contrast."""
        self.settings = settings

    def calibration(self) -> Optional[StereoCalibration]:
        """The source's own exact calibration (simulated rig), else None."""
        return None

    def base_T_camera(self) -> Optional[np.ndarray]:
        """The source's own camera_left pose in robot_base (simulated rig), else None."""
        return None

    def interrupt(self) -> None:
        """Wake a blocked ``read`` (shutdown)."""

    def __enter__(self):
        self.connect()
        return self

    def __exit__(self, *exc):
        self.disconnect()


class SimStereoCamera(CameraSource):
    """The simulated desk seen by the simulated rig, at ``fps`` on the given clock.

    ``set_arm_points`` tells the renderer where the arm is (chain points in robot_base), so the
    arm appears in both views as it moves.
    """

    kind = "sim"

    def __init__(self, scenario: str = "static", fps: float = 30.0, clock=None, seed: int = 0,
                 marker_ids=(23, 50), rig=None, **desk_options):
        super().__init__()
        from core.sim_rig import SimRig
        from core.simdesk import SimDesk

        if not (1.0 <= fps <= 240.0):
            raise ValueError(f"camera fps = {fps} is outside 1…240")
        self.rig = rig or SimRig()
        self.desk = SimDesk(self.rig, scenario=scenario, marker_ids=marker_ids, seed=seed, **desk_options)
        self.scenario = scenario
        self.fps = float(fps)
        self.clock = clock or WallClock()
        self._seq = SequenceCounter()
        self._connected = False
        self._t0 = 0.0
        self._next = 0.0
        self._arm_points: Optional[np.ndarray] = None
        self._lock = threading.Lock()

    @property
    def name(self) -> str:
        return f"simulated desk ({self.scenario})"

    def connect(self) -> None:
        self._connected = True
        self._t0 = self.clock.now()
        self._next = self._t0

    def disconnect(self) -> None:
        self._connected = False
        self.clock.interrupt()

    def interrupt(self) -> None:
        self.clock.interrupt()

    @property
    def is_connected(self) -> bool:
        return self._connected

    def set_settings(self, settings: CameraSettings) -> None:
        super().set_settings(settings)
        self.desk.set_camera_settings(settings)

    def set_arm_points(self, points: Optional[np.ndarray]) -> None:
        with self._lock:
            self._arm_points = None if points is None else np.array(points, dtype=float)

    def read(self) -> Optional[StereoFrame]:
        if not self._connected:
            return None
        if not self.clock.wait_until(self._next) or not self._connected:
            return None
        t = self.clock.now()
        # keep the frame grid; after a stall skip ahead instead of bursting
        self._next = max(self._next + 1.0 / self.fps, t)
        with self._lock:
            arm = self._arm_points
        left, right, truth = self.desk.render(t - self._t0, arm)
        return StereoFrame(seq=self._seq.next(), t=t, left=left, right=right, truth=truth)

    def calibration(self) -> StereoCalibration:
        return self.rig.calibration()

    def base_T_camera(self) -> np.ndarray:
        return self.rig.base_T_camera


def _quietly(factory, dev):
    """Open a capture without OpenCV's backend warnings (a missing camera is reported by us)."""
    import cv2

    logging = getattr(getattr(cv2, "utils", None), "logging", None)
    if logging is None:
        return factory(dev)
    previous = logging.getLogLevel()
    logging.setLogLevel(logging.LOG_LEVEL_ERROR)
    try:
        return factory(dev)
    finally:
        logging.setLogLevel(previous)


class WebcamStereoCamera(CameraSource):
    """Two USB webcams opened with OpenCV, one grabbing thread each keeping only the latest frame."""

    kind = "webcam"

    def __init__(self, left: int | str, right: int | str, width: int = 640, height: int = 480,
                 fps: float = 30.0, capture_factory: Callable | None = None):
        super().__init__()
        self.devices = (left, right)
        self.width, self.height, self.fps = width, height, fps
        self._factory = capture_factory
        self._caps: list = []
        self._threads: list[threading.Thread] = []
        self._latest: list[Optional[tuple[float, np.ndarray]]] = [None, None]
        self._new = threading.Condition()
        self._running = False
        self._seq = SequenceCounter()
        self._last_pair_t = (-1.0, -1.0)

    @property
    def name(self) -> str:
        return f"webcams {self.devices[0]},{self.devices[1]}"

    def connect(self) -> None:
        import cv2

        factory = self._factory or cv2.VideoCapture
        caps = []
        for dev in self.devices:
            cap = _quietly(factory, dev)
            if not cap.isOpened():
                for c in caps:
                    c.release()
                raise CameraError(
                    f"camera {dev} did not open — is it plugged in and not used by another program? "
                    f"(list devices with `v4l2-ctl --list-devices`)"
                )
            cap.set(cv2.CAP_PROP_FRAME_WIDTH, self.width)
            cap.set(cv2.CAP_PROP_FRAME_HEIGHT, self.height)
            cap.set(cv2.CAP_PROP_FPS, self.fps)
            caps.append(cap)
        self._caps = caps
        self._running = True
        self._threads = [
            threading.Thread(target=self._grab_loop, args=(k,), daemon=True, name=f"grab-{k}")
            for k in range(2)
        ]
        for th in self._threads:
            th.start()

    def _grab_loop(self, k: int) -> None:
        import time

        cap = self._caps[k]
        failures = 0
        while self._running:
            ok, img = cap.read()
            t = time.monotonic()
            if not ok or img is None:
                failures += 1
                if failures > 30:
                    self.status_message = f"camera {self.devices[k]} stopped delivering frames"
                    with self._new:
                        self._new.notify_all()
                    break
                continue
            failures = 0
            with self._new:
                self._latest[k] = (t, img)
                self._new.notify_all()

    def disconnect(self) -> None:
        self._running = False
        with self._new:
            self._new.notify_all()
        for th in self._threads:
            th.join(timeout=2.0)
        for cap in self._caps:
            cap.release()
        self._caps, self._threads = [], []

    def interrupt(self) -> None:
        with self._new:
            self._new.notify_all()

    @property
    def is_connected(self) -> bool:
        return self._running and all(th.is_alive() for th in self._threads)

    def read(self) -> Optional[StereoFrame]:
        """The newest pair that differs from the last one returned (waits up to 1 s)."""
        with self._new:
            ok = self._new.wait_for(
                lambda: not self.is_connected or (
                    self._latest[0] is not None and self._latest[1] is not None
                    and (self._latest[0][0], self._latest[1][0]) != self._last_pair_t
                ),
                timeout=1.0,
            )
            if not ok or not self.is_connected:
                return None
            (tl, left), (tr, right) = self._latest  # type: ignore[misc]
            self._last_pair_t = (tl, tr)
        return StereoFrame(seq=self._seq.next(), t=min(tl, tr), left=left, right=right, skew_s=abs(tl - tr))


CAMERA_CHOICES = "auto (webcams 0,1, else the simulated desk) | sim | IDX,IDX (two webcam indices, e.g. 0,2) | /dev/videoN,/dev/videoM"


def parse_camera_spec(spec: str) -> tuple[str, tuple]:
    """('sim', ()) or ('webcam', (left, right)); ValueError names the spec and the valid forms."""
    spec = (spec or "auto").strip()
    if spec in ("sim", "sim://"):
        return "sim", ()
    if spec == "auto":
        return "auto", (0, 1)
    parts = [p.strip() for p in spec.split(",")]
    if len(parts) == 2 and all(parts):
        devs = tuple(int(p) if p.isdigit() else p for p in parts)
        if all(isinstance(d, int) or str(d).startswith("/dev/") for d in devs):
            return "webcam", devs
    raise ValueError(f"unknown --camera value {spec!r}; valid: {CAMERA_CHOICES}")


def open_camera(spec: str, scenario: str = "static", clock=None, fps: float = 30.0,
                fallback_to_sim: bool = True) -> tuple[CameraSource, str]:
    """Open the camera(s) named by ``spec``; returns (source, banner).

    When real cameras do not open and ``fallback_to_sim`` is set, the simulated desk is returned
    with a banner saying why — a missing camera is a visible state, not a crash.
    """
    kind, devs = parse_camera_spec(spec)
    if kind == "sim":
        cam = SimStereoCamera(scenario=scenario, fps=fps, clock=clock)
        cam.connect()
        return cam, "SIMULATED DESK"
    cam = WebcamStereoCamera(*devs, fps=fps)
    try:
        cam.connect()
        return cam, ""
    except CameraError as exc:
        if not (fallback_to_sim or kind == "auto"):
            raise
        sim = SimStereoCamera(scenario=scenario, fps=fps, clock=clock)
        sim.connect()
        why = "no camera found" if kind == "auto" else str(exc)
        return sim, f"SIMULATED DESK — {why}"


__all__ = [
    "CameraSource", "SimStereoCamera", "WebcamStereoCamera", "CameraError", "open_camera",
    "parse_camera_spec", "CAMERA_CHOICES", "SimClock",
]
