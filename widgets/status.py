"""Status-bar labels and a coloured full-width message banner."""
from __future__ import annotations

import math

from PySide6 import QtCore, QtWidgets

from widgets._style import ERROR_COLOUR, INFO_COLOUR, OK_COLOUR, WARN_COLOUR

BANNER_LEVELS = {"info": INFO_COLOUR, "warn": WARN_COLOUR, "error": ERROR_COLOUR}


class Banner(QtWidgets.QLabel):
    """A coloured full-width message strip (levels ``info``, ``warn``, ``error``).

    Hidden until :meth:`show_message`; :meth:`clear` hides it again. The text wraps, so a long
    message on a narrow screen grows the strip instead of being cut. Mouse events pass through
    (it may sit over an image that the user taps).

    Signals:
    - sigChanged(): the message changed or was cleared (GUI thread) — its owner may move it.
    """

    sigChanged = QtCore.Signal()

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self._level = "info"
        self.setWordWrap(True)
        self.setAlignment(QtCore.Qt.AlignmentFlag.AlignCenter)
        self.setSizePolicy(QtWidgets.QSizePolicy.Policy.Expanding,
                           QtWidgets.QSizePolicy.Policy.Minimum)
        self.setAttribute(QtCore.Qt.WidgetAttribute.WA_TransparentForMouseEvents)
        self._apply_style()
        self.hide()

    @property
    def level(self) -> str:
        """The level of the current (or last) message."""
        return self._level

    def show_message(self, text: str, level: str = "info") -> None:
        """Show ``text`` on a strip coloured by ``level`` (info, warn or error)."""
        if level not in BANNER_LEVELS:
            raise ValueError(f"banner level {level!r}; allowed: {', '.join(BANNER_LEVELS)}")
        if level != self._level:
            self._level = level
            self._apply_style()
        changed = text != self.text() or self.isHidden()
        self.setText(text)
        self.show()
        if changed:
            self.sigChanged.emit()

    def clear(self) -> None:  # noqa: D102 - QLabel.clear, plus hiding
        """Remove the message and hide the strip."""
        super().clear()
        self.hide()
        self.sigChanged.emit()

    def _apply_style(self) -> None:
        colour = BANNER_LEVELS[self._level]
        self.setStyleSheet(f"QLabel {{ background: {colour}; color: white; font-weight: bold;"
                           f" padding: 6px 10px; }}")


