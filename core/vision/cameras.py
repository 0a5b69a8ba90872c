"""Stereo camera sources: one interface, a simulated desk, real webcams and saved image pairs.

``open_camera("sim")`` gives the simulated desk; ``open_camera("0,2")`` two V4L2 webcams (indices
or stable ``/dev/v4l/by-id/...`` paths); ``open_camera("sbs:0")`` one side-by-side stereo camera
split in halves; ``open_camera("folder:PATH")`` a folder of saved pairs. Webcam specs take
``@WxH``, ``@FPS`` and ``@FOURCC`` suffixes, e.g. ``0,2@640x480@30@MJPG``.

Every source follows one lifecycle: ``connect()``, ``disconnect()``, ``is_connected``, context
manager; ``read()`` returns the latest StereoFrame or None. ``controls()`` lists the image
controls (with their ranges) and ``set_control`` / ``set_auto`` set them, clamped to what the
device accepts, returning what was actually applied.
"""
from __future__ import annotations

import collections
import importlib
import math
import os
import re
import sys
import threading
import time
from abc import ABC, abstractmethod
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable, Deque, Optional, Sequence

import numpy as np

from core.capture import default_capture_factory, open_quietly  # noqa: F401 (re-exported)
from core.clock import SimClock, WallClock
from core.messages import SequenceCounter, StereoFrame
from core.settings import CameraSettings
from core.vision.calibration import StereoCalibration


class CameraError(RuntimeError):
    """A camera could not be opened or stopped delivering frames."""


# ----------------------------------------------------------------------------------------------
# image controls


@dataclass(frozen=True)
class CameraControl:
    """One image control of a camera, as the device describes it (units are the device's)."""

    name: str  # exposure | gain | brightness | contrast | saturation | white_balance | focus
    label: str  # what the user reads
    minimum: float
    maximum: float
    step: float  # > 0
    default: float
    value: float  # current value
    auto: Optional[bool] = None  # None: no automatic mode; else whether it is on
    range_known: bool = True  # False: the device would not tell, the range is a typical UVC one

    def clamp(self, value: float) -> float:
        """``value`` limited to [minimum, maximum] and snapped to the step grid."""
        v = min(self.maximum, max(self.minimum, float(value)))
        if self.step > 0:
            v = self.minimum + round((v - self.minimum) / self.step) * self.step
            v = min(self.maximum, max(self.minimum, v))
        return float(v)


@dataclass(frozen=True)
class _ControlSpec:
    name: str
    label: str
    prop: int  # cv2.CAP_PROP_*
    cid: int  # V4L2 control id
    auto_prop: Optional[int] = None
    auto_cid: Optional[int] = None
    auto_on: float = 1.0  # value of the auto control meaning "automatic"
    auto_off: float = 0.0
    typical: tuple[float, float, float, float] = (0, 255, 1, 128)  # min, max, step, default (UVC)


def _control_specs() -> tuple[_ControlSpec, ...]:
    import cv2

    return (
        # V4L2 exposure_auto is a menu: 1 = manual, 3 = aperture priority (what UVC webcams call auto)
        _ControlSpec("exposure", "Exposure", cv2.CAP_PROP_EXPOSURE, 0x009A0902, cv2.CAP_PROP_AUTO_EXPOSURE,
                     0x009A0901, 3.0, 1.0, (3, 2047, 1, 250)),
        _ControlSpec("gain", "Gain", cv2.CAP_PROP_GAIN, 0x00980913, typical=(0, 255, 1, 0)),
        _ControlSpec("brightness", "Brightness", cv2.CAP_PROP_BRIGHTNESS, 0x00980900, typical=(0, 255, 1, 128)),
        _ControlSpec("contrast", "Contrast", cv2.CAP_PROP_CONTRAST, 0x00980901, typical=(0, 255, 1, 32)),
        _ControlSpec("saturation", "Saturation", cv2.CAP_PROP_SATURATION, 0x00980902, typical=(0, 255, 1, 32)),
        _ControlSpec("white_balance", "White balance (K)", cv2.CAP_PROP_WB_TEMPERATURE, 0x0098091A,
                     cv2.CAP_PROP_AUTO_WB, 0x0098090C, 1.0, 0.0, (2000, 6500, 10, 4000)),
        _ControlSpec("focus", "Focus", cv2.CAP_PROP_FOCUS, 0x009A090A, cv2.CAP_PROP_AUTOFOCUS, 0x009A090C,
                     1.0, 0.0, (0, 250, 5, 0)),
    )


CONTROL_NAMES = ("exposure", "gain", "brightness", "contrast", "saturation", "white_balance", "focus")

