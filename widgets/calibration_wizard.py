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
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Optional, Union

import cv2
import numpy as np
import pyqtgraph as pg
from PySide6 import QtCore, QtGui, QtWidgets

from core.vision.board_print import (
    CAPTION_MM,
    PAGE_MARGIN_MM,
    PRINT_DPI,
    board_caption,
    board_print_image,
    choose_page,
    default_file_stem,
    printed_size_mm,
    px_per_mm,
    save_board_png,
)
from core.vision.stereo_calibration import (
    ARUCO_DICTIONARY_NAMES,
    BoardError,
    BoardSpec,
    CharucoSpec,
    ChessboardSpec,
    Coverage,
    rms_verdict,
)
from widgets._style import (
    show_adaptive,
    ACCENT_COLOUR,
    ERROR_COLOUR,
    OK_COLOUR,
    TOUCH_PX,
    WARN_COLOUR,
    TouchDoubleSpinBox,
    touch_button,
    touch_combo,
)
from widgets._plots import static_bar_plot
from widgets.estop import StopDialog
from widgets.file_dialog import open_file_dialog

PAGES = ("board", "capture", "results")
METERS = (("x", "X"), ("y", "Y"), ("size", "Size"), ("skew", "Skew"))
MIN_PAIRS = 4  # CalibrationOptions.min_pairs: Calibrate is enabled from here
GOOD_PAIRS = 12  # a hint: fewer rarely pins down the distortion
LIVE_REDRAW_MS = 15
CHECKBOX_STYLE = f"""
QCheckBox {{ min-height: {TOUCH_PX}px; spacing: 8px; }}
QCheckBox::indicator {{ width: 26px; height: 26px; }}
"""
USED_BRUSH = pg.mkBrush(58, 123, 213)
WORST_BRUSH = pg.mkBrush(211, 47, 47)
REJECTED_BRUSH = pg.mkBrush(160, 160, 160)
SELECTED_PEN = pg.mkPen("#ffd54f", width=3)
STOP_PX = TOUCH_PX + 8  # as tall as the window's STOP (widgets/estop.py)
STOP_STYLE = f"""
QPushButton {{
    min-height: {STOP_PX}px; min-width: 110px; font-size: 15pt; font-weight: bold; color: white;
    background: {ERROR_COLOUR}; border: 3px solid #7f0000; border-radius: 8px; padding: 0 14px;
}}
QPushButton:pressed {{ background: #7f0000; }}
QPushButton:disabled {{ background: #bdbdbd; color: #6d6d6d; border: 3px solid #9e9e9e; }}
"""
ESTOP_TEXT = {
    False: "Arm moving — STOP stops it",
    True: "ARM STOPPED (e-stop) — re-arm in the main window after closing this",
}
NO_BOARD_HINT_S = 3.0  # after this long (camera time) without a board the capture page says what to do
NO_BOARD_HINT = ("no board in view — hold the printed board so all of it is seen by both cameras; "
                 "print one with 'Save printable board…'")
NO_CHARUCO_HINT = ("no board in view — hold the printed board so both cameras see most of it; "
                   "print one with 'Save printable board…'")
PRINT_FILTERS = ("PDF, true size (*.pdf)", f"PNG image, {PRINT_DPI} dpi (*.png)")


def coverage_hint(cov: Coverage) -> str:
    """What to do next to fill the meters (the emptiest one first), "" when all are full."""
    hints = {
        "x": "move the board left and right, up to the image edges",
        "y": "move the board up and down, up to the image edges",
        "size": "bring the board closer so it fills more of the image",
        "skew": "tilt the board (up to about 45°) to the left, right, up and down",
    }
    values = cov.as_dict()
    name = min(values, key=values.get)
    return "" if values[name] >= 1.0 else hints[name]


