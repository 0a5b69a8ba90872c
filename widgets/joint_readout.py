"""A compact joint table: commanded and measured joint values against their limits."""
from __future__ import annotations

import math
from typing import Optional, Sequence

from PySide6 import QtCore, QtGui, QtWidgets

from widgets._style import ERROR_COLOUR, OK_COLOUR, WARN_COLOUR

NEAR_LIMIT_FRACTION = 0.10  # within 10 % of the range from a limit: orange
AT_LIMIT_FRACTION = 0.02  # within 2 %: red (the safety clamp is about to bite)
LEVEL_COLOURS = {"ok": OK_COLOUR, "near": WARN_COLOUR, "at": ERROR_COLOUR}
HEADERS_DEG = ("joint", "cmd °", "meas °", "limits °", "")
HEADERS_MIXED = ("joint", "cmd", "meas", "limits", "")  # units per row, in the limits column
# what the numbers are: a servo arm's table shows servo angles while the Jog tab shows the joint
# angles of the arm's model (the elbow's −118.3° there is its servo's 61.7° here)
SERVO_CAPTION = ("Servo angles, as sent to the board. The Jog tab shows joint angles (0° = joint "
                 "straight): the two differ by each servo's mounting offset.")
JOINT_CAPTION = "Joint values, as on the Jog tab (0° = joint straight)."


def limit_level(value_deg: Optional[float], min_deg: float, max_deg: float) -> str:
    """"ok", "near" or "at" a limit for one joint angle (None/NaN counts as "ok")."""
    if value_deg is None or not math.isfinite(value_deg) or max_deg <= min_deg:
        return "ok"
    margin = min(value_deg - min_deg, max_deg - value_deg) / (max_deg - min_deg)
    if margin <= AT_LIMIT_FRACTION:
        return "at"
    if margin <= NEAR_LIMIT_FRACTION:
        return "near"
    return "ok"


def _entry(values: Optional[Sequence[Optional[float]]], i: int) -> Optional[float]:
    if values is None or i >= len(values) or values[i] is None:
        return None
    return float(values[i])


def _worst(levels: Sequence[str]) -> str:
    order = ("ok", "near", "at")
    return max(levels, key=order.index)


class _LimitBar(QtWidgets.QWidget):
    """The joint's range as a bar: a thin tick for commanded, a block for measured."""

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.setMinimumSize(60, 18)
        self.setSizePolicy(QtWidgets.QSizePolicy.Policy.Expanding,
                           QtWidgets.QSizePolicy.Policy.Fixed)
        self.lo, self.hi = 0.0, 180.0
        self.commanded: Optional[float] = None
        self.measured: Optional[float] = None
        self.level = "ok"

    def sizeHint(self) -> QtCore.QSize:  # noqa: N802 (Qt override)
        return QtCore.QSize(100, 18)

    def _x(self, value: float, rect: QtCore.QRectF) -> float:
        f = (value - self.lo) / (self.hi - self.lo) if self.hi > self.lo else 0.5
        return rect.left() + min(max(f, 0.0), 1.0) * rect.width()

    def paintEvent(self, event) -> None:  # noqa: N802 (Qt override)
        painter = QtGui.QPainter(self)
        painter.setRenderHint(QtGui.QPainter.RenderHint.Antialiasing)
        rect = QtCore.QRectF(self.rect()).adjusted(3, 4, -3, -4)
        colour = QtGui.QColor(LEVEL_COLOURS[self.level])
        painter.setPen(QtGui.QPen(colour, 2))
        painter.setBrush(QtGui.QColor(128, 128, 128, 60))
        painter.drawRoundedRect(rect, 3, 3)
        if self.measured is not None and math.isfinite(self.measured):
            x = self._x(self.measured, rect)
            painter.setPen(QtCore.Qt.PenStyle.NoPen)
            painter.setBrush(colour)
            painter.drawRect(QtCore.QRectF(x - 4, rect.top(), 8, rect.height()))
        if self.commanded is not None and math.isfinite(self.commanded):
            x = self._x(self.commanded, rect)
            painter.setPen(QtGui.QPen(self.palette().color(QtGui.QPalette.ColorRole.WindowText),
                                      2))
            painter.drawLine(QtCore.QPointF(x, rect.top() - 3),
                             QtCore.QPointF(x, rect.bottom() + 3))
        painter.end()


