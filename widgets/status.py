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

    Signals: none.
    """

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
        self.setText(text)
        self.show()

    def clear(self) -> None:  # noqa: D102 - QLabel.clear, plus hiding
        """Remove the message and hide the strip."""
        super().clear()
        self.hide()

    def _apply_style(self) -> None:
        colour = BANNER_LEVELS[self._level]
        self.setStyleSheet(f"QLabel {{ background: {colour}; color: white; font-weight: bold;"
                           f" padding: 6px 10px; }}")


class StatusBarItems:
    """The labels deskarm shows in its QStatusBar: camera, bridge, fps and latency.

    Not a widget itself: it creates four QLabels (``camera_label``, ``bridge_label``,
    ``fps_label``, ``latency_label``) and, given a status bar, adds them as permanent widgets.
    A state string starting with "ok", "connected", "sim" or "running" is shown green, one
    containing "lost", "error" or "fail" red, anything else orange.

    Signals: none.
    """

    def __init__(self, status_bar: QtWidgets.QStatusBar | None = None) -> None:
        self.camera_label = QtWidgets.QLabel("camera: —")
        self.bridge_label = QtWidgets.QLabel("bridge: —")
        self.fps_label = QtWidgets.QLabel("— fps")
        self.latency_label = QtWidgets.QLabel("latency — ms")
        for label in self.labels():
            label.setMinimumHeight(24)
            label.setContentsMargins(6, 0, 6, 0)
        if status_bar is not None:
            self.add_to(status_bar)

    def labels(self) -> list[QtWidgets.QLabel]:
        """The four labels, left to right."""
        return [self.camera_label, self.bridge_label, self.fps_label, self.latency_label]

    def add_to(self, status_bar: QtWidgets.QStatusBar) -> None:
        """Add the labels to ``status_bar`` as permanent (right-aligned) widgets."""
        for label in self.labels():
            status_bar.addPermanentWidget(label)

    def update(self, camera: str, bridge: str, fps: float, latency_ms: float) -> None:
        """Show the camera and bridge states, frames per second and end-to-end latency.

        Only labels whose text or colour changed are touched: a style sheet set again, even
        the same one, re-polishes the label and re-lays out the status bar.
        """
        _set_label(self.camera_label, f"camera: {camera}", _state_style(camera))
        _set_label(self.bridge_label, f"bridge: {bridge}", _state_style(bridge))
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
