
"""The stereo calibration wizard: board → capture (live detection, gating, coverage) → results.

The wizard owns no thread and no calibration state: it shows what a worker reports (the app's
``CalibrationWorker``) and turns taps into requests. Three pages:

1. Board — chessboard (inner corners, square size) or ChArUco (squares, square and marker size,
   dictionary).
2. Capture — both live views with the detected corners, why a pair is not taken (board not seen,
   moving, cameras out of sync, pose already captured), ROS-style coverage meters X / Y / Size /
   Skew, automatic capture of accepted pairs, a Snapshot button and Calibrate.
3. Results — RMS per camera, stereo RMS, mean epipolar error, the per-pair error plot with the
   worst pairs in red, one-tap removal + recalibration, the rectified preview with horizontal
   lines, Save and use.

Usable on a 800×480 touch screen (full screen there, every target ≥ 44 px) and on desktops.
Full screen it hides the window's STOP while the arm keeps moving, so the wizard carries its own
STOP (and takes Esc as STOP, never as "close") in a strip above every page; it never re-arms.
The board page saves the chosen board as a PNG (300 dpi, stored in the file) or a PDF at true
size (``save_printable_board``) for the user to print.

This module is the wizard: its frame (title, STOP strip, Close), the capture page, paging and the
worker's slots. The other pages live beside it as mix-ins: ``widgets.calibration_board_page``
(``BoardPage``) and ``widgets.calibration_results_page`` (``ResultsPage``); their shared parts in
``widgets.calibration_wizard_parts``. Names other modules import from here are re-exported.
"""
from __future__ import annotations

from pathlib import Path
from typing import Optional

from PySide6 import QtCore, QtGui, QtWidgets

from core.vision.stereo_calibration import BoardSpec, CharucoSpec, Coverage
from widgets._style import ERROR_COLOUR, show_adaptive, touch_button
from widgets.calibration_board_page import BoardPage, save_printable_board
from widgets.calibration_results_page import ResultsPage
from widgets.calibration_wizard_parts import (
    ESTOP_TEXT,
    LIVE_REDRAW_MS,
    METERS,
    MIN_PAIRS,
    NO_BOARD_HINT,
    NO_BOARD_HINT_S,
    NO_CHARUCO_HINT,
    PAGES,
    STOP_PX,
    STOP_STYLE,
    ImagePane,
    _Meter,
    board_picture,
    _bold,
    coverage_hint,
    _status_style,
    worst_count,
)
from widgets.estop import StopDialog

# also re-exported: the app and the tests import these from widgets.calibration_wizard
from widgets.calibration_wizard_parts import PRINT_FILTERS


