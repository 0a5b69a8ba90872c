"""The simulated desk as a stereo camera source: the rig's two views rendered on a clock.

On a wall clock a sensor thread renders each frame *ahead* of its time, so a frame is ready at
its timestamp like a webcam's grabbed frame: the render (6–8 ms a pair here) is not on the
pipeline's critical path and not in its latency. On a simulated clock (``--fast``, tests) frames
are rendered in ``read``. When nothing in the scene moved (scene state, arm, camera settings)
the previous images are delivered again, flagged ``repeated``, and nothing is rendered.

``skew_s`` imitates two webcams that are not triggered together: the right view shows the scene
``skew_s`` later than the left one (the frame's ``t`` is the left view's time, its ``skew_s`` field
says how much later the right view is, as for real webcams where ``t = min(t_left, t_right)``).
With 0 (the default) both views show the same instant, exactly as before.

``realism`` (a ``core.sim.realism`` preset or its name, e.g. "webcam") passes each rendered pair
through ``apply_realism``: blur, rolling shutter, flicker, sensor noise, vignetting, distortion and
JPEG, drawn from (seed, frame time). None (the default) delivers the renders as before.

``show_board`` puts a calibration board in front of the cameras (while the calibration wizard is
open): painted over the desk, held still at each of BOARD_POSES varied poses for BOARD_HOLD_S of
the camera's clock, then moved to the next, so the wizard can capture it like a real one.
"""
from __future__ import annotations

import atexit
import collections
import itertools
import threading
import time
import weakref
from dataclasses import dataclass, replace
from typing import Optional

import numpy as np

from core.messages import SequenceCounter, StereoFrame
from core.settings import CameraSettings, replace_field
from core.sim.board_render import board_overlay, held_board_poses, paint_overlay, sim_rig_truth
from core.sim.desk import SimDesk
from core.sim.realism import apply_realism, preset_named
from core.sim.rig import SimRig
from core.vision.calibration import StereoCalibration
from core.vision.cameras import CameraControl, ClockPacedSource, check_side
from core.vision.stereo_calibration import BoardSpec

RENDER_MARGIN_S = 0.003  # a render starts this much earlier than the slowest recent render needs
READS_KEPT = 9  # the reader's cycle is the median gap of its last this many reads (SimStereoCamera._skips)
SKIP_SLACK = 0.5  # of a frame period: a frame is skipped only if the reader is due this much after the next
BOARD_POSES = 20  # poses a shown calibration board goes through (then round again)
BOARD_HOLD_S = 1.5  # each pose is held still this long (camera clock): the wizard's gate needs still frames
BOARD_SEED = 11  # seed of the shown board's poses (held_board_poses): the same poses every time
MAX_SKEW_S = 0.5  # the right view may lag the left one by 0…this (s)

_SIM_CONTROLS = (  # name, label, min, max, step (CameraSettings fields)
    ("exposure", "Exposure (EV)", -4.0, 4.0, 0.1),
    ("gain", "Gain (dB)", 0.0, 24.0, 0.5),
    ("brightness", "Brightness", -100.0, 100.0, 1.0),
    ("contrast", "Contrast", 0.2, 3.0, 0.05),
)