def board_picture(board: BoardSpec, px_per_square: int = 24) -> np.ndarray:
    """The board as printed (BGR) with its inner corners — what the detector looks for — marked."""
    from core.sim.board_render import board_texture

    tex = board_texture(board, px_per_square)
    img = cv2.cvtColor(tex.image, cv2.COLOR_GRAY2BGR)
    pts = board.object_points()[:, :2].astype(np.float64)
    uv = (np.linalg.inv(tex.A) @ np.c_[pts, np.ones(len(pts))].T).T[:, :2]
    r = max(2, px_per_square // 6)
    for u, v in uv:
        cv2.circle(img, (int(round(u)), int(round(v))), r, (40, 40, 220), -1, cv2.LINE_AA)
    return img


def worst_count(used: int) -> int:
    """How many of the used pairs to mark as the worst: 1 below 8 pairs, then 2, then 3 from 16."""
    return 0 if used == 0 else 1 if used < 8 else 2 if used < 16 else 3


def _bold(label: QtWidgets.QLabel, scale: float = 1.0) -> QtWidgets.QLabel:
    font = label.font()
    font.setBold(True)
    if scale != 1.0:
        font.setPointSizeF(font.pointSizeF() * scale)
    label.setFont(font)
    return label


def _status_style(level: str) -> str:
    colour = {"ok": OK_COLOUR, "warn": WARN_COLOUR, "error": ERROR_COLOUR, "info": ACCENT_COLOUR}[level]
    return f"QLabel {{ background: {colour}; color: white; font-weight: bold; padding: 4px 8px; border-radius: 3px; }}"


class ImagePane(pg.GraphicsLayoutWidget):
    """A BGR image shown with its aspect ratio kept (no mouse pan/zoom), with a corner caption.

    Signals: none (pyqtgraph's own only).
    """

    def __init__(self, caption: str = "", parent: Optional[QtWidgets.QWidget] = None,
                 background=None) -> None:
        super().__init__(parent)
        if background is not None:
            self.setBackground(background)
        self.setMinimumSize(120, 90)
        self.ci.setContentsMargins(0, 0, 0, 0)
        self.view_box = self.addViewBox(row=0, col=0, lockAspect=True, invertY=True,
                                        enableMouse=False, enableMenu=False)
        self.view_box.disableAutoRange()
        self.view_box.setDefaultPadding(0.0)
        self.image_item = pg.ImageItem()
        self.image_item.setPos(-0.5, -0.5)
        self.view_box.addItem(self.image_item)
        self._shape: Optional[tuple[int, int]] = None
        self._caption = QtWidgets.QLabel(caption, self)
        self._caption.setStyleSheet("QLabel { background: rgba(0,0,0,150); color: white; padding: 2px 6px; }")
        self._caption.setAttribute(QtCore.Qt.WidgetAttribute.WA_TransparentForMouseEvents)
        self._caption.adjustSize()
        self._caption.setVisible(bool(caption))
        self.image: Optional[np.ndarray] = None

    def set_caption(self, text: str) -> None:
        self._caption.setText(text)
        self._caption.adjustSize()
        self._caption.setVisible(bool(text))

    def set_image(self, bgr: Optional[np.ndarray]) -> None:
        """Show a BGR or grey uint8 image (None clears it)."""
        self.image = bgr
        if bgr is None:
            self.image_item.clear()
            return
        rgb = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB) if bgr.ndim == 3 else bgr
        self.image_item.setImage(rgb, autoLevels=False, levels=(0, 255))
        shape = bgr.shape[:2]
        if shape != self._shape:  # fixed range, set only when the size changes
            self._shape = shape
            self.view_box.setRange(xRange=(-0.5, shape[1] - 0.5), yRange=(-0.5, shape[0] - 0.5), padding=0.0)

    def sizeHint(self) -> QtCore.QSize:  # noqa: N802 (Qt override)
        return QtCore.QSize(320, 240)


class _Meter(QtWidgets.QWidget):
    """One coverage meter: a name and a bar that turns from red to orange to green."""

    def __init__(self, title: str, parent: Optional[QtWidgets.QWidget] = None) -> None:
        super().__init__(parent)
        self.title = QtWidgets.QLabel(title)
        _bold(self.title)
        self.title.setMinimumWidth(self.title.fontMetrics().horizontalAdvance("Size") + 6)
        self.bar = QtWidgets.QProgressBar()
        self.bar.setRange(0, 100)
        self.bar.setTextVisible(True)
        self.bar.setFormat("%p %")
        self.bar.setMinimumHeight(22)
        self.bar.setMinimumWidth(70)
        layout = QtWidgets.QHBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(4)
        layout.addWidget(self.title)
        layout.addWidget(self.bar, 1)
        self._level = None
        self.set_fraction(0.0)

    def set_fraction(self, value: float) -> None:
        self.bar.setValue(int(round(100 * min(1.0, max(0.0, value)))))
        level = "ok" if value >= 1.0 else "warn" if value >= 0.5 else "error"
        if level != self._level:  # restyle only on a change: stylesheets are not free
            self._level = level
            colour = {"ok": OK_COLOUR, "warn": WARN_COLOUR, "error": ERROR_COLOUR}[level]
            self.bar.setStyleSheet(f"QProgressBar {{ border: 1px solid #888; border-radius: 3px; text-align: center; }}"
                                   f"QProgressBar::chunk {{ background: {colour}; }}")

    def value(self) -> float:
        return self.bar.value() / 100.0


