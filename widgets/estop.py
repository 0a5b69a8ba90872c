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


KEEP_OFF_MARGIN_PX = 8  # popups and dialogs keep this far from STOP's rectangle
_MAX_MOVES_PER_SHOW = 4  # a window manager that insists on its place is not fought for ever
_PRESS_EVENTS = (QtCore.QEvent.Type.MouseButtonPress, QtCore.QEvent.Type.MouseButtonDblClick,
                 QtCore.QEvent.Type.TouchBegin, QtCore.QEvent.Type.TabletPress)
_FLOATING_TYPES = (QtCore.Qt.WindowType.Popup, QtCore.Qt.WindowType.ToolTip, QtCore.Qt.WindowType.Dialog,
                   QtCore.Qt.WindowType.Tool, QtCore.Qt.WindowType.Sheet, QtCore.Qt.WindowType.Drawer,
                   QtCore.Qt.WindowType.SplashScreen)


def _press_position(event: QtCore.QEvent) -> QtCore.QPointF | None:
    """Where on the screen a press landed (global coordinates), or None."""
    if isinstance(event, QtGui.QSinglePointEvent):  # mouse, tablet
        return event.globalPosition()
    if isinstance(event, QtGui.QTouchEvent) and event.points():
        return event.points()[0].globalPosition()
    return None


