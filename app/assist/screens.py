"""The assistive view on a screen: filling it (the 7" 800×480 panel, with or without a window
manager) and the ``--screenshot`` picture of it."""
from __future__ import annotations

import time

from PySide6 import QtCore, QtGui, QtWidgets

SCREENSHOT_WAIT_S = 30.0  # --screenshot: the longest wait for the boxes after --after


def show_filling_screen(window: QtWidgets.QWidget, size: tuple[int, int] = (800, 480)) -> None:
    """Show ``window`` over all of its screen's available geometry, with or without a window manager.

    Full screen (no title bar) on a screen no bigger than ``size`` (the 7" 800×480 panel),
    maximised on a bigger one. The geometry is set first: with no window manager nothing acts on
    the full-screen or maximised state, and the window came up at its size hint (526×392 on an
    800×480 screen: 30 px boxes, the hint cut off)."""
    screen = window.screen() or QtGui.QGuiApplication.primaryScreen()
    free = screen.availableGeometry() if screen is not None else QtCore.QRect(0, 0, *size)
    window.setGeometry(free)
    if free.width() <= size[0] and free.height() <= size[1]:
        window.showFullScreen()
    else:
        window.showMaximized()
    if window.geometry() != free:  # a platform that ignored the state (offscreen, X11 without a manager)
        window.setGeometry(free)
    if QtGui.QGuiApplication.platformName() != "offscreen":  # (offscreen has no raise: it would only warn)
        window.raise_()
        window.activateWindow()  # the keys (Esc, Ctrl+Q, key switches) go to the window from the start


def screenshot_when_ready(app: QtWidgets.QApplication, window, path: str, size: tuple[int, int],
                          after_s: float) -> dict:
    """Run ``app`` until ``window`` (shown and started) offers its boxes (``window.choosing``) or
    says "error" — at least ``after_s`` s, at most SCREENSHOT_WAIT_S more — then save it as a PNG
    of exactly ``size`` at ``path``, stop and close it. Returns {saved, state, after_s} ({} when
    the application quit first)."""
    started = time.monotonic()
    result: dict = {}

    def poll() -> None:
        elapsed = time.monotonic() - started
        ready = window.choosing or window.state_text == "error"
        if elapsed < after_s or (not ready and elapsed < after_s + SCREENSHOT_WAIT_S):
            return
        timer.stop()
        image = window.grab().toImage()
        if (image.width(), image.height()) != size:  # a device pixel ratio other than 1
            image = image.scaled(*size, QtCore.Qt.AspectRatioMode.IgnoreAspectRatio,
                                 QtCore.Qt.TransformationMode.SmoothTransformation)
        result.update(saved=image.save(path, "PNG"), state=window.state_text, after_s=elapsed)
        window.stop()
        window.close()
        app.quit()

    timer = QtCore.QTimer()
    timer.setInterval(50)
    timer.timeout.connect(poll)
    timer.start()
    app.exec()
    return result
