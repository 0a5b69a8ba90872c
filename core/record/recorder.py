"""Record a running desk into a rosbag2 folder (MCAP) from its own thread, never blocking the loop.

The loop (headless runner, window workers) calls ``frame``, ``result``, ``command``, ``state``,
``estop`` and ``calibration``: each is a put on a bounded queue and returns at once. The
recorder's thread encodes the JPEGs, converts (``core.record.topics``) and writes
(``core.record.writer``). A still scene costs little: an image pair equal to the last one
encoded within sensor noise (``blocks_changed``) is not encoded again but written with that
pair's JPEG bytes, which the MCAP chunk's zstd compression stores about once per chunk
(``frames_still`` counts them; every frame keeps its image messages, the replay repeats the
arrays without decoding). When the loop outruns the disk, the oldest queued image pair is
dropped (``frames_dropped``); when the disk fails (full, unplugged), recording stops with
``error`` naming the path and the loop goes on.

Recordings live in ``user_dir("data")/recordings`` as ``deskarm-YYYYmmdd-HHMMSS`` folders
(``default_recording_path``); ``list_recordings`` lists them for the user.
"""
from __future__ import annotations

import os
import tempfile
import threading
import time
from collections import deque
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import Callable, Optional, Sequence

import cv2
import numpy as np

from core.paths import os_error_reason, user_dir
from core.record import topics as tp
from core.record.writer import STATE_COMPLETE, BagWriter

STILL_SCALE = 4  # a still check compares images averaged over STILL_SCALE x STILL_SCALE pixel blocks…
STILL_LEVELS = 6  # …and finds no block changed by more than this (0…255): sensor noise averages out, a moving edge does not
SMALL_QUEUE_FACTOR = 32  # queued non-image messages allowed per queued image pair before the oldest go
COST_SAMPLES = 4096  # per-frame recorder costs kept (ms), for the bench
_STOP = object()


def recordings_dir() -> Path:
    """The folder recordings go to by default: ``user_dir("data")/recordings``."""
    return user_dir("data") / "recordings"


def default_recording_path(now: Optional[datetime] = None, folder: Optional[Path] = None) -> Path:
    """``recordings/deskarm-YYYYmmdd-HHMMSS`` (``-2``, ``-3``… when that second is taken)."""
    folder = Path(folder) if folder is not None else recordings_dir()
    stem = f"deskarm-{(now or datetime.now()):%Y%m%d-%H%M%S}"
    path, n = folder / stem, 1
    while path.exists():
        n += 1
        path = folder / f"{stem}-{n}"
    return path


def calibration_yaml(calib) -> str:
    """A StereoCalibration as the YAML text ``save_calibration`` writes (what the replay reloads)."""
    from core.vision.calibration import save_calibration

    with tempfile.TemporaryDirectory(prefix="deskarm-calib-") as tmp:
        path = save_calibration(Path(tmp) / "calibration.yaml", calib)
        return path.read_text("utf-8")


def deskarm_version() -> str:
    try:
        from importlib.metadata import version

        return version("deskarm")
    except Exception:  # not installed (run from a checkout): the version is simply unknown
        return "unknown"


def session_info(session) -> dict:
    """The /deskarm/session JSON object of a DeskSession (duck-typed: core.record never imports
    the session builder, which names the simulated desk)."""
    opts = session.options
    base_T_camera = np.asarray(session.perception.base_T_camera, dtype=float)
    return {
        "deskarm_version": deskarm_version(),
        "robot": session.profile.name,
        "camera": session.camera.name,
        "pair_id": str(getattr(session.camera, "pair_id", "")),
        "calibration_yaml": calibration_yaml(session.calibration),
        "base_T_camera": base_T_camera.tolist(),
        "scenario": opts.scenario,
        "fps": float(opts.fps),
    }


def fk_of(kinematics) -> Callable[[Sequence[float]], np.ndarray]:
    """base_T_tool (4x4) of joint values when the kinematics gives a pose, else base_p_tool (3,)."""
    return getattr(kinematics, "fk_pose", None) or kinematics.fk


@dataclass(frozen=True)
class RecordingInfo:
    """One recording on disk, for the user's list."""

    path: Path  # the rosbag2 folder
    started: Optional[datetime]  # local wall time the recording started (None: unknown)
    duration_s: float  # recorded span (s); for an unfinished one, up to its last file write
    size_bytes: int  # the folder's files together
    robot: str  # robot profile name ("" when unknown)
    complete: bool = True  # False: the recorder was killed; readable up to its last chunk