class ElidedLabel(QtWidgets.QLabel):
    """A one-line label that shows as much of its text as fits, ending in "…", with the full
    text in its tooltip — shown at once by a tap (or click) on the cut label, since a touch
    screen has no hover to bring a tooltip up.

    ``text()`` is the full text; ``shown_text()`` what is drawn. It asks for its full width
    (``sizeHint``) but can shrink to a few characters (``minimumSizeHint``), so in a status
    bar it gives way to the labels beside it instead of pushing them off the edge.

    Signals: none.
    """

    def __init__(self, text: str = "", min_chars: int = 12,
                 parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self._full = ""
        self._min_chars = int(min_chars)
        self.setSizePolicy(QtWidgets.QSizePolicy.Policy.Preferred,
                           QtWidgets.QSizePolicy.Policy.Preferred)
        self.setText(text)

    def setText(self, text: str) -> None:  # noqa: N802 (Qt override)
        """Show ``text`` (elided when it does not fit); the tooltip holds all of it."""
        if text == self._full and self.toolTip() == text:
            return
        self._full = text
        self.setToolTip(text)
        self._elide()
        self.updateGeometry()

    def text(self) -> str:  # Qt override
        """The full text, as set."""
        return self._full

    def shown_text(self) -> str:
        """The text as drawn: the full text, or its start and "…"."""
        return super().text()

    def is_elided(self) -> bool:
        """True when the label is too narrow for its text."""
        return self.shown_text() != self._full

    def show_full_text(self) -> None:
        """Show the full text in a tooltip at the label, now (it wraps if wider than the screen
        and goes at the next press anywhere, or after ~10 s)."""
        QtWidgets.QToolTip.showText(self.mapToGlobal(QtCore.QPoint(0, 0)), self._full, self)

    def mousePressEvent(self, event) -> None:  # noqa: N802 (Qt override)
        if event.button() == QtCore.Qt.MouseButton.LeftButton and self.is_elided():
            event.accept()  # a tap on a cut label is for it: its release shows the text
            return
        super().mousePressEvent(event)

    def mouseReleaseEvent(self, event) -> None:  # noqa: N802 (Qt override)
        # on release: a tooltip shown on the press would be hidden by the release
        if (event.button() == QtCore.Qt.MouseButton.LeftButton and self.is_elided()
                and self.rect().contains(event.position().toPoint())):
            event.accept()
            self.show_full_text()
            return
        super().mouseReleaseEvent(event)

    def _extra_px(self) -> int:
        m = self.contentsMargins()
        return m.left() + m.right() + 2 * self.margin() + 2 * self.frameWidth() + 2

    def sizeHint(self) -> QtCore.QSize:  # noqa: N802 (Qt override)
        """Wide enough for the full text."""
        self.ensurePolished()  # the style sheet's bold font is what is measured
        hint = super().sizeHint()
        width = math.ceil(self.fontMetrics().horizontalAdvance(self._full)) + self._extra_px()
        return QtCore.QSize(width, hint.height())

    def minimumSizeHint(self) -> QtCore.QSize:  # noqa: N802 (Qt override)
        """Wide enough for the first few characters and "…"."""
        self.ensurePolished()
        hint = super().minimumSizeHint()
        start = self._full[:self._min_chars] + ("…" if len(self._full) > self._min_chars else "")
        width = math.ceil(self.fontMetrics().horizontalAdvance(start)) + self._extra_px()
        return QtCore.QSize(min(width, self.sizeHint().width()), hint.height())

    def resizeEvent(self, event) -> None:  # noqa: N802 (Qt override)
        super().resizeEvent(event)
        self._elide()

    def changeEvent(self, event) -> None:  # noqa: N802 (Qt override)
        super().changeEvent(event)
        if event.type() in (QtCore.QEvent.Type.FontChange, QtCore.QEvent.Type.StyleChange):
            self._elide()

    def _elide(self) -> None:
        room = self.contentsRect().width() - 2 * self.margin()
        shown = self.fontMetrics().elidedText(self._full, QtCore.Qt.TextElideMode.ElideRight,
                                              max(0, room))
        if shown != super().text():
            super().setText(shown)


class FixedWidthLabel(QtWidgets.QLabel):
    """A label at least as wide as its widest expected text (``widest``), so a changing number
    ("latency 48 ms" → "latency 1203 ms") is never cut and never makes its neighbours jump.

    Signals: none.
    """

    def __init__(self, text: str, widest: str, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(text, parent)
        self.widest = widest

    def widest_px(self) -> int:
        """The width (px) the widest text takes in this label, margins included."""
        self.ensurePolished()
        m = self.contentsMargins()
        extra = m.left() + m.right() + 2 * self.margin() + 2 * self.frameWidth() + 2
        return math.ceil(self.fontMetrics().horizontalAdvance(self.widest)) + extra

    def sizeHint(self) -> QtCore.QSize:  # noqa: N802 (Qt override)
        """At least as wide as the widest text."""
        hint = super().sizeHint()
        return QtCore.QSize(max(hint.width(), self.widest_px()), hint.height())

    def minimumSizeHint(self) -> QtCore.QSize:  # noqa: N802 (Qt override)
        """Never narrower than the widest text: a status bar must not squeeze it."""
        hint = super().minimumSizeHint()
        return QtCore.QSize(max(hint.width(), self.widest_px()), hint.height())


FPS_WIDEST = "99.9 fps"
LATENCY_WIDEST = "latency 9999 ms"


class StatusBarItems:
    """The labels deskarm shows in its QStatusBar: camera, bridge, fps and latency.

    Not a widget itself: it creates four labels (``camera_label``, ``bridge_label``,
    ``fps_label``, ``latency_label``) and, given a status bar, adds them as permanent widgets.
    A state string starting with "ok", "connected", "sim" or "running" is shown green, one
    containing "lost", "error" or "fail" red, anything else orange.

    The fps and latency labels are always wide enough for "99.9 fps" and "latency 9999 ms";
    on a narrow screen the camera and bridge labels give way, elided with "…" (the full text
    in their tooltips, which a tap on the label shows).

    Signals: none.
    """

    def __init__(self, status_bar: QtWidgets.QStatusBar | None = None) -> None:
        self.camera_label = ElidedLabel("camera: —")
        self.robot_label = ElidedLabel("camera→arm: —")  # the hand-eye state
        self.bridge_label = ElidedLabel("bridge: —")
        self.fps_label = FixedWidthLabel("— fps", FPS_WIDEST)
        self.latency_label = FixedWidthLabel("latency — ms", LATENCY_WIDEST)
        for label in self.labels():
            label.setMinimumHeight(24)
            label.setContentsMargins(6, 0, 6, 0)
        for label in (self.fps_label, self.latency_label):
            # the number ends where the label does, however short it is
            label.setAlignment(QtCore.Qt.AlignmentFlag.AlignRight
                               | QtCore.Qt.AlignmentFlag.AlignVCenter)
        if status_bar is not None:
            self.add_to(status_bar)

    def labels(self) -> list[QtWidgets.QLabel]:
        """The five labels, left to right."""
        return [self.camera_label, self.robot_label, self.bridge_label, self.fps_label, self.latency_label]

    def add_to(self, status_bar: QtWidgets.QStatusBar) -> None:
        """Add the labels to ``status_bar`` as permanent (right-aligned) widgets."""
        for label in self.labels():
            status_bar.addPermanentWidget(label)

    def update(self, camera: str, bridge: str, fps: float, latency_ms: float, camera_to_robot: str = "") -> None:
        """Show the camera and bridge states, frames per second and end-to-end latency, and the
        camera→arm calibration state ("camera→arm: NOMINAL — run calibration" in orange).

        Only labels whose text or colour changed are touched: a style sheet set again, even
        the same one, re-polishes the label and re-lays out the status bar.
        """
        _set_label(self.camera_label, f"camera: {camera}", _state_style(camera))
        _set_label(self.bridge_label, f"bridge: {bridge}", _state_style(bridge))
        if camera_to_robot:
            state = camera_to_robot.split(":", 1)[-1].strip()
            _set_label(self.robot_label, camera_to_robot, _state_style("ok" if state.startswith(("calibrated", "sim"))
                                                                        else state))
        _set_label(self.fps_label, "— fps" if not math.isfinite(fps) else f"{fps:.1f} fps")
        _set_label(self.latency_label, "latency — ms" if not math.isfinite(latency_ms)
                   else f"latency {latency_ms:.0f} ms")


def _set_label(label: QtWidgets.QLabel, text: str, style: str | None = None) -> None:
    """setText / setStyleSheet only when they change what the label shows."""
    if label.text() != text:
        label.setText(text)
    if style is not None and label.styleSheet() != style:
        label.setStyleSheet(style)


def _state_style(state: str) -> str:
    s = state.lower()
    if any(word in s for word in ("lost", "error", "fail", "disconnected", "no ")):
        colour = ERROR_COLOUR
    elif s.startswith(("ok", "connected", "sim", "running", "live")):
        colour = OK_COLOUR
    else:
        colour = WARN_COLOUR
    return f"QLabel {{ color: {colour}; font-weight: bold; }}"