# ControlRange: (minimum, maximum, step, default) as the device reports it
ControlRange = tuple[float, float, float, float]
ControlQuery = Callable[[object], dict[int, ControlRange]]  # device -> {V4L2 id: range}

_VIDIOC_QUERYCTRL = 0xC0445624  # _IOWR('V', 36, struct v4l2_queryctrl), 68 bytes
_V4L2_CTRL_FLAG_DISABLED = 0x0001


def v4l2_device_path(device) -> Optional[str]:
    """The /dev/videoN node of an index or a (by-id / by-path) path, if it exists."""
    path = f"/dev/video{device}" if isinstance(device, int) else str(device)
    if not path.startswith("/dev/"):
        return None
    real = os.path.realpath(path)
    return real if os.path.exists(real) else None


def v4l2_control_ranges(device) -> dict[int, ControlRange]:
    """Ranges of the V4L2 controls of ``device`` (VIDIOC_QUERYCTRL); {} off Linux or on error."""
    path = v4l2_device_path(device)
    if path is None or not sys.platform.startswith("linux"):
        return {}
    import fcntl
    import struct

    out: dict[int, ControlRange] = {}
    try:
        fd = os.open(path, os.O_RDWR | os.O_NONBLOCK)
    except OSError:
        return {}
    try:
        for spec in _control_specs():
            for cid in (spec.cid, spec.auto_cid):
                if cid is None:
                    continue
                buf = bytearray(struct.pack("<II32siiiiI2I", cid, 0, b"", 0, 0, 0, 0, 0, 0, 0))
                try:
                    fcntl.ioctl(fd, _VIDIOC_QUERYCTRL, buf, True)
                except OSError:
                    continue
                _, _, _, lo, hi, step, default, flags, _, _ = struct.unpack("<II32siiiiI2I", buf)
                if not flags & _V4L2_CTRL_FLAG_DISABLED:
                    out[cid] = (float(lo), float(hi), float(max(1, step)), float(default))
    finally:
        os.close(fd)
    return out


# ----------------------------------------------------------------------------------------------
# the interface


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

    @property
    def pair_id(self) -> str:
        """A stable key for this camera pair (stereo presets and calibrations are stored per pair)."""
        return self.name

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
        """Apply exposure, gain, brightness and contrast (the simulated camera's controls)."""
        self.settings = settings

    def controls(self, side: str = "left") -> list[CameraControl]:
        """The image controls of one camera (``side`` in left/right), current values included."""
        return []

    def set_control(self, name: str, value: float, side: str = "both") -> CameraControl:
        """Set a control (clamped to the device's range; a manual value turns its auto mode off);
        returns the control as now applied (of the left camera when ``side`` is both)."""
        raise KeyError(f"{self.name} has no control {name!r}")

    def set_auto(self, name: str, on: bool, side: str = "both") -> CameraControl:
        """Switch a control's automatic mode (exposure, white balance, focus)."""
        raise KeyError(f"{self.name} has no automatic {name!r}")

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


def check_side(side: str, allowed=("left", "right", "both")) -> None:
    if side not in allowed:
        raise ValueError(f"camera side {side!r}; valid: {', '.join(allowed)}")


# ----------------------------------------------------------------------------------------------
# sources paced by a clock (the simulated desk, folders, rendered boards)


class ClockPacedSource(CameraSource):
    """A source whose frames come on a clock (simulated desk, folders, rendered boards):
    connected is a flag, and disconnecting wakes a ``read`` blocked on the clock."""

    def __init__(self, clock=None) -> None:
        super().__init__()
        self.clock = clock or WallClock()
        self._connected = False
        self._next = 0.0  # when the next frame is due, on ``clock``

    @property
    def next_frame_t(self) -> float:
        """When the next frame is due (the headless runner runs control steps due before it)."""
        return self._next

    def disconnect(self) -> None:
        self._connected = False
        self.clock.interrupt()

    def interrupt(self) -> None:
        self.clock.interrupt()

    @property
    def is_connected(self) -> bool:
        return self._connected


# ----------------------------------------------------------------------------------------------
# webcams