class Recorder:
    """Records a desk session into ``path`` (a new rosbag2 folder) from its own thread.

    Every public method but ``start``/``close`` is a non-blocking queue put. ``clock`` stamps
    messages that carry no time of their own (estop, calibration, session); ``joint_names``
    names the joints; ``fk`` gives the tool pose for /tf (none: no /tf). ``still=False`` records
    as before still pairs were re-used: every changed pair encoded, chunks uncompressed (the
    bench's baseline).
    """

    def __init__(self, path, session_info: dict, jpeg_quality: int = 85, queue_size: int = 64, *,
                 clock=None, joint_names: Sequence[str] = (), fk: Optional[Callable] = None,
                 still: bool = True) -> None:
        if not 1 <= int(jpeg_quality) <= 100:
            raise ValueError(f"jpeg_quality = {jpeg_quality}: expected 1…100")
        if int(queue_size) < 1:
            raise ValueError(f"queue_size = {queue_size}: expected ≥ 1")
        missing = [k for k in tp.SESSION_KEYS if k not in session_info]
        if missing:
            raise ValueError(f"session_info lacks {', '.join(missing)}")
        self.path = Path(path) if path else default_recording_path()
        if self.path.exists():
            raise ValueError(f"{self.path}: already exists — a recording needs a new folder")
        self.session_info = dict(session_info)
        self.jpeg_quality = int(jpeg_quality)
        self.queue_size = int(queue_size)
        self._clock = clock
        self._now = clock.now if clock is not None else time.monotonic
        self._epoch = 0.0  # clock s -> stamp s (ROS time for a live clock), fixed by start()
        self.joint_names = tuple(joint_names)
        self.fk = fk
        self._bag: Optional[BagWriter] = None
        self._items: deque = deque()
        self._cond = threading.Condition()
        self._frames_queued = 0
        self._thread: Optional[threading.Thread] = None
        self._closed = False
        self._error = ""
        self._t_start: Optional[float] = None
        self._t_end: Optional[float] = None
        self._last_estop: Optional[bool] = None
        self._last_goal_seq: Optional[int] = None
        self._last_state_seq: Optional[int] = None
        self._jpeg_cache = (None, None, b"", b"")  # (left array, right array, jpeg left, jpeg right)
        self.still = bool(still)  # False: encode every pair that is not the very same arrays, chunks uncompressed
        self._encoded_blocks = None  # (left, right) ``_blocks`` of the pair the JPEG cache holds
        self.frames_written = 0
        self.frames_still = 0  # of those, pairs equal to the last encoded within noise: its JPEGs reused
        self.frames_dropped = 0  # image pairs dropped because the queue was full
        self.messages_dropped = 0  # other messages dropped (a queue full of them)
        self.frame_costs_ms: deque = deque(maxlen=COST_SAMPLES)  # JPEG + write per frame, in the thread

    @classmethod
    def for_session(cls, session, path=None, **kwargs) -> "Recorder":
        """A recorder of a DeskSession (its clock, joint names, forward kinematics)."""
        return cls(path, session_info(session), clock=session.clock, joint_names=session.profile.joint_names,
                   fk=fk_of(session.kinematics), **kwargs)

    # -- properties ------------------------------------------------------------------------

    @property
    def error(self) -> str:
        """Why recording stopped ("" while it works): names the path, the reason and the fix."""
        return self._error

    @property
    def bytes_written(self) -> int:
        return self._bag.bytes_written if self._bag is not None else 0

    @property
    def file_bytes(self) -> int:
        """What the recording takes on disk now (its chunks are compressed: less than ``bytes_written``)."""
        return self._bag.file_bytes if self._bag is not None else 0

    @property
    def elapsed_s(self) -> float:
        """Wall seconds since ``start`` (until ``close``)."""
        if self._t_start is None:
            return 0.0
        return (self._t_end if self._t_end is not None else time.monotonic()) - self._t_start

    @property
    def is_recording(self) -> bool:
        return self._thread is not None and not self._closed and not self._error

    # -- the loop's side (never blocks) ----------------------------------------------------

    def start(self, calibration=None, base_T_camera=None, estopped: bool = False) -> "Recorder":
        """Create the folder (OSError naming it when that fails), start the thread and queue the
        session, camera_info, /tf_static and e-stop messages. ``base_T_camera`` defaults to the
        session info's; ``calibration`` (a StereoCalibration) to the one its YAML holds."""
        if self._thread is not None:
            raise RuntimeError("Recorder.start() called twice")
        self._epoch = tp.ros_epoch(self._clock)
        clock_kind = tp.clock_kind(self._clock)
        clock_text = ("ros: header stamps and log times are wall-clock nanoseconds since the UNIX epoch"
                      if clock_kind == tp.CLOCK_ROS else
                      "simulated: header stamps and log times are the simulated clock's time since the run "
                      "started (a --fast run), not wall-clock time")
        bag = BagWriter(self.path, custom_data={"deskarm_started": datetime.now().isoformat(timespec="seconds"),
                                                "deskarm_robot": str(self.session_info.get("robot", "")),
                                                "deskarm_clock": clock_kind, "deskarm_clock_meaning": clock_text},
                        compress=self.still)
        try:
            bag.open()
        except OSError as exc:
            from core.paths import write_error

            raise write_error(self.path, exc) from None
        self._bag = bag
        self._t_start = time.monotonic()
        self._thread = threading.Thread(target=self._run, name="deskarm-recorder", daemon=True)
        self._thread.start()
        t = self._now()
        self._put("session", (t, dict(self.session_info)))
        if calibration is None:
            calibration = _calibration_from_yaml(self.session_info.get("calibration_yaml"))
        if base_T_camera is None:
            base_T_camera = self.session_info.get("base_T_camera")
        self.calibration(calibration, base_T_camera)
        self.estop(estopped)
        return self

    def frame(self, frame) -> None:
        """Queue a StereoFrame (images, and the simulated desk's truth when it has one)."""
        self._put("frame", frame)

    def result(self, result) -> None:
        """Queue a PerceptionResult's found markers (one MarkerArray per result)."""
        found = tuple((m.marker_id, tuple(m.base_p_centre)) for m in result.markers
                      if m.found and m.base_p_centre is not None)
        self._put("result", (result.t, found))

    def command(self, command, goal=None) -> None:
        """Queue a JointCommand (commanded joint state) and its Goal (when valid and new)."""
        self._put("command", (command.t, tuple(command.q)))
        if goal is not None and goal.valid and goal.seq != self._last_goal_seq:
            self._last_goal_seq = goal.seq
            self._put("goal", goal)

    def state(self, state) -> None:
        """Queue a JointState (measured joints and, with ``fk``, robot_base → tool); one per seq."""
        if state is None or state.seq == self._last_state_seq:
            return
        self._last_state_seq = state.seq
        self._put("state", (state.t, tuple(state.q)))

    def estop(self, on: bool) -> None:
        """Record the e-stop state when it changed (call it as often as convenient)."""
        on = bool(on)
        if on != self._last_estop:
            self._last_estop = on
            self._put("estop", (self._now(), on))

    def calibration(self, calibration=None, base_T_camera=None) -> None:
        """Record a new stereo calibration (both camera_info) and/or camera→arm pose (/tf_static)."""
        t = self._now()
        if calibration is not None:
            self._put("camera_info", (t, calibration))
        if base_T_camera is not None:
            self._put("tf_static", (t, np.array(base_T_camera, dtype=float).reshape(4, 4)))

    def close(self, timeout_s: float = 60.0) -> None:
        """Write what is queued, finish the MCAP and metadata.yaml, join the thread."""
        thread = self._thread
        with self._cond:
            if self._closed:
                return
            self._closed = True
            self._items.append((_STOP, None))
            self._cond.notify()
        if thread is not None:
            thread.join(timeout_s)
            if thread.is_alive() and not self._error:
                self._error = f"{self.path}: the recorder did not finish within {timeout_s:g} s"
        self._t_end = time.monotonic()

    def __enter__(self) -> "Recorder":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _put(self, kind: str, payload) -> None:
        with self._cond:
            if self._closed or self._error or self._thread is None:
                return
            items = self._items
            if kind == "frame":
                if self._frames_queued >= self.queue_size:
                    for i, (k, _) in enumerate(items):
                        if k == "frame":
                            del items[i]
                            break
                    self._frames_queued -= 1
                    self.frames_dropped += 1
                self._frames_queued += 1
            elif len(items) - self._frames_queued >= self.queue_size * SMALL_QUEUE_FACTOR:
                for i, (k, _) in enumerate(items):
                    if k != "frame":
                        del items[i]
                        break
                self.messages_dropped += 1
            items.append((kind, payload))
            self._cond.notify()

    # -- the recorder's thread -------------------------------------------------------------

    def _run(self) -> None:
        bag = self._bag
        while True:
            with self._cond:
                while not self._items:
                    self._cond.wait()
                kind, payload = self._items.popleft()
                if kind == "frame":
                    self._frames_queued -= 1
            if kind is _STOP:
                break
            if self._error:
                continue
            try:
                self._write(bag, kind, payload)
            except OSError as exc:
                self._fail(f"{self.path}: recording stopped: {os_error_reason(exc)} — free space on that "
                           f"disk or record to another folder (--record PATH); what was written so far is readable")
            except Exception as exc:  # a bug must not take the loop down: say it and stop recording
                self._fail(f"{self.path}: recording stopped: {type(exc).__name__}: {exc}")
        if not self._error:
            try:
                bag.close()
            except OSError as exc:
                self._fail(f"{self.path}: recording could not be finished: {os_error_reason(exc)} — "
                           "the messages written so far are readable")
        else:
            bag.abort()

    def _fail(self, message: str) -> None:
        with self._cond:
            self._error = message
            stop = [item for item in self._items if item[0] is _STOP]  # close() may be waiting already
            self._items.clear()
            self._items.extend(stop)
            self._frames_queued = 0

    def _write(self, bag: BagWriter, kind: str, payload) -> None:
        e = self._epoch  # every clock time below becomes a stamp as t + e (the stream's own sum)
        if kind == "frame":
            w0 = time.perf_counter()
            self._write_frame(bag, payload)
            self.frame_costs_ms.append((time.perf_counter() - w0) * 1e3)
        elif kind == "result":
            t, found = payload
            t += e
            bag.write(tp.MARKERS, tp.time_ns(t), tp.found_marker_array(found, t))
        elif kind == "command":
            t, q = payload
            t += e
            bag.write(tp.JOINTS_COMMANDED, tp.time_ns(t), tp.joint_state(q, t, self.joint_names))
        elif kind == "goal":
            msg = tp.goal_point(payload, payload.t + e)
            if msg is not None:
                bag.write(tp.GOAL, tp.time_ns(payload.t + e), msg)
        elif kind == "state":
            t, q = payload
            t += e
            bag.write(tp.JOINTS_MEASURED, tp.time_ns(t), tp.joint_state(q, t, self.joint_names))
            if self.fk is not None:
                bag.write(tp.TF, tp.time_ns(t), tp.tf_base_tool(q, t, self.fk))
        elif kind == "estop":
            t, on = payload
            t += e
            bag.write(tp.ESTOP, tp.time_ns(t), tp.bool_msg(on))
        elif kind == "camera_info":
            t, calib = payload
            t += e
            bag.write(tp.CAMERA_LEFT_INFO, tp.time_ns(t), tp.camera_info(calib, "left", t))
            bag.write(tp.CAMERA_RIGHT_INFO, tp.time_ns(t), tp.camera_info(calib, "right", t))
        elif kind == "tf_static":
            t, base_T_camera = payload
            t += e
            bag.write(tp.TF_STATIC, tp.time_ns(t), tp.tf_base_camera(base_T_camera, t))
        elif kind == "session":
            t, info = payload
            t += e
            bag.write(tp.SESSION, tp.time_ns(t), tp.session_msg(info))

    def _write_frame(self, bag: BagWriter, frame) -> None:
        last_left, last_right, jl, jr = self._jpeg_cache
        if not (frame.left is last_left and frame.right is last_right):  # a repeated frame re-uses its JPEGs
            if self._still(frame):
                self.frames_still += 1  # the same JPEG bytes again: zstd stores them once per chunk
            else:
                jl, jr = self._jpeg(frame.left), self._jpeg(frame.right)
            self._jpeg_cache = (frame.left, frame.right, jl, jr)
        t = frame.t + self._epoch  # the stream stamps this frame frame.t + the same epoch (ros_epoch)
        ns = tp.time_ns(t)
        bag.write(tp.CAMERA_LEFT_IMAGE, ns, tp.compressed_image(jl, t, tp.FRAME_CAMERA_LEFT))
        bag.write(tp.CAMERA_RIGHT_IMAGE, ns, tp.compressed_image(jr, t, tp.FRAME_CAMERA_RIGHT))
        if frame.truth is not None:
            bag.write(tp.TRUTH_MARKERS, ns, tp.truth_marker_array(frame.truth, t))
        self.frames_written += 1

    def _still(self, frame) -> bool:
        """True when both images equal the pair the JPEG cache holds within sensor noise
        (``blocks_changed``); otherwise the frame's blocks become the ones to compare with."""
        if not self.still:
            return False
        left, right = _blocks(frame.left), _blocks(frame.right)
        last = self._encoded_blocks
        if last is not None and not blocks_changed(last[0], left) and not blocks_changed(last[1], right):
            return True
        self._encoded_blocks = (left, right)
        return False

    def _jpeg(self, image: np.ndarray) -> bytes:
        ok, buf = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, self.jpeg_quality])
        if not ok:
            raise ValueError(f"JPEG encoding failed for an image of shape {image.shape}")
        return buf.tobytes()


