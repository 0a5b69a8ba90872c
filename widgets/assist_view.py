"""The assistive view's camera: the hand camera's image with the selectable boxes, big and numbered.

``AssistView`` paints the latest hand-camera image scaled to fit (aspect kept, centred) and, over
it, every selectable box as a thick black-and-white frame with its number in a large label; the
highlighted box (scanning) gets a wide yellow frame on black and a tinted fill — high contrast on
any background; the chosen box (the arm is on its way) is drawn green. A tap (or click) outside
every box shows a brief acknowledgement — a grey ring and "not a button" — and nothing else.
A box and its number badge are one target: ``box_at`` finds the box under a point on either
(the badges sit half outside the outline, where a finger aiming at the big number lands).

The view only shows and reports: the window decides what a press means (a tap in touch mode,
a switch in the scanning modes).

Signals (GUI thread):
- sigPressed(str, object, object): a mouse button ("mouse:left", "mouse:right", "mouse:middle")
  went down over the view; the image point (x, y) in pixels (None outside the image) and the box
  under the press, outline or badge (its index, None when on none).
- sigReleased(str): that mouse button came up.

``SwitchSafeButton``: a push button that a switch press never clicks — in the switch modes a
mouse button that is a switch, pressed over it, is handed on as that switch (the window's ☰ menu).
"""
from __future__ import annotations

from typing import Callable, Optional, Sequence

import numpy as np
from PySide6 import QtCore, QtGui, QtWidgets

ACK_MS = 800  # how long the "not a button" acknowledgement stays
HIGHLIGHT_COLOUR = QtGui.QColor("#ffd600")  # yellow on black: the strongest contrast on a grey metal panel
CHOSEN_COLOUR = QtGui.QColor("#00e676")
LABEL_MIN_PX = 30  # the number labels are at least this tall on the screen

MOUSE_NAMES = {
    QtCore.Qt.MouseButton.LeftButton: "mouse:left",
    QtCore.Qt.MouseButton.RightButton: "mouse:right",
    QtCore.Qt.MouseButton.MiddleButton: "mouse:middle",
}


