"""What the user sees in the first second: the QApplication and a splash, before the heavy imports.

``deskarm`` imports OpenCV, Pinocchio and pyqtgraph and opens the cameras before its window can
show a frame; on a Raspberry Pi that is seconds of nothing. ``show_splash`` puts a small
"starting…" card on screen at once (only PySide6 is imported here); the window replaces it.
"""
from __future__ import annotations

import sys
from pathlib import Path
from typing import Optional

from PySide6 import QtCore, QtGui, QtWidgets

SPLASH_SIZE = (420, 150)
GARBAGE_PERIOD_MS = 1000  # GuiThreadGarbage: a young-generation collection this often …
GARBAGE_FULL_EVERY = 60  # … and a full one every this many


class GuiThreadGarbage(QtCore.QObject):
    """Python's garbage collection for a running window, only ever in the GUI thread.

    Left automatic, a collection starts in whichever thread allocates at that moment — a camera
    or render thread does so 30 times a second — and may delete a Qt object caught in a
    reference cycle (a closed dialog, a replaced widget) there, while the GUI thread is
    delivering an event to it: Python then aborts ("pure virtual method called"). This turns
    the automatic collector off and collects from a GUI-thread timer instead (young generations
    every ``GARBAGE_PERIOD_MS``, everything every ``GARBAGE_FULL_EVERY`` ticks); the workers'
    loops also no longer pause for a collection. ``stop()`` turns the automatic one back on."""

    def __init__(self, parent: QtCore.QObject, period_ms: int = GARBAGE_PERIOD_MS,
                 full_every: int = GARBAGE_FULL_EVERY):
        import gc

        super().__init__(parent)
        self.collections = 0
        self._full_every = max(1, int(full_every))
        self._timer = QtCore.QTimer(self)
        self._timer.setInterval(int(period_ms))
        self._timer.timeout.connect(self.collect)
        gc.disable()
        self._timer.start()

    @QtCore.Slot()
    def collect(self) -> None:
        import gc

        self.collections += 1
        gc.collect(2 if self.collections % self._full_every == 0 else 1)

    def stop(self) -> None:
        import gc

        self._timer.stop()
        gc.enable()


def make_app() -> QtWidgets.QApplication:
    """The application (created once), named and with deskarm's icon."""
    app = QtWidgets.QApplication.instance() or QtWidgets.QApplication(sys.argv[:1])
    app.setApplicationName("deskarm")
    icon = Path(__file__).resolve().parents[1] / "resources" / "deskarm.svg"
    if icon.is_file():
        app.setWindowIcon(QtGui.QIcon(str(icon)))
    return app


def show_splash(text: str = "starting cameras and the robot model…") -> QtWidgets.QLabel:
    """A "deskarm — starting…" card, painted and on screen before this returns.

    A plain frameless label with the SplashScreen window flag: ``QSplashScreen.show()`` blocks
    for about a second on Qt 6.11 (measured by bench/bench_startup.py), this shows in ~1 ms.
    Close it with :func:`finish_splash` once the window is up.
    """
    app = make_app()
    w, h = SPLASH_SIZE
    pixmap = QtGui.QPixmap(w, h)
    pixmap.fill(QtGui.QColor("#1e6fd0"))
    painter = QtGui.QPainter(pixmap)
    painter.setPen(QtGui.QColor("white"))
    font = painter.font()
    font.setPointSize(22)
    font.setBold(True)
    painter.setFont(font)
    painter.drawText(QtCore.QRect(0, 18, w, 50), QtCore.Qt.AlignmentFlag.AlignCenter, "deskarm")
    font.setPointSize(11)
    font.setBold(False)
    painter.setFont(font)
    painter.drawText(QtCore.QRect(10, 80, w - 20, 50), QtCore.Qt.AlignmentFlag.AlignCenter
                     | QtCore.Qt.TextFlag.TextWordWrap, text)
    painter.end()
    splash = QtWidgets.QLabel()
    splash.setWindowFlags(QtCore.Qt.WindowType.SplashScreen | QtCore.Qt.WindowType.FramelessWindowHint)
    splash.setPixmap(pixmap)
    splash.setFixedSize(w, h)
    screen = app.primaryScreen()
    if screen is not None:
        splash.move(screen.availableGeometry().center() - splash.rect().center())
    splash.show()
    app.processEvents()  # painted now, not when the event loop starts
    return splash


def finish_splash(splash: Optional[QtWidgets.QWidget]) -> None:
    """Close the start-up card (None: there was none)."""
    if splash is not None:
        splash.close()
        splash.deleteLater()


def run_until_quit(app: QtWidgets.QApplication, window: QtWidgets.QWidget) -> int:
    """``app.exec()``, then ``window``'s Qt objects deleted at once, while Python still holds their
    wrappers. Left to the interpreter's exit, the cycle collector (paused during start-up by
    app.cli.start_up, back on at its end) could free a child's Python wrapper before Qt destroys the
    child, and Qt would then call that child's Python overrides (DragScroll's and StopGuard's event
    filters) through an empty wrapper: a traceback per event on every exit."""
    import shiboken6

    code = app.exec()
    if shiboken6.isValid(window):
        shiboken6.delete(window)
    return code