def pick_pair(left: Sequence[tuple[float, int]], right: Sequence[tuple[float, int]],
              last: Optional[tuple[int, int]] = None) -> Optional[tuple[int, int]]:
    """Pair frames by timestamp: the lagging camera's newest frame with the other camera's frame
    closest in time. ``left``/``right`` are (t, frame_number) oldest first; returns positions in
    them, or None when there is no pair newer than ``last`` (frame numbers) on both sides."""
    if not left or not right:
        return None
    tl, tr = left[-1][0], right[-1][0]
    if tl <= tr:
        il = len(left) - 1
        ir = min(range(len(right)), key=lambda k: abs(right[k][0] - tl))
    else:
        ir = len(right) - 1
        il = min(range(len(left)), key=lambda k: abs(left[k][0] - tr))
    if last is not None and (left[il][1] <= last[0] or right[ir][1] <= last[1]):
        return None
    return il, ir


class _Grabber:
    """One device: a thread grabbing frames into a small time-stamped buffer; reopens after unplug."""

    def __init__(self, owner: "WebcamStereoCamera", device, sides: tuple[int, ...]):
        self.owner = owner
        self.device = device
        self.sides = sides  # (0,), (1,) or (0, 1) for a side-by-side camera
        self.cap = None
        self.lock = threading.Lock()  # VideoCapture is not thread-safe: grab vs set
        self.connected = False
        self.frames = 0
        self.thread: Optional[threading.Thread] = None
        self.ranges: dict[int, ControlRange] = {}
        self.actual = (0, 0, 0.0)  # width, height, fps the device agreed to

    # opening ---------------------------------------------------------------------------------
    def open(self) -> bool:
        import cv2

        o = self.owner
        cap = open_quietly(o._factory, self.device)
        if cap is None or not cap.isOpened():
            if cap is not None:
                cap.release()
            return False
        width = o.width * (2 if o.side_by_side else 1)
        if o.fourcc:
            cap.set(cv2.CAP_PROP_FOURCC, cv2.VideoWriter_fourcc(*o.fourcc))
        cap.set(cv2.CAP_PROP_FRAME_WIDTH, width)
        cap.set(cv2.CAP_PROP_FRAME_HEIGHT, o.height)
        cap.set(cv2.CAP_PROP_FPS, o.fps)
        cap.set(cv2.CAP_PROP_BUFFERSIZE, 1)  # the newest frame, not a queue of old ones
        self.actual = (int(cap.get(cv2.CAP_PROP_FRAME_WIDTH) or 0), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT) or 0),
                       float(cap.get(cv2.CAP_PROP_FPS) or 0.0))
        try:
            self.ranges = dict(o._control_query(self.device) or {})
        except Exception:  # noqa: BLE001 - a control query must never stop the camera
            self.ranges = {}
        with self.lock:
            self.cap = cap
        o._reapply_controls(self)
        self.connected = True
        return True

    def release(self) -> None:
        with self.lock:
            cap, self.cap = self.cap, None
        if cap is not None:
            cap.release()
        self.connected = False

    def start(self) -> None:
        self.thread = threading.Thread(target=self.run, daemon=True, name=f"grab-{self.device}")
        self.thread.start()

    # grabbing --------------------------------------------------------------------------------
    def run(self) -> None:
        o = self.owner
        failures = 0
        while o._running.is_set():
            if not self.connected:
                if o._stop.wait(o.retry_interval_s):
                    break
                if self.open():
                    failures = 0
                    o._on_state_change(self)
                continue
            with self.lock:
                cap = self.cap
                ok = cap is not None and cap.grab()
                t = o._now()
                img = None
                if ok:
                    ok, img = cap.retrieve()
            if not ok or img is None:
                failures += 1
                if failures >= o.max_failures:
                    self.release()
                    o._on_state_change(self)
                else:
                    o._stop.wait(0.005)  # a failing device returns at once: do not spin
                continue
            failures = 0
            self.frames += 1
            o._push(self, t, self.frames, img)


