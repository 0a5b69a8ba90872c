"""Teach the detector a new object: frames, a tap or a box on it, a progress bar, time left, Cancel.

The panel shows; it owns no camera and no training. Its owner (``app.features.teach.TeachFeature``)
feeds it frames (``set_frames``), runs the teaching and reports ``set_progress`` / ``set_done``.

The user types a name, presses "Take frames" (the owner collects frames while the user moves the
object), then marks the object on the shown frame: a tap on it, or a box dragged around it (once is
enough; the slider picks another frame to mark more, ≤ 10 marks). "Teach" starts; Cancel (≥ 44 px)
stops it and keeps the old model.

Signals (GUI thread):
- sigCaptureRequested(): take frames now.
- sigTeachRequested(str name, list marks): ``marks`` are ``core.detect.learned.teach.Mark``.
- sigCancelRequested(): stop teaching (the old model stays).
"""
from __future__ import annotations

from typing import Optional

import numpy as np
from PySide6 import QtCore, QtGui, QtWidgets

from widgets._style import ERROR_COLOUR, OK_COLOUR, TOUCH_PX

DRAG_PX = 8  # a press that moves less than this is a tap
MAX_MARKS = 10


class TeachCanvas(QtWidgets.QWidget):
    """One frame, scaled to fit; a tap or a dragged box on it is reported in image pixels."""

    sigTapped = QtCore.Signal(float, float)  # x, y (image px)
    sigBoxed = QtCore.Signal(float, float, float, float)  # x0, y0, x1, y1 (image px)

    def __init__(self, parent: Optional[QtWidgets.QWidget] = None):
        super().__init__(parent)
        self.setObjectName("teachCanvas")
        self.setMinimumSize(200, 150)
        self._image: Optional[QtGui.QImage] = None
        self._size = (0, 0)
        self._press: Optional[QtCore.QPointF] = None
        self._drag: Optional[QtCore.QPointF] = None
        self.marks: list[tuple] = []  # boxes (4) or taps (2) on the shown frame, image px

    def set_image(self, bgr: Optional[np.ndarray], marks: list[tuple] = ()) -> None:
        if bgr is None:
            self._image, self._size = None, (0, 0)
        else:
            rgb = np.ascontiguousarray(bgr[..., ::-1])
            h, w = rgb.shape[:2]
            self._image = QtGui.QImage(rgb.data, w, h, 3 * w, QtGui.QImage.Format.Format_RGB888).copy()
            self._size = (w, h)
        self.marks = list(marks)
        self.update()

    def _frame_rect(self) -> QtCore.QRectF:
        w, h = self._size
        if not w or not h:
            return QtCore.QRectF()
        s = min(self.width() / w, self.height() / h)
        return QtCore.QRectF((self.width() - s * w) / 2, (self.height() - s * h) / 2, s * w, s * h)

    def to_image(self, p: QtCore.QPointF) -> Optional[tuple[float, float]]:
        r = self._frame_rect()
        if r.isEmpty() or not r.contains(p):
            return None
        return ((p.x() - r.x()) * self._size[0] / r.width(), (p.y() - r.y()) * self._size[1] / r.height())

    def to_widget(self, x: float, y: float) -> QtCore.QPointF:
        r = self._frame_rect()
        return QtCore.QPointF(r.x() + x * r.width() / self._size[0], r.y() + y * r.height() / self._size[1])

    def mousePressEvent(self, event: QtGui.QMouseEvent) -> None:
        if self._image is not None and self.to_image(event.position()) is not None:
            self._press = self._drag = event.position()

    def mouseMoveEvent(self, event: QtGui.QMouseEvent) -> None:
        if self._press is not None:
            self._drag = event.position()
            self.update()

    def mouseReleaseEvent(self, event: QtGui.QMouseEvent) -> None:
        if self._press is None:
            return
        a, b = self._press, event.position()
        self._press = self._drag = None
        self.update()
        r = self._frame_rect()
        b = QtCore.QPointF(min(max(b.x(), r.left()), r.right() - 1e-3), min(max(b.y(), r.top()), r.bottom() - 1e-3))
        pa, pb = self.to_image(a), self.to_image(b)
        if pa is None or pb is None:
            return
        if abs(a.x() - b.x()) < DRAG_PX and abs(a.y() - b.y()) < DRAG_PX:
            self.sigTapped.emit(*pa)
        else:
            self.sigBoxed.emit(min(pa[0], pb[0]), min(pa[1], pb[1]), max(pa[0], pb[0]), max(pa[1], pb[1]))

    def paintEvent(self, event) -> None:
        p = QtGui.QPainter(self)
        p.fillRect(self.rect(), QtGui.QColor(40, 40, 40))
        if self._image is None:
            p.setPen(QtGui.QColor(200, 200, 200))
            p.drawText(self.rect(), QtCore.Qt.AlignmentFlag.AlignCenter, "no frames yet — press Take frames")
            return
        p.drawImage(self._frame_rect(), self._image)
        pen = QtGui.QPen(QtGui.QColor(OK_COLOUR), 2)
        p.setPen(pen)
        for m in self.marks:
            if len(m) == 4:
                p.drawRect(QtCore.QRectF(self.to_widget(m[0], m[1]), self.to_widget(m[2], m[3])))
            else:
                p.drawEllipse(self.to_widget(*m), 8, 8)
        if self._press is not None and self._drag is not None:
            p.setPen(QtGui.QPen(QtGui.QColor(255, 255, 255), 1, QtCore.Qt.PenStyle.DashLine))
            p.drawRect(QtCore.QRectF(self._press, self._drag).normalized())