class AssistView(QtWidgets.QWidget):
    """The camera image with numbered boxes, a highlight, the chosen box and tap acknowledgements."""

    sigPressed = QtCore.Signal(str, object, object)
    sigReleased = QtCore.Signal(str)

    def __init__(self, parent: Optional[QtWidgets.QWidget] = None):
        super().__init__(parent)
        self.setMinimumSize(320, 240)
        self.setSizePolicy(QtWidgets.QSizePolicy.Policy.Expanding, QtWidgets.QSizePolicy.Policy.Expanding)
        self.setFocusPolicy(QtCore.Qt.FocusPolicy.NoFocus)
        self.setAttribute(QtCore.Qt.WidgetAttribute.WA_OpaquePaintEvent)
        self._image: Optional[QtGui.QImage] = None
        self._image_size = (640, 480)
        self.boxes: list[tuple[float, float, float, float]] = []
        self.highlight: Optional[int] = None
        self.chosen: Optional[int] = None
        self.chosen_centre: Optional[tuple[float, float]] = None
        self.chosen_radius: Optional[float] = None
        self.message = ""  # shown across the image when there is nothing to choose
        self._ack_point: Optional[tuple[float, float]] = None
        self._ack_timer = QtCore.QTimer(self)
        self._ack_timer.setSingleShot(True)
        self._ack_timer.setInterval(ACK_MS)
        self._ack_timer.timeout.connect(self._clear_ack)

    # -- what to show --------------------------------------------------------------------------

    def set_image(self, image_bgr: np.ndarray) -> None:
        """Show a BGR uint8 image (copied)."""
        h, w = image_bgr.shape[:2]
        rgb = np.ascontiguousarray(image_bgr[:, :, ::-1])
        self._image = QtGui.QImage(rgb.data, w, h, 3 * w, QtGui.QImage.Format.Format_RGB888).copy()
        self._image_size = (w, h)
        self.update()

    def set_boxes(self, boxes: Sequence[Sequence[float]]) -> None:
        """The selectable boxes (x, y, w, h) in image pixels, in their numbering order (1, 2, …)."""
        self.boxes = [tuple(float(v) for v in b) for b in boxes]
        self.highlight = None if self.highlight is None or self.highlight >= len(self.boxes) else self.highlight
        self.update()

    def set_highlight(self, index: Optional[int]) -> None:
        self.highlight = index
        self.update()

    def set_chosen(self, index: Optional[int], centre_px: Optional[tuple[float, float]] = None) -> None:
        """The box the arm is going to (drawn green; the other boxes are hidden: the image moves
        with the arm, their places are stale), and where it is followed in the image now."""
        self.chosen = index
        self.chosen_centre = centre_px
        self.chosen_radius = None
        self.update()

    def set_follow(self, centre_px: Optional[tuple[float, float]], radius_px: Optional[float]) -> None:
        """Where the chosen box is followed in the latest image (centre and radius, px)."""
        if centre_px is not None:
            self.chosen_centre = (float(centre_px[0]), float(centre_px[1]))
            self.chosen_radius = None if radius_px is None else float(radius_px)
            self.update()

    def set_message(self, text: str) -> None:
        self.message = text
        self.update()

    def acknowledge(self, image_point: tuple[float, float]) -> None:
        """A tap outside every box: show a grey ring and "not a button" there for ACK_MS."""
        self._ack_point = (float(image_point[0]), float(image_point[1]))
        self._ack_timer.start()
        self.update()

    @property
    def ack_visible(self) -> bool:
        """True while a tap acknowledgement is shown."""
        return self._ack_point is not None

    def _clear_ack(self) -> None:
        self._ack_point = None
        self.update()

    # -- geometry ------------------------------------------------------------------------------

    def _transform(self) -> tuple[float, float, float]:
        """(scale, x offset, y offset) from image pixels to widget pixels."""
        iw, ih = self._image_size
        s = min(self.width() / iw, self.height() / ih)
        return s, (self.width() - iw * s) / 2, (self.height() - ih * s) / 2

    def to_image(self, widget_point: QtCore.QPointF) -> Optional[tuple[float, float]]:
        """The image pixel under a widget point, or None outside the image."""
        s, ox, oy = self._transform()
        x, y = (widget_point.x() - ox) / s, (widget_point.y() - oy) / s
        iw, ih = self._image_size
        return (x, y) if 0 <= x < iw and 0 <= y < ih else None

    def to_widget(self, image_point: Sequence[float]) -> QtCore.QPointF:
        s, ox, oy = self._transform()
        return QtCore.QPointF(ox + image_point[0] * s, oy + image_point[1] * s)

    def box_rect(self, index: int) -> QtCore.QRectF:
        """Box ``index`` in widget coordinates (the chosen one where it is followed now)."""
        s, ox, oy = self._transform()
        x, y, w, h = self.boxes[index]
        if index == self.chosen and self.chosen_centre is not None:
            half = max(w, h) / 2 if self.chosen_radius is None else 1.3 * self.chosen_radius
            x, y, w, h = self.chosen_centre[0] - half, self.chosen_centre[1] - half, 2 * half, 2 * half
        return QtCore.QRectF(ox + x * s, oy + y * s, w * s, h * s)

    def _label_font(self) -> QtGui.QFont:
        font = QtGui.QFont(self.font())
        font.setBold(True)
        font.setPixelSize(max(LABEL_MIN_PX - 6, int(min(self.width(), self.height()) / 14)))
        return font

    def badge_rect(self, index: int) -> QtCore.QRectF:
        """Box ``index``'s number badge in widget coordinates (on the outline's top-left corner)."""
        fm = QtGui.QFontMetrics(self._label_font())
        r = self.box_rect(index)
        h = max(LABEL_MIN_PX, fm.height() + 4)
        w = max(h, fm.horizontalAdvance(str(index + 1)) + 14)
        return QtCore.QRectF(r.left() - w / 3, r.top() - h / 2, w, h)

    def shown_boxes(self) -> list[int]:
        """The boxes drawn now (all, or only the chosen one while the arm goes to it)."""
        return [i for i in range(len(self.boxes)) if self.chosen is None or i == self.chosen]

    def box_at(self, widget_point: QtCore.QPointF) -> Optional[int]:
        """The box under a widget point — on its badge or inside its outline — or None.

        The badges are drawn over every outline, so a badge wins; among outlines the smallest
        (as ``core.motion.scanning.TouchSelector`` chooses)."""
        shown = self.shown_boxes()
        for i in reversed(shown):  # the last badge drawn is the one on top
            if self.badge_rect(i).contains(widget_point):
                return i
        inside = [i for i in shown if self.box_rect(i).contains(widget_point)]
        if not inside:
            return None
        return min(inside, key=lambda i: self.box_rect(i).width() * self.box_rect(i).height())

    # -- input ---------------------------------------------------------------------------------

    def mousePressEvent(self, event: QtGui.QMouseEvent) -> None:  # noqa: N802 (Qt override)
        name = MOUSE_NAMES.get(event.button())
        if name is None:
            return super().mousePressEvent(event)
        event.accept()
        self.sigPressed.emit(name, self.to_image(event.position()), self.box_at(event.position()))

    def mouseReleaseEvent(self, event: QtGui.QMouseEvent) -> None:  # noqa: N802 (Qt override)
        name = MOUSE_NAMES.get(event.button())
        if name is None:
            return super().mouseReleaseEvent(event)
        event.accept()
        self.sigReleased.emit(name)

    # -- painting ------------------------------------------------------------------------------

    def paintEvent(self, event: QtGui.QPaintEvent) -> None:  # noqa: N802 (Qt override)
        p = QtGui.QPainter(self)
        p.setRenderHint(QtGui.QPainter.RenderHint.Antialiasing)
        p.fillRect(self.rect(), QtGui.QColor("#101010"))
        s, ox, oy = self._transform()
        iw, ih = self._image_size
        if self._image is not None:
            p.drawImage(QtCore.QRectF(ox, oy, iw * s, ih * s), self._image)
        label_font = self._label_font()
        p.setFont(label_font)
        shown = self.shown_boxes()
        for i in shown:
            self._paint_box(p, i)
        for i in shown:  # the badges over every outline: what is on top is what a tap chooses (box_at)
            self._paint_badge(p, i)
        if self._ack_point is not None:
            self._paint_ack(p, label_font)
        if self.message:
            font = QtGui.QFont(self.font())
            font.setPixelSize(max(18, int(self.height() / 14)))
            font.setBold(True)
            p.setFont(font)
            band = QtCore.QRectF(0, self.height() / 2 - 30, self.width(), 60)
            p.fillRect(band, QtGui.QColor(0, 0, 0, 170))
            p.setPen(QtGui.QColor("white"))
            p.drawText(band, QtCore.Qt.AlignmentFlag.AlignCenter, self.message)
        p.end()

    def _paint_box(self, p: QtGui.QPainter, i: int) -> None:
        r = self.box_rect(i)
        highlighted = i == self.highlight
        chosen = i == self.chosen
        if chosen:
            colour, width = CHOSEN_COLOUR, 7
        elif highlighted:
            colour, width = HIGHLIGHT_COLOUR, 8
        else:
            colour, width = QtGui.QColor("white"), 3
        if highlighted and not chosen:
            tint = QtGui.QColor(HIGHLIGHT_COLOUR)
            tint.setAlpha(90)
            p.fillRect(r, tint)
        # a black frame under the coloured one: readable on a bright ring and on a dark face alike
        p.setBrush(QtCore.Qt.BrushStyle.NoBrush)
        p.setPen(QtGui.QPen(QtGui.QColor("black"), width + 4))
        p.drawRoundedRect(r, 6, 6)
        p.setPen(QtGui.QPen(colour, width))
        p.drawRoundedRect(r, 6, 6)
        if chosen and self.chosen_centre is not None:
            c = self.to_widget(self.chosen_centre)
            p.setPen(QtGui.QPen(CHOSEN_COLOUR, 3))
            p.drawLine(QtCore.QPointF(c.x() - 14, c.y()), QtCore.QPointF(c.x() + 14, c.y()))
            p.drawLine(QtCore.QPointF(c.x(), c.y() - 14), QtCore.QPointF(c.x(), c.y() + 14))

    def _paint_badge(self, p: QtGui.QPainter, i: int) -> None:
        """The number: a filled label on the box's top-left corner (``badge_rect``)."""
        lit = i == self.highlight or i == self.chosen
        colour = CHOSEN_COLOUR if i == self.chosen else HIGHLIGHT_COLOUR
        label = self.badge_rect(i)
        p.setPen(QtGui.QPen(QtGui.QColor("black") if lit else QtGui.QColor("white"), 2))
        p.setBrush(colour if lit else QtGui.QColor("black"))
        p.drawRoundedRect(label, 6, 6)
        p.setPen(QtGui.QColor("black") if lit else QtGui.QColor("white"))
        p.drawText(label, QtCore.Qt.AlignmentFlag.AlignCenter, str(i + 1))

    def _paint_ack(self, p: QtGui.QPainter, font: QtGui.QFont) -> None:
        c = self.to_widget(self._ack_point)
        p.setBrush(QtGui.QColor(255, 255, 255, 70))
        p.setPen(QtGui.QPen(QtGui.QColor("#9e9e9e"), 4))
        p.drawEllipse(c, 26, 26)
        text = "not a button"
        fm = QtGui.QFontMetrics(font)
        w, h = fm.horizontalAdvance(text) + 16, fm.height() + 6
        x = min(max(0.0, c.x() - w / 2), self.width() - w)
        y = c.y() + 32 if c.y() + 32 + h < self.height() else c.y() - 32 - h
        band = QtCore.QRectF(x, y, w, h)
        p.setPen(QtCore.Qt.PenStyle.NoPen)
        p.setBrush(QtGui.QColor(0, 0, 0, 200))
        p.drawRoundedRect(band, 6, 6)
        p.setPen(QtGui.QColor("white"))
        p.drawText(band, QtCore.Qt.AlignmentFlag.AlignCenter, text)