class WebcamStereoCamera(CameraSource):
    """Two USB webcams (or one side-by-side stereo camera) opened with OpenCV.

    One grabbing thread per device keeps only the newest few frames with their arrival time;
    ``read`` pairs the lagging camera's newest frame with the other camera's closest one and
    reports the time skew between them. A device that stops delivering (unplugged) is released
    and reopened every ``retry_interval_s``; meanwhile ``is_connected`` is False and
    ``status_message`` says which camera and what happens. ``capture_factory(device)`` returns a
    cv2.VideoCapture-like object (grab, retrieve, set, get, isOpened, release) — tests pass fakes.
    """

    kind = "webcam"

    def __init__(self, left, right=None, width: int = 640, height: int = 480, fps: float = 30.0,
                 capture_factory: Callable | None = None, fourcc: str = "MJPG", side_by_side: bool = False,
                 retry_interval_s: float = 1.0, max_failures: int = 30, read_timeout_s: float = 1.0,
                 control_query: Optional[ControlQuery] = None, clock: Callable[[], float] | None = None,
                 buffer_frames: int = 4):
        super().__init__()
        if side_by_side and right is not None:
            raise ValueError("a side-by-side camera is one device: give only the left one")
        if not side_by_side and right is None:
            raise ValueError("two webcams need a left and a right device")
        if not (16 <= width <= 8192 and 16 <= height <= 8192):
            raise ValueError(f"camera size {width}x{height} is outside 16x16…8192x8192")
        if not (1.0 <= fps <= 240.0):
            raise ValueError(f"camera fps = {fps} is outside 1…240")
        if fourcc and len(fourcc) != 4:
            raise ValueError(f"FOURCC {fourcc!r} must have 4 characters, e.g. MJPG or YUYV")
        self.devices = (left,) if side_by_side else (left, right)
        self.side_by_side = side_by_side
        self.width, self.height, self.fps = int(width), int(height), float(fps)
        self.fourcc = fourcc
        self.retry_interval_s = float(retry_interval_s)
        self.max_failures = int(max_failures)
        self.read_timeout_s = float(read_timeout_s)
        self._factory = capture_factory or default_capture_factory
        self._control_query = control_query or v4l2_control_ranges
        self._now = clock or time.monotonic
        self._grabbers: list[_Grabber] = []
        self._buffers: list[Deque[tuple[float, int, np.ndarray]]] = [
            collections.deque(maxlen=max(2, buffer_frames)) for _ in range(2)]
        self._cond = threading.Condition()
        self._running = threading.Event()
        self._stop = threading.Event()
        self._interrupts = 0
        self._seq = SequenceCounter()
        self._last_pair: Optional[tuple[int, int]] = None
        self._skews: Deque[float] = collections.deque(maxlen=120)
        self._desired: dict[tuple[int, str], tuple[str, float]] = {}  # (grabber, name) -> (kind, value)
        self._specs = {s.name: s for s in _control_specs()}

    # identity --------------------------------------------------------------------------------
    @property
    def name(self) -> str:
        if self.side_by_side:
            return f"side-by-side camera {self.devices[0]}"
        return f"webcams {self.devices[0]},{self.devices[1]}"

    @property
    def pair_id(self) -> str:
        return ("sbs:" if self.side_by_side else "webcam:") + ",".join(str(d) for d in self.devices)

    # lifecycle -------------------------------------------------------------------------------
    def connect(self, keep_trying: bool = False) -> None:
        """Open the device(s); CameraError when one does not open.

        ``keep_trying``: a device that does not open is tried again every ``retry_interval_s``
        instead (as after an unplug): the source runs, ``is_connected`` stays False and
        ``status_message`` says which camera is missing until it delivers frames.
        """
        if self._running.is_set():
            return
        grabbers = ([_Grabber(self, self.devices[0], (0, 1))] if self.side_by_side else
                    [_Grabber(self, self.devices[0], (0,)), _Grabber(self, self.devices[1], (1,))])
        missing = []
        for g in grabbers:
            if not g.open():
                missing.append(g)
                if keep_trying:
                    continue
                for other in grabbers:
                    other.release()
                raise CameraError(
                    f"camera {g.device} did not open — is it plugged in and not used by another program? "
                    f"(list devices with `v4l2-ctl --list-devices`)"
                )
        self._grabbers = grabbers
        self._stop.clear()
        self._running.set()
        self.status_message = ""
        for g in grabbers:
            g.start()
        if missing:
            self._on_state_change(missing[0])

    def disconnect(self) -> None:
        self._running.clear()
        self._stop.set()
        with self._cond:
            self._cond.notify_all()
        for g in self._grabbers:
            if g.thread is not None:
                g.thread.join(timeout=2.0)
            g.release()
        self._grabbers = []

    def interrupt(self) -> None:
        with self._cond:
            self._interrupts += 1
            self._cond.notify_all()

    @property
    def is_connected(self) -> bool:
        return self._running.is_set() and bool(self._grabbers) and all(g.connected for g in self._grabbers)

    def wait_connected(self, connected: bool = True, timeout: float = 5.0) -> bool:
        """Block until ``is_connected == connected`` (or timeout); for tests and reconnect UIs."""
        with self._cond:
            return self._cond.wait_for(lambda: self.is_connected == connected, timeout)

    @property
    def actual_mode(self) -> list[tuple[int, int, float]]:
        """(width, height, fps) each device agreed to (a side-by-side device is twice as wide)."""
        return [g.actual for g in self._grabbers]

    # frames ----------------------------------------------------------------------------------
    def _push(self, grabber: _Grabber, t: float, n: int, img: np.ndarray) -> None:
        with self._cond:
            if self.side_by_side:
                half = img.shape[1] // 2
                self._buffers[0].append((t, n, img[:, :half]))
                self._buffers[1].append((t, n, img[:, half:2 * half]))
            else:
                self._buffers[grabber.sides[0]].append((t, n, img))
            self._cond.notify_all()

    def _on_state_change(self, grabber: _Grabber) -> None:
        with self._cond:
            if not grabber.connected:  # frames from before the unplug must not pair with new ones
                for side in grabber.sides:
                    self._buffers[side].clear()
            down = [str(g.device) for g in self._grabbers if not g.connected]
            if not down:
                self.status_message = ""
            else:
                what = f"camera {down[0]}" if len(down) == 1 else f"cameras {', '.join(down)}"
                self.status_message = (f"{what} unplugged or not delivering frames — retrying every "
                                       f"{self.retry_interval_s:g} s")
            self._cond.notify_all()

    def read(self) -> Optional[StereoFrame]:
        """The newest time-matched pair not returned before (waits up to ``read_timeout_s``)."""
        with self._cond:
            interrupts = self._interrupts
            found: list = []

            def ready() -> bool:
                if self._interrupts != interrupts or not self._running.is_set():
                    return True
                if not self.is_connected:
                    return False
                lb, rb = self._buffers
                pick = pick_pair([(t, n) for t, n, _ in lb], [(t, n) for t, n, _ in rb], self._last_pair)
                if pick is None:
                    return False
                found[:] = [lb[pick[0]], rb[pick[1]]]
                return True

            if not self._cond.wait_for(ready, timeout=self.read_timeout_s) or not found:
                return None
            (tl, nl, left), (tr, nr, right) = found
            self._last_pair = (nl, nr)
            skew = abs(tl - tr)
            self._skews.append(skew)
        return StereoFrame(seq=self._seq.next(), t=min(tl, tr), left=left, right=right, skew_s=skew)

    def skew_stats(self) -> tuple[float, float]:
        """(median, max) time skew between paired left/right frames over recent pairs (s)."""
        with self._cond:
            s = list(self._skews)
        return (float(np.median(s)), float(max(s))) if s else (0.0, 0.0)

    # controls --------------------------------------------------------------------------------
    def _side_grabbers(self, side: str) -> list[tuple[int, _Grabber]]:
        check_side(side)
        if not self._grabbers:
            raise CameraError(f"{self.name} is not connected")
        if self.side_by_side:
            return [(0, self._grabbers[0])]
        idx = {"left": [0], "right": [1], "both": [0, 1]}[side]
        return [(i, self._grabbers[i]) for i in idx]

    def _read_control(self, g: _Grabber, spec: _ControlSpec) -> Optional[CameraControl]:
        with g.lock:
            cap = g.cap
            if cap is None:
                return None
            value = float(cap.get(spec.prop))
            auto_value = float(cap.get(spec.auto_prop)) if spec.auto_prop is not None else None
        rng = g.ranges.get(spec.cid)
        known = rng is not None
        if rng is None:
            if g.ranges:  # the device answered and does not have this control
                return None
            if value == -1.0 or not math.isfinite(value):  # OpenCV's "not supported"
                return None
            rng = spec.typical
        lo, hi, step, default = rng
        auto = None
        if spec.auto_prop is not None and (spec.auto_cid in g.ranges or not g.ranges):
            auto = auto_value is not None and auto_value != -1.0 and abs(auto_value - spec.auto_off) > 1e-6
        return CameraControl(spec.name, spec.label, lo, hi, step, default, value, auto, known)

    def controls(self, side: str = "left") -> list[CameraControl]:
        check_side(side, ("left", "right"))
        (_, g), = self._side_grabbers(side)
        out = []
        for spec in self._specs.values():
            c = self._read_control(g, spec)
            if c is not None:
                out.append(c)
        return out

    def _control(self, g: _Grabber, name: str) -> CameraControl:
        if name not in self._specs:
            raise KeyError(f"unknown camera control {name!r}; valid: {', '.join(CONTROL_NAMES)}")
        c = self._read_control(g, self._specs[name])
        if c is None:
            raise KeyError(f"camera {g.device} has no control {name!r}")
        return c

    def set_control(self, name: str, value: float, side: str = "both") -> CameraControl:
        applied = []
        for i, g in self._side_grabbers(side):
            c = self._control(g, name)
            spec = self._specs[name]
            v = c.clamp(value)
            with g.lock:
                if g.cap is not None:
                    if c.auto:
                        g.cap.set(spec.auto_prop, spec.auto_off)
                    g.cap.set(spec.prop, v)
            self._desired[(i, name)] = ("value", v)
            if c.auto:
                self._desired[(i, name + ":auto")] = ("auto", 0.0)
            now = self._control(g, name)
            # some drivers read back stale values for a frame: report what we set when they do
            applied.append(now if abs(now.value - v) <= max(now.step, 1e-6) else replace(now, value=v))
        return applied[0]

    def set_auto(self, name: str, on: bool, side: str = "both") -> CameraControl:
        applied = []
        for i, g in self._side_grabbers(side):
            c = self._control(g, name)
            spec = self._specs[name]
            if c.auto is None:
                raise KeyError(f"camera {g.device}: {name} has no automatic mode")
            with g.lock:
                if g.cap is not None:
                    g.cap.set(spec.auto_prop, spec.auto_on if on else spec.auto_off)
            self._desired[(i, name + ":auto")] = ("auto", 1.0 if on else 0.0)
            applied.append(replace(self._control(g, name), auto=bool(on)))
        return applied[0]

    def _reapply_controls(self, g: _Grabber) -> None:
        """After a replug the device starts from its defaults: set what the user chose again."""
        if not self._grabbers:
            return
        i = self._grabbers.index(g) if g in self._grabbers else -1
        with g.lock:
            if g.cap is None:
                return
            for (gi, key), (kind, value) in sorted(self._desired.items(), key=lambda kv: kv[1][0] != "auto"):
                if gi != i:
                    continue
                spec = self._specs[key.split(":")[0]]
                if kind == "auto":
                    g.cap.set(spec.auto_prop, spec.auto_on if value else spec.auto_off)
                else:
                    g.cap.set(spec.prop, value)


