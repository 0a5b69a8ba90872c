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