@dataclass(frozen=True, eq=False)
class _ShownBoard:
    """A board shown by ``show_board``: what, where, since when."""

    serial: int  # a new one per show_board call (part of the scene key)
    board: BoardSpec
    poses: tuple  # BoardPose in camera_left
    t0: float  # camera clock time of the first pose
    hold_s: float

    def index_at(self, t: float) -> int:
        """The pose shown at camera time ``t``."""
        return int(max(0.0, t - self.t0) // self.hold_s) % len(self.poses)


class SimStereoCamera(ClockPacedSource):
    """The simulated desk seen by the simulated rig, at ``fps`` on the given clock.

    ``set_arm_points`` tells the renderer where the arm is (chain points in robot_base), so the
    arm appears in both views as it moves. ``show_board`` shows a calibration board held at a
    sequence of poses (see the module docstring).
    """

    kind = "sim"

    def __init__(self, scenario="static", fps: float = 30.0, clock=None, seed: int = 0,
                 marker_ids=(23, 50), rig=None, skew_s: float = 0.0, realism=None, **desk_options):
        super().__init__(clock)
        self.realism = preset_named(realism)  # RealismPreset or None: what a webcam adds to each render
        if not (1.0 <= fps <= 240.0):
            raise ValueError(f"camera fps = {fps} is outside 1…240")
        self._skew_s = _check_skew(skew_s)
        self.rig = rig or SimRig()
        self.desk = SimDesk(self.rig, scenario=scenario, marker_ids=marker_ids, seed=seed, **desk_options)
        self.scenario = self.desk.scenario  # the name (also when a Scenario instance was given)
        self.fps = float(fps)
        self._seq = SequenceCounter()
        self._t0 = 0.0
        self._next = 0.0
        self._arm_points: Optional[np.ndarray] = None
        self._lock = threading.Lock()
        self.repeat_unchanged = True  # re-deliver the last images when nothing in the scene moved
        self._last_key = None  # what the last render depended on (scene, arm, camera settings, board)
        self._last_render = None  # (left, right, truth) of that render
        self._desk_key = None  # what the last desk render (without the board) depended on
        self._desk_render = None  # (left, right, truth) of the desk alone
        self._board: Optional[_ShownBoard] = None  # guarded by _lock (show_board runs in the GUI thread)
        self._board_serial = itertools.count(1)
        self._overlays: Optional[tuple] = None  # ((serial, pose index), (left, right) BoardOverlay)
        self.frames_rendered = 0
        self.frames_repeated = 0
        self.render_ahead = True  # wall clock: a sensor thread renders each frame before its time
        self._render_s: collections.deque = collections.deque(maxlen=60)  # recent render durations
        self._sensor: Optional[threading.Thread] = None
        self._ready = threading.Condition()
        self._published: Optional[StereoFrame] = None  # the newest frame of the sensor thread
        self._returned_seq = 0
        self._interrupted = False
        self._read_at: collections.deque = collections.deque(maxlen=READS_KEPT)  # monotonic times of reads
        self._waiting = 0  # reads waiting for a frame (guarded by _ready)
        self.frames_skipped = 0  # frames of the wall clock's grid not rendered: nobody would have read them
        self.frames_unread = 0  # frames rendered and published, then replaced by a newer one before a read

    @property
    def name(self) -> str:
        return f"simulated desk ({self.scenario})"

    @property
    def skew_s(self) -> float:
        """How much later (s) the right view shows the scene than the left one (0: together)."""
        return self._skew_s

    @skew_s.setter
    def skew_s(self, value: float) -> None:
        """Any thread; from the next frame on. ValueError outside 0…MAX_SKEW_S."""
        self._skew_s = _check_skew(value)

    @property
    def pair_id(self) -> str:
        return "sim"

    def set_settings(self, settings: CameraSettings) -> None:
        super().set_settings(settings)
        self.desk.set_camera_settings(settings)

    def controls(self, side: str = "left") -> list[CameraControl]:
        check_side(side, ("left", "right"))
        default = CameraSettings()
        return [CameraControl(name, label, lo, hi, step, float(getattr(default, name)),
                              float(getattr(self.settings, name)))
                for name, label, lo, hi, step in _SIM_CONTROLS]

    def set_control(self, name: str, value: float, side: str = "both") -> CameraControl:
        check_side(side)
        by_name = {c.name: c for c in self.controls()}
        if name not in by_name:
            raise KeyError(f"{self.name} has no control {name!r}; available: {', '.join(by_name)}")
        applied = by_name[name].clamp(value)
        self.set_settings(replace_field(self.settings, **{name: applied}))
        return replace(by_name[name], value=applied)

    def set_arm_points(self, points: Optional[np.ndarray]) -> None:
        with self._lock:
            self._arm_points = None if points is None else np.array(points, dtype=float)

    def show_board(self, board: Optional[BoardSpec]) -> None:
        """Hold ``board`` in front of the cameras (None takes it away); any thread.

        From the next frame on the board is painted over the desk, still for BOARD_HOLD_S at each
        of BOARD_POSES poses (a fixed sequence, all of the paper in both views), then again from
        the first. Without a board the frames are exactly those of a camera that never showed one.
        RuntimeError if the board is too large to be held in view of this rig.
        """
        shown = None
        if board is not None:
            poses = held_board_poses(board, sim_rig_truth(self.rig), BOARD_POSES, seed=BOARD_SEED)
            shown = _ShownBoard(next(self._board_serial), board, tuple(poses), self.clock.now(), BOARD_HOLD_S)
        with self._lock:
            self._board = shown

    @property
    def shown_board(self) -> Optional[BoardSpec]:
        """The board ``show_board`` put in front of the cameras, or None."""
        with self._lock:
            return None if self._board is None else self._board.board

    def board_pose_index(self, t: float) -> Optional[int]:
        """Which of the shown board's poses a frame at camera time ``t`` shows (None: no board)."""
        with self._lock:
            shown = self._board
        return None if shown is None else shown.index_at(t)

    def connect(self) -> None:
        self.disconnect()  # a second connect restarts the sensor thread
        self._connected = True
        self._t0 = self.clock.now()
        self._next = self._t0
        self._last_key = self._last_render = None
        self._desk_key = self._desk_render = None
        self._read_at.clear()
        if not self.clock.simulated and self.render_ahead:
            self._sensor = threading.Thread(target=self._sensor_loop, name="sim-camera", daemon=True)
            self._sensor.start()
            _SENSING.add(self)

    def disconnect(self) -> None:
        super().disconnect()
        with self._ready:
            self._ready.notify_all()
        sensor, self._sensor = self._sensor, None
        if sensor is not None and sensor is not threading.current_thread():
            sensor.join(timeout=5.0)
        _SENSING.discard(self)

    def interrupt(self) -> None:
        super().interrupt()
        with self._ready:
            self._interrupted = True
            self._ready.notify_all()

    def _frame_at(self, t: float) -> StereoFrame:
        """The frame of time ``t``: rendered, or the last one again when nothing moved."""
        with self._lock:
            arm = self._arm_points
            shown = self._board
        skew = frame_skew = self._skew_s  # read once: a setter in another thread takes the next frame
        if skew:
            # the right view's instant: when the scene there is the left's (nothing moved in
            # between) the pair is that of an unskewed camera, else the right view is rendered again
            ts = t - self._t0
            moved = self.desk.scene_key(ts, arm) != self.desk.scene_key(ts + skew, arm)
            if not moved:
                skew = 0.0
        desk_key = self.desk.scene_key(t - self._t0, arm) if self.repeat_unchanged else None
        if skew and desk_key is not None:
            desk_key = (desk_key, "right at", self.desk.scene_key(t - self._t0 + skew, arm))
        board_key = None if shown is None else (shown.serial, shown.index_at(t))
        key = desk_key if board_key is None or desk_key is None else (desk_key, board_key)
        if key is not None and key == self._last_key and self._last_render is not None:
            # a still scene: the same images (and their noise) again, flagged so that perception
            # reuses its answer and the views skip the redraw
            left, right, truth = self._last_render
            self.frames_repeated += 1
            return StereoFrame(seq=self._seq.next(), t=t, left=left, right=right, truth=truth, repeated=True,
                               skew_s=frame_skew)
        w0 = time.perf_counter()
        if desk_key is not None and desk_key == self._desk_key and self._desk_render is not None:
            # only the board moved (or went away): the desk's own images, as a camera without a
            # board would deliver them
            left, right, truth = self._desk_render
        else:
            left, right, truth = self.desk.render(t - self._t0, arm)
            if skew:  # the right view of the scene skew later (truth stays the left view's instant)
                right = self.desk.render(t - self._t0 + skew, arm)[1]
            if self.realism is not None:  # a webcam's blur, shutter, flicker, noise and JPEG, per frame
                rng = np.random.default_rng([self.desk.seed & 0x7FFFFFFF, int(round((t - self._t0) * 1e6)) & 0x7FFFFFFF])
                left, right = apply_realism((left, right), rng, t - self._t0, self.realism)
            left.flags.writeable = right.flags.writeable = False  # they may be delivered again
            self._desk_key, self._desk_render = desk_key, (left, right, truth)
            self.frames_rendered += 1
        if shown is not None:
            left, right = self._paint_board(shown, board_key[1], left, right)
        self._render_s.append(time.perf_counter() - w0)
        self._last_key, self._last_render = key, (left, right, truth)
        return StereoFrame(seq=self._seq.next(), t=t, left=left, right=right, truth=truth, skew_s=frame_skew)

    def _paint_board(self, shown: _ShownBoard, k: int, left: np.ndarray, right: np.ndarray):
        """Copies of the desk images with the shown board at pose ``k`` painted over them."""
        cached = self._overlays
        if cached is None or cached[0] != (shown.serial, k):
            truth = sim_rig_truth(self.rig)
            # fixed noise per pose: a still board gives still pixels (the gate's "held still")
            overlays = tuple(board_overlay(shown.board, truth, side, shown.poses[k],
                                           blur_sigma_px=self.desk.blur_sigma_px,
                                           noise_sigma=self.desk.noise_sigma, seed=shown.serial * 1000 + k)
                             for side in ("left", "right"))
            cached = self._overlays = ((shown.serial, k), overlays)
        out = (paint_overlay(left.copy(), cached[1][0]), paint_overlay(right.copy(), cached[1][1]))
        for image in out:
            image.flags.writeable = False
        return out

    def render_lead_s(self) -> float:
        """How long before a frame's time its render starts: the slowest of the last 60 renders
        plus a margin, at most 80 % of a frame period."""
        slow = max(self._render_s) if self._render_s else 0.010
        return min(slow + RENDER_MARGIN_S, 0.8 / self.fps)

    def _sensor_loop(self) -> None:
        """Render each frame ahead, publish it at its time (wall clock only)."""
        period = 1.0 / self.fps
        t_frame = self._t0
        while self._connected:
            now = time.monotonic()
            if t_frame < now - period:  # after a stall skip ahead instead of bursting
                t_frame = now
            start = t_frame - self.render_lead_s()
            if start > now and self._stop_wait(start - now):
                return
            if self._skips(t_frame, period):
                self.frames_skipped += 1
                t_frame += period
                continue
            frame = self._frame_at(t_frame)
            now = time.monotonic()
            if t_frame > now and self._stop_wait(t_frame - now):
                return
            with self._ready:
                old = self._published
                if old is not None and old.seq > self._returned_seq:
                    self.frames_unread += 1  # replaced before anyone read it: its render was wasted
                self._published = frame
                self._next = t_frame + period
                self._ready.notify_all()
            t_frame += period

    def _skips(self, t_frame: float, period: float) -> bool:
        """True when the frame of ``t_frame`` would never be read: no read is waiting, and the
        reader (busy with an earlier frame) is due only after the next frame is out.

        A webcam's frames that a slow loop never takes cost it nothing but their decoding; this
        camera's are rendered, and a loop held to a Pi's CPU read one frame in five while the
        renders of the other four took the CPU it needed (the rendered scene stays the same: the
        frames a reader gets are those it would have got). A reader that comes earlier than its
        recent pace waits for the next frame (at most one period).

        Nor is a frame rendered while the previous one, published a period ago, is still unread:
        the busy reader takes that one when it comes, and a newer one would replace it unseen (in
        a Pi 4 core's budget a fifth of the renders were so wasted: the pace of a starved reader
        jitters too much to predict). An unread frame older than that (a reader that paused) does
        not hold the next render back: a returning reader gets a frame at most two periods old."""
        with self._ready:
            if self._waiting:
                return False
            last = self._published
            if last is not None and last.seq > self._returned_seq and last.t >= t_frame - 1.5 * period:
                return True
            if len(self._read_at) < 3:
                return False
            reads = list(self._read_at)
        cycle = float(np.median(np.diff(reads)))
        return reads[-1] + cycle >= t_frame + period * (1.0 + SKIP_SLACK)

    def _stop_wait(self, seconds: float) -> bool:
        """Sleep ``seconds`` unless disconnected first (then True)."""
        with self._ready:
            self._ready.wait_for(lambda: not self._connected, timeout=seconds)
            return not self._connected

    def read(self) -> Optional[StereoFrame]:
        if not self._connected:
            return None
        if self._sensor is not None:
            with self._ready:
                self._interrupted = False
                self._waiting += 1
                try:
                    self._ready.wait_for(lambda: (not self._connected or self._interrupted or (
                        self._published is not None and self._published.seq > self._returned_seq)), timeout=1.0)
                finally:
                    self._waiting -= 1
                frame = self._published
                if not self._connected or frame is None or frame.seq <= self._returned_seq:
                    return None
                self._returned_seq = frame.seq
                self._read_at.append(time.monotonic())
                return frame
        if not self.clock.wait_until(self._next) or not self._connected:
            return None
        t = self.clock.now()
        # keep the frame grid; after a stall skip ahead instead of bursting
        self._next = max(self._next + 1.0 / self.fps, t)
        return self._frame_at(t)

    def calibration(self) -> StereoCalibration:
        return self.rig.calibration()

    def base_T_camera(self) -> np.ndarray:
        """The rig's NOMINAL mount: what a program knows without a hand-eye calibration."""
        return self.rig.nominal_base_T_camera

    def true_base_T_camera(self) -> np.ndarray:
        """Where camera_left really is (the renders' mount, offset included): the truth to score against."""
        return self.rig.base_T_camera

    @property
    def hand_eye_pair_id(self) -> str:
        """The camera pair a hand-eye file must name: a rig mounted elsewhere is another pair."""
        off = self.rig.config.mount_offset
        if not any(off):
            return "sim"
        return "sim rig-offset " + ",".join(f"{v:.6g}" for v in (*off[:3], *np.degrees(off[3:])))

    def set_rig_offset(self, offset) -> None:
        """Mount the rig ``offset`` (dx, dy, dz m, roll, pitch, yaw rad) off its nominal pose; the
        desk is rebuilt for the moved cameras (its scenario, seed and settings are kept)."""
        from dataclasses import replace as _replace

        from core.sim.rig import check_rig_offset

        rig = SimRig(_replace(self.rig.config, mount_offset=check_rig_offset(offset)))
        old = self.desk
        desk = SimDesk(rig, scenario=old.scenario_object, marker_ids=old.marker_ids, marker_size_m=old.marker_size_m,
                       seed=old.seed, blur_sigma_px=old.blur_sigma_px, noise_sigma=old.noise_sigma)
        desk.set_camera_settings(old.settings)
        if old.tool_marker is not None:
            desk.set_tool_marker(_ToolPlate(*old.tool_marker))
        with self._lock:
            self.rig, self.desk = rig, desk
            self._last_key = self._last_render = None
            self._desk_key = self._desk_render = None
            self._overlays = None

    def set_tool_marker(self, marker) -> None:
        """Put a marker plate on the simulated arm's tool (see ``SimDesk.set_tool_marker``)."""
        with self._lock:
            self.desk.set_tool_marker(marker)
            self._last_key = self._last_render = None


def _check_skew(value) -> float:
    skew = float(value)
    if not (0.0 <= skew <= MAX_SKEW_S):  # also NaN
        raise ValueError(f"skew_s = {value} is outside 0…{MAX_SKEW_S} s (the right view lags the left)")
    return skew


@dataclass(frozen=True)
class _ToolPlate:
    marker_id: int
    offset_m: tuple
    size_m: float


# Cameras whose sensor thread runs. A daemon thread still inside OpenCV while the interpreter
# shuts down aborts the process ("terminate called without an active exception", exit 134):
# a program (or a test) that forgot to disconnect gets its sensors stopped and joined first.
_SENSING: "weakref.WeakSet[SimStereoCamera]" = weakref.WeakSet()


@atexit.register
def _stop_sensors_at_exit() -> None:
    for camera in list(_SENSING):
        camera.disconnect()