# ----------------------------------------------------------------------------------------------
# folders of saved pairs

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".ppm", ".pgm", ".webp")
_SIDE_WORDS = re.compile(r"(left|right)", re.IGNORECASE)


def _side_key(path: Path) -> str:
    return _SIDE_WORDS.sub("", path.name.lower(), count=1)


def _number_key(path: Path) -> Optional[int]:
    nums = re.findall(r"\d+", path.stem)
    return int(nums[-1]) if nums else None


def pair_image_files(lefts: Sequence[Path], rights: Sequence[Path]) -> tuple[list[tuple[Path, Path]], list[Path], list[Path]]:
    """Match left and right image files: by name without the word left/right, else by the last
    number in the name, else (equal counts) by sorted order. Returns (pairs, unmatched_left,
    unmatched_right), pairs sorted by name."""
    lefts, rights = sorted(map(Path, lefts)), sorted(map(Path, rights))
    for key in (lambda p: p.name.lower() if p.parent.name.lower() in ("left", "right") else _side_key(p), _number_key):
        kl = {key(p): p for p in lefts}
        kr = {key(p): p for p in rights}
        if None in kl or None in kr or len(kl) != len(lefts) or len(kr) != len(rights):
            continue
        common = sorted(set(kl) & set(kr), key=lambda k: (str(type(k)), k))
        if common:
            pairs = [(kl[k], kr[k]) for k in common]
            return pairs, [kl[k] for k in sorted(set(kl) - set(kr), key=str)], [kr[k] for k in sorted(set(kr) - set(kl), key=str)]
    if len(lefts) == len(rights):
        return list(zip(lefts, rights)), [], []
    return [], list(lefts), list(rights)