class SwitchSafeButton(QtWidgets.QPushButton):
    """A push button that a switch press never clicks.

    ``is_switch(name)`` (set by the owner) says whether a mouse button ("mouse:left", …) is a
    switch in the current input mode. Such a press over the button is not a click: it is handed
    on through ``sigSwitchPressed`` / ``sigSwitchReleased``, as a press on the camera view would
    be — a switch user whose pointer rests on the button neither opens nor triggers it. Other
    buttons (and every button in touch mode) click as usual.

    Signals (GUI thread):
    - sigSwitchPressed(str): a mouse switch went down over the button (its name).
    - sigSwitchReleased(str): that mouse switch came up.
    """

    sigSwitchPressed = QtCore.Signal(str)
    sigSwitchReleased = QtCore.Signal(str)

    def __init__(self, text: str, is_switch: Callable[[str], bool] = lambda name: False,
                 parent: Optional[QtWidgets.QWidget] = None):
        super().__init__(text, parent)
        self.is_switch = is_switch
        self._switch_down: Optional[str] = None
        self.setFocusPolicy(QtCore.Qt.FocusPolicy.NoFocus)

    def mousePressEvent(self, event: QtGui.QMouseEvent) -> None:  # noqa: N802 (Qt override)
        name = MOUSE_NAMES.get(event.button())
        if name is not None and self.is_switch(name):
            event.accept()
            self._switch_down = name
            self.sigSwitchPressed.emit(name)
            return
        super().mousePressEvent(event)

    def mouseDoubleClickEvent(self, event: QtGui.QMouseEvent) -> None:  # noqa: N802 (Qt override)
        self.mousePressEvent(event)  # a quick second press is a second switch press, never a click

    def mouseReleaseEvent(self, event: QtGui.QMouseEvent) -> None:  # noqa: N802 (Qt override)
        name = MOUSE_NAMES.get(event.button())
        if name is not None and name == self._switch_down:
            event.accept()
            self._switch_down = None
            self.sigSwitchReleased.emit(name)
            return
        super().mouseReleaseEvent(event)