class CalibrationWizard(StopDialog):
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


    # ---------------------------------------------------------------------------- page 1: board
    def _build_board_page(self) -> QtWidgets.QWidget:
        page = QtWidgets.QWidget()
        outer = QtWidgets.QHBoxLayout(page)
        outer.setContentsMargins(0, 0, 0, 0)
        form = QtWidgets.QWidget()
        self.board_preview = ImagePane("the board, inner corners marked",
                                       background=self.palette().color(QtGui.QPalette.ColorRole.Window))
        outer.addWidget(form, 3)
        outer.addWidget(self.board_preview, 2)
        grid = QtWidgets.QGridLayout(form)
        grid.setContentsMargins(0, 0, 0, 0)
        grid.setHorizontalSpacing(8)
        grid.setColumnStretch(1, 1)
        grid.setColumnStretch(3, 1)
        self.kind_buttons: dict[str, QtWidgets.QPushButton] = {}
        kinds = QtWidgets.QHBoxLayout()
        group = QtWidgets.QButtonGroup(page)
        group.setExclusive(True)
        for kind, text in (("chessboard", "Chessboard"), ("charuco", "ChArUco")):
            b = touch_button(text, checkable=True)
            group.addButton(b)
            b.toggled.connect(self._on_board_edited)
            kinds.addWidget(b)
            self.kind_buttons[kind] = b
        self.kind_buttons["chessboard"].setChecked(True)
        grid.addWidget(QtWidgets.QLabel("Board"), 0, 0)
        grid.addLayout(kinds, 0, 1, 1, 3)

        def spin(lo, hi, value, decimals=0, step=1.0, suffix=""):
            box = TouchDoubleSpinBox(lo, hi, decimals, step, suffix)
            box.setValue(value)
            box.valueChanged.connect(self._on_board_edited)
            return box

        self.fields: dict[str, QtWidgets.QWidget] = {
            "cols": spin(3, 40, 9), "rows": spin(3, 40, 6),
            "squares_x": spin(3, 40, 5), "squares_y": spin(3, 40, 7),
            "square_mm": spin(2, 500, 25.0, 1, 0.5, " mm"), "marker_mm": spin(1, 499, 18.0, 1, 0.5, " mm"),
        }
        combo = touch_combo(QtWidgets.QComboBox())  # 44 px rows, no wheel surprises
        combo.addItems(list(ARUCO_DICTIONARY_NAMES))
        combo.setCurrentText("DICT_4X4_50")
        combo.setMinimumHeight(TOUCH_PX)
        combo.currentIndexChanged.connect(self._on_board_edited)
        self.fields["dictionary"] = combo
        legacy = QtWidgets.QCheckBox("legacy layout (boards from OpenCV < 4.6)")
        legacy.setStyleSheet(CHECKBOX_STYLE)
        legacy.toggled.connect(self._on_board_edited)
        self.fields["legacy"] = legacy

        self._chess_rows = [
            (QtWidgets.QLabel("Inner corners"), self.fields["cols"], QtWidgets.QLabel("×"), self.fields["rows"]),
        ]
        self._charuco_rows = [
            (QtWidgets.QLabel("Squares"), self.fields["squares_x"], QtWidgets.QLabel("×"), self.fields["squares_y"]),
            (QtWidgets.QLabel("Marker side"), self.fields["marker_mm"], QtWidgets.QLabel("Dictionary"),
             self.fields["dictionary"]),
        ]
        row = 1
        for widgets in self._chess_rows + self._charuco_rows:
            for col, w in enumerate(widgets):
                grid.addWidget(w, row, col)
            row += 1
        grid.addWidget(QtWidgets.QLabel("Square side"), row, 0)
        grid.addWidget(self.fields["square_mm"], row, 1)
        row += 1
        grid.addWidget(legacy, row, 1, 1, 3)
        row += 1
        self.board_help = QtWidgets.QLabel()
        self.board_help.setWordWrap(True)
        grid.addWidget(self.board_help, row, 0, 1, 4)
        # after "Save printable board…" what was saved and how to print it, in board_help's place
        # (no extra row: the page already fills a 800×480 screen)
        self.print_label = QtWidgets.QLabel()
        self.print_label.setWordWrap(True)
        self.print_label.setTextInteractionFlags(QtCore.Qt.TextInteractionFlag.TextSelectableByMouse)
        self.print_label.hide()
        grid.addWidget(self.print_label, row, 0, 1, 4)
        row += 1
        self.board_error = QtWidgets.QLabel()
        self.board_error.setWordWrap(True)
        self.board_error.setStyleSheet(_status_style("error"))
        grid.addWidget(self.board_error, row, 0, 1, 4)
        row += 1
        grid.setRowStretch(row, 1)
        self.print_button = touch_button("Save printable board…")
        self.print_button.setToolTip(f"Save the board above as a PDF at true size or a {PRINT_DPI} dpi PNG, "
                                     "to print at 100 %")
        self.print_button.clicked.connect(self._on_save_printable)
        self.start_button = touch_button("Start capturing ▶")
        self.start_button.clicked.connect(self._on_start)
        buttons = QtWidgets.QHBoxLayout()
        buttons.addWidget(self.print_button)
        buttons.addStretch(1)
        buttons.addWidget(self.start_button)
        grid.addLayout(buttons, row + 1, 0, 1, 4)
        return page

    def board(self) -> BoardSpec:
        """The board the fields describe (BoardError with the reason when they do not fit)."""
        f = self.fields
        square_m = f["square_mm"].value() / 1e3
        if self.kind_buttons["chessboard"].isChecked():
            return ChessboardSpec(int(f["cols"].value()), int(f["rows"].value()), square_m)
        return CharucoSpec(int(f["squares_x"].value()), int(f["squares_y"].value()), square_m,
                           f["marker_mm"].value() / 1e3, f["dictionary"].currentText(), f["legacy"].isChecked())

    def set_board(self, board: BoardSpec) -> None:
        """Fill the fields from ``board``."""
        f = self.fields
        f["square_mm"].setValue(board.square_m * 1e3)
        if isinstance(board, ChessboardSpec):
            self.kind_buttons["chessboard"].setChecked(True)
            f["cols"].setValue(board.cols)
            f["rows"].setValue(board.rows)
        else:
            self.kind_buttons["charuco"].setChecked(True)
            f["squares_x"].setValue(board.squares_x)
            f["squares_y"].setValue(board.squares_y)
            f["marker_mm"].setValue(board.marker_m * 1e3)
            f["dictionary"].setCurrentText(board.dictionary)
            f["legacy"].setChecked(board.legacy)
        self._on_board_edited()

    def _on_board_edited(self, *_args) -> None:
        if not hasattr(self, "board_error"):  # still building the page
            return
        self.print_label.hide()  # it named the board saved before this edit
        self.board_help.show()
        chess = self.kind_buttons["chessboard"].isChecked()
        for widgets in self._chess_rows:
            for w in widgets:
                w.setVisible(chess)
        for widgets in self._charuco_rows:
            for w in widgets:
                w.setVisible(not chess)
        self.fields["legacy"].setVisible(not chess)
        self.board_help.setText(
            "Count the inner corners, where four squares meet: a board of 10×7 squares has 9×6. "
            "Measure a square on the print and glue the board to something flat." if chess else
            "Count the squares (markers sit in the white ones); measure a square and a marker on the print. "
            "The board may be partly out of view.")
        try:
            board = self.board()
        except BoardError as exc:
            self.board_error.setText(str(exc))
            self.board_error.show()
            self.start_button.setEnabled(False)
        else:
            self.board_error.hide()
            self.start_button.setEnabled(True)
            self.start_button.setToolTip(board.describe())
            self.board_preview.set_image(board_picture(board))

    def _board_or_say_why(self) -> Optional[BoardSpec]:
        """The board the page describes, or None with the reason shown under it."""
        try:
            return self.board()
        except BoardError as exc:
            self.board_error.setText(str(exc))
            self.board_error.show()
            return None

    def _on_save_printable(self) -> None:
        """Ask where, then write the board as a PDF (true size) or a 300 dpi PNG, by the suffix."""
        board = self._board_or_say_why()
        if board is None:
            return
        start = str(Path.home() / f"{default_file_stem(board)}.pdf")

        def chosen(path: str, name_filter: str) -> None:
            target = Path(path)
            if target.suffix.lower() not in (".pdf", ".png"):
                target = target.with_name(target.name + (".png" if name_filter == PRINT_FILTERS[1] else ".pdf"))
            self.save_printable(board, target)

        # Qt's own dialog with STOP, not modal: Esc stops the arm and the window's STOP stays live
        self.file_dialog = open_file_dialog(self, "Save printable board", chosen, start, ";;".join(PRINT_FILTERS),
                                            save=True, selected_filter=PRINT_FILTERS[0])

    def save_printable(self, board: BoardSpec, path: Union[str, Path]) -> Optional[Path]:
        """Write ``board`` to ``path`` (``save_printable_board``) and say on the page what to do next."""
        try:
            written = save_printable_board(board, path)
        except (OSError, ValueError) as exc:
            self._show_print_result(f"could not save the printable board: {exc} — choose another folder or name",
                                    "error", str(path))
            return None
        square = f"{board.square_m * 1e3:g} mm"
        self._show_print_result(f"✓ saved {_short(str(written))} — print it at 100 % / actual size (no 'fit to "
                                f"page'), then measure one square: it must be {square}", "ok", str(written))
        self.last_printed = written
        return written

    def _show_print_result(self, text: str, level: str, tooltip: str = "") -> None:
        self.print_label.setText(text)
        self.print_label.setToolTip(tooltip)
        self.print_label.setStyleSheet(_status_style(level))
        self.board_help.hide()
        self.print_label.show()

    def _on_start(self) -> None:
        board = self._board_or_say_why()
        if board is None:
            return
        self.session_id = None  # updates from the old session are stale from now on
        self._board_missing_since = None
        self._capture_board = board
        self.numbers = ()
        self.coverage = None
        self.report_update = None
        self._last_number = -1
        self.left_pane.set_image(None)
        self.right_pane.set_image(None)
        self._show_coverage(Coverage(0, 0, 0, 0, 0, False))
        self._set_gate_text("waiting for the cameras …", "info")
        self.set_page("capture")
        self.sigStartRequested.emit(board)

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

    # ---------------------------------------------------------------------------- page 3: results
    def _build_results_page(self) -> QtWidgets.QWidget:
        page = QtWidgets.QWidget()
        layout = QtWidgets.QVBoxLayout(page)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(4)
        self.progress_bar = QtWidgets.QProgressBar()
        self.progress_bar.setRange(0, 1000)
        self.progress_bar.setMinimumHeight(24)
        layout.addWidget(self.progress_bar)
        numbers = QtWidgets.QGridLayout()
        numbers.setHorizontalSpacing(12)
        numbers.setVerticalSpacing(0)
        self.rms_labels: dict[str, QtWidgets.QLabel] = {}
        for col, (key, title) in enumerate((("left", "RMS left"), ("right", "RMS right"),
                                            ("stereo", "Stereo RMS"), ("epipolar", "Epipolar error"))):
            name = QtWidgets.QLabel(title)
            value = _bold(QtWidgets.QLabel("—"), 1.3)
            numbers.addWidget(name, 0, col)
            numbers.addWidget(value, 1, col)
            self.rms_labels[key] = value
        layout.addLayout(numbers)
        self.summary_label = QtWidgets.QLabel()
        self.summary_label.setWordWrap(True)
        layout.addWidget(self.summary_label)

        body = QtWidgets.QHBoxLayout()
        body.setSpacing(6)
        left = QtWidgets.QVBoxLayout()
        left.setSpacing(4)
        self.error_plot, self._bars = static_bar_plot("error (px)", "capture")
        self.error_plot.scene().sigMouseClicked.connect(self._on_plot_clicked)
        left.addWidget(self.error_plot, 3)
        self.pair_list = QtWidgets.QListWidget()
        self.pair_list.setSelectionMode(QtWidgets.QAbstractItemView.SelectionMode.MultiSelection)
        self.pair_list.setMinimumHeight(TOUCH_PX + 8)
        self.pair_list.verticalScrollBar().setStyleSheet("QScrollBar:vertical { width: 26px; }")
        self.pair_list.itemSelectionChanged.connect(self._on_selection_changed)
        QtWidgets.QScroller.grabGesture(self.pair_list.viewport(), QtWidgets.QScroller.ScrollerGestureType.TouchGesture)
        left.addWidget(self.pair_list, 2)
        body.addLayout(left, 1)
        right = QtWidgets.QVBoxLayout()
        right.setSpacing(2)
        self.preview_pane = ImagePane("rectified: features must sit on the same line")
        right.addWidget(self.preview_pane, 1)
        self.saved_label = QtWidgets.QLabel()
        self.saved_label.setWordWrap(True)
        self.saved_label.setTextInteractionFlags(QtCore.Qt.TextInteractionFlag.TextSelectableByMouse)
        self.saved_label.hide()
        right.addWidget(self.saved_label)
        body.addLayout(right, 1)
        layout.addLayout(body, 1)

        buttons = QtWidgets.QHBoxLayout()
        self.more_button = touch_button("◀ Capture more")
        self.more_button.clicked.connect(lambda: self.set_page("capture"))
        self.remove_worst_button = touch_button("Remove worst (#000)")
        self.remove_worst_button.setToolTip("Drop the pair with the largest error and calibrate again")
        self.remove_worst_button.clicked.connect(self._on_remove_worst)
        self.remove_selected_button = touch_button("Remove selected")
        self.remove_selected_button.setToolTip("Drop the pairs selected in the list (or tapped in the plot)")
        self.remove_selected_button.clicked.connect(self._on_remove_selected)
        self.save_button = touch_button("Save and use")
        self.save_button.setToolTip("Make this the app's calibration: perception and disparity switch to it now")
        self.save_button.clicked.connect(self._on_save)
        for b in (self.more_button, self.remove_worst_button, self.remove_selected_button):
            buttons.addWidget(b)
        buttons.addStretch(1)
        buttons.addWidget(self.save_button)
        layout.addLayout(buttons)
        self._update_result_buttons()
        return page

    def _start_busy(self, text: str) -> None:
        self._busy = True
        self.progress_bar.setValue(0)
        self.progress_bar.setFormat(text)
        self.progress_bar.show()
        self._update_result_buttons()
        self._update_calibrate_button()

    def _update_result_buttons(self) -> None:
        ok = self.report_update is not None and not self._busy
        self.remove_worst_button.setEnabled(ok and bool(self._worst))
        self.remove_worst_button.setText(f"Remove worst (#{self._worst[0]})" if self._worst else "Remove worst")
        self.remove_selected_button.setEnabled(ok and bool(self.pair_list.selectedItems()))
        report = self.report_update.report if self.report_update is not None else None
        self.save_button.setEnabled(ok and bool(getattr(report, "ok", True)))  # never install a failed check
        self.more_button.setEnabled(not self._busy)

    def _on_selection_changed(self) -> None:
        self._update_result_buttons()
        self._colour_bars()

    def _on_plot_clicked(self, event) -> None:
        """A tap on the plot selects (or unselects) the nearest bar's pair in the list."""
        if not self._bar_numbers or event.button() != QtCore.Qt.MouseButton.LeftButton:
            return
        vb = self.error_plot.getPlotItem().vb
        if not vb.sceneBoundingRect().contains(event.scenePos()):
            return
        x = vb.mapSceneToView(event.scenePos()).x()
        k = int(round(x))
        if 0 <= k < len(self._bar_numbers):
            self.select_pair(self._bar_numbers[k], toggle=True)

    def select_pair(self, number: int, toggle: bool = False) -> None:
        """Select the list row of capture ``number`` (toggle: unselect if selected)."""
        for i in range(self.pair_list.count()):
            item = self.pair_list.item(i)
            if item.data(QtCore.Qt.ItemDataRole.UserRole) == number:
                item.setSelected(not item.isSelected() if toggle else True)
                self.pair_list.scrollToItem(item)

    def selected_numbers(self) -> tuple[int, ...]:
        return tuple(sorted(int(i.data(QtCore.Qt.ItemDataRole.UserRole)) for i in self.pair_list.selectedItems()))

    def _on_remove_worst(self) -> None:
        if self._worst:
            self._request_remove((self._worst[0],))

    def _on_remove_selected(self) -> None:
        numbers = self.selected_numbers()
        if numbers:
            self._request_remove(numbers)

    def _request_remove(self, numbers: tuple[int, ...]) -> None:
        self._start_busy(f"removing #{', #'.join(map(str, numbers))} and calibrating again …")
        self.saved_label.hide()
        self.sigRemoveRequested.emit(tuple(numbers))

    def _on_save(self) -> None:
        if self.report_update is not None:
            self.sigSaveRequested.emit(self.report_update)

    def _colour_bars(self) -> None:
        if not self._bar_numbers or self.report_update is None:
            return
        selected = set(self.selected_numbers())
        brushes, pens = [], []
        rep, numbers = self.report_update.report, self.report_update.numbers
        for p in rep.pairs:
            n = numbers[p.index]
            brushes.append(REJECTED_BRUSH if not p.used else WORST_BRUSH if n in self._worst else USED_BRUSH)
            pens.append(SELECTED_PEN if n in selected else pg.mkPen(None))
        self._bars.setOpts(brushes=brushes, pens=pens)

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
        """A finished calibration (ReportUpdate): numbers, plot, list, preview."""
        if update.session_id != self.session_id:
            return
        self._busy = False
        self.report_update = update
        rep = update.report
        self.rms_labels["left"].setText(f"{rep.rms_left:.3f} px")
        self.rms_labels["right"].setText(f"{rep.rms_right:.3f} px")
        self.rms_labels["stereo"].setText(f"{rep.rms_stereo:.3f} px")
        self.rms_labels["epipolar"].setText(f"{rep.epipolar_error_px:.3f} px")
        c = rep.calibration
        verdict = rms_verdict(rep.rms_stereo, rep.epipolar_error_px)
        summary = (f"{rep.pairs_used} of {rep.pairs_total} pairs used · baseline {c.baseline_m * 1e3:.1f} mm · "
                   f"fx {c.M1[0, 0]:.0f} / {c.M2[0, 0]:.0f} px · {rep.duration_s:.1f} s")
        problems = list(getattr(rep, "problems", ()) or ())
        notes = [verdict] if verdict else ["good: errors below 0.5 px"]
        if problems:  # a sanity check failed: said first, and Save and use stays off
            notes = [f"NOT INSTALLABLE — {p}" for p in problems] + notes
            consequences = list(getattr(rep, "consequences", ()) or ())
            if consequences:  # checks that failed only because of the problem above, after it
                notes.insert(len(problems), "which also explains: " + "; ".join(consequences))
        notes += list(rep.notes)
        self.summary_label.setText(summary + "\n" + "\n".join(notes))
        bad = problems or "warning" in verdict
        self.summary_label.setStyleSheet(f"QLabel {{ color: {ERROR_COLOUR if bad else WARN_COLOUR if verdict else OK_COLOUR}; }}")
        used = sum(p.used for p in rep.pairs)
        self._worst = [update.numbers[k] for k in rep.worst(worst_count(used))]
        self._fill_pairs(update)
        self.preview_pane.set_image(update.preview)
        if update.preview_number is not None:
            self.preview_pane.set_caption(f"#{update.preview_number} rectified: features must sit on the same line")
        self.progress_bar.setValue(1000)
        self.progress_bar.setFormat("calibrated")
        self.progress_bar.hide()  # the numbers say it all; the row is worth more on a small screen
        self._update_result_buttons()
        self._update_calibrate_button()

    def _fill_pairs(self, update) -> None:
        rep, numbers = update.report, update.numbers
        self.pair_list.blockSignals(True)
        self.pair_list.clear()
        order = sorted(rep.pairs, key=lambda p: (not p.used, -(p.error_px or 0.0)))
        for p in order:
            n = numbers[p.index]
            if p.used:
                text = f"#{n}   {p.error_px:.3f} px   (epipolar {p.epipolar_px or 0:.3f} px)"
                if n in self._worst:
                    text += "   ◀ worst"
            else:
                text = f"#{n}   rejected: {p.reason}"
            item = QtWidgets.QListWidgetItem(text)
            item.setData(QtCore.Qt.ItemDataRole.UserRole, int(n))
            item.setSizeHint(QtCore.QSize(0, TOUCH_PX))
            if not p.used or n in self._worst:
                item.setForeground(QtGui.QBrush(QtGui.QColor(ERROR_COLOUR if n in self._worst else "#777777")))
            self.pair_list.addItem(item)
        self.pair_list.blockSignals(False)
        # the plot: one bar per pair in capture order; rejected pairs grey, the worst red
        xs = np.arange(len(rep.pairs), dtype=float)
        heights = [p.error_px if p.error_px is not None else 0.0 for p in rep.pairs]
        self._bar_numbers = [numbers[p.index] for p in rep.pairs]
        self._bars.setOpts(x=xs, height=heights, width=0.7)
        self._colour_bars()
        top = max([h for h in heights if math.isfinite(h)] + [0.1]) * 1.15
        self.error_plot.setXRange(-0.6, len(rep.pairs) - 0.4, padding=0)
        self.error_plot.setYRange(0, top, padding=0)
        step = max(1, int(math.ceil(len(rep.pairs) / 12)))
        ticks = [(float(k), str(n)) for k, n in enumerate(self._bar_numbers) if k % step == 0]
        self.error_plot.getAxis("bottom").setTicks([ticks])

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
        self.saved_label.setText(f"✓ Saved and in use: {_short(path)}"
                                 + (f" · ROS camera_info and pairs in {_short(self.folder)}" if self.folder else ""))
        details = [f"calibration: {path}"]
        if ros_folder:
            details.append(f"ROS camera_info (left.yaml, right.yaml): {ros_folder}")
        if self.folder:
            details.append(f"captured pairs: {self.folder} — `deskarm calibrate --folder` redoes the calibration")
        self.saved_label.setToolTip("\n".join(details))
        self.saved_label.setStyleSheet(_status_style("ok"))
        self.saved_label.show()