def _images_in(folder: Path, prefix: str = "") -> list[Path]:
    return sorted(p for p in folder.iterdir()
                  if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES and p.name.lower().startswith(prefix))


def find_image_pairs(folder) -> list[tuple[Path, Path]]:
    """Image pairs in ``folder``: ``left*/right*`` files, or ``left/`` and ``right/`` subfolders."""
    folder = Path(folder)
    if not folder.is_dir():
        return []
    if (folder / "left").is_dir() and (folder / "right").is_dir():
        pairs, _, _ = pair_image_files(_images_in(folder / "left"), _images_in(folder / "right"))
        return pairs
    pairs, _, _ = pair_image_files(_images_in(folder, "left"), _images_in(folder, "right"))
    return pairs


class FolderStereoCamera(ClockPacedSource):
    """Saved image pairs played back as a camera, at ``fps``, looping or stopping at the end."""

    kind = "folder"

    def __init__(self, path, fps: float = 30.0, loop: bool = True, clock=None):
        super().__init__(clock)
        if not (0.1 <= fps <= 240.0):
            raise ValueError(f"camera fps = {fps} is outside 0.1…240")
        self.path = Path(path)
        self.fps = float(fps)
        self.loop = loop
        self.pairs: list[tuple[Path, Path]] = []
        self.index = 0  # the next pair to show
        self._seq = SequenceCounter()
        self._next = 0.0

    @property
    def name(self) -> str:
        return f"image pairs in {self.path}"

    @property
    def pair_id(self) -> str:
        return f"folder:{self.path.resolve()}"

    def connect(self) -> None:
        if not self.path.is_dir():
            raise CameraError(f"{self.path}: no such folder of image pairs")
        self.pairs = find_image_pairs(self.path)
        if not self.pairs:
            raise CameraError(
                f"{self.path}: no image pairs found — expected left_*.png and right_*.png files "
                f"(any image type) or left/ and right/ subfolders with matching names")
        self.index = 0
        self._connected = True
        self.status_message = ""
        self._next = self.clock.now()


    def read(self) -> Optional[StereoFrame]:
        import cv2

        if not self._connected or not self.clock.wait_until(self._next) or not self._connected:
            return None
        t = self.clock.now()
        self._next = max(self._next + 1.0 / self.fps, t)
        for _ in range(len(self.pairs)):
            if self.index >= len(self.pairs):
                if not self.loop:
                    self._connected = False
                    self.status_message = f"{self.path}: end of the {len(self.pairs)} image pairs"
                    return None
                self.index = 0
            lp, rp = self.pairs[self.index]
            self.index += 1
            left, right = cv2.imread(str(lp)), cv2.imread(str(rp))
            if left is not None and right is not None:
                return StereoFrame(seq=self._seq.next(), t=t, left=left, right=right)
            self.status_message = f"cannot read {lp.name} / {rp.name} — skipped"
        self._connected = False
        self.status_message = f"{self.path}: none of the image pairs can be read"
        return None