class StopGuard(QtCore.QObject):
    """Keeps one STOP within reach of a finger and a key, whatever else the application shows.

    Installed on the QApplication for one window's STOP widget:

    - **a press on STOP's screen rectangle stops** — mouse, touch or pen, also while a menu, a
      drop-down list, a tooltip or a dialog is open and has the pointer grabbed (open popups
      close); the press is taken, so nothing under it acts as well;
    - **Esc stops in every window of the application** (a popup also closes; a dialog stays open:
      Esc never cancels a dialog, its Cancel / Close button does);
    - **nothing covers STOP**: menus, lists, tooltips and dialogs that open (or grow, or are moved)
      over STOP's rectangle are moved off it — below it, or beside it — and shrunk to fit if they
      have to be;
    - **the keys keep working without a window manager**: when a dialog or popup closes, and when
      the window first shows, the window takes the keyboard focus back (on X11 with no window
      manager the focus otherwise falls to the root window and Esc, F1 and Ctrl+Q do nothing);
      a key that reaches the window while Qt counts it as inactive still triggers the window's
      action for it (its shortcuts would not match).

    STOP from here is the same request as the button's: ``sigStopRequested`` fires on every press
    and Esc (stopping twice is stopping). Modal dialogs block Qt's input to every other window,
    so the application opens none while a guard is installed (file dialogs: :func:`open_file_dialog`).

    Until its window first shows, the guard watches only that window: each of the above needs
    STOP on screen, and an application-wide filter sees every event of building the window's
    widgets (thousands, each a call into Python: a noticeable part of a Pi's start-up).
    ``watching_application`` says which.

    Signals:
    - sigStopRequested(): a press on STOP's area or Esc, from the GUI thread.
    """

    sigStopRequested = QtCore.Signal()
    _live: list["StopGuard"] = []  # every installed guard (a dialog's own STOP stops them all)

    def __init__(self, stop_widget: QtWidgets.QWidget, window: QtWidgets.QWidget | None = None):
        super().__init__(stop_widget)
        self.stop_widget = stop_widget
        self.window = window or stop_widget.window()
        self._moves: dict[int, int] = {}  # id(top-level) → moves since it was shown
        self._last_key = None  # (timestamp, key) of the last Esc handled: one stop per key press
        self._focus_timer = QtCore.QTimer(self)  # reclaim_focus once the closing window is gone
        self._focus_timer.setSingleShot(True)
        self._focus_timer.setInterval(0)
        self._focus_timer.timeout.connect(self.reclaim_focus)
        self.watching_application = False  # see the class docstring: from the window's first show
        if self.window.isVisible():
            self._watch_application()
        else:
            self.window.installEventFilter(self)
        StopGuard._live.append(self)
        stop_widget.destroyed.connect(self._forget)

    def _watch_application(self) -> None:
        if self._alive():
            self.window.removeEventFilter(self)
        QtWidgets.QApplication.instance().installEventFilter(self)
        self.watching_application = True

    @classmethod
    def stop_all(cls) -> None:
        """STOP from somewhere without an owner (a file dialog's STOP): every guarded window stops."""
        for guard in list(cls._live):
            guard.sigStopRequested.emit()

    def _forget(self, *_args) -> None:
        if self in StopGuard._live:
            StopGuard._live.remove(self)
        app = QtWidgets.QApplication.instance()
        if app is not None:
            app.removeEventFilter(self)
        if self._alive():
            self.window.removeEventFilter(self)

    def remove(self) -> None:
        """Stop guarding (the window is closing)."""
        self._forget()

    # -- geometry ---------------------------------------------------------------------------------
    def _alive(self) -> bool:
        import shiboken6

        return shiboken6.isValid(self.stop_widget) and shiboken6.isValid(self.window)

    def stop_rect(self) -> QtCore.QRect:
        """STOP's rectangle on the screen (global pixels); empty while it is not shown."""
        w = self.stop_widget
        if not self._alive() or not w.isVisible() or self.window.isMinimized():
            return QtCore.QRect()
        return QtCore.QRect(w.mapToGlobal(QtCore.QPoint(0, 0)), w.size())

    def keep_off_stop(self, top: QtWidgets.QWidget) -> bool:
        """Move (and if need be shrink) a popup, tooltip or dialog so that it leaves STOP's
        rectangle, with a margin, uncovered; True when it was moved."""
        stop = self.stop_rect()
        if stop.isEmpty():
            return False
        keep = stop.adjusted(-KEEP_OFF_MARGIN_PX, -KEEP_OFF_MARGIN_PX, KEEP_OFF_MARGIN_PX, KEEP_OFF_MARGIN_PX)
        frame = top.frameGeometry()
        if not frame.intersects(keep):
            return False
        screen = top.screen() or self.window.screen()
        area = screen.availableGeometry() if screen is not None else frame.united(keep)
        extra_w = frame.width() - top.width()  # the window manager's frame around the client area
        extra_h = frame.height() - top.height()
        below = QtCore.QRect(frame)
        below.moveTop(keep.bottom() + 1)
        beside = QtCore.QRect(frame)
        if keep.center().x() >= area.center().x():
            beside.moveRight(keep.left() - 1)
        else:
            beside.moveLeft(keep.right() + 1)
        popup = bool(top.windowType() in (QtCore.Qt.WindowType.Popup, QtCore.Qt.WindowType.ToolTip))
        # a list or menu keeps its column (it belongs to what opened it): below first; a dialog
        # keeps its height: beside first
        order = (below, beside) if popup else (beside, below)
        for candidate in order:
            if area.contains(candidate):
                top.move(candidate.topLeft())
                return True
        # does not fit whole: shrink it below STOP (lists scroll) or beside STOP — where its
        # minimum size still fits (a wizard's pages need their height), else where it has more room
        right_side = keep.center().x() >= area.center().x()
        room_below = area.bottom() - keep.bottom()
        room_beside = (keep.left() - area.left()) if right_side else (area.right() - keep.right())
        width = min(frame.width(), area.width())
        left = min(max(frame.left(), area.left()), area.right() + 1 - width)
        shrunk_below = QtCore.QRect(left, keep.bottom() + 1, width, min(frame.height(), room_below))
        width = min(frame.width(), room_beside)
        height = min(frame.height(), area.height())
        y = min(max(frame.top(), area.top()), area.bottom() + 1 - height)
        shrunk_beside = QtCore.QRect(keep.left() - width if right_side else keep.right() + 1, y, width, height)
        least = top.minimumSizeHint().expandedTo(top.minimumSize())

        def fits(r: QtCore.QRect) -> bool:
            return r.width() - extra_w >= least.width() and r.height() - extra_h >= least.height()

        options = (shrunk_below, shrunk_beside) if popup else (shrunk_beside, shrunk_below)
        wanted = max(options, key=lambda r: (fits(r), r.width() * r.height() if not fits(r) else 0))
        border = top.geometry().topLeft() - frame.topLeft()  # the window manager's frame, if any
        top.setGeometry(wanted.left() + border.x(), wanted.top() + border.y(),
                        wanted.width() - extra_w, wanted.height() - extra_h)
        return True

    def reclaim_focus_soon(self) -> None:
        """:meth:`reclaim_focus` once the events being handled now are done (a closing dialog gone)."""
        self._focus_timer.start()

    def reclaim_focus(self) -> None:
        """Give the window the keyboard back when nothing of the application holds it (no
        window manager after a dialog closed, or at start-up)."""
        if not self._alive() or not self.window.isVisible():
            return
        app = QtWidgets.QApplication.instance()
        active = app.activeWindow()
        if app.activePopupWidget() is not None or app.activeModalWidget() is not None:
            return
        if active is None or not active.isVisible():
            self.window.activateWindow()

    # -- the filter -------------------------------------------------------------------------------
    def eventFilter(self, obj: QtCore.QObject, event: QtCore.QEvent) -> bool:  # noqa: N802 (Qt override)
        kind = event.type()
        if not self.watching_application:  # the window's own events, until it shows
            if kind == QtCore.QEvent.Type.Show and obj is self.window:
                self._watch_application()
            return False
        if kind in _PRESS_EVENTS:
            return self._on_press(event)
        if kind == QtCore.QEvent.Type.KeyPress:
            return self._on_key(obj, event)
        if kind in (QtCore.QEvent.Type.Show, QtCore.QEvent.Type.Resize, QtCore.QEvent.Type.Move):
            self._on_geometry(obj, kind)
        elif kind in (QtCore.QEvent.Type.Hide, QtCore.QEvent.Type.Close):
            if isinstance(obj, QtWidgets.QWidget) and obj.isWindow() and self._alive() and obj is not self.window:
                self.reclaim_focus_soon()
        return False

    def _on_press(self, event: QtCore.QEvent) -> bool:
        where = _press_position(event)
        if where is None:
            return False
        stop = self.stop_rect()
        if stop.isEmpty() or not stop.contains(where.toPoint()):
            return False
        app = QtWidgets.QApplication.instance()
        popup = app.activePopupWidget()
        while popup is not None:  # a menu, a list: close it (a submenu's parent too)
            popup.close()
            nxt = app.activePopupWidget()
            popup = nxt if nxt is not popup else None
        self.sigStopRequested.emit()
        event.accept()
        return True  # taken: the press does nothing else (no list item picked, no button under it)

    def _on_key(self, obj: QtCore.QObject, event: QtGui.QKeyEvent) -> bool:
        if not self._alive():
            return False
        if event.key() != QtCore.Qt.Key.Key_Escape:
            return self._key_without_activation(obj, event)
        stamp = (event.timestamp(), event.key(), event.isAutoRepeat())
        if stamp != self._last_key or event.timestamp() == 0:
            self._last_key = stamp
            self.sigStopRequested.emit()
        # a popup closes as well (Esc's usual meaning); a dialog stays open and the main window
        # has nothing else to do with Esc
        return QtWidgets.QApplication.instance().activePopupWidget() is None

    def _key_without_activation(self, obj: QtCore.QObject, event: QtGui.QKeyEvent) -> bool:
        """A key the X server gave the window while Qt counts no window as active — with no window
        manager, the focus set back after a dialog closes is sometimes not seen as an activation
        (a late focus-out of the closing dialog): the window's own shortcuts (F1, Ctrl+Q) would
        not match. Trigger the window's action for that key, and ask for the activation again."""
        app = QtWidgets.QApplication.instance()
        if (app.activeWindow() is not None or event.isAutoRepeat() or not isinstance(obj, QtGui.QWindow)
                or obj is not self.window.windowHandle()):
            return False
        self.window.activateWindow()
        pressed = QtGui.QKeySequence(event.keyCombination())
        for action in self.window.actions():
            if action.isEnabled() and any(shortcut.matches(pressed) == QtGui.QKeySequence.SequenceMatch.ExactMatch
                                          for shortcut in action.shortcuts()):
                action.trigger()
                return True
        return False

    def _on_geometry(self, obj: QtCore.QObject, kind: QtCore.QEvent.Type) -> None:
        if not isinstance(obj, QtWidgets.QWidget) or not obj.isWindow() or obj is self.window:
            return
        if obj.windowType() not in _FLOATING_TYPES or not obj.isVisible() and kind != QtCore.QEvent.Type.Show:
            return
        if not self._alive():
            return
        key = id(obj)
        if kind == QtCore.QEvent.Type.Show:
            if len(self._moves) > 64:  # windows long closed
                self._moves.clear()
            self._moves[key] = 0
        if self._moves.get(key, 0) >= _MAX_MOVES_PER_SHOW:
            return
        if self.keep_off_stop(obj):
            self._moves[key] = self._moves.get(key, 0) + 1
