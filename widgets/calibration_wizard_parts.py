"""The calibration wizard's small parts, shared by its pages: the wizard's constants (pages, pair
counts, colours, the STOP strip's style, the capture hints), the coverage hint, a board's preview
picture, an image pane with a caption and a coverage meter. No page and no wizard state here.

Re-exported by ``widgets.calibration_wizard``.
"""
from __future__ import annotations

from typing import Optional

import cv2
import numpy as np
from PySide6 import QtCore, QtWidgets

from core.vision.board_print import PRINT_DPI
from core.vision.stereo_calibration import BoardSpec, Coverage
from widgets._pyqtgraph import pg
from widgets._style import ACCENT_COLOUR, ERROR_COLOUR, OK_COLOUR, TOUCH_PX, WARN_COLOUR
from widgets._style import bold_label as _bold
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


def _short(path: str, keep: int = 2) -> str:
    """The last ``keep`` parts of a path, after "…/" when there are more (full paths go in tooltips)."""
    parts = [p for p in str(path).replace("\\", "/").split("/") if p]
    return str(path) if len(parts) <= keep else "…/" + "/".join(parts[-keep:])