# ----------------------------------------------------------------------------------------------
# choosing a source


CAMERA_CHOICES = (
    "auto (webcams 0,1, else the simulated desk) | sim | IDX,IDX (two webcam indices, e.g. 0,2) | "
    "/dev/videoN,/dev/videoM or /dev/v4l/by-id/...,... | sbs:DEV (one side-by-side stereo camera) | "
    "folder:PATH or a folder PATH (saved left_*/right_* image pairs) | replay:PATH (a deskarm recording); "
    "webcams take @WxH, @FPS and @FOURCC, e.g. 0,2@640x480@30@MJPG"
)


@dataclass(frozen=True)
class CameraSpec:
    """A parsed --camera value."""

    kind: str  # auto | sim | webcam | sbs | folder | replay
    devices: tuple = ()  # webcam: (left, right); sbs: (device,)
    path: Optional[str] = None  # folder, replay
    size: Optional[tuple[int, int]] = None  # @WxH (per eye)
    fps: Optional[float] = None  # @FPS
    fourcc: Optional[str] = None  # @FOURCC


def _device(text: str):
    text = text.strip()
    if text.isdigit():
        return int(text)
    if text.startswith("/dev/"):
        return text
    return None


def camera_spec(spec: str) -> CameraSpec:
    """Parse a --camera value; ValueError names the value and the valid forms."""
    raw = (spec or "auto").strip()
    bad = ValueError(f"unknown --camera value {raw!r}; valid: {CAMERA_CHOICES}")
    if raw in ("sim", "sim://"):
        return CameraSpec("sim")
    if raw == "auto":
        return CameraSpec("auto", (0, 1))
    if raw.startswith("folder:"):
        path = raw[len("folder:"):]
        if not path:
            raise bad
        return CameraSpec("folder", path=path)
    if raw.startswith("replay:"):
        path = raw[len("replay:"):]
        if not path:
            raise ValueError(f"--camera {raw!r}: name the recording, e.g. replay:recordings/2026-11-05_1412")
        return CameraSpec("replay", path=path)
    if "," not in raw and not raw.startswith("sbs:") and os.path.isdir(raw) and not raw.startswith("/dev/"):
        return CameraSpec("folder", path=raw)
    head, *options = raw.split("@")
    size = fps = fourcc = None
    for opt in options:
        m = re.fullmatch(r"(\d+)x(\d+)", opt.lower())
        if m:
            size = (int(m.group(1)), int(m.group(2)))
        elif re.fullmatch(r"\d+(\.\d+)?", opt):
            fps = float(opt)
        elif re.fullmatch(r"[A-Za-z][A-Za-z0-9]{3}", opt):  # MJPG, YUYV, H264, …
            fourcc = opt.upper()
        else:
            raise bad
    if head.startswith("sbs:"):
        dev = _device(head[4:])
        if dev is None:
            raise bad
        return CameraSpec("sbs", (dev,), size=size, fps=fps, fourcc=fourcc)
    parts = head.split(",")
    if len(parts) == 2 and all(p.strip() for p in parts):
        devs = tuple(_device(p) for p in parts)
        if all(d is not None for d in devs):
            return CameraSpec("webcam", devs, size=size, fps=fps, fourcc=fourcc)
    raise bad


