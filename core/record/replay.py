"""A recording played back as a stereo camera: ``--camera replay:PATH``.

Like the simulated camera it delivers StereoFrames on the session's clock: the recorded capture
times are mapped onto the clock (the first pair at ``connect()``), so a replay runs at recorded
speed on a wall clock and as fast as the machine allows on a simulated one (headless ``--fast``).
With ``fast`` the frames come as fast as they are read on any clock. Each frame carries the
ground truth recorded with it (``frame.truth``), so the headless metrics score a replay like the
live run; images byte-identical to the previous pair are delivered again as the very same arrays,
flagged ``repeated``, as the simulated camera does.

``calibration()`` and ``base_T_camera()`` are the recorded ones; ``seek(t_s)`` (any thread) jumps;
``recorded_state_at(t)`` gives the measured joints at a frame time, for the twin to show beside
the recomputed command. At the end ``read()`` returns None with ``status_message`` "… replay
finished" (``is_connected`` turns False), or starts again with ``loop``.
"""
from __future__ import annotations

import threading
from pathlib import Path
from typing import Iterator, Optional

import numpy as np

from core.messages import JointState, SequenceCounter, StereoFrame
from core.record.reader import RecordedPair, Recording, RecordingError, open_recording
from core.vision.cameras import CameraError, ClockPacedSource