class JointReadout(QtWidgets.QWidget):
    """Per joint: name, commanded and measured servo angles (deg), limits and a limit bar.

    The bar shows the range with the measured angle as a block and the commanded one as a
    tick; it turns orange within 10 % of a limit and red within 2 %. A caption above says which
    angles these are (servo angles, not the Jog tab's joint angles).

    Signals: none (display only).
    """

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        outer = QtWidgets.QVBoxLayout(self)
        outer.setContentsMargins(0, 0, 0, 0)
        self.caption = QtWidgets.QLabel(SERVO_CAPTION)
        self.caption.setWordWrap(True)
        self.caption.setContentsMargins(4, 2, 4, 0)
        outer.addWidget(self.caption)
        self._grid = QtWidgets.QGridLayout()
        outer.addLayout(self._grid)
        outer.addStretch(1)
        self._grid.setContentsMargins(4, 2, 4, 2)
        self._grid.setHorizontalSpacing(8)
        self._grid.setVerticalSpacing(2)
        self._grid.setColumnStretch(4, 1)
        self._headers: list[QtWidgets.QLabel] = []
        for col, text in enumerate(HEADERS_DEG):
            header = QtWidgets.QLabel(text)
            font = header.font()
            font.setBold(True)
            header.setFont(font)
            self._grid.addWidget(header, 0, col)
            self._headers.append(header)
        self._rows: list[tuple[QtWidgets.QLabel, ...]] = []
        self._bars: list[_LimitBar] = []
        self._min: list[float] = []
        self._max: list[float] = []
        self._levels: list[str] = []

    def set_joints(self, names: Sequence[str], min_deg: Sequence[float],
                   max_deg: Sequence[float], units: Optional[Sequence[str]] = None) -> None:
        """Lay out one row per joint with its limits (servo degrees).

        ``units`` names each joint's display unit when they are not all degrees (e.g. the
        UMI-RTX's column in "mm": ``JointSpec.display_unit``); the values and limits are then
        in those units and each row's limits say their unit. Without ``units`` the values are
        servo angles (a servo arm), with them the joints' own values, and the caption says so.
        """
        if not len(names) == len(min_deg) == len(max_deg):
            raise ValueError(f"set_joints: {len(names)} names, {len(min_deg)} minima and "
                             f"{len(max_deg)} maxima; expected the same count")
        if units is not None and len(units) != len(names):
            raise ValueError(f"set_joints: {len(units)} units for {len(names)} joints;"
                             " expected one unit per joint")
        mixed = units is not None and any(u not in ("deg", "°") for u in units)
        self.caption.setText(SERVO_CAPTION if units is None else JOINT_CAPTION)
        for header, text in zip(self._headers, HEADERS_MIXED if mixed else HEADERS_DEG):
            header.setText(text)
        for widgets in self._rows:
            for w in widgets:
                self._grid.removeWidget(w)
                w.deleteLater()
        for bar in self._bars:
            self._grid.removeWidget(bar)
            bar.deleteLater()
        self._rows, self._bars = [], []
        self._min = [float(v) for v in min_deg]
        self._max = [float(v) for v in max_deg]
        number_width = self.fontMetrics().horizontalAdvance("−180.0") + 4
        for i, name in enumerate(names):
            row = i + 1
            name_label = QtWidgets.QLabel(name)
            cmd = QtWidgets.QLabel("—")
            meas = QtWidgets.QLabel("—")
            for label in (cmd, meas):
                label.setMinimumWidth(number_width)
                label.setAlignment(QtCore.Qt.AlignmentFlag.AlignRight
                                   | QtCore.Qt.AlignmentFlag.AlignVCenter)
            unit = "" if not mixed else " " + ("°" if units[i] in ("deg", "°") else units[i])
            limits = QtWidgets.QLabel(f"{self._min[i]:.0f}…{self._max[i]:.0f}{unit}")
            bar = _LimitBar()
            bar.lo, bar.hi = self._min[i], self._max[i]
            for col, w in enumerate((name_label, cmd, meas, limits, bar)):
                self._grid.addWidget(w, row, col)
            self._rows.append((name_label, cmd, meas, limits))
            self._bars.append(bar)
        self._levels = ["ok"] * len(names)

    def set_values(self, commanded_deg: Optional[Sequence[float]],
                   measured_deg: Optional[Sequence[float]]) -> None:
        """Show commanded and measured angles (deg); None (whole or per joint) shows "—".

        Labels and bars whose values did not change are not touched (no relayout, no repaint).
        """
        for i, ((_, cmd, meas, _), bar) in enumerate(zip(self._rows, self._bars)):
            c, m = _entry(commanded_deg, i), _entry(measured_deg, i)
            for label, text in ((cmd, "—" if c is None else f"{c:.1f}"),
                                (meas, "—" if m is None else f"{m:.1f}")):
                if label.text() != text:
                    label.setText(text)
            level = _worst([limit_level(c, self._min[i], self._max[i]),
                            limit_level(m, self._min[i], self._max[i])])
            self._levels[i] = level
            if (bar.commanded, bar.measured, bar.level) != (c, m, level):
                bar.commanded, bar.measured, bar.level = c, m, level
                bar.update()

    def row_texts(self, row: int) -> tuple[str, str, str, str]:
        """(name, commanded, measured, limits) as shown in joint ``row``."""
        return tuple(label.text() for label in self._rows[row])  # type: ignore[return-value]

    def levels(self) -> list[str]:
        """Per joint: "ok", "near" or "at" a limit (worst of commanded and measured)."""
        return list(self._levels)