def parse_camera_spec(spec: str) -> tuple[str, tuple]:
    """('sim', ()), ('auto', (0, 1)), ('webcam', (left, right)), ('sbs', (device,)),
    ('folder', (path,)) or ('replay', (path,)); ValueError names the spec and the valid forms."""
    s = camera_spec(spec)
    return s.kind, ((s.path,) if s.kind in ("folder", "replay") else s.devices)


SIMULATED_CAMERA = "core.sim.camera:SimStereoCamera"  # by name: vision/ never imports sim/
REPLAY_CAMERA = "core.record.replay:ReplayStereoCamera"  # by name: vision/ never imports record/


def _named_class(name: str):
    module_name, class_name = name.split(":")
    return getattr(importlib.import_module(module_name), class_name)


def simulated_camera(**options) -> CameraSource:
    """The simulated desk's stereo camera (``core.sim``), imported by name only when asked for."""
    return _named_class(SIMULATED_CAMERA)(**options)


def replay_camera(path, **options) -> CameraSource:
    """A recording played back as a camera (``core.record``), imported by name only when asked for."""
    return _named_class(REPLAY_CAMERA)(path, **options)


def open_camera(spec: str, scenario: str = "static", clock=None, fps: float = 30.0,
                fallback_to_sim: bool = True, capture_factory: Callable | None = None) -> tuple[CameraSource, str]:
    """Open the camera(s) named by ``spec``; returns (source, banner).

    ``auto`` with no webcam gives the simulated desk when ``fallback_to_sim`` (nothing plugged
    in, a simulated arm). A webcam the user named, or any webcam when ``fallback_to_sim`` is off
    (a real arm attached), that does not open gives that source, not connected and retrying,
    with a banner saying so: a missing camera is a visible state, never a crash and never a
    simulated scene behind a real arm. A folder or a recording that cannot be read raises
    CameraError. A recording (``replay:PATH``) plays at its recorded rate on ``clock``.
    """
    s = camera_spec(spec)
    if s.kind == "replay":
        cam = replay_camera(s.path, clock=clock)
        cam.connect()  # CameraError naming the recording and what is wrong with it
        return cam, f"REPLAY — {s.path}"
    if s.kind == "sim":
        cam = simulated_camera(scenario=scenario, fps=fps, clock=clock)
        cam.connect()
        return cam, "SIMULATED DESK"
    if s.kind == "folder":
        cam = FolderStereoCamera(s.path, fps=fps, clock=clock)
    else:
        width, height = s.size or (640, 480)
        kwargs = dict(width=width, height=height, fps=s.fps or fps, capture_factory=capture_factory,
                      fourcc=s.fourcc or "MJPG")
        if s.kind == "sbs":
            cam = WebcamStereoCamera(s.devices[0], None, side_by_side=True, **kwargs)
        else:
            cam = WebcamStereoCamera(*s.devices, **kwargs)
    try:
        cam.connect()
        return cam, ""
    except CameraError as exc:
        if s.kind == "auto" and fallback_to_sim:  # nothing plugged in: the simulated desk
            sim = simulated_camera(scenario=scenario, fps=fps, clock=clock)
            sim.connect()
            return sim, "SIMULATED DESK — no camera found"
        if s.kind == "folder":
            raise
        # a camera the user named, or any camera with a real arm attached: never the simulated
        # desk (a real arm would follow a scene that does not exist); no frames, no goal, the
        # arm holds, and the source keeps trying the device
        cam.connect(keep_trying=True)
        return cam, f"CAMERA MISSING — {exc} The arm holds until the camera delivers frames (retrying)."


__all__ = [
    "CameraSource", "ClockPacedSource", "simulated_camera", "replay_camera", "WebcamStereoCamera",
    "FolderStereoCamera", "CameraError",
    "CameraControl", "CONTROL_NAMES", "open_camera", "parse_camera_spec", "camera_spec", "CameraSpec",
    "CAMERA_CHOICES", "SimClock", "pick_pair", "find_image_pairs", "pair_image_files",
    "v4l2_control_ranges", "default_capture_factory", "open_quietly",
]