class ReplayStereoCamera(ClockPacedSource):
    """The image pairs of a recording, delivered as a camera (see the module docstring)."""

    kind = "replay"

    def __init__(self, path, clock=None, fast: bool = False, loop: bool = False,
                 recording: Optional[Recording] = None):
        super().__init__(clock)
        self.path = Path(path)
        self.fast = bool(fast)
        self.loop = bool(loop)
        self.recording = recording
        self.finished = False  # the last pair was delivered (and not looping)
        self.frames_delivered = 0
        self.frames_skipped = 0  # pairs dropped to keep up on a wall clock
        self._lock = threading.Lock()  # guards _seek_to
        self._seek_to: Optional[float] = None
        self._pairs: Optional[Iterator[RecordedPair]] = None
        self._index = 0  # the next pair to deliver
        self._t0 = 0.0  # clock time of recorded t_s = 0
        self._last_t_s = 0.0  # recorded time of the last pair delivered
        self._last: Optional[tuple[bytes, bytes, np.ndarray, np.ndarray]] = None
        self._seq = SequenceCounter()
        self._open = False

    # -- identity -------------------------------------------------------------------------------
    @property
    def name(self) -> str:
        return f"replay: {self.path}"

    @property
    def pair_id(self) -> str:
        rec = self.recording
        return (rec.session.pair_id if rec is not None and rec.session.pair_id else f"replay:{self.path.resolve()}")

    @property
    def is_connected(self) -> bool:
        return self._open and not self.finished

    def calibration(self):
        """The recorded stereo calibration (None when the recording has none)."""
        return None if self.recording is None else self.recording.calibration

    def base_T_camera(self) -> Optional[np.ndarray]:
        """The recorded camera_left pose in robot_base (None when the recording has none)."""
        rec = self.recording
        return None if rec is None or rec.base_T_camera is None else rec.base_T_camera.copy()

    @property
    def warnings(self) -> list[str]:
        return [] if self.recording is None else list(self.recording.warnings)

    # -- the timeline ---------------------------------------------------------------------------
    @property
    def duration_s(self) -> float:
        """From the first image pair to one frame period after the last."""
        return 0.0 if self.recording is None else self.recording.frames_s

    @property
    def progress(self) -> float:
        """How far the replay is, 0…1."""
        d = self.duration_s
        if d <= 0:
            return 0.0
        if self.finished:
            return 1.0
        return min(1.0, max(0.0, (self._last_t_s + self.recording.frame_period_s) / d)) if self.frames_delivered \
            else min(1.0, self._last_t_s / d)

    def seek(self, t_s: float) -> None:
        """Continue from recorded time ``t_s`` (clamped to the recording) with the next ``read``; any thread."""
        with self._lock:
            self._seek_to = float(t_s)
        self.clock.interrupt()  # a read waiting for a later frame goes to the new place now

    def recorded_state_at(self, t: float) -> Optional[JointState]:
        """The measured joint state recorded at clock time ``t`` (a frame's ``t``), else None."""
        rec = self.recording
        if rec is None:
            return None
        row = rec.joints_at(t - self._t0, "measured")
        if row is None:
            return None
        return JointState(seq=0, t=self._t0 + row.t_s, q=row.q, measured=True)

    # -- lifecycle ------------------------------------------------------------------------------
    def connect(self) -> None:
        """Open the recording (once) and start from its first pair; CameraError naming the path."""
        if self.recording is None:
            try:
                self.recording = open_recording(self.path)
            except RecordingError as exc:
                raise CameraError(str(exc)) from None
        self.status_message = "; ".join(self.recording.warnings)
        self._open = True
        self._restart(0, self.clock.now())

    def disconnect(self) -> None:
        self._open = False
        self._pairs = None
        super().disconnect()

    def _restart(self, index: int, due: float) -> None:
        """Deliver pair ``index`` next, due at clock time ``due``."""
        rec = self.recording
        self._index = index
        self._t0 = due - rec.pair_times_s[index]
        self._next = due
        self._pairs = rec.pairs(index)
        self._last = None
        self._last_t_s = rec.pair_times_s[index]
        self.finished = False

    def _due(self, index: int) -> float:
        return self._t0 + self.recording.pair_times_s[index]

    # -- frames ---------------------------------------------------------------------------------
    def read(self) -> Optional[StereoFrame]:
        if not self._open:
            return None
        rec = self.recording
        with self._lock:
            seek, self._seek_to = self._seek_to, None
        if seek is not None:  # the sought pair comes when the next frame would have (time moves on)
            self._restart(rec.index_at(seek), max(self.clock.now(), self._next))
        if self.finished:
            # nothing more: wait a frame period (the caller's loop does not spin), then say so
            self.clock.wait_until(self._next)
            self._next = max(self._next, self.clock.now()) + rec.frame_period_s
            return None
        if self._index >= len(rec.pair_times_s):
            return self._end()
        due = self._due(self._index)
        if not self.fast:
            if not self.clock.wait_until(due) or not self._open:
                return None  # interrupted (disconnect, seek)
            with self._lock:
                if self._seek_to is not None:
                    return None
            if not self.clock.simulated:  # late on a wall clock: skip to the pair due now
                now = self.clock.now()
                while self._index + 1 < len(rec.pair_times_s) and self._due(self._index + 1) <= now:
                    self._index += 1
                    self.frames_skipped += 1
                due = self._due(self._index)
        elif self.clock.simulated:
            self.clock.wait_until(due)
        pair = self._next_pair(self._index)
        if pair is None:
            return self._end()
        t = due if (not self.fast or self.clock.simulated) else self.clock.now()
        self._index = pair.index + 1
        self._last_t_s = pair.t_s
        self._next = self._due(self._index) if self._index < len(rec.pair_times_s) else due + rec.frame_period_s
        return self._frame(pair, t)

    def _next_pair(self, index: int) -> Optional[RecordedPair]:
        """Pair ``index`` from the open iterator (pairs before it are skipped, not decoded)."""
        for pair in self._pairs or ():
            if pair.index >= index:
                return pair
        return None

    def _frame(self, pair: RecordedPair, t: float) -> Optional[StereoFrame]:
        import cv2

        last = self._last
        if last is not None and last[0] == pair.left_jpeg and last[1] == pair.right_jpeg:
            self.frames_delivered += 1
            return StereoFrame(seq=self._seq.next(), t=t, left=last[2], right=last[3], skew_s=pair.skew_s,
                               truth=pair.truth, repeated=True)
        left = cv2.imdecode(np.frombuffer(pair.left_jpeg, np.uint8), cv2.IMREAD_COLOR)
        right = cv2.imdecode(np.frombuffer(pair.right_jpeg, np.uint8), cv2.IMREAD_COLOR)
        if left is None or right is None:
            self.status_message = f"{self.path}: the image pair at {pair.t_s:.2f} s cannot be decoded — skipped"
            self._last = None
            return None
        left.flags.writeable = right.flags.writeable = False  # they may be delivered again
        self._last = (pair.left_jpeg, pair.right_jpeg, left, right)
        self.frames_delivered += 1
        return StereoFrame(seq=self._seq.next(), t=t, left=left, right=right, skew_s=pair.skew_s, truth=pair.truth)

    def _end(self) -> Optional[StereoFrame]:
        rec = self.recording
        end = self._t0 + rec.frames_s
        if self.loop:
            # the first pair again, one period after the last (the next read delivers it)
            self._restart(0, max(end, self.clock.now()) if not self.fast else self.clock.now())
            return None
        self.finished = True
        self._next = max(end, self._next)
        self.status_message = f"{self.path}: replay finished ({len(rec.pair_times_s)} frames, {rec.frames_s:.1f} s)"
        if rec.problem is not None:
            self.status_message += f"; {rec.problem.message()}"
        return None


def open_replay(path, clock=None, fast: bool = False, loop: bool = False) -> ReplayStereoCamera:
    """A connected ReplayStereoCamera; CameraError naming the path when the recording cannot be read."""
    cam = ReplayStereoCamera(path, clock=clock, fast=fast, loop=loop)
    cam.connect()
    return cam


__all__ = ["ReplayStereoCamera", "open_replay"]