def save_printable_board(board: BoardSpec, path: Union[str, Path]) -> Path:
    """Write ``board`` for printing: ``.png`` at 300 dpi (stored in the file) or ``.pdf`` at true
    size on the smallest A-sheet that holds it, with a caption saying how to check the print.

    The PDF needs a QGuiApplication (fonts). ValueError for another suffix or a board larger
    than A0; OSError when the file cannot be written.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".png":
        return save_board_png(board, path, PRINT_DPI)
    if suffix == ".pdf":
        return _save_board_pdf(board, path)
    raise ValueError(f"{path.name}: cannot save a board as {suffix or 'a file without a suffix'} — "
                     f"name it .pdf (true size) or .png ({PRINT_DPI} dpi)")


def _save_board_pdf(board: BoardSpec, path: Path) -> Path:
    name, page_w_mm, page_h_mm = choose_page(board)  # ValueError beyond A0, before touching the file
    if not path.parent.is_dir():
        raise OSError(f"{path.parent}: no such folder")
    img = board_print_image(board, PRINT_DPI)
    h, w = img.shape
    image = QtGui.QImage(img.data, w, h, int(img.strides[0]), QtGui.QImage.Format.Format_Grayscale8).copy()
    dots_per_m = int(round(PRINT_DPI / 0.0254))
    image.setDotsPerMeterX(dots_per_m)
    image.setDotsPerMeterY(dots_per_m)
    caption = board_caption(board)
    orientation = (QtGui.QPageLayout.Orientation.Landscape if page_w_mm > page_h_mm
                   else QtGui.QPageLayout.Orientation.Portrait)
    writer = QtGui.QPdfWriter(str(path))
    writer.setResolution(PRINT_DPI)
    writer.setPageLayout(QtGui.QPageLayout(QtGui.QPageSize(getattr(QtGui.QPageSize.PageSizeId, name)),
                                           orientation, QtCore.QMarginsF(0, 0, 0, 0),
                                           QtGui.QPageLayout.Unit.Millimeter))
    writer.setTitle(caption)
    writer.setCreator("deskarm")
    painter = QtGui.QPainter()
    if not painter.begin(writer):
        raise OSError(f"{path}: cannot write the PDF — check that the folder is writable")
    try:
        # the image's pixels are the device's (both 300 dpi): drawn 1:1, never resampled
        painter.setRenderHint(QtGui.QPainter.RenderHint.LosslessImageRendering)
        ppmm = px_per_mm(PRINT_DPI)
        board_w_mm, board_h_mm = printed_size_mm(board)
        x_mm = (page_w_mm - board_w_mm) / 2
        y_mm = PAGE_MARGIN_MM + (page_h_mm - 2 * PAGE_MARGIN_MM - CAPTION_MM - board_h_mm) / 2
        painter.drawImage(QtCore.QRectF(x_mm * ppmm, y_mm * ppmm, w, h), image)
        font = QtGui.QFont(painter.font())
        font.setPointSizeF(7.5)
        painter.setFont(font)
        painter.setPen(QtGui.QColor("black"))
        text_rect = QtCore.QRectF(PAGE_MARGIN_MM * ppmm, (y_mm + board_h_mm + 1.0) * ppmm,
                                  (page_w_mm - 2 * PAGE_MARGIN_MM) * ppmm, (CAPTION_MM + PAGE_MARGIN_MM / 2) * ppmm)
        painter.drawText(text_rect, int(QtCore.Qt.AlignmentFlag.AlignHCenter | QtCore.Qt.AlignmentFlag.AlignTop
                                        | QtCore.Qt.TextFlag.TextWordWrap), caption)
    finally:
        painter.end()
    if not path.is_file():
        raise OSError(f"{path}: the PDF was not written — check the free space and the folder's permissions")
    return path


def _short(path: str, keep: int = 2) -> str:
    """The last ``keep`` parts of a path, after "…/" when there are more (full paths go in tooltips)."""
    parts = [p for p in str(path).replace("\\", "/").split("/") if p]
    return str(path) if len(parts) <= keep else "…/" + "/".join(parts[-keep:])


__all__ = ["CalibrationWizard", "ImagePane", "coverage_hint", "worst_count", "PAGES", "board_picture",
           "save_printable_board", "NO_BOARD_HINT", "NO_BOARD_HINT_S"]
