"""The status feature: the banner's most important message, one-off notes, the status bar.

``StatusFeature`` owns the banner (camera lost, e-stop, pause, a finished replay, calibration
drift, a note, the session's notes — in that order) and the status bar's items (camera, bridge,
fps, latency, camera→arm state). It builds the STOP strip's message area (``strip_messages``:
the banner while it fits on one line, and the target's reach line) and the row below the strip
(``banner_row``) a longer banner moves to. The window tells it what it learns: a camera
problem, the calibration's health.

Signals: ``sigChanged()`` — the banner's text changed (GUI thread).
"""
from __future__ import annotations

from typing import Optional

from PySide6 import QtCore, QtWidgets

from app.window_texts import replay_end_text
from widgets.status import Banner, StatusBarItems

NOTE_SHOW_MS = 15_000  # how long a one-off note (e.g. "new calibration in use") stays in the banner


class StatusFeature(QtCore.QObject):
    """The banner and the status bar of one session's window."""

    sigChanged = QtCore.Signal()

    def __init__(self, session, parent: Optional[QtCore.QObject] = None):
        super().__init__(parent)
        self.session = session
        self.banner = Banner()
        self.banner.sigChanged.connect(self.sigChanged)
        self.banner.sigChanged.connect(self.place_banner)
        self.strip_messages: Optional[QtWidgets.QWidget] = None  # made by build_strip
        self.banner_row: Optional[QtWidgets.QVBoxLayout] = None
        self.status_items = StatusBarItems()
        self.note = ""
        self.camera_error: Optional[str] = None
        self.health_message = ""
        self._note_timer = QtCore.QTimer(self)
        self._note_timer.setSingleShot(True)
        self._note_timer.timeout.connect(self.clear_note)

    def build_strip(self, reach_label: QtWidgets.QWidget) -> QtWidgets.QWidget:
        """The STOP strip's messages (the banner, ``reach_label``: the target's state whatever
        tab is open; never taller than the strip) and ``banner_row``, for the window to place."""
        self.strip_messages = QtWidgets.QWidget()
        self.strip_messages.setSizePolicy(QtWidgets.QSizePolicy.Policy.Ignored,
                                          QtWidgets.QSizePolicy.Policy.Ignored)
        messages = QtWidgets.QVBoxLayout(self.strip_messages)
        messages.setContentsMargins(0, 0, 0, 0)
        messages.setSpacing(2)
        messages.addWidget(self.banner)
        reach_label.setSizePolicy(QtWidgets.QSizePolicy.Policy.Ignored, QtWidgets.QSizePolicy.Policy.Preferred)
        messages.addWidget(reach_label)
        messages.addStretch(1)
        # a banner longer than one line in the strip: here, full width, wrapped (STOP stays put)
        self.banner_row = QtWidgets.QVBoxLayout()
        self.banner_row.setContentsMargins(0, 0, 0, 0)
        return self.strip_messages

    @QtCore.Slot()
    def place_banner(self) -> None:
        """The banner in the STOP strip while its text fits there on one line, else in the row
        below the strip (wrapped, full width): short messages cost no height, long ones are read
        whole, and STOP — alone at the strip's right end, at a fixed height — never moves."""
        banner = self.banner
        if self.strip_messages is None or self.banner_row is None:
            return
        room = self.strip_messages.width()
        padding = 2 * 10 + 8  # the banner's horizontal padding and a margin
        fits = banner.fontMetrics().horizontalAdvance(banner.text()) + padding <= room
        in_strip = banner.parentWidget() is self.strip_messages
        if fits == in_strip or not banner.text():
            return
        if fits:
            self.banner_row.removeWidget(banner)
            self.strip_messages.layout().insertWidget(0, banner)
        else:
            self.strip_messages.layout().removeWidget(banner)
            self.banner_row.addWidget(banner)

    @QtCore.Slot(str)
    def show_note(self, text: str) -> None:
        """A one-off message for NOTE_SHOW_MS (unless something more important is up)."""
        self.note = text
        self._note_timer.start(NOTE_SHOW_MS)
        self.restore()

    @QtCore.Slot()
    def clear_note(self) -> None:
        self.note = ""
        self.restore()

    def set_camera_error(self, message: Optional[str]) -> None:
        """A camera problem (None or "": the camera delivers)."""
        self.camera_error = message or None
        self.restore()

    @QtCore.Slot(object)
    def set_health(self, status) -> None:
        """Calibration health (HealthStatus): the drift message goes to the banner."""
        self.health_message = (f"{status.message} (or Camera tab → Calibrate cameras…)"
                               if status.drifted and status.message else "")
        self.restore()

    def restore(self) -> None:
        """The most important message: camera lost, e-stop, calibration drift, a note, session notes."""
        s = self.session
        if self.camera_error:
            retry = "" if "retrying" in self.camera_error else " — retrying"
            self.banner.show_message(f"camera lost — {self.camera_error}{retry}", "error")
        elif not s.controller.armed:
            self.banner.show_message("E-STOP — the arm is stopped. To resume, hold RE-ARM (top left) for 1 s.", "error")
        elif s.controller.paused:
            self.banner.show_message(f"arm paused while {', '.join(sorted(s.controller.paused_by))} — "
                                     "it holds still until that closes", "warn")
        elif replay_end_text(s.camera):  # the recording played to its end: no fault
            self.banner.show_message(replay_end_text(s.camera), "info")
        elif self.health_message:
            self.banner.show_message(self.health_message, "warn")
        elif self.note:
            self.banner.show_message(self.note, "info")
        elif s.banners:
            self.banner.show_message(" · ".join(s.banners), "warn" if "UNCALIBRATED" in " ".join(s.banners) else "info")
        else:
            self.banner.clear()

    def refresh(self, fps: float, latency_ms: float, bridge_status) -> None:
        """Camera, bridge (E-STOP first while stopped), fps and latency in the status bar."""
        s, b = self.session, bridge_status
        bridge_text = "—" if b is None else (f"{b.url} ✓ {b.commands_sent} cmds" if b.connected else f"{b.url} ✗ {b.message}")
        if not s.controller.armed:
            bridge_text = f"E-STOP · {bridge_text}"
        self.status_items.update(s.camera.name, bridge_text, fps, latency_ms, s.camera_to_robot_state())
