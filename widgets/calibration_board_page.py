"""The calibration wizard's first page: choose the board (chessboard or ChArUco) with a live
preview, save it for printing (``save_printable_board``: a PNG at 300 dpi or a PDF at true size),
and Start the capture.

``BoardPage`` holds the page's code; ``CalibrationWizard`` (``widgets.calibration_wizard``) mixes it in
and owns the signals and the state it uses (``sigStartRequested``, ``set_page``, the capture
panes). Re-exported by ``widgets.calibration_wizard``.
"""
from __future__ import annotations

from pathlib import Path
from typing import Optional, Union

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
)
from widgets._style import TOUCH_PX, TouchDoubleSpinBox, touch_button, touch_combo
from widgets.calibration_wizard_parts import (
    CHECKBOX_STYLE,
    PRINT_FILTERS,
    ImagePane,
    board_picture,
    _short,
    _status_style,
)
from widgets.file_dialog import open_file_dialog


class BoardPage:
    """The board page of ``CalibrationWizard``: a mix-in that builds the page and handles its
    taps, with the wizard's attributes and signals (it has no state of its own)."""

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