class TeachPanel(QtWidgets.QWidget):
    """Name, frames, marks, Teach / Cancel (≥ 44 px), a progress bar and the time left."""

    sigCaptureRequested = QtCore.Signal()
    sigTeachRequested = QtCore.Signal(str, list)
    sigCancelRequested = QtCore.Signal()

    def __init__(self, parent: Optional[QtWidgets.QWidget] = None):
        super().__init__(parent)
        self.setObjectName("teachPanel")
        layout = QtWidgets.QVBoxLayout(self)
        row = QtWidgets.QHBoxLayout()
        row.addWidget(QtWidgets.QLabel("Name"))
        self.name_edit = QtWidgets.QLineEdit()
        self.name_edit.setPlaceholderText("e.g. mug")
        self.name_edit.setMinimumHeight(TOUCH_PX)
        row.addWidget(self.name_edit, 1)
        self.capture_button = QtWidgets.QPushButton("Take frames")
        row.addWidget(self.capture_button)
        layout.addLayout(row)
        self.hint = QtWidgets.QLabel("Take frames while you move the object, then tap it or draw a box around it.")
        self.hint.setWordWrap(True)
        layout.addWidget(self.hint)
        self.canvas = TeachCanvas()
        layout.addWidget(self.canvas, 1)
        self.frame_slider = QtWidgets.QSlider(QtCore.Qt.Orientation.Horizontal)
        self.frame_slider.setMinimumHeight(TOUCH_PX)
        self.frame_slider.setEnabled(False)
        layout.addWidget(self.frame_slider)
        self.progress = QtWidgets.QProgressBar()
        self.progress.setRange(0, 1000)
        self.progress.setValue(0)
        self.progress.setFormat("")
        layout.addWidget(self.progress)
        self.time_left = QtWidgets.QLabel("")
        self.time_left.setObjectName("teachTimeLeft")
        layout.addWidget(self.time_left)
        buttons = QtWidgets.QHBoxLayout()
        self.teach_button = QtWidgets.QPushButton("Teach")
        self.cancel_button = QtWidgets.QPushButton("Cancel")
        self.clear_button = QtWidgets.QPushButton("Clear marks")
        for b in (self.capture_button, self.teach_button, self.cancel_button, self.clear_button):
            b.setMinimumHeight(TOUCH_PX)
            b.setMinimumWidth(TOUCH_PX)
            b.setFocusPolicy(QtCore.Qt.FocusPolicy.NoFocus)
        for b in (self.teach_button, self.clear_button, self.cancel_button):
            buttons.addWidget(b)
        layout.addLayout(buttons)
        self.frames: list[np.ndarray] = []
        self.marks: dict[int, tuple] = {}  # frame index -> box (4) or tap (2)
        self._running = False
        self.capture_button.clicked.connect(self.sigCaptureRequested)
        self.teach_button.clicked.connect(self._on_teach)
        self.cancel_button.clicked.connect(self.sigCancelRequested)
        self.clear_button.clicked.connect(self.clear_marks)
        self.frame_slider.valueChanged.connect(self._show)
        self.canvas.sigTapped.connect(lambda x, y: self._mark((x, y)))
        self.canvas.sigBoxed.connect(lambda x0, y0, x1, y1: self._mark((x0, y0, x1, y1)))
        self.name_edit.textChanged.connect(lambda _t: self._update_buttons())
        self._update_buttons()

    # --- frames and marks -------------------------------------------------------------------
    def set_frames(self, frames: list[np.ndarray]) -> None:
        """The frames to teach from (BGR); marks start empty, the first frame is shown."""
        self.frames = list(frames)
        self.marks = {}
        self.frame_slider.blockSignals(True)
        self.frame_slider.setRange(0, max(0, len(self.frames) - 1))
        self.frame_slider.setValue(0)
        self.frame_slider.blockSignals(False)
        self.frame_slider.setEnabled(len(self.frames) > 1)
        self._show(0)
        self.hint.setText(f"{len(self.frames)} frames: tap the object or draw a box around it (≤ {MAX_MARKS} marks)."
                          if self.frames else "no frames")
        self._update_buttons()

    @property
    def current_frame(self) -> int:
        return int(self.frame_slider.value())

    def _show(self, index: int) -> None:
        if not self.frames:
            self.canvas.set_image(None)
            return
        index = int(min(max(index, 0), len(self.frames) - 1))
        self.canvas.set_image(self.frames[index], [self.marks[index]] if index in self.marks else [])

    def _mark(self, mark: tuple) -> None:
        if self._running or not self.frames:
            return
        i = self.current_frame
        if i not in self.marks and len(self.marks) >= MAX_MARKS:
            self.hint.setText(f"at most {MAX_MARKS} marks: the tracker carries the box between them")
            return
        self.marks[i] = tuple(float(v) for v in mark)
        self._show(i)
        self.hint.setText(f"{len(self.marks)} mark(s); Teach when ready, or mark another frame")
        self._update_buttons()

    def clear_marks(self) -> None:
        self.marks = {}
        self._show(self.current_frame)
        self._update_buttons()

    def mark_list(self) -> list:
        from core.detect.learned.teach import Mark

        return [Mark(frame=i, box=m) if len(m) == 4 else Mark(frame=i, tap=m) for i, m in sorted(self.marks.items())]

    # --- teaching -----------------------------------------------------------------------------
    @property
    def running(self) -> bool:
        return self._running

    def _on_teach(self) -> None:
        name = self.name_edit.text().strip()
        if not name or not self.marks:
            return
        self._running = True
        self.progress.setValue(0)
        self.time_left.setText("starting …")
        self.time_left.setStyleSheet("")
        self._update_buttons()
        self.sigTeachRequested.emit(name, self.mark_list())

    @QtCore.Slot(float, float, str)
    def set_progress(self, fraction: float, seconds_left: float, text: str = "") -> None:
        self._running = True
        self.progress.setValue(int(round(1000 * min(max(fraction, 0.0), 1.0))))
        self.progress.setFormat(f"{100 * min(max(fraction, 0.0), 1.0):.0f} %")
        if seconds_left != seconds_left:
            self.time_left.setText(text or "…")
        else:
            s = int(round(max(seconds_left, 0.0)))
            self.time_left.setText(f"{s // 60}:{s % 60:02d} left")
        self._update_buttons()

    @QtCore.Slot(bool, str)
    def set_done(self, ok: bool, text: str) -> None:
        self._running = False
        if ok:
            self.progress.setValue(1000)
        self.time_left.setText(text)
        self.time_left.setStyleSheet(f"color: {OK_COLOUR if ok else ERROR_COLOUR};")
        self._update_buttons()

    def _update_buttons(self) -> None:
        ready = bool(self.frames) and bool(self.marks) and bool(self.name_edit.text().strip())
        self.teach_button.setEnabled(ready and not self._running)
        self.capture_button.setEnabled(not self._running)
        self.clear_button.setEnabled(bool(self.marks) and not self._running)
        self.cancel_button.setEnabled(self._running)
        self.name_edit.setEnabled(not self._running)
