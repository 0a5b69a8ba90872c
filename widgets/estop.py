"""The emergency stop: a STOP button that only ever stops, and a separate hold-to-re-arm button.

STOP is idempotent: every tap (and Esc) stops, a second tap — a panicked double tap, a
bouncing touch screen — stops again and nothing else. Re-arming is a different control that
is shown only while stopped and acts only when held down for ``REARM_HOLD_MS`` (a fill shows
the hold); releasing earlier does nothing. The owner shows the state with ``set_engaged``.
"""
from __future__ import annotations

from PySide6 import QtCore, QtGui, QtWidgets

from widgets._style import ERROR_COLOUR, OK_COLOUR, TOUCH_PX

REARM_HOLD_MS = 1000  # how long RE-ARM must be held down
HOLD_TICK_MS = 30  # repaint period of the hold fill

_STOP_STYLE = """
QPushButton {{
    min-height: {h}px; min-width: 120px; font-size: 15pt; font-weight: bold; color: white;
    background: {stop}; border: 3px solid #7f0000; border-radius: 8px; padding: 0 14px;
}}
QPushButton[engaged="true"] {{ background: #8e0000; border: 3px solid #ffcdd2; }}
QPushButton:pressed {{ background: #7f0000; }}
"""


class EStopButton(QtWidgets.QPushButton):
    """STOP — every tap stops the arm; it never re-arms.

    Signals:
    - sigStopRequested(): the user tapped STOP (also when already stopped; stopping twice is
      stopping). ``engage()`` (Esc, a dialog's STOP) does the same.
    Shows "STOPPED" while :meth:`set_engaged` (True) says the arm is stopped.
    """

    sigStopRequested = QtCore.Signal()

    def __init__(self, parent: QtWidgets.QWidget | None = None):
        super().__init__("STOP", parent)
        self._engaged = False
        self.setFocusPolicy(QtCore.Qt.FocusPolicy.NoFocus)
        self.setStyleSheet(_STOP_STYLE.format(h=TOUCH_PX + 8, stop=ERROR_COLOUR))
        self.setProperty("engaged", False)
        self.setToolTip("Emergency stop (Esc). Re-arm with the separate RE-ARM button (hold it).")
        # room for the longer of the two texts, so the button never changes width
        bold = QtGui.QFont(self.font())
        bold.setPointSize(15)
        bold.setBold(True)
        self.setMinimumWidth(QtGui.QFontMetrics(bold).horizontalAdvance("STOPPED") + 40)
        self.clicked.connect(self.engage)

    @property
    def engaged(self) -> bool:
        """True while the arm is shown as stopped."""
        return self._engaged

    def engage(self) -> None:
        """Request a stop (any number of times: each one stops)."""
        self.sigStopRequested.emit()

    def set_engaged(self, engaged: bool) -> None:
        """Show the e-stop state: "STOPPED" (darker) or "STOP"."""
        engaged = bool(engaged)
        if engaged == self._engaged:
            return
        self._engaged = engaged
        self.setText("STOPPED" if engaged else "STOP")
        self.setProperty("engaged", engaged)
        self.style().unpolish(self)
        self.style().polish(self)


class HoldButton(QtWidgets.QPushButton):
    """A button that acts only when held down for ``hold_ms``; a fill shows the progress.

    A tap, a double tap or a press released early does nothing. Works with a mouse, a touch
    screen (Qt synthesises the press/release) and Space/Enter held down while focused.

    Signals:
    - sigHeld(): the button was held for the whole ``hold_ms``.
    """

    sigHeld = QtCore.Signal()

    def __init__(self, text: str, hold_ms: int = REARM_HOLD_MS, colour: str = OK_COLOUR,
                 parent: QtWidgets.QWidget | None = None):
        super().__init__(text, parent)
        self.hold_ms = int(hold_ms)
        self._colour = QtGui.QColor(colour)
        self._clock = QtCore.QElapsedTimer()
        self._ticker = QtCore.QTimer(self)
        self._ticker.setInterval(HOLD_TICK_MS)
        self._ticker.timeout.connect(self._tick)
        self._progress = 0.0
        self.setMinimumHeight(TOUCH_PX + 8)
        self.setFocusPolicy(QtCore.Qt.FocusPolicy.NoFocus)
        self.setAutoRepeat(False)
        self.pressed.connect(self._start_hold)
        self.released.connect(self._cancel_hold)

    @property
    def holding(self) -> bool:
        """True while a hold is in progress (pressed, not yet held long enough)."""
        return self._ticker.isActive()

    @property
    def progress(self) -> float:
        """0…1: how far the current hold is."""
        return self._progress

    def _start_hold(self) -> None:
        self._clock.start()
        self._progress = 0.0
        self._ticker.start()
        self.update()

    def _cancel_hold(self) -> None:
        self._ticker.stop()
        self._progress = 0.0
        self.update()

    def _tick(self) -> None:
        if not self.isDown() or not self.isVisible() or not self.isEnabled():
            self._cancel_hold()
            return
        self._progress = min(1.0, self._clock.elapsed() / max(1, self.hold_ms))
        self.update()
        if self._progress >= 1.0:
            self._ticker.stop()
            self._progress = 0.0
            self.setDown(False)  # a completed hold is one action, not one per tick
            self.sigHeld.emit()

    def hideEvent(self, event: QtGui.QHideEvent) -> None:  # noqa: N802 (Qt override)
        self._cancel_hold()
        super().hideEvent(event)

    def paintEvent(self, event: QtGui.QPaintEvent) -> None:  # noqa: N802 (Qt override)
        super().paintEvent(event)
        if self._progress > 0.0:
            painter = QtGui.QPainter(self)
            fill = QtGui.QColor(self._colour)
            fill.setAlpha(150)
            r = self.rect().adjusted(3, 3, -3, -3)
            r.setWidth(int(r.width() * self._progress))
            painter.fillRect(r, fill)
            painter.end()


_REARM_STYLE = """
QPushButton {{
    min-height: {h}px; font-size: 12pt; font-weight: bold; color: {ok};
    background: white; border: 3px solid {ok}; border-radius: 8px; padding: 0 10px;
}}
"""


class RearmButton(HoldButton):
    """"Hold to RE-ARM": shown only while stopped; resumes the arm after a 1 s hold."""

    def __init__(self, hold_ms: int = REARM_HOLD_MS, parent: QtWidgets.QWidget | None = None):
        super().__init__(f"RE-ARM\n(hold {hold_ms / 1000:g} s)", hold_ms=hold_ms, parent=parent)
        self.setStyleSheet(_REARM_STYLE.format(h=TOUCH_PX + 8, ok=OK_COLOUR))
        self.setToolTip(f"Hold for {hold_ms / 1000:g} s to re-arm the arm")


class StopDialog(QtWidgets.QDialog):
    """A dialog that may cover the window's STOP: Esc is STOP here too, as in the main window,
    and never closes it (its Close button does).

    Signals:
    - sigStopRequested(): STOP asked for on this dialog (Esc, or a STOP button wired to
      :meth:`request_stop`); the owner stops the arm, as often as it is asked.
    """

    sigStopRequested = QtCore.Signal()

    def request_stop(self) -> None:
        """Ask the owner to stop the arm."""
        self.sigStopRequested.emit()

    def keyPressEvent(self, event: QtGui.QKeyEvent) -> None:  # noqa: N802 (Qt override)
        if event.key() == QtCore.Qt.Key.Key_Escape:
            event.accept()
            self.request_stop()
            return
        super().keyPressEvent(event)
