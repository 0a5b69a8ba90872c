"""The calibration wizard's thread: live board detection, capture gating, calibration.

The wizard (``widgets/calibration_wizard.py``) owns no thread. ``CalibrationController`` creates
it and one ``CalibrationWorker`` for it, hands the worker the window's live frames (newest only)
and installs the result the user saves. The worker owns the Qt-free ``CalibrationSession``: every
session call runs in the worker's thread, one after the other, so the session needs no lock.

Signals of CalibrationWorker (emitted from its own thread, received queued in the GUI thread by
slot methods of the wizard):
- sigSession(SessionInfo) — a capture session started (board, folder)
- sigLive(LiveUpdate) — one per processed frame: detection overlays, gate verdict, coverage
- sigPairs(PairsUpdate) — a pair was captured or pairs were removed
- sigProgress(float, str) — calibration progress 0 … 1 and the step it is on
- sigReport(ReportUpdate) — a calibration finished
- sigFailed(str) — a user action (start, snapshot, calibrate, remove) failed; says why and what to do

CalibrationController's signals (GUI thread):
- sigCalibrationInstalled(Path, StereoCalibration) — after "Save and use" wrote the app's
  calibration (``install_calibration``; the simulated desk's goes to its own file, which real
  webcams never load)
- sigStopRequested() — STOP (or Esc) in the wizard: the window stops the arm and calls
  ``set_estop(True)``; the wizard covers the window's own STOP on a small screen
- sigBoardShown(BoardSpec or None) — a capture session started with this board / the wizard
  closed: a simulated camera shows the board meanwhile (``SimStereoCamera.show_board``)
"""
from __future__ import annotations

import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Optional, Sequence

import cv2
import numpy as np
from PySide6 import QtCore, QtWidgets

from core.messages import StereoFrame
from core.paths import user_dir
from core.vision.calibration import (
    StereoCalibration,
    export_ros_camera_info,
    install_calibration,
    is_simulated_pair,
)
from core.vision.stereo_calibration import (
    BoardSpec,
    CalibrationFailed,
    CalibrationReport,
    CalibrationSession,
    Coverage,
    GateResult,
    PairDetection,
    draw_detection,
    rectified_preview,
    suggest_board,
)

LIVE_MAX_WIDTH = 640  # overlays wider than this are shrunk in the worker (the GUI only scales them)
LIVE_MIN_INTERVAL_S = 0.05  # at most ~20 detections a second: leaves CPU for perception on a Pi
SUGGEST_AFTER_MISSES = 45  # look for a wrongly described board after this many frames without one
SESSIONS_FOLDER = "calibration_sessions"


# ----------------------------------------------------------------------------------------------
# what the worker emits (frozen: the GUI may keep them)


@dataclass(frozen=True)
class SessionInfo:
    """A capture session has started."""

    session_id: int  # increases with every new session; older updates are stale
    board_text: str  # command-line form, e.g. chessboard:9x6
    board_description: str  # for the user
    folder: str  # where captured pairs are saved


@dataclass(frozen=True, eq=False)
class LiveUpdate:
    """One processed live frame."""

    session_id: int
    number: int  # counts the worker's processed frames: the GUI drops a number it has passed
    seq: int  # the frame's sequence number
    t: float  # the frame's capture time (s)
    left: np.ndarray  # BGR left image with the detected corners drawn (≤ LIVE_MAX_WIDTH wide)
    right: np.ndarray
    left_ok: bool  # the board was found in this view
    right_ok: bool
    gate: GateResult  # may this pair be captured, and why not
    coverage: Coverage  # the meters over the captured pairs
    n_pairs: int  # captured pairs
    detect_ms: float  # detection time of this frame in the worker (ms)
    auto_capture: bool  # whether accepted pairs are captured without a tap
    captured: Optional[int] = None  # number of the pair captured from this very frame
    note: str = ""  # e.g. why an accepted frame still could not be captured, or a board hint


@dataclass(frozen=True)
class PairsUpdate:
    """The captured pairs changed."""

    session_id: int
    numbers: tuple[int, ...]  # capture numbers of the pairs, in order
    coverage: Coverage
    added: Optional[int] = None  # number of the pair just captured
    manual: bool = False  # captured with the snapshot button
    removed: tuple[int, ...] = ()  # numbers just removed