def _blocks(image: np.ndarray) -> np.ndarray:
    """The image averaged over STILL_SCALE x STILL_SCALE pixel blocks (what ``blocks_changed`` compares)."""
    h, w = image.shape[:2]
    size = (max(1, w // STILL_SCALE), max(1, h // STILL_SCALE))
    return cv2.resize(image, size, interpolation=cv2.INTER_AREA)


def blocks_changed(a: np.ndarray, b: np.ndarray, levels: int = STILL_LEVELS) -> bool:
    """Whether two ``_blocks`` differ anywhere by more than ``levels`` (or in shape)."""
    if a.shape != b.shape or a.dtype != b.dtype:
        return True
    return bool(cv2.absdiff(a, b).max() > levels)


def _calibration_from_yaml(text):
    """A StereoCalibration from the YAML text ``calibration_yaml`` gives (None without text)."""
    if not text:
        return None
    from core.vision.calibration import load_calibration

    with tempfile.TemporaryDirectory(prefix="deskarm-calib-") as tmp:
        path = Path(tmp) / "calibration.yaml"
        path.write_text(text, "utf-8")
        return load_calibration(path)


def folder_size(path: Path) -> int:
    """Bytes of the files in ``path`` (not following links)."""
    total = 0
    for entry in Path(path).rglob("*"):
        try:
            if entry.is_file() and not entry.is_symlink():
                total += entry.stat().st_size
        except OSError:  # a file removed while listing
            pass
    return total


def read_recording_info(path: Path) -> Optional[RecordingInfo]:
    """What ``metadata.yaml`` of a recording folder says (None: not a recording)."""
    from ruamel.yaml import YAML

    meta = Path(path) / "metadata.yaml"
    try:
        data = YAML(typ="safe").load(meta.read_text("utf-8"))  # safe loader: plain data only
        info = data["rosbag2_bagfile_information"]
    except Exception:  # no file, not YAML, not a rosbag2 folder: not a recording of ours
        return None
    custom = info.get("custom_data") or {}
    try:
        started = datetime.fromisoformat(custom["deskarm_started"])
    except (KeyError, TypeError, ValueError):
        started = None
    complete = custom.get("deskarm_state") == STATE_COMPLETE
    duration = float((info.get("duration") or {}).get("nanoseconds", 0)) / 1e9
    if not complete and started is not None:
        mcap = Path(path) / f"{Path(path).name}.mcap"
        try:  # killed: the last write is the best estimate of its end
            duration = max(0.0, mcap.stat().st_mtime - started.timestamp())
        except OSError:
            pass
    return RecordingInfo(path=Path(path), started=started, duration_s=duration, size_bytes=folder_size(path),
                         robot=str(custom.get("deskarm_robot", "")), complete=complete)


def list_recordings(folder: Optional[os.PathLike] = None) -> list[RecordingInfo]:
    """The recordings in ``folder`` (default ``recordings_dir()``), newest first."""
    folder = Path(folder) if folder is not None else recordings_dir()
    if not folder.is_dir():
        return []
    found = [info for p in folder.iterdir() if p.is_dir() and (info := read_recording_info(p)) is not None]
    return sorted(found, key=lambda i: (i.started or datetime.min, i.path.name), reverse=True)