class CalibrationWizard(StopDialog, BoardPage, ResultsPage):
    """The stereo calibration wizard (see the module docstring); fed by a worker's signals.

    Signals (all emitted from the GUI thread):
        sigStartRequested(object board): the user chose a BoardSpec and tapped Start.
        sigAutoCaptureChanged(bool): automatic capture of accepted pairs on / off.
        sigSnapshotRequested(): capture the pair shown now (the Snapshot button).
        sigCalibrateRequested(): calibrate from the captured pairs.
        sigRemoveRequested(object numbers): drop these capture numbers (tuple of int) and recalibrate.
        sigSaveRequested(object update): make the calibration of this ReportUpdate the app's.
        sigStopRequested(): STOP tapped or Esc pressed — stop the arm (the wizard stays open;
            ``set_estop`` shows the state; nothing here re-arms).

    Slots for the worker (GUI thread, queued): ``on_session``, ``on_live``, ``on_pairs``,
    ``on_progress``, ``on_report``, ``on_failed``; and ``on_saved`` for whoever saves.
    Live updates of another session or older than the one shown are dropped.
    """

    sigStartRequested = QtCore.Signal(object)
    sigAutoCaptureChanged = QtCore.Signal(bool)
    sigSnapshotRequested = QtCore.Signal()
    sigCalibrateRequested = QtCore.Signal()
    sigRemoveRequested = QtCore.Signal(object)
    sigSaveRequested = QtCore.Signal(object)

    def __init__(self, board: Optional[BoardSpec] = None, parent: Optional[QtWidgets.QWidget] = None) -> None:
        super().__init__(parent)
        self.setWindowTitle("Calibrate cameras")
        self.setModal(False)
        self.session_id: Optional[int] = None
        self.folder = ""
        self.numbers: tuple[int, ...] = ()
        self.coverage: Optional[Coverage] = None
        self.report_update = None
        self.last_live = None
        self.live_count = 0  # live updates shown (tests, diagnostics)
        self.last_printed: Optional[Path] = None  # the printable board saved last
        self._last_number = -1
        self._pending_live = None
        self._busy = False
        self._worst: list[int] = []
        self._bar_numbers: list[int] = []
        self._live_timer = QtCore.QTimer(self)
        self._live_timer.setSingleShot(True)
        self._live_timer.setInterval(LIVE_REDRAW_MS)
        self._live_timer.timeout.connect(self._draw_live)
        self._board_missing_since: Optional[float] = None  # camera time since when no view sees the board
        self._capture_board: Optional[BoardSpec] = None  # the board of the capture session started last

        self.title = _bold(QtWidgets.QLabel(), 1.15)
        self.close_button = touch_button("Close")
        self.close_button.clicked.connect(self.close)
        # the e-stop strip: above every page, never scrolled away, STOP where the window has it
        self.estop_engaged = False
        self.estop_label = QtWidgets.QLabel()
        self.estop_label.setWordWrap(True)
        self.estop_label.setMinimumWidth(120)
        self.stop_button = QtWidgets.QPushButton("STOP")
        self.stop_button.setStyleSheet(STOP_STYLE)
        self.stop_button.setMinimumHeight(STOP_PX)
        self.stop_button.setFocusPolicy(QtCore.Qt.FocusPolicy.NoFocus)
        self.stop_button.setToolTip("Emergency stop (Esc): the arm stops. Re-arm it in the main window.")
        stop_font = QtGui.QFont(self.stop_button.font())
        stop_font.setPointSize(15)
        stop_font.setBold(True)
        self.stop_button.setMinimumWidth(QtGui.QFontMetrics(stop_font).horizontalAdvance("STOPPED") + 40)
        self.stop_button.clicked.connect(self.request_stop)
        top = QtWidgets.QHBoxLayout()
        top.setSpacing(8)
        top.addWidget(self.title)
        top.addWidget(self.estop_label, 1)
        top.addWidget(self.stop_button)
        top.addSpacing(12)  # a finger aiming at STOP must not land on Close
        top.addWidget(self.close_button)
        self.stack = QtWidgets.QStackedWidget()
        self.stack.addWidget(self._build_board_page())
        self.stack.addWidget(self._build_capture_page())
        self.stack.addWidget(self._build_results_page())
        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(6, 4, 6, 6)
        layout.setSpacing(4)
        layout.addLayout(top)
        layout.addWidget(self.stack, 1)
        if board is not None:
            self.set_board(board)
        self._on_board_edited()
        self.set_page("board")
        self.set_estop(False)

    # ---------------------------------------------------------------------------- e-stop

    def set_estop(self, engaged: bool) -> None:
        """Show the arm's e-stop state: STOP greyed out while stopped (this wizard never re-arms)."""
        self.estop_engaged = bool(engaged)
        self.estop_label.setText(ESTOP_TEXT[self.estop_engaged])
        self.estop_label.setStyleSheet(_status_style("error") if self.estop_engaged else
                                       f"QLabel {{ color: {ERROR_COLOUR}; font-weight: bold; }}")
        self.stop_button.setText("STOPPED" if self.estop_engaged else "STOP")
        self.stop_button.setEnabled(not self.estop_engaged)


    # ---------------------------------------------------------------------------- page 2: capture
    def _build_capture_page(self) -> QtWidgets.QWidget:
        page = QtWidgets.QWidget()
        layout = QtWidgets.QVBoxLayout(page)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(4)
        views = QtWidgets.QHBoxLayout()
        views.setSpacing(4)
        self.left_pane = ImagePane("Left")
        self.right_pane = ImagePane("Right")
        views.addWidget(self.left_pane)
        views.addWidget(self.right_pane)
        layout.addLayout(views, 1)
        self.gate_label = QtWidgets.QLabel()
        self.gate_label.setWordWrap(True)
        self.gate_label.setMinimumHeight(28)
        layout.addWidget(self.gate_label)
        meters = QtWidgets.QHBoxLayout()
        meters.setSpacing(10)
        self.meters: dict[str, _Meter] = {}
        for name, title in METERS:
            m = _Meter(title)
            self.meters[name] = m
            meters.addWidget(m, 1)
        layout.addLayout(meters)
        buttons = QtWidgets.QHBoxLayout()
        self.board_button = touch_button("◀ Board")
        self.board_button.clicked.connect(lambda: self.set_page("board"))
        self.auto_button = touch_button("Auto capture", checkable=True)
        self.auto_button.setChecked(True)
        self.auto_button.setToolTip("Capture every accepted pose by itself: hold the board still in a new pose")
        self.auto_button.toggled.connect(self._on_auto_toggled)
        self.snapshot_button = touch_button("Snapshot")
        self.snapshot_button.setToolTip("Capture the pair shown now, even if it is similar to one already taken")
        self.snapshot_button.clicked.connect(self._on_snapshot)
        self.calibrate_button = touch_button("Calibrate (00) ▶")
        self.calibrate_button.clicked.connect(self._on_calibrate)
        for b in (self.board_button, self.auto_button, self.snapshot_button):
            buttons.addWidget(b)
        buttons.addStretch(1)
        buttons.addWidget(self.calibrate_button)
        layout.addLayout(buttons)
        self._update_calibrate_button()
        return page

    def _on_auto_toggled(self, on: bool) -> None:
        self.sigAutoCaptureChanged.emit(bool(on))

    def _on_snapshot(self) -> None:
        self.sigSnapshotRequested.emit()

    def _on_calibrate(self) -> None:
        self._start_busy("calibrating …")
        self.set_page("results")
        self.sigCalibrateRequested.emit()

    def _update_calibrate_button(self) -> None:
        n = len(self.numbers)
        self.calibrate_button.setText(f"Calibrate ({n}) ▶")
        self.calibrate_button.setEnabled(n >= MIN_PAIRS and not self._busy)

    def _set_gate_text(self, text: str, level: str) -> None:
        self.gate_label.setText(text)
        self.gate_label.setStyleSheet(_status_style(level))

    def _show_coverage(self, cov: Coverage) -> None:
        self.coverage = cov
        for name, value in cov.as_dict().items():
            self.meters[name].set_fraction(value)


    # ---------------------------------------------------------------------------- pages
    def set_page(self, name: str) -> None:
        """Show "board", "capture" or "results"."""
        k = PAGES.index(name)
        self.stack.setCurrentIndex(k)
        self.title.setText(("1 · Board", "2 · Capture pairs", "3 · Results")[k])

    def page(self) -> str:
        return PAGES[self.stack.currentIndex()]

    def show_adaptive(self) -> None:
        """Full screen on small screens (a 7" panel), a roomy dialog on desktops."""
        show_adaptive(self, (1180, 780))

    # ---------------------------------------------------------------------------- worker slots
    @QtCore.Slot(object)
    def on_session(self, info) -> None:
        """A capture session started (SessionInfo)."""
        self.session_id = info.session_id
        self.folder = info.folder
        self._last_number = -1
        self._board_missing_since = None
        self.numbers = ()
        self._update_calibrate_button()
        self._set_gate_text(f"{info.board_description} — show it to both cameras"
                            + (f"; pairs are saved in {info.folder}" if info.folder else ""), "info")

    @QtCore.Slot(object)
    def on_live(self, live) -> None:
        """One processed live frame (LiveUpdate); older or other-session ones are dropped."""
        if live.session_id != self.session_id or live.number <= self._last_number:
            return
        self._last_number = live.number
        self.last_live = live
        self.live_count += 1
        if live.left_ok or live.right_ok:
            self._board_missing_since = None
        elif self._board_missing_since is None or live.t < self._board_missing_since:
            self._board_missing_since = live.t  # (an earlier t: another camera; count from here)
        self._show_coverage(live.coverage)
        self._set_gate_text(*self._gate_text(live))
        self._pending_live = live
        if not self._live_timer.isActive():  # images at display rate, the newest only
            self._live_timer.start()

    def board_missing_s(self, live=None) -> float:
        """How long (camera time, s) no view has seen the board, up to the live update ``live``."""
        live = live if live is not None else self.last_live
        if live is None or self._board_missing_since is None or live.left_ok or live.right_ok:
            return 0.0
        return max(0.0, live.t - self._board_missing_since)

    def _gate_text(self, live) -> tuple[str, str]:
        g = live.gate
        if not (live.left_ok or live.right_ok) and self.board_missing_s(live) >= NO_BOARD_HINT_S:
            text = NO_CHARUCO_HINT if isinstance(self._capture_board, CharucoSpec) else NO_BOARD_HINT
            return text + (f" ({live.note})" if live.note else ""), "error"
        if live.captured is not None:
            hint = coverage_hint(live.coverage)
            return (f"✓ captured #{live.captured}" + (f" — now {hint}" if hint else
                                                      " — the meters are full: tap Calibrate"), "ok")
        if g.accepted:
            return ("✓ ready — tap Snapshot" if not live.auto_capture else "✓ capturing …"), "ok"
        reasons = list(g.reasons)
        if any("too close to capture" in r for r in reasons):
            hint = coverage_hint(live.coverage)
            reasons = [r.split(" — ")[0] + (f" — {hint}" if hint else " — try a new pose")
                       if "too close to capture" in r else r for r in reasons]
        text = "; ".join(reasons[:2])
        if live.note:
            text += f" ({live.note})"
        return text, "warn" if (live.left_ok and live.right_ok) else "error"

    def _draw_live(self) -> None:
        live, self._pending_live = self._pending_live, None
        if live is None:
            return
        self.left_pane.set_image(live.left)
        self.right_pane.set_image(live.right)
        self.left_pane.set_caption("Left ✓" if live.left_ok else "Left: no board")
        self.right_pane.set_caption("Right ✓" if live.right_ok else "Right: no board")

    def flush_live(self) -> None:
        """Draw a pending live frame now (tests, screenshots)."""
        if self._live_timer.isActive():
            self._live_timer.stop()
        self._draw_live()

    def set_camera_problem(self, message: str) -> None:
        """The cameras stopped delivering frames (message) or are back (""): say so on the capture page,
        where the window's banner may be hidden behind a full-screen wizard."""
        if message:
            self._set_gate_text(f"no pictures: {message} — the live views resume when the camera is back", "error")
        elif self.last_live is not None:
            self._set_gate_text(*self._gate_text(self.last_live))

    @QtCore.Slot(object)
    def on_pairs(self, update) -> None:
        """The captured pairs changed (PairsUpdate)."""
        if update.session_id != self.session_id:
            return
        self.numbers = tuple(update.numbers)
        self._show_coverage(update.coverage)
        self._update_calibrate_button()
        if update.added is not None and update.manual:
            self._set_gate_text(f"✓ snapshot captured #{update.added}", "ok")

    @QtCore.Slot(float, str)
    def on_progress(self, fraction: float, message: str) -> None:
        """Calibration progress 0 … 1."""
        self.progress_bar.setValue(int(round(1000 * min(1.0, max(0.0, fraction)))))
        self.progress_bar.setFormat(f"{message} — %p %")

    @QtCore.Slot(object)
    def on_report(self, update) -> None:
        """A finished calibration (ReportUpdate): numbers, plot, list, preview (``ResultsPage``)."""
        if update.session_id != self.session_id:
            return
        self._show_report(update)

    @QtCore.Slot(str)
    def on_failed(self, message: str) -> None:
        """A user action failed: say why where the user is looking."""
        self._busy = False
        if self.page() == "results":
            self.progress_bar.setFormat("failed")
            self.progress_bar.hide()
            self.summary_label.setText(message)
            self.summary_label.setStyleSheet(f"QLabel {{ color: {ERROR_COLOUR}; font-weight: bold; }}")
        else:
            self._set_gate_text(message, "error")
        self._update_result_buttons()
        self._update_calibrate_button()

    @QtCore.Slot(str, str)
    def on_saved(self, path: str, ros_folder: str = "") -> None:
        """The calibration was installed at ``path`` (and exported for ROS to ``ros_folder``)."""
        self._show_saved(path, ros_folder)


__all__ = ["CalibrationWizard", "ImagePane", "coverage_hint", "worst_count", "PAGES", "board_picture",
           "save_printable_board", "NO_BOARD_HINT", "NO_BOARD_HINT_S"]