@dataclass(frozen=True, eq=False)
class ReportUpdate:
    """A finished calibration."""

    session_id: int
    report: CalibrationReport
    numbers: tuple[int, ...]  # capture number of report.pairs[k] is numbers[k]
    preview: Optional[np.ndarray]  # rectified pair side by side with horizontal lines (BGR)
    preview_number: Optional[int]  # the pair the preview shows
    folder: str
    thread_name: str = ""  # where it ran (the worker's thread, never the GUI's)


# ----------------------------------------------------------------------------------------------
# the worker


def _shrink(image: np.ndarray, max_width: int = LIVE_MAX_WIDTH) -> np.ndarray:
    w = image.shape[1]
    if w <= max_width:
        return image
    f = max_width / w
    return cv2.resize(image, None, fx=f, fy=f, interpolation=cv2.INTER_AREA)


class CalibrationWorker(QtCore.QThread):
    """Runs a CalibrationSession: detect the board in the newest frame, gate, capture, calibrate.

    The public methods are called from the GUI thread and only leave a request (the newest frame
    replaces an unprocessed one; user actions queue in order). ``stop()`` ends and joins the thread.
    """

    sigSession = QtCore.Signal(object)
    sigLive = QtCore.Signal(object)
    sigPairs = QtCore.Signal(object)
    sigProgress = QtCore.Signal(float, str)
    sigReport = QtCore.Signal(object)
    sigFailed = QtCore.Signal(str)

    def __init__(self, min_interval_s: float = LIVE_MIN_INTERVAL_S, parent: Optional[QtCore.QObject] = None):
        super().__init__(parent)
        self.setObjectName("calibration")
        self.min_interval_s = float(min_interval_s)
        self._cond = threading.Condition()
        self._frame: Optional[StereoFrame] = None
        self._frame_version = 0
        self._requests: list[tuple] = []
        self._running = False
        self._auto = True
        # worker-thread state
        self.session: Optional[CalibrationSession] = None
        self._session_id = 0
        self._previous: Optional[PairDetection] = None
        self._last: Optional[tuple[StereoFrame, PairDetection]] = None
        self._misses = 0
        self._hint = ""
        self._processed = 0

    # --- GUI-thread API ---------------------------------------------------------------------
    def start(self, *args) -> None:  # noqa: D102
        with self._cond:
            self._running = True
        super().start(*args)

    def stop(self) -> None:
        """Ask the loop to end and join the thread (a calibration in progress finishes first)."""
        with self._cond:
            self._running = False
            self._cond.notify_all()
        if not self.wait(10_000):
            self.terminate()  # never leave a running QThread behind (aborts the interpreter)
            self.wait()

    def feed(self, frame: StereoFrame) -> None:
        """The newest live frame (replaces one not yet processed)."""
        with self._cond:
            self._frame = frame
            self._frame_version += 1
            self._cond.notify_all()

    def start_session(self, board: BoardSpec, folder: Optional[Path]) -> None:
        """Begin capturing ``board`` (pairs saved in ``folder``); forgets the previous session."""
        self._request(("session", board, folder))

    def set_auto_capture(self, on: bool) -> None:
        """Capture every accepted pair by itself (on) or only with the snapshot button (off)."""
        with self._cond:
            self._auto = bool(on)

    def snapshot(self) -> None:
        """Capture the frame last shown, even if the board moves or the pose is not new."""
        self._request(("snapshot",))

    def calibrate(self) -> None:
        """Calibrate from the captured pairs (progress, then sigReport or sigFailed)."""
        self._request(("calibrate",))

    def remove(self, numbers: Sequence[int], recalibrate: bool = True) -> None:
        """Drop captured pairs by capture number (their files move to removed/), then recalibrate."""
        self._request(("remove", tuple(int(n) for n in numbers), bool(recalibrate)))

    def _request(self, req: tuple) -> None:
        with self._cond:
            self._requests.append(req)
            self._cond.notify_all()

    # --- worker thread ----------------------------------------------------------------------
    def run(self) -> None:  # noqa: D102 (QThread override)
        seen = 0
        due = 0.0
        while True:
            with self._cond:
                while True:
                    if not self._running:
                        return
                    if self._requests:
                        break
                    now = time.monotonic()
                    if self._frame_version != seen and now >= due:
                        break
                    self._cond.wait(0.2 if self._frame_version == seen else max(0.001, due - now))
                requests, self._requests = self._requests, []
                frame = self._frame if self._frame_version != seen and not requests else None
                if frame is not None:
                    seen = self._frame_version
                auto = self._auto
            for req in requests:
                self._handle(req)
            if frame is not None and self.session is not None:
                due = time.monotonic() + self.min_interval_s
                self._process(frame, auto)

    def _handle(self, req: tuple) -> None:
        kind = req[0]
        try:
            if kind == "session":
                self._new_session(req[1], req[2])
            elif self.session is None:
                self.sigFailed.emit("choose the board first")
            elif kind == "snapshot":
                self._snapshot()
            elif kind == "calibrate":
                self._calibrate()
            elif kind == "remove":
                self._remove(req[1], req[2])
        except OSError as exc:  # the session folder cannot be written
            self.sigFailed.emit(f"{exc} — check the free space and the permissions of the session folder")

    def _new_session(self, board: BoardSpec, folder: Optional[Path]) -> None:
        self.session = CalibrationSession(board, folder)
        self._session_id += 1
        self._previous = None
        self._last = None
        self._misses = 0
        self._hint = ""
        self.sigSession.emit(SessionInfo(self._session_id, board.text(), board.describe(),
                                         str(folder) if folder is not None else ""))
        self._emit_pairs()

    def _process(self, frame: StereoFrame, auto: bool) -> None:
        s = self.session
        t0 = time.perf_counter()
        det = s.detect(frame.left, frame.right, fast=True)
        gate = s.gate(det, frame.skew_s, previous=self._previous)
        detect_ms = (time.perf_counter() - t0) * 1e3
        self._previous = det
        self._last = (frame, det)
        captured, note = None, ""
        if gate.accepted and auto:
            try:
                pair = s.add(frame.left, frame.right)
            except ValueError as exc:  # the full-quality detection disagrees with the quick one
                note = str(exc)
            else:
                captured = pair.number
                self._emit_pairs(added=pair.number)
        if det.left.ok or det.right.ok:
            self._misses, self._hint = 0, ""
        else:
            self._misses += 1
            if self._misses == SUGGEST_AFTER_MISSES:
                self._hint = suggest_board([frame.left], s.board) or ""
        left = _shrink(draw_detection(frame.left, det.left, s.board))
        right = _shrink(draw_detection(frame.right, det.right, s.board))
        self._processed += 1
        self.sigLive.emit(LiveUpdate(
            self._session_id, self._processed, frame.seq, frame.t, left, right, det.left.ok, det.right.ok, gate, s.coverage(),
            len(s.pairs), detect_ms, auto, captured, note or self._hint))

    def _snapshot(self) -> None:
        if self._last is None:
            self.sigFailed.emit("no picture from the cameras yet — wait for the live views")
            return
        frame, det = self._last
        gate = self.session.gate(det, frame.skew_s, manual=True)
        if not gate.accepted:
            self.sigFailed.emit("snapshot not taken: " + gate.reason)
            return
        try:
            pair = self.session.add(frame.left, frame.right, manual=True)
        except ValueError as exc:
            self.sigFailed.emit(f"snapshot not taken: {exc}")
            return
        self._emit_pairs(added=pair.number, manual=True)

    def _emit_pairs(self, added: Optional[int] = None, manual: bool = False, removed: tuple = ()) -> None:
        s = self.session
        self.sigPairs.emit(PairsUpdate(self._session_id, tuple(p.number for p in s.pairs), s.coverage(),
                                       added, manual, removed))

    def _calibrate(self) -> None:
        s = self.session
        need = s.calibration_options.min_pairs
        if len(s.pairs) < need:
            self.sigFailed.emit(f"calibration needs at least {need} captured pairs (have {len(s.pairs)}) — "
                                f"capture more; 10–20 varied poses give the best result")
            return
        self.sigProgress.emit(0.0, f"calibrating with {len(s.pairs)} pairs")
        numbers = tuple(p.number for p in s.pairs)
        try:
            # the session reports 0 … 1; the preview after it takes the last tenth
            report = s.calibrate(lambda f, m: self.sigProgress.emit(0.9 * float(f), str(m)))
        except CalibrationFailed as exc:
            self.sigProgress.emit(1.0, "calibration failed")
            self.sigFailed.emit(str(exc))
            return
        self.sigProgress.emit(0.95, "drawing the rectified preview")
        preview, preview_number = self._preview(report, numbers)
        self.sigProgress.emit(1.0, "done")
        self.sigReport.emit(ReportUpdate(self._session_id, report, numbers, preview, preview_number,
                                         str(s.folder) if s.folder is not None else "",
                                         threading.current_thread().name))

    def _preview(self, report: CalibrationReport, numbers: tuple[int, ...]):
        """The rectified pair of the most recent used capture, lines every ~1/15 of the height."""
        used = [p.index for p in report.pairs if p.used]
        for k in reversed(used):
            try:
                left, right = self.session.pairs[k].images()
            except (FileNotFoundError, IndexError):
                continue
            h = left.shape[0]
            return rectified_preview(left, right, report.calibration, line_every_px=max(16, h // 15)), numbers[k]
        return None, None

    def _remove(self, numbers: tuple[int, ...], recalibrate: bool) -> None:
        s = self.session
        index = {p.number: k for k, p in enumerate(s.pairs)}
        missing = [n for n in numbers if n not in index]
        if missing:
            self.sigFailed.emit(f"pair #{missing[0]} is not in the session any more")
            return
        s.remove([index[n] for n in numbers])
        self._emit_pairs(removed=tuple(numbers))
        if recalibrate:
            self._calibrate()


# ----------------------------------------------------------------------------------------------
# the controller: wizard + worker + saving


def new_session_folder(root: Optional[Path] = None) -> Path:
    """A fresh, timestamped folder for a wizard session (``<cache>/calibration_sessions/…``)."""
    root = Path(root) if root is not None else user_dir("cache") / SESSIONS_FOLDER
    stamp = time.strftime("%Y%m%d-%H%M%S")
    folder = root / stamp
    k = 2
    while folder.exists():
        folder = root / f"{stamp}-{k}"
        k += 1
    return folder


class CalibrationController(QtCore.QObject):
    """Opens the calibration wizard, runs its worker while it is open, installs what it saves.

    Signals (GUI thread):
        sigCalibrationInstalled(object path, object calibration): "Save and use" wrote ``path``
            (the app's calibration, or the simulated desk's own file) holding ``calibration``;
            the window switches to it.
        sigStopRequested(): the wizard's STOP was tapped (or Esc pressed): stop the arm, then
            tell the wizard with ``set_estop(True)``.
        sigBoardShown(object board): a capture session started for ``board`` (a BoardSpec), or
            None when the wizard closed — a simulated camera shows that board meanwhile.
    """

    sigCalibrationInstalled = QtCore.Signal(object, object)
    sigStopRequested = QtCore.Signal()
    sigBoardShown = QtCore.Signal(object)

    def __init__(self, parent: Optional[QtCore.QObject] = None, sessions_root: Optional[Path] = None,
                 board: Optional[BoardSpec] = None, min_interval_s: float = LIVE_MIN_INTERVAL_S,
                 export_ros: bool = True, simulated: Optional[bool] = None):
        super().__init__(parent)
        # the frames come from the simulated desk: "Save and use" writes its own file, never the one
        # real webcams load (None: the parent window's session says, by its camera's pair id)
        self.simulated = simulated
        self.sessions_root = sessions_root
        self.board = board
        self.min_interval_s = min_interval_s
        self.export_ros = export_ros
        self.wizard = None
        self.worker: Optional[CalibrationWorker] = None
        self.installed_path: Optional[Path] = None
        self.estop_engaged = False  # the arm's e-stop state, shown by every wizard opened

    @property
    def active(self) -> bool:
        return self.worker is not None and self.worker.isRunning()

    @property
    def calibrates_simulated_desk(self) -> bool:
        """True when the wizard calibrates the simulated desk's cameras (``simulated``, else the
        parent window's session camera: the simulated desk, or a replay of it)."""
        if self.simulated is not None:
            return bool(self.simulated)
        camera = getattr(getattr(self.parent(), "session", None), "camera", None)
        return camera is not None and is_simulated_pair(getattr(camera, "pair_id", ""))

    def open(self, parent: Optional[QtWidgets.QWidget] = None):
        """Show the wizard (a new one, or the one already open) and start its worker."""
        from widgets.calibration_wizard import CalibrationWizard

        if self.wizard is not None:
            self.wizard.raise_()
            self.wizard.activateWindow()
            return self.wizard
        wizard = CalibrationWizard(board=self.board, parent=parent)
        worker = CalibrationWorker(self.min_interval_s)
        worker.sigSession.connect(wizard.on_session)
        worker.sigLive.connect(wizard.on_live)
        worker.sigPairs.connect(wizard.on_pairs)
        worker.sigProgress.connect(wizard.on_progress)
        worker.sigReport.connect(wizard.on_report)
        worker.sigFailed.connect(wizard.on_failed)
        wizard.sigStartRequested.connect(self.on_start_requested)
        wizard.sigAutoCaptureChanged.connect(worker.set_auto_capture)
        wizard.sigSnapshotRequested.connect(worker.snapshot)
        wizard.sigCalibrateRequested.connect(worker.calibrate)
        wizard.sigRemoveRequested.connect(self.on_remove_requested)
        wizard.sigSaveRequested.connect(self.on_save_requested)
        wizard.sigStopRequested.connect(self.sigStopRequested)
        wizard.finished.connect(self.on_wizard_finished)
        wizard.set_estop(self.estop_engaged)
        self.wizard, self.worker = wizard, worker
        worker.start()
        wizard.show_adaptive()
        return wizard

    def feed(self, frame: Optional[StereoFrame]) -> None:
        """A live frame from the window (ignored while the wizard is closed)."""
        if frame is not None and self.worker is not None:
            self.worker.feed(frame)

    def set_estop(self, engaged: bool) -> None:
        """The arm's e-stop state (the window's): shown by the open wizard and any opened later."""
        self.estop_engaged = bool(engaged)
        if self.wizard is not None:
            self.wizard.set_estop(self.estop_engaged)

    def camera_problem(self, message: str) -> None:
        """Tell the open wizard that the cameras stopped (message) or are back ("")."""
        if self.wizard is not None:
            self.wizard.set_camera_problem(message)

    def close(self) -> None:
        """Close the wizard (if open) and stop its worker."""
        if self.wizard is not None:
            self.wizard.close()  # a visible dialog emits finished -> on_wizard_finished
        self.on_wizard_finished()

    def _stop_worker(self) -> None:
        worker, self.worker = self.worker, None
        if worker is not None:
            worker.stop()
            worker.deleteLater()

    # --- wizard slots -----------------------------------------------------------------------
    @QtCore.Slot(object)
    def on_start_requested(self, board) -> None:
        self.board = board
        if self.worker is not None:
            self.worker.start_session(board, new_session_folder(self.sessions_root))
            self.sigBoardShown.emit(board)

    @QtCore.Slot(object)
    def on_remove_requested(self, numbers) -> None:
        if self.worker is not None:
            self.worker.remove(numbers, recalibrate=True)

    @QtCore.Slot(object)
    def on_save_requested(self, update) -> None:
        """Install the calibration of ``update`` (a ReportUpdate) as the app's; ROS files beside the pairs."""
        report = update.report
        if not getattr(report, "ok", True):
            self.wizard.on_failed("not installed: " + "; ".join(report.problems))
            return
        try:
            path = install_calibration(report.calibration, extra=report.file_extras(),
                                       simulated=self.calibrates_simulated_desk)
            ros = []
            if self.export_ros and update.folder:
                ros = export_ros_camera_info(report.calibration, Path(update.folder) / "ros")
        except (OSError, ValueError) as exc:
            self.wizard.on_failed(f"could not save the calibration: {exc}")
            return
        self.installed_path = path
        # the saved file is what the app loads next time: use exactly that from now on
        calib = _reloaded(path, report.calibration)
        self.wizard.on_saved(str(path), str(ros[0].parent) if ros else "")
        self.sigCalibrationInstalled.emit(path, calib)

    @QtCore.Slot(int)
    def on_wizard_finished(self, _result: int = 0) -> None:
        self._stop_worker()
        wizard, self.wizard = self.wizard, None
        if wizard is not None:
            wizard.deleteLater()
            self.sigBoardShown.emit(None)  # a simulated camera takes its board away


def _reloaded(path: Path, fallback: StereoCalibration) -> StereoCalibration:
    from core.vision.calibration import CalibrationError, load_calibration

    try:
        return load_calibration(path, expected_size=fallback.image_size)
    except CalibrationError:
        return fallback


__all__ = ["CalibrationWorker", "CalibrationController", "SessionInfo", "LiveUpdate", "PairsUpdate",
           "ReportUpdate", "new_session_folder", "LIVE_MIN_INTERVAL_S"]
